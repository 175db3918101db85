"""A calibration (or robot file) and a firmware's settings of different printers are refused, every command.

The other printer is a real configuration of ``tests/data/klipper/`` (an FLSUN QQS or Q5 beside a
Kossel's calibration) or an ``M503`` capture written here for a Q5-sized printer; the same printer's
exported values are not refused.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.geometry import Tolerances
from deltacal.io import load_calibration
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.base import classical_values
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.simulation import random_printer

KOSSEL = MODELS / "kossel.toml"
PRINTER = load_printer(KOSSEL)
DATA = Path(__file__).resolve().parent / "data"
QQS = DATA / "klipper" / "printer-flsun-qqs-2020.cfg"  # delta_radius 130, arm 280, endstop 370
Q5 = DATA / "klipper" / "printer-flsun-q5-2020.cfg"  # delta_radius 107.5, arm_length 215, same step distance
#: Marlin's M503 of a printer of a Q5's size (the shape of tests/data/marlin_m503.txt, other values).
OTHER_M503 = """echo:  M92 X80.00 Y80.00 Z80.00 E415.00
echo:  M666 X-0.20 Y0.00 Z-0.35
echo:  M665 L215.00 R107.50 H220.00 S200.00 X0.00 Y0.00 Z0.00 A0.00 B0.00 C0.00
echo:  M851 X0.00 Y0.00 Z0.00 ; (mm)
"""


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    return err


def test_classical_values_are_klippers_and_marlins_own():
    klipper, marlin = KLIPPER.read_config(QQS), MARLIN.nominal(PRINTER)
    radius, arm, endstop = classical_values(klipper)
    assert radius == pytest.approx(130.0, abs=1e-9)
    np.testing.assert_allclose(arm, 280.0, atol=1e-9)
    np.testing.assert_allclose(endstop, 370.0, atol=1e-9)
    radius, arm, endstop = classical_values(marlin)  # Marlin's M665/M666 of the Kossel
    nominal = KLIPPER.nominal(PRINTER)
    assert radius == pytest.approx(nominal.delta_radius, abs=1e-9)
    np.testing.assert_allclose(arm, nominal.arm_length, atol=1e-9)
    np.testing.assert_allclose(endstop, nominal.position_endstop, atol=1e-6)


def test_another_printers_values_are_refused_naming_both():
    with pytest.raises(InputError, match=r"position_endstop \(tower [ABC]\) is 295.601 mm in cal.toml but "
                                         r"370 mm in qqs.cfg: further apart than any build could be"):
        KLIPPER.check_same_printer(KLIPPER.nominal(PRINTER), KLIPPER.read_config(QQS), "cal.toml", "qqs.cfg")
    with pytest.raises(InputError, match=r"^delta_radius is 134.4 mm in a but 107.5 mm in b"):
        KLIPPER.check_same_printer(KLIPPER.nominal(PRINTER), KLIPPER.read_config(Q5), "a", "b")


def test_another_printers_m503_is_refused(tmp_path):
    other = tmp_path / "m503.txt"
    other.write_text(OTHER_M503)
    with pytest.raises(InputError, match=r"^M665 R is 134.4 mm in a but 107.5 mm in b"):
        MARLIN.check_same_printer(MARLIN.nominal(PRINTER), MARLIN.read_config(other), "a", "b")


@pytest.mark.long
def test_kit_printers_and_their_exported_values_are_not_refused():
    """10 simulated kit printers: their values, the nominal ones and the fitted ones (export's) agree."""
    nominal = {firmware.name: firmware.nominal(PRINTER) for firmware in (KLIPPER, MARLIN)}
    largest = np.zeros(3)
    for seed in range(10):
        truth = random_printer(PRINTER, np.random.default_rng(seed), Tolerances.printer_kit())
        for firmware in (KLIPPER, MARLIN):
            start = firmware.start(truth)
            fitted = firmware.fit(truth, nominal[firmware.name], PRINTER.step_distance, PRINTER.workspace,
                                  first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT).values
            for other in (nominal[firmware.name], fitted):
                firmware.check_same_printer(start, other, "cal.toml", "printer.cfg")
                firmware.check_same_printer(other, start, "printer.cfg", "cal.toml")
                ours, theirs = classical_values(start), classical_values(other)
                largest = np.maximum(largest, [abs(ours[0] - theirs[0]), np.max(abs(ours[1] - theirs[1])),
                                               np.max(abs(ours[2] - theirs[2]))])
    # the bounds' margin (same_printer's docstring): each at least 4 times the largest difference
    assert largest[0] * 4 < 0.05 * 134.4 and largest[1] * 4 < 0.05 * 269.0 and largest[2] * 4 < 20.0


# --------------------------------------------------------------------------- the commands
def test_identify_refuses_another_printers_configuration(tmp_path, capsys):
    probe, distances = tmp_path / "probe.csv", tmp_path / "d.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n50,0,0.2\n0,50,0.1\n")
    distances.write_text("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm\n0,0,8,50,0,8,50\n")
    assert main(["identify", str(KOSSEL), str(probe), str(distances), "--controller", str(Q5),
                 "-o", str(tmp_path / "cal.toml")]) == 1
    err = _one_line(capsys)
    assert "delta_radius is 134.4 mm in " in err and "but 107.5 mm in " in err and "different printers" in err
    assert not (tmp_path / "cal.toml").exists()


