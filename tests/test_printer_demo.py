"""``deltacal demo --printer`` (issue 24): the whole path on a simulated printer, beside Klipper's own."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from deltacal.io import load_calibration
from deltacal.printer.demo import ROWS, SEED, printer_table
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.measurement_files import read_printed_distances, read_probe_heights

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
    assert load_calibration(out / "printer_calibration.toml").geometry.joint == "prismatic"
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
    """The corrected part is the part's program with its moves split and corrected; nothing else changed."""
    source = (demo[0] / "part.gcode").read_text().splitlines()
    corrected = (demo[0] / "part_corrected.gcode").read_text().splitlines()
    kept = [line for line in corrected if not line.startswith(("G0 ", "G1 "))]
    assert kept == [line for line in source if not line.startswith(("G0 ", "G1 ", "G2 "))]
    moves = np.array([[float(w[1:]) for w in line.split()[1:4]] for line in corrected
                      if line.startswith(("G0 ", "G1 "))])
    assert len(moves) > 10 * sum(line.startswith(("G0 ", "G1 ", "G2 ")) for line in source)
    assert np.all(np.isfinite(moves))
