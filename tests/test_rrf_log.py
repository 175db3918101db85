"""RepRapFirmware's probe results read back from its console, and G31 read from config.g.

The round trip: the program ``plan --object`` writes for a config.g, run on a simulated printer
(the true printer's probe triggers, through RRF's model of config.g, tilt and all), rendered as RRF
answers it (``echo "probe at X,Y"`` prints the text; ``G30 S-1`` answers ``Stopped at height %.3f
mm``, ``GCodes4.cpp``), read back by ``import``, then identified.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.exceptions import InputError
from deltacal.io import load_calibration
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import read_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.probe_log import ProbeOffsets
from deltacal.printer.firmware.rrf.config import (
    load_rrf,
    read_rrf_settings,
    rrf_config_text,
    rrf_probe_offsets,
)
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.firmware.rrf.log import read_rrf_probe_log
from deltacal.printer.firmware.rrf.model import RRFController, RRFDelta
from deltacal.printer.simulation import nozzle_positions, probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
DATA = Path(__file__).resolve().parent / "data" / "rrf"
DATA = Path(__file__).resolve().parent / "data" / "rrf"
#: The simulated printer's probe: 1.5 mm left of, 2 mm behind the nozzle, triggering 1.2 mm above the bed.
G31 = ProbeOffsets(-1.5, 2.0, 1.2)
#: A point whose probing move fails (RRF's error, no answer kept).
FAILED = 3
ECHO = re.compile(r'^echo "(.*)"$')


def config_g(path: Path) -> Path:
    """The nominal kossel's config.g, tilted bed, with a probe (G31) and a second one (K1) not read."""
    rrf = RRFDelta.from_printer(load_printer(KOSSEL))
    rrf = RRFDelta(rrf.diagonal, rrf.radius, rrf.homed_height, rrf.angle_correction, rrf.endstop_adjustment,
                   np.array([0.0006, -0.0003]), rrf.step_distance, rrf.print_radius)
    text = rrf_config_text(rrf, complete=True, title="kossel")
    path.write_text(text + f"G31 P500 X{G31.x} Y{G31.y} Z{G31.z}\nG31 K1 P500 X9 Y9 Z9\n")
    return path


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """plan --object's program for config.g, each G30 S-1 run on a simulated printer."""
    folder = tmp_path_factory.mktemp("rrflog")
    config = config_g(folder / "config.g")
    plan = ["plan", str(KOSSEL), "--object", "--controller", str(config), "-o", str(folder / "plan")]
    assert main(plan) == 0
    program = (folder / "plan" / "probe.gcode").read_text().splitlines()
    echoed = [m.group(1) for line in program if (m := ECHO.match(line))]
    points = np.array([[float(v) for v in text.removeprefix("probe at ").split(",")] for text in echoed])
    assert program.count("G30 S-1") == len(points) > 10
    printer, rrf = load_printer(KOSSEL), load_rrf(config)
    rng = np.random.default_rng(11)
    truth = random_printer(printer, rng, typical_kit())
    commanded = probe_heights(truth, rrf, printer.step_distance, points, 0.003, rng, (G31.x, G31.y, -G31.z))
    return folder, config, program, commanded, truth


def console(program: list[str], commanded: np.ndarray, stamp: bool) -> str:
    """What RRF answers to the program: each echo's text, each G30 S-1's stopped height, ``ok``s.

    With ``stamp``, as Duet Web Control's console saves it (a time before each answer); the
    :data:`FAILED` point's probing move fails.
    """
    out, k = [], 0
    for line in program:
        command = line.split(";")[0].strip()
        if not command:
            continue
        if (m := ECHO.match(command)) is not None:
            out.append(m.group(1))
            k += 1
        elif command == "G30 S-1":
            if k == FAILED:
                out.append("Error: G30: Probe was not triggered during probing move")
            out.append(f"Stopped at height {commanded[k - 1, 2]:.3f} mm")
        out.append("ok")
    return "".join((f"10:{i // 60 % 60:02d}:{i % 60:02d} " if stamp else "") + f"{text}\n"
                   for i, text in enumerate(out))


