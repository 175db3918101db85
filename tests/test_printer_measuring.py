"""Measuring a printer without typing numbers: the probe program, the labelled object, the sheet."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import kossel_printer_cfg
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.printer.firmware.base import PROBE_CLEARANCE, Firmware
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.measurement_files import read_probe_heights
from deltacal.printer.object import probe_grid

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
MOVE = re.compile(r"^G1 X(-?\d+\.\d{3}) Y(-?\d+\.\d{3}) Z(\d+\.\d{3}) F\d+$")


def probed_points(program: str) -> np.ndarray:
    """The (x, y) of each ``PROBE``: where the last move before it left the nozzle, and its height."""
    position = None
    homed = False
    out = []
    for line in program.splitlines():
        command = line.split(";")[0].strip()
        if command == "G28":
            homed = True
        elif (m := MOVE.match(command)) is not None:
            position = tuple(float(v) for v in m.groups())
        elif command.startswith("G1 Z") and position is not None:
            position = (position[0], position[1], float(command.split()[1][1:]))
        elif command == "PROBE":
            assert homed, "PROBE before G28"
            assert position is not None
            out.append(position)
    return np.array(out)


# ------------------------------------------------------------------ the probe program
def test_klipper_probe_program_probes_each_point_in_order():
    grid = probe_grid(115.0, 7)
    program = KLIPPER.probe_program(grid, title="test")
    assert isinstance(KLIPPER, Firmware)
    assert program.splitlines()[0] == "; test"
    probed = probed_points(program)
    assert_allclose(probed[:, :2], grid[:, :2], rtol=0, atol=0)  # to the micrometre, as Klipper echoes
    assert np.all(probed[:, 2] == PROBE_CLEARANCE)  # each PROBE starts from the clearance
    assert program.count("PROBE\n") == len(grid)
    # after each probe the nozzle rises straight up before the next horizontal move
    lines = [line for line in program.splitlines() if not line.startswith(";")]
    after = [lines[k + 1] for k, line in enumerate(lines) if line == "PROBE"]
    assert all(line.startswith(f"G1 Z{PROBE_CLEARANCE:.3f} ") for line in after)
    with pytest.raises(ValueError, match="clearance"):
        KLIPPER.probe_program(grid, clearance=0.0)


def test_plan_writes_the_probe_program_of_probe_csv(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    out = tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(out),
                 "--distances", "12"]) == 0
    assert "probe.gcode" in capsys.readouterr().out
    probe = read_probe_heights(out / "probe.csv", filled=False)
    probed = probed_points((out / "probe.gcode").read_text())
    assert len(probed) == len(probe.commanded) == 49
    assert_allclose(probed[:, :2], probe.commanded[:, :2], rtol=0, atol=5e-4)
