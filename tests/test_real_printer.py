"""Real printers' saved DELTA_CALIBRATE runs: identified from one run, the others predicted.

The fixtures (``tests/data/klipper/real/``) hold two FLSUN V400s' saved runs, each file naming its
source; ``scripts/real_printer.py`` computes the figures of docs/printers.md from them.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.io import load_calibration
from deltacal.printer.firmware.klipper.config import load_klipper

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "real_printer.py"
DATA = Path(__file__).resolve().parent / "data" / "klipper" / "real"


def load_script():
    spec = importlib.util.spec_from_file_location("real_printer", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_a_real_run_imports_then_identifies_through_the_cli(tmp_path):
    run = DATA / "flsun-v400-b-run1.cfg"
    out, cal = tmp_path / "v400", tmp_path / "cal.toml"
    assert main(["import", str(run), "-o", str(out)]) == 0
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(run), "-o", str(cal)]) == 0
    result = load_calibration(cal)
    before, after = result.residuals_before, result.residuals_after
    assert after.height_rms < 0.2 * before.height_rms and after.distance_rms < before.distance_rms


def test_a_program_from_home_goes_through_on_a_real_printer(tmp_path):
    """Import, identify, then a program that homes and goes down: no command Klipper refuses.

    The V400's radius tapers to its axis in the top 40 mm; its corrections move the nozzle a few mm
    across: near the home they are blended in where the taper admits them (the move from the home).
    """
    run = DATA / "flsun-v400-b-run1.cfg"
    out, cal = tmp_path / "v400", tmp_path / "cal.toml"
    assert main(["import", str(run), "-o", str(out)]) == 0
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(run), "-o", str(cal)]) == 0
    program, corrected = tmp_path / "part.gcode", tmp_path / "part-corrected.gcode"
    program.write_text("G28\nG90\nM83\nG1 Z5 F3000\nG1 X50 Y0 Z0.2\nG1 X0 Y50 E2 F1500\nG1 X-50 Y0 E2\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(run), "-o", str(corrected)]) == 0
    moves = np.array([[float(w[1:]) for w in line.split()[1:4]] for line in corrected.read_text().splitlines()
                      if line.startswith("G1 X")])
    assert np.all(load_klipper(run).outside(moves) == 0)
    assert moves[0, 2] > 400.0  # the first point of the move down from the home (Z 419.9), in the taper


def test_the_saved_runs_steps_are_klippers_own():
    """Klipper's fitted values of a run put its probe heights where it fitted them (its residuals)."""
    script = load_script()
    run = script.read_run(DATA / "flsun-v400-a-run2.cfg")
    heights, _ = script.residuals_klipper(run.klipper, run)
    assert run.height.tolist() == [18.076] * 7
    assert np.max(np.abs(heights)) < 0.1  # what DELTA_CALIBRATE left of its own fit, not the 18 mm offset
    assert_allclose(run.step, 40.0 / (200 * 16), rtol=0, atol=0)


@pytest.mark.parametrize("printer", [pytest.param("a", marks=pytest.mark.slow), "b"])
@pytest.mark.long
def test_the_identified_printer_predicts_the_other_runs_better_than_klippers_values(printer):
    script = load_script()
    runs = [script.read_run(path) for path in script.PRINTERS[printer]]
    assert len(runs) >= 2
    for row in script.cross_validate(runs):
        ours, klippers = row["deltacal"], row["klipper"]
        for key in ("height_rms", "flatness_rms", "distance_rms", "scale_free_distance_rms"):
            assert ours[key] < klippers[key], (row["run"], key, ours[key], klippers[key])
