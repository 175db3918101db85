"""Printers without a probe (issue 47, item 1): ``plan --object`` writes the object, its distances, the
sheet and a probe.csv for heights by hand, no probe program, and says the firmware's paper test;
``identify`` takes the distances alone and says what heights would add."""

import csv
import re
import shutil

import numpy as np
import pytest
from conftest import MODELS, ROOT, kossel_printer_cfg

from deltacal.cli import main
from deltacal.io import load_calibration, load_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import printable_grid
from deltacal.printer.firmware.klipper.firmware import KLIPPER
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


def _route(folder, probe_z_offset: float | None, capsys) -> tuple[np.ndarray, np.ndarray, str]:
    """The printed-object route through the CLI on the Kossel of seed 7 (plan --object, simulate in place
    of the printer, identify, export, compensate of targets over the printable volume): the corrected
    commands' 3-D errors on the true printer less the shift along the bed and turn about its normal (which
    no measurement sees) [mm], the heights simulate filled in, and export's figures line."""
    folder.mkdir()
    cfg = kossel_printer_cfg(folder / "printer.cfg", probe_z_offset=probe_z_offset)
    cfg.write_text(cfg.read_text().replace("[printer]\n", "[printer]\nminimum_z_position: -3\n"))
    robot, obj, through = str(MODELS / "kossel.toml"), folder / "obj", ["--controller", str(cfg)]
    assert main(["plan", robot, "--object", *through, "--probe-grid", "3", "-o", str(obj)]) == 0
    probe, distances, cal = folder / "probe.csv", folder / "d.csv", folder / "cal.toml"
    assert main(["simulate", robot, str(obj / "probe.csv"), str(obj / "distances.csv"), *through,
                 "--perturb", "7", "-o", str(probe), "--distances-output", str(distances)]) == 0
    assert main(["identify", robot, str(probe), str(distances), *through, "-o", str(cal)]) == 0
    capsys.readouterr()
    assert main(["export", str(cal), "--controller", "klipper", "--config", str(cfg), "-o",
                 str(folder / "calibrated.cfg")]) == 0
    figures = next(line for line in capsys.readouterr().out.splitlines() if "these values: 3-D max" in line)
    printer = load_printer(robot)
    grid = printable_grid(printer.workspace)
    targets = folder / "targets.csv"
    targets.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in grid.tolist()))
    assert main(["compensate", str(cal), str(targets), *through, "-o", str(folder / "c.csv")]) == 0
    commands = np.loadtxt(folder / "c.csv", delimiter=",", skiprows=1, usecols=(3, 4, 5))
    truth = load_geometry(folder / "probe.truth.toml")
    readings = KLIPPER.read_config(cfg).inverse(commands, printer.step_distance)
    errors = exact.forward(truth, readings).point(truth.tool) - grid
    A = np.zeros((len(grid), 3, 3))  # x, y shift and turn about z: the motion no measurement sees
    A[:, 0, 0] = A[:, 1, 1] = 1.0
    A[:, 0, 2], A[:, 1, 2] = -grid[:, 1], grid[:, 0]
    motion = np.linalg.lstsq(A.reshape(-1, 3), errors.reshape(-1), rcond=None)[0]
    heights = np.loadtxt(probe, delimiter=",", skiprows=1, usecols=2)
    return np.linalg.norm(errors - A @ motion, axis=1), heights, figures


@pytest.mark.long
def test_the_whole_route_without_a_probe_is_as_accurate_as_with_one(tmp_path, capsys):
    """plan --object, simulate, identify, export, compensate on the same true printer (seed 7), its
    printer.cfg without a probe (heights by the paper test: trigger height 0.1 mm) and with a [probe]
    (z_offset 1.5). simulate fills the manual probe.csv with the commanded z at which the nozzle is the
    paper's 0.1 mm above the true bed (0.1 mm above the probe's), identify takes it off: the corrected
    commands land alike (665 targets over the printable volume: max 0.635 mm both, where the correction
    is not held the firmware's own command is sent; RMS 0.104 mm both), within 0.005 mm at every target.
    A paper thickness not taken off (or not simulated) would put the bed 0.1 mm off."""
    manual, by_hand, said_manual = _route(tmp_path / "manual", None, capsys)
    probed, by_probe, said_probe = _route(tmp_path / "probe", 1.5, capsys)
    np.testing.assert_allclose(by_hand - by_probe, PAPER_MM, rtol=0, atol=2e-3)  # the paper, not the probe
    assert np.max(np.abs(manual - probed)) < 0.005
    assert abs(np.sqrt(np.mean(manual**2)) - np.sqrt(np.mean(probed**2))) < 0.002
    assert np.max(probed) < 1.0 and np.median(probed) < 0.05  # the route corrects (not alike in error)
    assert said_manual == said_probe, (said_manual, said_probe)  # export's figures, as printed


