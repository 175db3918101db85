"""Klipper's probe results read back from its logs (every format it prints for a probe).

The round trip: the program ``plan --object`` writes, run on a simulated printer (the true
printer's probe triggers, through Klipper's model of printer.cfg), rendered as Klipper prints it
(``klippy/extras/probe.py``: before 2026 ``probe at X,Y is z=Z`` of the toolhead and ``Result is
z=Z``; from 2026 ``probe: at X,Y bed will contact at z=Z`` of the probe, its offsets applied, and
``Result: at X,Y estimate contact at z=Z``; ``Probe samples exceed tolerance. Retrying...`` when
the samples of a point spread more than ``samples_tolerance``), read back by ``import``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import kossel_printer_cfg
from numpy.testing import assert_allclose
from test_printer_measuring import probed_points

from deltacal.cli.main import main
from deltacal.exceptions import InputError
from deltacal.io import load_calibration
from deltacal.printer.files.measurements import read_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper, read_klipper_config
from deltacal.printer.firmware.klipper.log import ProbeOffsets, probe_offsets, read_probe_log
from deltacal.printer.simulation import nozzle_positions, probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
#: The [probe] of the simulated printer: its tip 1.5 mm left, 2 mm behind and 1.2 mm below the nozzle.
OFFSETS = ProbeOffsets(-1.5, 2.0, 1.2)
PROBE_SECTION = f"\n[probe]\npin: ^PA4\nx_offset: {OFFSETS.x}\ny_offset: {OFFSETS.y}\nz_offset: {OFFSETS.z}\n"
SAMPLES = 2
TOLERANCE = 0.02
OUTLIER = 0.1


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """plan --object's program run on a simulated printer: each point probed SAMPLES times."""
    folder = tmp_path_factory.mktemp("probelog")
    cfg = kossel_printer_cfg(folder / "printer.cfg")
    cfg.write_text(cfg.read_text() + PROBE_SECTION)
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(folder / "plan")]) == 0
    points = probed_points((folder / "plan" / "probe.gcode").read_text())[:, :2]
    printer, klipper = load_printer(KOSSEL), load_klipper(cfg)
    rng = np.random.default_rng(5)
    truth = random_printer(printer, rng, typical_kit())
    tip = (OFFSETS.x, OFFSETS.y, -OFFSETS.z)
    commanded = probe_heights(truth, klipper, printer.step_distance, np.repeat(points, SAMPLES, axis=0),
                              0.003, rng, tip)
    return folder, cfg, points, commanded.reshape(len(points), SAMPLES, 3), truth


def _console(lines: list[str]) -> str:
    return "".join(f"// {line}\n" for line in lines)


def _klippy_log(lines: list[str]) -> str:
    return "Start printer at Mon Aug 10 09:00:00 2026 (1786352400.0 8.1)\n" + "".join(f"{x}\n" for x in lines)


def _run(commanded: np.ndarray, sample, result) -> list[str]:
    """The lines of PROBE at each point (Klipper's run_probe): the third point's first sample an outlier."""
    lines = []
    for k, samples in enumerate(commanded):
        lines.append("$ PROBE")
        if k == 2:
            lines += [sample(samples[0] + [0.0, 0.0, OUTLIER]), sample(samples[0]),
                      "Probe samples exceed tolerance. Retrying..."]
        lines += [sample(s) for s in samples]
        assert np.ptp(samples[:, 2]) <= TOLERANCE
        lines.append(result(samples.mean(axis=0)))
    return lines


def klipper_2025(commanded: np.ndarray) -> list[str]:
    """The toolhead's position at each trigger."""
    return _run(commanded, lambda p: f"probe at {p[0]:.3f},{p[1]:.3f} is z={p[2]:.6f}",
                lambda p: f"Result is z={p[2]:.6f}")


def klipper_2026(commanded: np.ndarray) -> list[str]:
    """The probe's position at each trigger: the nozzle's + (x_offset, y_offset, -z_offset)."""
    def line(head, verb):
        def text(p):
            x, y, z = p + [OFFSETS.x, OFFSETS.y, -OFFSETS.z]
            return f"{head} at {x:.3f},{y:.3f} {verb} at z={z:.6f}"
        return text
    return _run(commanded, line("probe:", "bed will contact"), line("Result:", "estimate contact"))