@pytest.mark.parametrize("stamp", [False, True])
def test_the_probe_program_run_and_logged_reads_back_as_the_simulation(probed, tmp_path, capsys, stamp):
    folder, config, program, commanded, truth = probed
    log = tmp_path / "console.txt"
    log.write_text(console(program, commanded, stamp))
    out = tmp_path / "probe.csv"
    assert main(["import", str(log), "--config", str(config), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"{len(commanded) - 1} probe results of RepRapFirmware" in said
    assert f"trigger height 1.2 mm (G31 Z of {config})" in said
    read = read_probe_heights(out)
    expected = np.delete(commanded, FAILED - 1, axis=0)  # the failed point has no row
    assert_allclose(read.commanded[:, :2], expected[:, :2], rtol=0, atol=1e-9)
    assert_allclose(read.commanded[:, 2], expected[:, 2], rtol=0, atol=5e-4 + 1e-9)  # RRF's %.3f
    assert read.trigger_height.tolist() == [G31.z] * len(expected)
    if stamp:
        return
    cal = tmp_path / "cal.toml"
    assert main(["identify", str(KOSSEL), str(out), "--controller", str(config), "-o", str(cal)]) == 0
    result = load_calibration(cal)
    rrf, step = load_rrf(config), load_printer(KOSSEL).step_distance
    found = nozzle_positions(result.geometry, rrf, step, expected, result.geometry.tool)
    true = nozzle_positions(truth, rrf, step, expected, truth.tool)
    assert np.max(np.abs(found[:, 2] - true[:, 2])) < 0.1


def test_without_the_config_no_trigger_height(probed, tmp_path):
    folder, config, program, commanded, truth = probed
    log = tmp_path / "console.txt"
    log.write_text(console(program, commanded, False))
    assert main(["import", str(log), "-o", str(tmp_path / "probe.csv")]) == 0
    read = read_probe_heights(tmp_path / "probe.csv")
    assert read.trigger_height.size == 0  # no such column
    assert len(read.commanded) == len(commanded) - 1


def test_a_stopped_height_without_its_point_is_refused_in_one_line(tmp_path, capsys):
    log = tmp_path / "console.txt"
    log.write_text("G30 S-1\nStopped at height 1.204 mm\nok\n")
    assert main(["import", str(log), "-o", str(tmp_path / "probe.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: line 2: 'Stopped at height' follows no 'probe at X,Y'" in err
    assert not (tmp_path / "probe.csv").exists()


def test_samples_at_one_point_and_a_failed_point():
    text = ("probe at 10.000,-20.500\nStopped at height 1.211 mm\nStopped at height 1.213 mm\n"
            "probe at 0.000,0.000\nError: G30: Probe already triggered at start of probing move\n"
            "Stopped at height 9.000 mm\nprobe at -5.000,5.000\nStopped at height 1.190 mm\n")
    log = read_rrf_probe_log("console.txt", text, G31)
    assert_allclose(log.commanded, [[10.0, -20.5, 1.211], [10.0, -20.5, 1.213], [-5.0, 5.0, 1.19]],
                    rtol=0, atol=1e-12)
    assert log.lines.tolist() == [2, 3, 8] and log.trigger_height.tolist() == [1.2] * 3
    with pytest.raises(InputError, match="no probe result in this log"):
        read_rrf_probe_log("console.txt", "probe at 1.000,2.000\nok\n")


def test_g31_of_the_first_probe_read_defaults_otherwise(probed, tmp_path):
    assert rrf_probe_offsets(read_rrf_settings(probed[1])) == G31  # K1's G31 is another probe's
    bare = tmp_path / "config.g"
    bare.write_text("M665 L269 R134.4 H295\nM92 X80 Y80 Z80\n")
    assert rrf_probe_offsets(read_rrf_settings(bare)) == ProbeOffsets(0.0, 0.0, 0.7)  # RRF's defaults
    bare.write_text(bare.read_text() + "G31 P500 X1 Y2 Z{1+1}\n")
    with pytest.raises(InputError, match=r"config.g: line 3, G31 Z: value '\{1\+1\}' is an expression"):
        read_rrf_settings(bare)


# ------------------------------------------------------------------ import config.g
def test_import_config_g_commands_the_nozzle_exactly_through_rrfs_model(tmp_path, capsys):
    """Per-tower rods, corrected azimuths, endstops: the file's nominal through RRF's model, tilt zeroed."""
    assert main(["import", str(DATA / "config.g"), "-o", str(tmp_path / "out"), "--nozzle-drop", "25"]) == 0
    said = capsys.readouterr().out
    assert "its bed tilt M666 A B (0.05, -0.02 %) is not in the file" in said
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["printer.toml"]
    text = (tmp_path / "out" / "printer.toml").read_text()
    assert "# Bed tilt M666 A0.05 B-0.02 (percent) of config.g: not a robot file value" in text
    printer, rrf = load_printer(tmp_path / "out" / "printer.toml"), load_rrf(DATA / "config.g")
    assert printer.rod_length.tolist() == [269.0, 269.5, 268.8]  # M665 L269:269.5:268.8
    assert_allclose(np.degrees(printer.tower_azimuth), [210.1, 329.8, 90.0], rtol=0, atol=1e-12)
    assert printer.tower_radius - printer.effector_radius == 134.5  # config-override.g's R wins
    assert_allclose(printer.endstop_height, 295.7 + np.sqrt(rrf.diagonal**2 - 134.5**2) + [0.2, -0.1, -0.1]
                    + 25.0, rtol=0, atol=1e-12)
    assert printer.step_distance.tolist() == [1 / 80] * 3
    flat = RRFDelta(rrf.diagonal, rrf.radius, rrf.homed_height, rrf.angle_correction, rrf.endstop_adjustment,
                    step_distance=rrf.step_distance)
    ws = printer.workspace
    assert ws is not None and ws.radius == 115.0  # M665 B
    rng = np.random.default_rng(4)
    r, a = ws.radius * np.sqrt(rng.random(300)), rng.uniform(0.0, 2.0 * np.pi, 300)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, ws.height, 300)])
    readings = RRFController(flat, printer.step_distance).inverse(targets)
    nozzle = exact.forward(printer.geometry(), readings).point(printer.tool)
    assert np.max(np.abs(nozzle - targets)) < 1e-9
    tilted = RRFController(rrf, printer.step_distance).inverse(targets)  # the tilt is not in the file
    assert np.max(np.abs(exact.forward(printer.geometry(), tilted).point(printer.tool) - targets)) > 0.01


def test_import_config_g_then_identify_its_probe_log(probed, tmp_path):
    folder, config, program, commanded, truth = probed
    assert main(["import", str(config), "-o", str(tmp_path / "out")]) == 0
    log = tmp_path / "console.txt"
    log.write_text(console(program, commanded, False))
    assert main(["import", str(log), "--config", str(config), "-o", str(tmp_path / "probe.csv")]) == 0
    printer = tmp_path / "out" / "printer.toml"
    cal = tmp_path / "cal.toml"
    assert main(["identify", str(printer), str(tmp_path / "probe.csv"), "--controller", str(config),
                 "-o", str(cal)]) == 0
    assert load_calibration(cal).geometry.chain.firmware


def test_a_config_without_a_printable_volume_is_refused_in_one_line(tmp_path, capsys):
    config = tmp_path / "config.g"
    config.write_text("M665 L269 R134.4 H-300\nM92 X80 Y80 Z80\n")
    assert main(["import", str(config), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "M665 H" in err and "no printable volume above the bed" in err
    assert not (tmp_path / "out" / "printer.toml").exists()


# ------------------------------------------------------------------ homedelta.g
HOMEDELTA = """; homedelta.g in the shape RRF's configuration tool writes (written for deltacal's tests)
G91                              ; relative positioning
G1 H1 X705 Y705 Z705 F1800       ; move all towers to the high end stopping at the endstops (first pass)
G1 H2 X-5 Y-5 Z-5 F1800          ; go down a few mm
G1 H1 X10 Y10 Z10 F360           ; move all towers up once more (second pass)
G1 Z-5 F6000                     ; move down a few mm so that the nozzle can be centred
G90                              ; absolute positioning
G1 X0 Y0 F6000                   ; move X+Y to the centre
"""


def test_g28_leaves_the_nozzle_where_homedelta_g_moves_it(tmp_path):
    config = tmp_path / "config.g"
    config.write_text((DATA / "config.g").read_text())
    (tmp_path / "config-override.g").write_text((DATA / "config-override.g").read_text())
    endstops = load_rrf(config).home_position
    assert_allclose(RRF_FIRMWARE.dialect(config).home, endstops, rtol=0, atol=0)  # no homedelta.g
    (tmp_path / "homedelta.g").write_text(HOMEDELTA)
    assert_allclose(RRF_FIRMWARE.dialect(config).home, [0.0, 0.0, endstops[2] - 5.0], rtol=0, atol=1e-12)
    (tmp_path / "homedelta.g").write_text(HOMEDELTA.replace("G90  ", "G30  "))
    with pytest.raises(InputError, match=r"homedelta.g: line 7: G30 after the last G1 H1: where G28 leaves"):
        RRF_FIRMWARE.dialect(config)
    (tmp_path / "homedelta.g").write_text(HOMEDELTA + "G1 H2 Z-2\n")
    with pytest.raises(InputError, match=r"homedelta.g: line 9: G1 H2 moves single motors to absolute"):
        RRF_FIRMWARE.dialect(config)

