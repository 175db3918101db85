"""``deltacal compare OLD NEW``: what changed in a printer between two calibrations, in its owner's words.

The session's Kossel (``kossel_identified``: simulated with ``--perturb 5`` and identified through its
printer.cfg) is OLD; NEW is the same true printer (its ``probe.truth.toml``) with tower B's endstop moved
up 0.2 mm, simulated again (other noise) and identified through the same printer.cfg.
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest
from conftest import MODELS, complete_fit

from deltacal.cli import main
from deltacal.io import load_calibration, load_geometry
from deltacal.io.calibration import save_calibration
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.history import SIGNIFICANT_SIGMAS, compare_calibrations
from deltacal.printer.identification.errormodels import PrinterModel

MOVED_MM = 0.2


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    return err


@pytest.fixture(scope="module")
def moved(tmp_path_factory, kossel_identified):
    """OLD (the session's calibration) and NEW (tower B's endstop 0.2 mm higher), in one folder."""
    folder = tmp_path_factory.mktemp("compare")
    shutil.copytree(kossel_identified, folder, dirs_exist_ok=True)
    model = PrinterModel()
    dk = np.zeros(model.size)
    dk[model.names.index("endstop2")] = MOVED_MM
    save_geometry(model.apply(load_geometry(folder / "probe.truth.toml"), dk), folder / "moved.toml")
    kossel, cfg, plan = str(MODELS / "kossel.toml"), str(folder / "printer.cfg"), folder / "obj"
    assert main(["simulate", kossel, str(plan / "probe.csv"), str(plan / "distances.csv"), "--controller",
                 cfg,
                 "--truth", str(folder / "moved.toml"), "--seed", "1", "-o", str(folder / "probe2.csv"),
                 "--distances-output", str(folder / "d2.csv")]) == 0
    assert main(["identify", kossel, str(folder / "probe2.csv"), str(folder / "d2.csv"), "--controller", cfg,
                 "-o", str(folder / "new.toml")]) == 0
    return folder


@pytest.mark.long
def test_the_moved_endstop_is_found_and_nothing_else_is_significant(moved, capsys):
    capsys.readouterr()
    old, new = str(moved / "cal.toml"), str(moved / "new.toml")
    assert main(["compare", old, new, "-o", str(moved / "c.html")]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "tower B's endstop" in x)
    found = re.search(r"moved ([+-][0-9.]+) ± ([0-9.]+) mm", line)
    assert found is not None, line
    change, sigma = float(found[1]), float(found[2])
    assert abs(change - MOVED_MM) < SIGNIFICANT_SIGMAS * sigma, line
    changes = {c.what: c for c in compare_calibrations(load_calibration(moved / "cal.toml"),
                                                       load_calibration(moved / "new.toml"))}
    b = changes["tower B's endstop"]
    assert abs(b.change - MOVED_MM) < 0.05, b  # the estimate itself is close: its σ is the question
    for what, c in changes.items():
        if what != "tower B's endstop":
            assert not c.significant, c.words()
    assert "no significant change between them" in out or "significant: tower B's endstop" in out
    page = (moved / "c.html").read_text()
    assert "tower B&#x27;s endstop" in page and "<script" not in page


@pytest.mark.long
@pytest.mark.xfail(strict=True, reason="each calibration's endstop σ (0.08 mm) is its prior's, shared by "
                   "both: in quadrature 0.12 mm, a 0.2 mm move is not 3 σ (issue 46 item 6, left to "
                   "the lead)")
def test_the_moved_endstop_is_significant(moved):
    changes = {c.what: c for c in compare_calibrations(load_calibration(moved / "cal.toml"),
                                                       load_calibration(moved / "new.toml"))}
    assert changes["tower B's endstop"].significant
    assert [w for w, c in changes.items() if c.significant] == ["tower B's endstop"]


def test_a_calibration_against_itself_changes_nothing(kossel_identified, capsys):
    cal = str(kossel_identified / "cal.toml")
    assert main(["compare", cal, cal]) == 0
    out = capsys.readouterr().out
    assert "tower A's endstop moved +0.00 ± " in out
    assert out.strip().endswith("no significant change between them")


def _edited(source, target, old: str, new: str):
    text = source.read_text()
    assert old in text
    target.write_text(text.replace(old, new, 1))
    return str(target)


def test_a_changed_controller_is_refused_naming_the_key(kossel_identified, tmp_path, capsys):
    cal = kossel_identified / "cal.toml"
    value = re.search(r'"stepper_b.arm_length" = ([0-9.]+)', cal.read_text())
    assert value is not None
    longer = f'"stepper_b.arm_length" = {float(value[1]) + 1.5}'
    changed = _edited(cal, tmp_path / "new.toml", value[0], longer)
    assert main(["compare", str(cal), changed, "-o", str(tmp_path / "c.html")]) == 1
    err = _one_line(capsys)
    assert re.search(r"stepper_b\.arm_length [0-9.]+ -> [0-9.]+", err), err
    assert "re-anchored" in err and err.startswith(f"deltacal compare: error: {cal}"), err
    assert not (tmp_path / "c.html").exists()


def test_another_firmware_is_refused_naming_both(kossel_identified, tmp_path, capsys):
    cal = kossel_identified / "cal.toml"
    other = _edited(cal, tmp_path / "marlin.toml", 'firmware = "klipper"', 'firmware = "marlin"')
    assert main(["compare", other, str(cal)]) == 1
    err = _one_line(capsys)
    assert "Marlin" in err and "Klipper" in err, err


def test_another_printer_is_refused(kossel_identified, tmp_path, capsys):
    cal = kossel_identified / "cal.toml"
    text = cal.read_text()

    def longer(found: re.Match) -> str:  # every rod 30 mm longer, nominal and identified: beyond any build
        return "rod_length_mm = [" + ", ".join(repr(float(v) + 30.0) for v in found[1].split(",")) + "]"

    text, n = re.subn(r"rod_length_mm = \[([^\]]*)\]", longer, text)
    assert n == 6
    (tmp_path / "other.toml").write_text(text)
    assert main(["compare", str(cal), str(tmp_path / "other.toml")]) == 1
    err = _one_line(capsys)
    assert "arm_length" in err, err


def test_a_geometry_file_and_a_rotary_calibration_are_refused(kossel_identified, tmp_path, bai, capsys):
    cal = str(kossel_identified / "cal.toml")
    truth = str(kossel_identified / "probe.truth.toml")
    assert main(["compare", truth, cal]) == 1
    assert "geometry file" in _one_line(capsys)
    save_calibration(complete_fit(bai, 5), tmp_path / "rotary.toml")
    assert main(["compare", cal, str(tmp_path / "rotary.toml")]) == 1
    err = _one_line(capsys)
    assert "rotary" in err and "rotary.toml" in err, err