def test_simulate_and_plan_refuse_another_printers_configuration(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(tmp_path / "obj")]) == 0
    capsys.readouterr()
    assert main(["simulate", str(KOSSEL), str(tmp_path / "obj" / "probe.csv"), "--controller", str(QQS),
                 "--perturb", "3", "-o", str(tmp_path / "p.csv")]) == 1
    err = _one_line(capsys)
    assert "position_endstop" in err and "but 370 mm in " in err and not (tmp_path / "p.csv").exists()
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(Q5), "-o", str(tmp_path / "o2")]) == 1
    assert "delta_radius is 134.4 mm" in _one_line(capsys) and not (tmp_path / "o2").exists()


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory, kossel_identified):
    """A Kossel identified through its printer.cfg (plan --object, simulate, identify; seed 5)."""
    folder = tmp_path_factory.mktemp("same_printer")
    shutil.copytree(kossel_identified, folder, dirs_exist_ok=True)
    targets = folder / "targets.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,0.2\n40,-30,10\n")
    program = folder / "part.gcode"
    program.write_text("G28\nG90\nG1 X0 Y0 Z5 F3000\nG1 X20 Y10 Z0.3\n")
    return folder


@pytest.mark.slow
def test_compensate_refuses_another_printers_configuration(calibrated, tmp_path, capsys):
    cal = calibrated / "cal.toml"
    for source, options in ((calibrated / "targets.csv", []), (calibrated / "part.gcode", []),
                            (calibrated / "targets.csv", ["--firmware", "klipper"])):
        out = tmp_path / f"out{source.suffix}"
        assert main(["compensate", str(cal), str(source), "--controller", str(QQS), "-o", str(out),
                     *options]) == 1
        err = _one_line(capsys)
        assert f"in {cal}'s geometry but 370 mm in {QQS}" in err and "position_endstop" in err
        assert not out.exists()
    other = tmp_path / "m503.txt"
    other.write_text(OTHER_M503)
    assert main(["compensate", str(cal), str(calibrated / "targets.csv"), "--controller", str(other),
                 "--firmware", "marlin", "-o", str(tmp_path / "m.csv")]) == 1
    err = _one_line(capsys)
    assert "M665 R is 134." in err and "mm in " in err and "but 107.5 mm in " in err


@pytest.mark.slow
def test_export_refuses_another_printers_configuration(calibrated, tmp_path, capsys):
    cal = calibrated / "cal.toml"
    assert main(["export", str(cal), "--controller", "klipper", "--config", str(Q5),
                 "-o", str(tmp_path / "k.cfg")]) == 1
    err = _one_line(capsys)
    assert "delta_radius is 134." in err and "but 107.5 mm in " in err and not (tmp_path / "k.cfg").exists()
    other = tmp_path / "m503.txt"
    other.write_text(OTHER_M503)
    assert main(["export", str(cal), "--controller", "marlin", "--config", str(other),
                 "-o", str(tmp_path / "m.gcode")]) == 1
    err = _one_line(capsys)
    assert "M665 R is 134." in err and "but 107.5 mm in " in err and not (tmp_path / "m.gcode").exists()


