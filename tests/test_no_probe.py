"""Printers without a probe (issue 47, item 1): ``plan --object`` writes the object, its distances, the
sheet and a probe.csv for heights by hand, no probe program, and says the firmware's paper test;
``identify`` takes the distances alone and says what heights would add."""

import csv
import shutil

import numpy as np
import pytest
from conftest import MODELS, ROOT, kossel_printer_cfg

from deltacal.cli import main
from deltacal.io import load_calibration, load_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import printable_grid
from deltacal.printer.firmware.probing import PAPER_MM

MARLIN_NO_PROBE = ROOT / "tests" / "data" / "marlin" / "delta-1.1.6-m503-no-m211.txt"
WRITTEN = ("object.stl", "probe.csv", "distances.csv", "sheet.html")


def _planned(folder, out: str) -> None:
    for name in WRITTEN:
        assert (folder / name).stat().st_size > 0, name
    assert not (folder / "probe.gcode").exists()  # no probe: no probe program
    with open(folder / "probe.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert rows and all(float(row["trigger_height_mm"]) == PAPER_MM and row["z_mm"] == "" for row in rows)
    assert out.count("identify PRINTER.toml distances.csv fits the distances alone") == 1  # one line


def test_plan_object_on_a_printer_cfg_without_a_probe(tmp_path, capsys):
    """Before: refused 'no probe section ([probe], ...)'. Now: Klipper's MANUAL_PROBE at each point."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=None)
    assert main(["plan", str(MODELS / "kossel.toml"), "--object", "--controller", str(cfg),
                 "--probe-grid", "3", "-o", str(tmp_path / "obj")]) == 0
    out = capsys.readouterr().out
    _planned(tmp_path / "obj", out)
    assert "no probe section in" in out and "MANUAL_PROBE, TESTZ" in out and "'Z position is Z'" in out


def test_plan_object_on_an_m503_without_m851(tmp_path, capsys):
    """A real M503 of a printer without a probe (no M851): before, refused 'no M851 Z'; now planned."""
    m503 = shutil.copy(MARLIN_NO_PROBE, tmp_path / "m503.txt")
    assert main(["import", str(m503), "-o", str(tmp_path / "printer")]) == 0
    capsys.readouterr()
    assert main(["plan", str(tmp_path / "printer" / "printer.toml"), "--object", "--controller", str(m503),
                 "--probe-grid", "3", "-o", str(tmp_path / "obj")]) == 0
    out = capsys.readouterr().out
    _planned(tmp_path / "obj", out)
    assert "no M851 in" in out and "M114" in out


def test_a_probe_section_still_gets_its_program(tmp_path, capsys):
    """With a probe, nothing changes: probe.gcode, no paper test, probe.csv without trigger heights."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=1.5)
    assert main(["plan", str(MODELS / "kossel.toml"), "--object", "--controller", str(cfg),
                 "--probe-grid", "3", "-o", str(tmp_path / "obj")]) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "obj" / "probe.gcode").exists() and "MANUAL_PROBE" not in out
    assert (tmp_path / "obj" / "probe.csv").read_text().splitlines()[0] == "x_mm,y_mm,z_mm"


def _shape_errors(truth, calibration, workspace) -> np.ndarray:
    """|nozzle error| over the printable volume, less the rigid motion that fits it best [mm]: the
    printer's shape, which distances see (the bed's height and tilt under it they do not)."""
    grid = printable_grid(workspace)
    geometry = load_calibration(calibration).geometry
    errors = exact.forward(truth, exact.inverse(geometry, grid)).point(truth.tool) - grid
    x, y, z = grid.T
    A = np.zeros((len(grid), 3, 6))
    A[:, :, :3] = np.eye(3)
    A[:, 0, 4], A[:, 0, 5], A[:, 1, 3], A[:, 1, 5], A[:, 2, 3], A[:, 2, 4] = z, -y, -z, x, y, -x
    motion = np.linalg.lstsq(A.reshape(-1, 6), errors.reshape(-1), rcond=None)[0]
    return np.linalg.norm(errors - A @ motion, axis=1)


@pytest.mark.long
def test_distances_alone_know_the_shape_as_well_as_with_the_heights(tmp_path, capsys):
    """plan (no probe) -> simulate -> identify with and without the heights, on the same true printer.

    Before: identify refused a distances file given alone ('not probe heights'). The shape's errors
    (less the rigid motion) of the distances alone are within 10 % of the heights' and distances'
    (seed 7: max 0.077 vs 0.076 mm, RMS 0.026 vs 0.025 mm, 40 distances, 5 heights)."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=None)
    robot = str(MODELS / "kossel.toml")
    assert main(["plan", robot, "--object", "--controller", str(cfg), "--probe-grid", "3",
                 "-o", str(tmp_path / "obj")]) == 0
    (tmp_path / "m").mkdir()
    probe, distances = str(tmp_path / "m" / "probe.csv"), str(tmp_path / "m" / "distances.csv")
    planned = tmp_path / "obj"
    assert main(["simulate", robot, str(planned / "probe.csv"), str(planned / "distances.csv"),
                 "--controller", str(cfg), "--perturb", "7", "-o", probe,
                 "--distances-output", distances]) == 0
    both, alone = tmp_path / "both.toml", tmp_path / "alone.toml"
    assert main(["identify", robot, probe, distances, "--controller", str(cfg), "-o", str(both)]) == 0
    capsys.readouterr()
    assert main(["identify", robot, distances, "--controller", str(cfg), "-o", str(alone)]) == 0
    out = capsys.readouterr().out
    assert "no probe heights: the 40 distances alone determine" in out and "would add" in out
    truth, workspace = load_geometry(tmp_path / "m" / "probe.truth.toml"), load_printer(robot).workspace
    with_heights, without = (_shape_errors(truth, c, workspace) for c in (both, alone))
    assert without.max() < 1.1 * with_heights.max() and without.max() < 0.1
    assert np.sqrt(np.mean(without**2)) < 1.1 * np.sqrt(np.mean(with_heights**2))
