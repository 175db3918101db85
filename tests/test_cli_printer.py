"""``deltacal identify`` of a printer: plan's templates filled by a simulated printer."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from conftest import kossel_printer_cfg

from deltacal.cli.main import main
from deltacal.io import load_calibration
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.measurement_files import write_printed_distances, write_probe_heights
from deltacal.printer.robot_file import load_printer
from deltacal.printer.simulation import printed_distances, probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"


def _column(path: Path, keys: tuple[str, ...]) -> np.ndarray:
    with open(path) as f:
        return np.array([[float(row[k]) for k in keys] for row in csv.DictReader(f)])


def test_plan_simulate_identify_a_printer(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    plan = ["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(tmp_path / "plan")]
    assert main(plan) == 0
    printer, firmware = load_printer(KOSSEL), load_klipper(cfg)
    rng = np.random.default_rng(24)
    truth = random_printer(printer, rng, typical_kit())
    xy = _column(tmp_path / "plan" / "probe.csv", ("x_mm", "y_mm"))
    probe = probe_heights(truth, firmware, printer.step_distance, xy, 0.01, rng)
    write_probe_heights(tmp_path / "probe.csv", probe[:, :2], probe[:, 2])
    keys = ("x1_mm", "y1_mm", "z1_mm", "x2_mm", "y2_mm", "z2_mm")
    pairs = _column(tmp_path / "plan" / "distances.csv", keys)
    measured = printed_distances(truth, firmware, printer.step_distance, pairs, 0.02, rng)
    write_printed_distances(tmp_path / "d.csv", pairs, measured)
    out = tmp_path / "cal.toml"
    assert main(["identify", str(KOSSEL), str(tmp_path / "probe.csv"), str(tmp_path / "d.csv"),
                 "--controller", str(cfg), "-o", str(out)]) == 0
    assert "the build tolerances scaled by" in capsys.readouterr().out  # the measurements chose it
    calibration = load_calibration(out)
    assert calibration.model.name == "printer" and calibration.geometry.joint == "prismatic"
    # the identified printer's first layer is flat on the true bed
    layer = np.column_stack([xy * 0.8, np.full(len(xy), 0.2)])
    landed = exact.forward(truth, exact.inverse(calibration.geometry, layer)).point(truth.tool)
    assert np.ptp(landed[:, 2]) < 0.05


def test_a_printers_tolerance_scale_is_taken_as_asked_and_refused_for_a_rotary_delta(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    probe = tmp_path / "probe.csv"
    printer = load_printer(KOSSEL)
    firmware = load_klipper(cfg)
    xy = np.array([[r * np.cos(a), r * np.sin(a)]
                   for r in (0.0, 50.0, 100.0) for a in np.arange(0.0, 6.3, 0.7)])
    heights = probe_heights(printer.geometry(), firmware, printer.step_distance, xy, 0.01,
                            np.random.default_rng(4))
    write_probe_heights(probe, heights[:, :2], heights[:, 2])
    out = tmp_path / "c.toml"
    assert main(["identify", str(KOSSEL), str(probe), "--controller", str(cfg), "-o", str(out),
                 "--tolerance-scale", "0.25"]) == 0
    assert "the build tolerances scaled by 0.25 (as asked)" in capsys.readouterr().out
    rotary = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "flexpicker.toml"
    code = main(["identify", str(rotary), str(probe), "-o", str(tmp_path / "r.toml"),
                 "--tolerance-scale", "1"])
    assert code == 2 and "--tolerance-scale applies to a printer" in capsys.readouterr().err
    assert not (tmp_path / "r.toml").exists()


def test_a_printers_measurements_need_the_firmware(tmp_path, capsys):
    probe = tmp_path / "probe.csv"
    write_probe_heights(probe, np.zeros((3, 2)), np.zeros(3))
    assert main(["identify", str(KOSSEL), str(probe), "-o", str(tmp_path / "c.toml")]) == 2
    assert "give --controller printer.cfg" in capsys.readouterr().err
    assert not (tmp_path / "c.toml").exists()


@pytest.mark.parametrize("flag", [["--distances"], ["--compliance"]])
def test_rotary_options_are_refused_for_a_printer(tmp_path, capsys, flag):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    probe = tmp_path / "probe.csv"
    write_probe_heights(probe, np.zeros((3, 2)), np.zeros(3))
    code = main(["identify", str(KOSSEL), str(probe), "--controller", str(cfg),
                 "-o", str(tmp_path / "c.toml"), *flag])
    assert code == 2 and "applies to a rotary Delta" in capsys.readouterr().err