RRF_MINIKOSSEL = ROOT / "tests" / "data" / "rrf" / "duet3d-minikossel" / "config.g"


def _rrf_config(folder, probe_type: str):
    """The real Duet Mini Kossel config.g (its comments as found), its M558 P4 (a switch) ``probe_type``."""
    folder.mkdir()
    text = RRF_MINIKOSSEL.read_text()
    assert text.count("\nM558 P4 ") == 1
    (folder / "config.g").write_text(text.replace("\nM558 P4 ", f"\nM558 {probe_type} "))
    return folder / "config.g"


@pytest.mark.parametrize("probe_type", ["P0", "P4"])
def test_rrf_m558_p0_is_manual_probing_by_its_g30(tmp_path, capsys, probe_type):
    """RRF's M558 P0 (no probe): plan keeps probe.gcode (at each G30 S-1 RRF asks the user to jog Z and
    answers 'Stopped at height Z mm', the nozzle's height), probe.csv's trigger height is the paper's and
    the console imported through config.g takes the paper's 0.1 mm, not G31 Z (4.80 here). Before: M558 P
    was not read; the console's heights took G31 Z's 4.8 mm (the bed 4.7 mm off) and probe.csv had none.
    With P4 (its switch) nothing changes."""
    config = _rrf_config(tmp_path / "sys", probe_type)
    manual = probe_type == "P0"
    assert main(["import", str(config), "-o", str(tmp_path / "printer")]) == 0
    robot, obj = str(tmp_path / "printer" / "printer.toml"), tmp_path / "obj"
    capsys.readouterr()
    through = ["--controller", str(config)]
    assert main(["plan", robot, "--object", *through, "--probe-grid", "3", "-o", str(obj)]) == 0
    out = capsys.readouterr().out
    program = (obj / "probe.gcode").read_text()
    assert program.count("\nG30 S-1\n") == 5
    travel = re.search(r"travels at Z(\S+) between points: (.*?) \+ M558 H8 \(line 51 of ", program)
    assert travel is not None
    assert travel.groups() == (("8.100", "the paper's 0.1") if manual else ("12.800", "G31 Z"))
    header = (obj / "probe.csv").read_text().splitlines()[0]
    assert header == ("x_mm,y_mm,z_mm,trigger_height_mm" if manual else "x_mm,y_mm,z_mm")
    assert out.count("identify PRINTER.toml distances.csv fits the distances alone") == int(manual)
    assert ("M558 P0 in " in out and "Adjust height until the nozzle just touches the bed" in out) == manual
    # the printer run: RRF's console, each point echoed, then its answer (%.3f), read back through config.g
    assert main(["simulate", robot, str(obj / "probe.csv"), "--controller", str(config), "--perturb", "7",
                 "-o", str(tmp_path / "filled.csv")]) == 0
    filled = np.loadtxt(tmp_path / "filled.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2), ndmin=2)
    console = [f'echo "probe at {x:.3f},{y:.3f}"\nprobe at {x:.3f},{y:.3f}\nStopped at height {z:.3f} mm\n'
               for x, y, z in filled]
    (tmp_path / "console.txt").write_text("".join(console))
    capsys.readouterr()
    assert main(["import", str(tmp_path / "console.txt"), "--config", str(config), "-o",
                 str(tmp_path / "probe.csv")]) == 0
    with open(tmp_path / "probe.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [float(row["trigger_height_mm"]) for row in rows] == [PAPER_MM if manual else 4.8] * 5
    assert ("the paper test: M558 P0 of" in capsys.readouterr().out) == manual
