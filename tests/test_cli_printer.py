"""``deltacal identify`` of a printer: plan's templates filled by a simulated printer."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from conftest import copy_object_plan, kossel_printer_cfg

from deltacal.cli.main import main
from deltacal.io import load_calibration
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import write_printed_distances, write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper
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
    capsys.readouterr()  # plan's words aside
    assert main(["identify", str(KOSSEL), str(tmp_path / "probe.csv"), str(tmp_path / "d.csv"),
                 "--controller", str(cfg), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "the build tolerances scaled by" in said  # the measurements chose it
    # issue 39: the owner's part first, in Klipper's words: each tower's endstop in mm and lean in deg,
    # the value that holds it, before any of the engineer's parameter names
    first = said.index("tower A: endstop")
    assert first < said.index("b11x") and first < said.index("The engineer's part")
    assert "[stepper_a] position_endstop" in said and "tower C: leans outwards" in said and " deg" in said
    assert "next: deltacal export" in said
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


@pytest.fixture(scope="module")
def measured(tmp_path_factory, kossel_object_plan):
    """A simulated printer's probe heights and distances on the planned object, and its printer.cfg."""
    folder = tmp_path_factory.mktemp("measured")
    cfg = copy_object_plan(kossel_object_plan, folder)
    printer, firmware = load_printer(KOSSEL), load_klipper(cfg)
    rng = np.random.default_rng(77)
    truth = random_printer(printer, rng, typical_kit())
    xy = _column(folder / "plan" / "probe.csv", ("x_mm", "y_mm"))
    probe = probe_heights(truth, firmware, printer.step_distance, xy, 0.01, rng)
    pairs = _column(folder / "plan" / "distances.csv", ("x1_mm", "y1_mm", "z1_mm", "x2_mm", "y2_mm", "z2_mm"))
    return cfg, probe, pairs, printed_distances(truth, firmware, printer.step_distance, pairs, 0.02, rng)


def _identify(tmp_path, measured, probe=None, distance=None, options=(), cfg=None):
    default_cfg, default_probe, pairs, default_distance = measured
    probe = default_probe if probe is None else probe
    write_probe_heights(tmp_path / "probe.csv", probe[:, :2], probe[:, 2])
    write_printed_distances(tmp_path / "d.csv", pairs, default_distance if distance is None else distance)
    return main(["identify", str(KOSSEL), str(tmp_path / "probe.csv"), str(tmp_path / "d.csv"),
                 "--controller", str(cfg or default_cfg), "-o", str(tmp_path / "cal.toml"), *options])


@pytest.mark.long
def test_a_gross_probe_height_is_refused_by_its_line(tmp_path, measured, capsys):
    probe = measured[1].copy()
    probe[6, 2] += 1.0
    assert _identify(tmp_path, measured, probe=probe) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "probe.csv: line 8 (data row 7), column z_mm: z_mm = " in err and "--accept-poor-fit" in err
    # the others' value: the height less the 1 mm
    expected = float(err.split("they give ")[1].split(" mm")[0])
    assert abs(expected - (probe[6, 2] - 1.0)) < 0.05
    assert not (tmp_path / "cal.toml").exists()
    assert _identify(tmp_path, measured, probe=probe, options=["--accept-poor-fit"]) == 0
    captured = capsys.readouterr()
    assert "probe.csv: line 8 (data row 7) does not fit the other measurements" in captured.err
    assert "outliers (data snooping at 4 σ): row 7" in captured.out


def test_a_mistyped_distance_is_refused_by_its_line(tmp_path, measured, capsys):
    distance = measured[3].copy()
    distance[7] += 2.0
    assert _identify(tmp_path, measured, distance=distance) == 1
    err = capsys.readouterr().err
    assert "d.csv: line 9 (data row 8), column distance_mm: distance_mm = " in err
    off = float(err.split("mm (")[1].split(" mm,")[0])  # what the reading is off by, about the others' fit
    assert abs(off - 2.0) < 0.1 and "σ of a distance off: a typo, a misread caliper?" in err


@pytest.mark.parametrize(("change", "expected"), [
    ("distance+10", "d.csv: line 5 (data row 4), column distance_mm: the distance measured"),
    ("cm", "centimetres? deltacal reads millimetres; 40 of 40 rows"),
    ("um", "column z_mm: the probe triggered at z_mm = "),
    ("m", "less than the probe's σ 0.01 mm: metres? deltacal reads millimetres"),
])
def test_files_in_another_unit_or_far_off_are_refused_in_one_line(tmp_path, measured, capsys, change,
                                                                   expected):
    probe, distance = measured[1].copy(), measured[3].copy()
    if change == "distance+10":
        distance[3] += 10.0
    elif change == "cm":
        distance = distance / 10.0
    elif change == "um":
        probe[:, 2] *= 1000.0
    else:
        probe[:, 2] /= 1000.0
    assert _identify(tmp_path, measured, probe=probe, distance=distance) == 1
    err = capsys.readouterr().err.strip()
    assert expected in err and len(err.splitlines()) == 1 and "deg" not in err
    assert not (tmp_path / "cal.toml").exists()


def test_a_probe_offset_off_the_effector_is_refused(tmp_path, measured, capsys):
    assert _identify(tmp_path, measured, options=["--probe-offset", "1000,0,0"]) == 2
    assert ("argument --probe-offset: the probe's trigger point is on the effector, within 100 mm of the "
            "nozzle; X = 1000 mm in '1000,0,0'") in capsys.readouterr().err


def test_a_configuration_of_another_step_distance_is_refused(tmp_path, measured, capsys):
    other = tmp_path / "other.cfg"
    other.write_text(measured[0].read_text().replace("microsteps: 16", "microsteps: 32"))
    assert _identify(tmp_path, measured, cfg=other) == 1
    err = capsys.readouterr().err
    assert "kossel.toml: key geometry.step_distance_mm = 0.0125 mm, but " in err
    assert ("other.cfg: sections [stepper_a..c], key rotation_distance gives 0.00625 mm per step "
            "(tower A)") in err