@pytest.mark.parametrize("render", [klipper_2025, klipper_2026])
@pytest.mark.parametrize("frame", [_console, _klippy_log])
def test_a_probe_program_run_and_logged_reads_back_as_the_simulation(probed, tmp_path, capsys, render, frame):
    folder, cfg, points, commanded, truth = probed
    log = tmp_path / "klippy.log"
    log.write_text(frame(render(commanded)))
    out = tmp_path / "probe.csv"
    assert main(["import", str(log), "--config", str(cfg), "-o", str(out)]) == 0
    assert f"{commanded.size // 3} probe results" in capsys.readouterr().out
    read = read_probe_heights(out)
    expected = commanded.reshape(-1, 3)
    assert_allclose(read.commanded[:, :2], np.repeat(points, SAMPLES, axis=0), rtol=0, atol=1e-9)
    assert_allclose(read.commanded[:, 2], expected[:, 2], rtol=0, atol=5e-7 + 1e-9)  # Klipper's %.6f
    assert read.trigger_height.tolist() == [OFFSETS.z] * len(expected)
    if frame is _console:
        return
    cal = tmp_path / "cal.toml"
    assert main(["identify", str(KOSSEL), str(out), "--controller", str(cfg), "-o", str(cal)]) == 0
    result = load_calibration(cal)
    klipper, step = load_klipper(cfg), load_printer(KOSSEL).step_distance
    found = nozzle_positions(result.geometry, klipper, step, expected, result.geometry.tool)
    true = nozzle_positions(truth, klipper, step, expected, truth.tool)
    assert np.max(np.abs(found[:, 2] - true[:, 2])) < 0.1


def test_the_2026_lines_without_the_config_are_refused_in_one_line(probed, tmp_path, capsys):
    log = tmp_path / "klippy.log"
    log.write_text(_console(klipper_2026(probed[3][:2])))
    assert main(["import", str(log), "-o", str(tmp_path / "probe.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: line 2: " in err and "--config printer.cfg" in err
    assert not (tmp_path / "probe.csv").exists()


def test_the_2025_lines_without_the_config_carry_no_trigger_height(probed, tmp_path):
    log = tmp_path / "klippy.log"
    log.write_text(_console(klipper_2025(probed[3])))
    assert main(["import", str(log), "-o", str(tmp_path / "probe.csv")]) == 0
    read = read_probe_heights(tmp_path / "probe.csv")
    assert read.trigger_height.size == 0  # no such column
    assert_allclose(read.commanded[:, 2], probed[3].reshape(-1, 3)[:, 2], rtol=0, atol=5e-7 + 1e-9)


ACCURACY = """$ PROBE_ACCURACY SAMPLES=3
// PROBE_ACCURACY at X:10.000 Y:20.000 Z:5.000 (samples=3 retract=2.000 speed=5.0 lift_speed=5.0)
// probe: at 8.500,22.000 bed will contact at z=0.012500
// probe: at 8.500,22.000 bed will contact at z=0.015000
// probe: at 8.500,22.000 bed will contact at z=0.012500
// probe accuracy results: maximum 0.015000, minimum 0.012500, range 0.002500, average 0.013333, median \
0.012500, standard deviation 0.001179
$ PROBE
// probe: at 8.500,22.000 bed will contact at z=0.011000
// probe: at 8.500,22.000 bed will contact at z=0.051000
!! Probe samples exceed samples_tolerance
$ PROBE
// Result: at -21.500,2.000 estimate contact at z=-0.250000
"""


def test_probe_accuracy_each_sample_a_row_a_failed_probe_none_a_lone_result_one():
    log = read_probe_log("console.txt", ACCURACY, OFFSETS)
    assert_allclose(log.commanded, [[10.0, 20.0, 1.2125], [10.0, 20.0, 1.215], [10.0, 20.0, 1.2125],
                                    [-20.0, 0.0, 0.95]], rtol=0, atol=1e-12)
    assert log.lines.tolist() == [3, 4, 5, 12]


def test_the_probe_offsets_come_from_the_configs_probe_section(probed, tmp_path):
    assert probe_offsets(read_klipper_config(probed[1])) == OFFSETS
    bare = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=None)
    bare.write_text(bare.read_text() + "\n[smart_effector]\npin: PC1\nz_offset: 0.1\n")
    assert probe_offsets(read_klipper_config(bare)) == ProbeOffsets(0.0, 0.0, 0.1)
    kossel_printer_cfg(bare, probe_z_offset=None)
    with pytest.raises(InputError, match=r"printer.cfg: no probe section \(\[probe\]"):
        probe_offsets(read_klipper_config(bare))
    bare.write_text(bare.read_text() + "\n[probe]\npin: PC1\n")
    with pytest.raises(InputError, match=r"section \[probe\]: missing required key 'z_offset' \(the probe's"):
        probe_offsets(read_klipper_config(bare))


def test_config_applies_to_a_log_only(probed, tmp_path, capsys):
    assert main(["import", str(probed[1]), "--config", str(probed[1]), "-o", str(tmp_path / "out")]) == 2
    assert "--config applies to a log" in capsys.readouterr().err
