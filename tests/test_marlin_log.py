"""Marlin's probe results read back from its console (``Bed X: x Y: y Z: z`` of G30 and G29 V3).

The round trip: the program ``plan --object`` writes for Marlin, run on a simulated printer whose
probe sits off the nozzle (``M851 X-1.5 Y2 Z-1.2``), rendered as Marlin prints it (``G30.cpp``: the
probe's position, the bed's height under it ``run_z_probe() + M851 Z``, with Marlin's default two
decimals), read back by ``import``; and an ``M503`` capture imported as a robot file.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import read_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import log_firmware
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.settings import load_marlin
from deltacal.printer.simulation import probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
PRINTER = load_printer(KOSSEL)
OFFSET = np.array([-1.5, 2.0, -1.2])  # M851: the probe 1.5 mm left, 2 mm behind, 1.2 mm below the nozzle
#: Half of the last decimal Marlin prints (SERIAL_FLOAT_PRECISION 2), and the float's rounding.
PRINTED = 0.005 + 1e-9
MOVE = re.compile(r"^G1 X(-?[\d.]+) Y(-?[\d.]+) Z")


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """plan --object's Marlin program run on a simulated kit printer: the commanded nozzle positions."""
    folder = tmp_path_factory.mktemp("marlinlog")
    nominal = MARLIN.nominal(PRINTER)  # H with M851 Z: the same home, the same printer
    marlin = replace(nominal, probe_offset=OFFSET, height=nominal.height + OFFSET[2])
    settings = MARLIN.save_config(folder / "m503.txt", marlin, complete=True)
    plan = folder / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(settings), "-o", str(plan)]) == 0
    program = (folder / "plan" / "probe.gcode").read_text().splitlines()
    points = np.array([[float(v) for v in MOVE.match(line).groups()]
                       for line, after in zip(program, program[1:], strict=False) if after == "G30"])
    rng = np.random.default_rng(11)
    truth = random_printer(PRINTER, rng, typical_kit())
    commanded = probe_heights(truth, marlin, PRINTER.step_distance, points, 0.003, rng, OFFSET)
    return folder, settings, points, commanded


def _console(commanded: np.ndarray) -> str:
    """What a host shows of Marlin's answers to the program's G30s."""
    lines = ["Send: G28", "Recv: ok"]
    for x, y, z in commanded:
        probe = (x + OFFSET[0], y + OFFSET[1], z + OFFSET[2])
        lines += ["Send: G30", f"Recv: Bed X: {probe[0]:.2f} Y: {probe[1]:.2f} Z: {probe[2]:.2f}",
                  f"Recv: X:{x:.2f} Y:{y:.2f} Z:{z + 5:.2f} E:0.00 Count A:0 B:0 C:0", "Recv: ok"]
    return "\n".join(lines) + "\n"


def test_the_probe_program_read_back_gives_the_simulated_probe_heights(probed, tmp_path, capsys):
    folder, settings, points, commanded = probed
    assert len(points) >= 10
    log = tmp_path / "console.log"
    log.write_text(_console(commanded))
    assert log_firmware(log.read_text()) is MARLIN
    out = tmp_path / "probe.csv"
    assert main(["import", str(log), "--config", str(settings), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"{len(points)} probe results of Marlin" in said and "trigger height 1.2 mm" in said
    read = read_probe_heights(out)
    assert_allclose(read.commanded, commanded, atol=PRINTED)
    assert_allclose(read.commanded[:, :2], points, atol=PRINTED)  # the program's points
    assert_allclose(read.trigger_height, 1.2, atol=0.0)  # -M851 Z: the nozzle above the bed at the trigger


def test_a_marlin_console_needs_its_m503_and_g33_alone_is_named(probed, tmp_path, capsys):
    _, _, _, commanded = probed
    log = tmp_path / "console.log"
    log.write_text(_console(commanded[:3]))
    assert main(["import", str(log), "-o", str(tmp_path / "probe.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: line 4: " in err and "--config M503.txt" in err
    assert not (tmp_path / "probe.csv").exists()
    g33 = tmp_path / "g33.log"
    g33.write_text("Send: G33 V3\nRecv: G33 Auto Calibrate\nRecv: .    c:+0.05  x:-0.12  y:+0.03  z:+0.08\n")
    assert log_firmware(g33.read_text()) is MARLIN and not KLIPPER.is_probe_log(g33.read_text())
    assert main(["import", str(g33), "--config", str(probed[1]), "-o", str(tmp_path / "probe.csv")]) == 1
    err = capsys.readouterr().err
    assert f"{g33}: line 3: G33's results" in err and "G30" in err


# ------------------------------------------------------------------ import M503.txt -o DIR
M503 = Path(__file__).parent / "data" / "marlin_m503.txt"


def test_an_m503_capture_imports_and_commands_the_nozzle_exactly(tmp_path, capsys):
    assert main(["import", str(M503), "--effector-radius", "25", "-o", str(tmp_path / "out")]) == 0
    assert "Marlin's model of" in capsys.readouterr().out
    text = (tmp_path / "out" / "printer.toml").read_text()
    assert "taken by default: rod spacing 50 mm, nozzle drop 30 mm" in text
    printer, marlin = load_printer(tmp_path / "out" / "printer.toml"), load_marlin(M503)
    assert_allclose(printer.rod_length, [269.10, 268.95, 269.00], atol=1e-12)  # L + A, B, C
    assert_allclose(np.degrees(printer.tower_azimuth), [210.12, 329.80, 90.08], atol=1e-9)
    assert_allclose(printer.step_distance, 1.0 / 80.0, atol=0.0)
    assert printer.workspace is not None and printer.workspace.radius == 115.0  # M211's Min/Max
    # commanding the file's nominal printer through Marlin's model puts the nozzle where commanded
    ws = printer.workspace
    rng = np.random.default_rng(7)
    r, a = ws.radius * np.sqrt(rng.random(200)), rng.uniform(0.0, 2.0 * np.pi, 200)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, ws.height, 200)])
    readings = MARLIN.controller(marlin, printer.step_distance).inverse(targets)
    nozzle = exact.forward(printer.geometry(), readings).point(printer.tool)
    assert np.max(np.abs(nozzle - targets)) < 1e-9
    home = exact.forward(printer.geometry(), np.zeros((1, 3)) + marlin.homing_moves).point(printer.tool)
    assert_allclose(home[0], [0.0, 0.0, 296.8], atol=1e-9)  # G28 with M666: H - M851 Z
