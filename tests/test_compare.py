"""``deltacal compare OLD NEW``: what changed in a printer between two calibrations, in its owner's words.

The session's Kossel (``kossel_identified``: simulated with ``--perturb 5`` and identified through its
printer.cfg) is OLD; NEW is the same true printer (its ``probe.truth.toml``) with tower B's endstop moved
up 0.2 mm, simulated again (other noise) and identified through the same printer.cfg.
"""

from __future__ import annotations

import dataclasses
import re
import shutil

import numpy as np
import pytest
from conftest import MODELS, complete_fit

from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.io import load_calibration, load_geometry
from deltacal.io.calibration import save_calibration
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.history import SIGNIFICANT_SIGMAS, compare_calibrations, old_against_new_controller
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


def test_changed_controller_values_with_one_nominal_are_compared_as_identified(kossel_identified, tmp_path,
                                                                                 capsys):
    """NEW records tower B's arm 1.5 mm longer but the same robot file: both priors are centred on it, the
    readings are the printer's own: compared as they are, the differing key said."""
    cal = kossel_identified / "cal.toml"
    value = re.search(r'"stepper_b.arm_length" = ([0-9.]+)', cal.read_text())
    assert value is not None
    longer = f'"stepper_b.arm_length" = {float(value[1]) + 1.5}'
    changed = _edited(cal, tmp_path / "new.toml", value[0], longer)
    assert main(["compare", str(cal), changed, "-o", str(tmp_path / "c.html")]) == 0
    out = capsys.readouterr().out
    said = r"same nominal printer.*stepper_b\.arm_length [0-9.]+ -> [0-9.]+.*compared as identified"
    assert re.search(said, out), out
    assert "tower B's endstop moved +0.00" in out and (tmp_path / "c.html").exists()


def test_another_nominal_without_measurements_is_refused(kossel_identified):
    """An OLD written before calibrations recorded their measurements cannot be re-anchored to another
    nominal printer: refused in one line naming the file."""
    cal = load_calibration(kossel_identified / "cal.toml")
    old = dataclasses.replace(cal, measured=None)
    other = dataclasses.replace(cal.nominal, rod_length=cal.nominal.rod_length + 0.5)
    with pytest.raises(InputError, match="records no measurements to identify again"):
        old_against_new_controller(old, dataclasses.replace(cal, nominal=other), "old.toml", "new.toml")


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


@pytest.fixture(scope="module")
def recalibrated(moved):
    """NEW measured and identified through a printer.cfg whose values were changed since OLD (tower B's
    endstop value 0.3 mm up, tower A's arm 1 mm longer, as a re-run of the firmware's calibration would)
    and from the robot file its owner imports of it: the changes, OLD re-anchored to NEW's nominal."""
    cfg = moved / "printer.cfg"
    text = cfg.read_text()
    edited = re.sub(r"(\[stepper_b\][^\[]*?position_endstop\s*[:=]\s*)([0-9.]+)",
                    lambda m: f"{m[1]}{float(m[2]) + 0.3!r}", text, count=1)
    edited = re.sub(r"(\[stepper_a\][^\[]*?arm_length\s*[:=]\s*)([0-9.]+)",
                    lambda m: f"{m[1]}{float(m[2]) + 1.0!r}", edited, count=1)
    assert edited.count("\n") == text.count("\n") and edited != text
    cfg2 = moved / "printer2.cfg"
    cfg2.write_text(edited)
    plan = moved / "obj"
    assert main(["import", str(cfg2), "-o", str(moved / "imported2")]) == 0  # its owner's robot file of it
    printer2 = str(moved / "imported2" / "printer.toml")
    assert main(["simulate", printer2, str(plan / "probe.csv"), str(plan / "distances.csv"), "--controller",
                 str(cfg2), "--truth", str(moved / "moved.toml"), "--seed", "2",
                 "-o", str(moved / "probe3.csv"), "--distances-output", str(moved / "d3.csv")]) == 0
    assert main(["identify", printer2, str(moved / "probe3.csv"), str(moved / "d3.csv"), "--controller",
                 str(cfg2), "-o", str(moved / "new2.toml")]) == 0
    pair = _anchored_pair(moved / "cal.toml", moved / "new2.toml")
    return {c.what: c for c in compare_calibrations(*pair)}


@pytest.mark.long
def test_the_moved_endstop_is_found_across_a_recalibrated_printer_cfg(moved, recalibrated, capsys):
    """Before re-anchoring, compare refused the pair; now OLD is re-anchored (said, naming the keys) and
    tower B's endstop is a significant change within 3 σ of 0.2 mm."""
    capsys.readouterr()
    assert main(["compare", str(moved / "cal.toml"), str(moved / "new2.toml")]) == 0
    out = capsys.readouterr().out
    assert "under one prior" in out and "stepper_b.position_endstop" in out, out
    b = recalibrated["tower B's endstop"]
    assert b.significant and abs(b.change - MOVED_MM) < SIGNIFICANT_SIGMAS * b.sigma, b.words()


@pytest.mark.long
def test_across_a_recalibrated_printer_cfg_nothing_else_is_significant(recalibrated):
    """Under one prior (before: OLD re-anchored with its own tolerances' scale, 0.57 against NEW's 1.17, read
    tower A's endstop moved -0.21 ± 0.07 mm: significant)."""
    assert [w for w, c in recalibrated.items() if c.significant] == ["tower B's endstop"]


def _anchored_pair(old, new):
    a, b = load_calibration(old), load_calibration(new)
    return old_against_new_controller(a, b, old, new)[:2]


def test_another_step_distance_cannot_be_brought_under_one_prior(kossel_identified):
    """NEW's robot file counts steps in another step distance: OLD's readings cannot be identified from it;
    refused in one line naming OLD (before this wrap: a ValueError, exit 3)."""
    cal = load_calibration(kossel_identified / "cal.toml")
    other = dataclasses.replace(cal.nominal, rod_length=cal.nominal.rod_length + 0.5,
                                step_distance=cal.nominal.step_distance * 2.0)
    with pytest.raises(InputError, match="identifying it again under new.toml's prior failed"):
        old_against_new_controller(cal, dataclasses.replace(cal, nominal=other), "old.toml", "new.toml")