@pytest.mark.long
def test_the_same_printers_exported_values_are_not_refused(calibrated, tmp_path, capsys):
    """export's values of the calibration, given back to compensate and to export (Klipper's: the firmware
    it was identified with; another firmware's values are refused naming both, issue 46)."""
    cal = calibrated / "cal.toml"
    settings = MARLIN.save_config(tmp_path / "m503.gcode", MARLIN.nominal(PRINTER), complete=True)
    assert main(["export", str(cal), "--controller", "marlin", "--config", str(settings),
                 "-o", str(tmp_path / "fitted.gcode")]) == 1
    assert "identified with Klipper" in capsys.readouterr().err and not (tmp_path / "fitted.gcode").exists()
    fitted = KLIPPER.fit(load_calibration(cal).geometry, KLIPPER.nominal(PRINTER), PRINTER.step_distance,
                         PRINTER.workspace, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT).values  # export's
    complete = KLIPPER.save_config(tmp_path / "fitted.cfg", fitted, calibrated / "printer.cfg", complete=True)
    assert main(["compensate", str(cal), str(calibrated / "part.gcode"), "--controller", str(complete),
                 "-o", str(tmp_path / "out.gcode")]) == 0
    assert main(["export", str(cal), "--controller", "klipper", "--config", str(complete),
                 "-o", str(tmp_path / "again.cfg")]) == 0


# --------------------------------------------------------------------------- low messages
def test_swapped_probe_and_distance_files_are_said_swapped(tmp_path, capsys):
    probe, distances = tmp_path / "probe.csv", tmp_path / "d.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n50,0,0.2\n0,50,0.1\n")
    distances.write_text("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm\n0,0,8,50,0,8,50\n")
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    assert main(["identify", str(KOSSEL), str(distances), str(probe), "--controller", str(cfg),
                 "-o", str(tmp_path / "cal.toml")]) == 1
    err = _one_line(capsys)
    assert f"{distances}: line 1: holds distances" in err and "the files look swapped" in err
    assert "PRINTER.toml PROBE.csv DISTANCES.csv" in err and "did you mean" not in err


@pytest.mark.parametrize("option", [["--firmware", "klipper"], []])
def test_a_robot_file_as_controller_is_named_a_robot_file(tmp_path, capsys, option):
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(KOSSEL), *option,
                 "-o", str(tmp_path / "obj")]) == 2
    err = _one_line(capsys)
    assert f"--controller {KOSSEL}: a deltacal robot file, not a firmware's configuration" in err
    assert "outside any" not in err


@pytest.mark.long
def test_a_short_caliper_is_said_short_with_one_that_works(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--caliper", "10",
                 "-o", str(tmp_path / "o")]) == 1
    err = _one_line(capsys)
    assert "a caliper of 10 mm is too short" in err and "feature levels" in err
    works = int(err.split("(--caliper ")[1].split(";")[0])
    assert f"{works - 1} mm is too short" in err
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--caliper", str(works - 1),
                 "-o", str(tmp_path / "o")]) == 1
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--caliper", str(works),
                 "-o", str(tmp_path / "o")]) == 0


@pytest.mark.long
def test_without_distances_asked_the_object_plans_those_it_offers(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--caliper", "80",
                 "-o", str(tmp_path / "o")]) == 0
    rows = (tmp_path / "o" / "distances.csv").read_text().strip().splitlines()[1:]
    out = capsys.readouterr().out
    assert 0 < len(rows) < 40 and f"offers {len(rows)} distances" in out and f"planned the {len(rows)}" in out
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--caliper", "80",
                 "--distances", "40", "-o", str(tmp_path / "o2")]) == 1
    assert f"--distances {len(rows)}, or a caliper of " in _one_line(capsys)


@pytest.mark.parametrize("command", ["plan", "import"])
def test_an_output_folder_whose_parent_is_missing_is_refused_before_any_work(tmp_path, capsys, command):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    out = tmp_path / "missing" / "obj"
    args = (["plan", str(KOSSEL), "--object", "--controller", str(cfg)] if command == "plan"
            else ["import", str(cfg)])
    assert main([*args, "-o", str(out)]) == 2
    err = _one_line(capsys)
    assert f"{out}: the folder '{out.parent}' does not exist" in err
    assert not out.parent.exists()
    (tmp_path / "afile").write_text("")
    assert main([*args, "-o", str(tmp_path / "afile" / "obj")]) == 2
    assert "a part of the path is a file, not a folder" in _one_line(capsys)
