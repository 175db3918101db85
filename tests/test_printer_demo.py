"""``deltacal demo --printer`` (issue 24): the whole path on a simulated printer, beside Klipper's own."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.gcode.marker import MARKER
from deltacal.io import load_calibration
from deltacal.printer.demo import ROWS, SEED, printer_table
from deltacal.printer.files.measurements import read_printed_distances, read_probe_heights
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER

FILES = ("printer.cfg", "object.stl", "probe.csv", "distances.csv", "probe_measured.csv",
         "distances_measured.csv", "printer_calibration.toml", "printer_calibrated.cfg", "part.gcode",
         "part_corrected.gcode", "printer_demo.json")


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """`deltacal demo --printer --quick` run once from an unrelated folder: its folder and the process."""
    cwd = tmp_path_factory.mktemp("anywhere")
    command = [sys.executable, "-m", "deltacal.cli", "demo", "--printer", "--quick", "--out", "out"]
    proc = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300)
    return cwd / "out", proc


def _row(summary: dict, method: str) -> dict:
    return next(r for r in summary["rows"] if r["method"] == method)


def test_printer_demo_writes_the_whole_path(demo):
    out, proc = demo
    assert proc.returncode == 0, proc.stderr
    assert "identified" in proc.stderr  # progress on the long steps
    for name in FILES:
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "printer_demo.json").read_text())
    assert summary["seed"] == SEED
    assert [r["method"] for r in summary["rows"]] == list(ROWS)
    table = printer_table(summary)
    for method in ROWS:
        assert method in table and method in proc.stdout
    # what a user hands over reads back: the measurements, the calibration, both configurations
    assert len(read_probe_heights(out / "probe_measured.csv").commanded) == summary["probe_points"] == 49
    assert len(read_printed_distances(out / "distances_measured.csv").distance) == summary["distances"] == 40
    calibration = load_calibration(out / "printer_calibration.toml")
    assert calibration.geometry.joint == "prismatic"
    # it records the configuration it was measured through, as identify's does (issue 46)
    assert calibration.controller is not None and calibration.controller.firmware == "klipper"
    assert calibration.controller.values["stepper_a.position_endstop"] == pytest.approx(
        load_klipper(out / "printer.cfg").position_endstop[0])
    assert calibration.controller.changes(KLIPPER.values_read(load_klipper(out / "printer.cfg"))) == []
    nominal = load_klipper(out / "printer.cfg")
    assert (out / "printer_calibrated.cfg").read_text().count("position_endstop:") == 3
    assert nominal.delta_radius == pytest.approx(134.4)


def test_printer_demo_g_code_route_beats_klippers_calibration(demo):
    """On the demo's printer the G-code route's 3-D max is a third of Klipper's enhanced one's or less."""
    summary = json.loads((demo[0] / "printer_demo.json").read_text())
    gcode, enhanced = _row(summary, "deltacal G-code route"), _row(summary, "Klipper enhanced")
    basic, before = _row(summary, "Klipper basic"), _row(summary, "uncalibrated")
    assert gcode["max_3d_mm"] < enhanced["max_3d_mm"] / 3.0
    assert gcode["max_3d_mm"] < 0.05
    assert gcode["flatness_mm"] <= min(enhanced["flatness_mm"], basic["flatness_mm"])
    assert gcode["part_max_mm"] < enhanced["part_max_mm"] / 3.0
    assert before["max_3d_mm"] > 2.0 * basic["max_3d_mm"]
    assert 0.5 < summary["variance_factor"] < 2.0


def test_printer_demo_corrected_program_differs_only_in_moves(demo):
    """The corrected part is the part's program with its moves split and corrected; nothing else changed.

    Its first line is the marker that says it is corrected (for the demo's printer.cfg and calibration).
    """
    source = (demo[0] / "part.gcode").read_text().splitlines()
    marker, *corrected = (demo[0] / "part_corrected.gcode").read_text().splitlines()
    assert marker.startswith(MARKER) and marker.endswith("for printer.cfg with printer_calibration.toml")
    kept = [line for line in corrected if not line.startswith(("G0 ", "G1 "))]
    assert kept == [line for line in source if not line.startswith(("G0 ", "G1 ", "G2 "))]
    moves = np.array([[float(w[1:]) for w in line.split()[1:4]] for line in corrected
                      if line.startswith(("G0 ", "G1 "))])
    assert len(moves) > 10 * sum(line.startswith(("G0 ", "G1 ", "G2 ")) for line in source)
    assert np.all(np.isfinite(moves))


def _moves(path) -> np.ndarray:
    """Every G0/G1 end of a program the demo wrote (X Y Z on each) [mm], (N, 3)."""
    return np.array([[float(w[1:]) for w in line.split()[1:4]] for line in path.read_text().splitlines()
                     if line.startswith(("G0 ", "G1 "))])


def test_printer_demo_corrected_program_is_within_its_printer_cfg(demo):
    """Every move of part_corrected.gcode is one the demo's own printer.cfg accepts (Klipper's limits).

    Its first layer goes below Klipper's z 0 (the true bed is lower than the nominal values put it):
    printer.cfg holds the minimum_z_position that admits it.
    """
    cfg = load_klipper(demo[0] / "printer.cfg")
    moves = _moves(demo[0] / "part_corrected.gcode")
    assert np.min(moves[:, 2]) < 0.0
    assert cfg.minimum_z_position < np.min(moves[:, 2])
    assert cfg.outside(moves).tolist() == [0] * len(moves)


def test_compensate_refuses_a_program_its_cfg_refuses_by_line_with_key_and_value(demo, tmp_path, capsys):
    """The demo's calibration with Klipper's default minimum_z_position: refused; the value asked works."""
    out = demo[0]
    text = (out / "printer.cfg").read_text()
    assert "minimum_z_position:" in text
    default = tmp_path / "default.cfg"
    default.write_text("\n".join(line for line in text.splitlines() if "minimum_z_position" not in line)
                       + "\n")
    program = out / "part.gcode"
    command = ["compensate", str(out / "printer_calibration.toml"), str(program), "--controller",
               str(default), "-o", str(tmp_path / "sent.gcode")]
    assert main(command) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    written = _moves(out / "part_corrected.gcode")  # the same moves, corrected the same way
    lowest = np.min(written[:, 2])
    match = re.search(rf"error: {re.escape(str(program))}: line (\d+): corrected Z (-[0-9.]+) mm is below "
                      r"minimum_z_position 0 of default.cfg: set \[printer\] minimum_z_position: (-[0-9.]+); "
                      r"(\d+) commands refused in all", err)
    assert match is not None, err
    line, first, value, count = int(match[1]), float(match[2]), float(match[3]), int(match[4])
    assert program.read_text().splitlines()[line - 1].startswith(("G0 ", "G1 ", "G2 "))
    assert count == np.sum(written[:, 2] < 0.0)
    assert first in np.round(written[written[:, 2] < 0.0, 2], 4)
    assert lowest - 0.01 <= value <= lowest
    assert not (tmp_path / "sent.gcode").exists()
    # the value asked for admits the program: the same corrected program comes out
    with_value = default.read_text().replace("[printer]\n", f"[printer]\nminimum_z_position: {value}\n")
    default.write_text(with_value)
    assert main(command) == 0
    sent, demo = ((tmp_path / "sent.gcode").read_text().splitlines(),
                  (out / "part_corrected.gcode").read_text().splitlines())
    assert sent[0].startswith(MARKER) and demo[0].startswith(MARKER)  # each names its own files
    assert sent[1:] == demo[1:]


def test_compensate_refuses_csv_targets_its_cfg_refuses_by_row(demo, tmp_path, capsys):
    """Targets on the bed: those Klipper's default minimum_z_position refuses are named by their row."""
    out = demo[0]
    default = tmp_path / "default.cfg"
    default.write_text("\n".join(line for line in (out / "printer.cfg").read_text().splitlines()
                                 if "minimum_z_position" not in line) + "\n")
    targets = tmp_path / "targets.csv"
    grid = [(x, y, z) for z in (50.0, 0.0) for x in (-60.0, 0.0, 60.0) for y in (-60.0, 0.0, 60.0)]
    targets.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x},{y},{z}\n" for x, y, z in grid))
    base = ["compensate", str(out / "printer_calibration.toml"), str(targets), "-o"]
    assert main([*base, str(tmp_path / "ok.csv"), "--controller", str(out / "printer.cfg")]) == 0
    z_cmd = np.loadtxt(tmp_path / "ok.csv", delimiter=",", skiprows=1)[:, 5]
    below = np.flatnonzero(z_cmd < 0.0)
    assert below.size and np.all(below >= 9)  # the bed's rows, not those at z 50
    capsys.readouterr()
    assert main([*base, str(tmp_path / "sent.csv"), "--controller", str(default)]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    first = int(below[0])
    assert (f"{targets}: line {first + 2} (data row {first + 1}): corrected Z {z_cmd[first]:.4f} mm is below "
            "minimum_z_position 0 of default.cfg: set [printer] minimum_z_position: ") in err
    assert f"{below.size} commands refused in all" in err or below.size == 1
    assert not (tmp_path / "sent.csv").exists()
