"""Bed-level heights alone (issue 46, item 5): what seven saved heights determine is corrected and exported.

A real FLSUN V400's printer.cfg holds only Klipper's basic ``DELTA_CALIBRATE`` (7 heights, no printed
object). Before: ``export`` exited 1 "no value to export" though Klipper's values already fit the
heights; now exit 0, the values unchanged, the residuals said.
"""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_where_it_holds import load_script

from deltacal.cli import main

REAL = Path(__file__).resolve().parent / "data" / "klipper" / "real" / "flsun-v400-fzechert.cfg"


@pytest.fixture(scope="module")
def identified(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("heights")
    shutil.copy(REAL, folder / "printer.cfg")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["import", str(folder / "printer.cfg"), "-o", str(folder / "imp")]) == 0
        assert main(["identify", str(folder / "imp" / "printer.toml"), str(folder / "imp" / "probe.csv"),
                     "--controller", str(folder / "printer.cfg"), "-o", str(folder / "cal.toml")]) == 0
    return folder


def _endstops(text: str) -> list[float]:
    return [float(v) for v in re.findall(r"position_endstop\s*[:=]\s*([-0-9.]+)", text)]


def test_klippers_values_already_fit_the_heights_export_exits_0_unchanged(identified, capsys):
    capsys.readouterr()
    out_file = identified / "calibrated.cfg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["export", str(identified / "cal.toml"), "--controller", "klipper", "--config",
                       str(identified / "printer.cfg"), "-o", str(out_file)])
    out = capsys.readouterr().out
    assert status == 0, out
    found = re.search(r"7 heights: RMS ([0-9.]+), max ([0-9.]+) mm \(σ 0\.01\): within 2 σ", out)
    assert found is not None and "nothing to change" in out, out
    assert float(found[1]) <= 0.02 and float(found[2]) >= float(found[1])
    saved = (identified / "printer.cfg").read_text()
    saved_endstops = _endstops(saved[saved.index("#*# [stepper_a]"):].replace("#*# ", ""))
    assert np.allclose(_endstops(out_file.read_text())[:3], saved_endstops[:3], atol=1e-6)


def test_values_that_do_not_fit_the_heights_are_not_called_unchanged(identified, tmp_path, capsys):
    """The same calibration through a printer.cfg whose tower A endstop is 0.2 mm off its saved value:
    the heights' residuals are beyond 2 σ, so there is something to change; held nowhere, refused."""
    text = (identified / "printer.cfg").read_text()
    moved = re.sub(r"(#\*# \[stepper_a\]\n(?:#\*# .*\n)*?#\*# position_endstop = )([-0-9.]+)",
                   lambda m: f"{m[1]}{float(m[2]) + 0.2:.6f}", text, count=1)
    assert moved != text
    (tmp_path / "printer.cfg").write_text(moved)
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["export", str(identified / "cal.toml"), "--controller", "klipper", "--config",
                       str(tmp_path / "printer.cfg"), "-o", str(tmp_path / "calibrated.cfg")])
    captured = capsys.readouterr()
    assert status == 1 and "no value to export" in captured.err, captured
    assert "nothing to change" not in captured.out and not (tmp_path / "calibrated.cfg").exists()


def test_the_owners_endstop_lines_say_not_determined(identified):
    """Seven heights at one level do not tell a tower's endstop from its travel: 'not determined', not
    'stops low'."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["report", str(identified / "cal.toml"), "-o", str(identified / "r.html"),
                     "--no-view"]) == 0
    page = (identified / "r.html").read_text()
    assert "not determined by these measurements" in page and "stops low" not in page


@pytest.fixture(scope="module")
def script():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield load_script()


@pytest.mark.long
@pytest.mark.parametrize(("label", "seed"), [
    ("typical kit", 46500), ("typical kit", 46501), ("typical kit", 46502),
    ("well built", 46500), ("well built", 46501),
    pytest.param("well built", 46502, marks=pytest.mark.xfail(
        strict=True, reason="issue 46 item 5, left open: 0.0155 mm against Klipper's 0.0151 (seven heights "
                            "at σ 0.01 mm are the noise floor; with the arms' wide prior too: 0.0145, but "
                            "the kit 46500 then 0.0293 against 0.0289)")),
])
def test_seven_heights_correct_the_first_layer_no_worse_than_klipper(script, tmp_path, label, seed):
    """Klipper's basic calibration from its 7 heights saved in printer.cfg, identified through it: the first
    layer corrected (its vertical weight over half on average), its height error at most Klipper's own."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = script.simulate(seed, label, "plain", tmp_path, distances_too=False)
        cal, _ = script.calibrate(run.nominal, run.data, run.config)
    assert run.data.distance.size == 0
    layers = {z: script.disc(script.SIM_RADIUS, z) for z in script.SIM_HEIGHTS}
    controller = script.KLIPPER.controller(run.klipper, run.step)
    sent = {z: script.commands_of(cal, controller, t) for z, t in layers.items()}
    first = sent[script.SIM_HEIGHTS[0]][1]
    assert np.mean(first[:, 1]) > 0.5
    ours = script.judged(run.truth, run, layers, {z: c for z, (c, _) in sent.items()}, run.klipper)
    own = script.judged(run.truth, run, layers, layers, run.klipper)
    assert ours["first_layer_height_error_mm"] <= own["first_layer_height_error_mm"], (ours, own)
