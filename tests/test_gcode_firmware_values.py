"""A program that sets the firmware's own values (issue 40 item 4): refused by its line.

The program is corrected for the values of the configuration given (an ``M503`` capture,
``config.g``); a line that changes them (``M665 R130 H290``, ``M666``, ``M92 X``, ``M501``, ``M502``,
RRF's ``M98 P"config-override.g"``, an auto-calibration) would leave the printer running the
corrected moves with values it no longer has. Klipper runs none of these (``M665`` is an unknown
command to it; its ``DELTA_CALIBRATE`` keeps the values until ``SAVE_CONFIG`` restarts it).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from deltacal import InputError
from deltacal.cli import main
from deltacal.gcode import filter_lines
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).parent / "data"
KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
START = ["G28", "G1 X0 Y0 Z10 F3000"]
CHANGE = "the program is corrected for the values of the"


def run(lines: list[str], dialect) -> str:
    return "".join(filter_lines([line + "\n" for line in lines], lambda p: p + 0.01, dialect=dialect))


@pytest.fixture(scope="module")
def marlin():
    return MARLIN.dialect(DATA / "marlin_m503.txt")


@pytest.fixture(scope="module")
def rrf():
    return RRF_FIRMWARE.dialect(DATA / "rrf" / "config.g")


@pytest.mark.parametrize("line, says", [
    ("M665 R130 H290", "M665: it sets Marlin's delta values"),
    ("M665 L250.5", "M665: it sets Marlin's delta values"),
    ("M666 X-0.5 Y0 Z-0.2", "M666: it sets Marlin's endstop adjustments"),
    ("M92 X100 Y100 Z100", "M92: it sets the towers' steps per mm"),
    ("M851 Z-1.5", r"M851: it sets the probe's Z offset, and with it where G28 leaves the nozzle"),
    ("M501", "M501: it loads the settings saved in the EEPROM"),
    ("M502 ; factory reset", "M502: it resets Marlin's settings to the firmware's defaults"),
    ("N12 m665 h290", "M665: it sets"),
    ("G33 P4", "G33: Marlin's delta auto-calibration changes M665 and M666"),
])
def test_marlin_values_set_in_the_program_are_refused_by_their_line(marlin, line, says):
    with pytest.raises(InputError, match=rf"^G-code: line 3: {says}"):
        run([*START, line, "G1 X10 Y10 Z0.3"], marlin)


def test_marlin_lines_that_change_no_value_of_the_correction_are_kept(marlin):
    lines = ["M665", "M665 S200", "M666", "M92 E415", "M851 X10 Y-5", "M503", "M500"]  # reports, E, segments
    assert run([*START, *lines], marlin).splitlines()[-len(lines):] == lines


@pytest.mark.parametrize("line, says", [
    ("M665 R140 L280", "M665: it sets RepRapFirmware's delta values"),
    ("M666 X0.1 A0.2", "M666: it sets the endstop corrections and the bed tilt"),
    ("M92 Z80", "M92: it sets the towers' steps per mm"),
    ("M669 K3 R140", "M669: it sets the kinematics"),
    ("M579 X1.01", "M579: it scales the coordinates"),
    ("M556 S100 X0.5", "M556: it corrects the axes' skew"),
    ("M501", "M501: it runs config-override.g"),
    ("M502", "M502: it sets config.g's values again"),
    ('M98 P"config-override.g"', "M98: it runs config.g, config-override.g or bed.g"),
    ('M98 P"0:/sys/Config.g"', "M98: it runs config.g"),
    ('M98 P"bed.g"', "M98: it runs"),
    ("G32", "G32: it runs bed.g, RepRapFirmware's delta auto-calibration"),
    ("G30 P5 X0 Y0 Z-99999 S6", "G30: with S 0 or more it calibrates the delta"),
])
def test_rrf_values_set_in_the_program_are_refused_by_their_line(rrf, line, says):
    with pytest.raises(InputError, match=rf"^G-code: line 3: {says}"):
        run([*START, line, "G1 X10 Y10 Z0.3"], rrf)


def test_rrf_lines_that_change_no_value_of_the_correction_are_kept(rrf):
    lines = ["M665", "M666", "M92 E415", 'M98 P"purge.g"', "M98 P", "M500"]
    assert run([*START, *lines], rrf).splitlines()[-len(lines):] == lines
    out = run([*START, "G30 S-1", "G1 X0 Y0 Z5"], rrf)  # a probe that reports: the position unknown after
    assert out.splitlines()[-2:] == ["G30 S-1", "G1 X0.0100 Y0.0100 Z5.0100"]


def test_klipper_runs_none_of_them():
    klipper = KLIPPER.dialect(DATA / "klipper" / "printer.cfg")
    lines = ["M665 R130 H290", "M666 X-0.5", "M92 X100", "M501", "M502"]  # unknown commands to Klipper
    assert run([*START, *lines], klipper).splitlines()[-len(lines):] == lines


def test_compensate_refuses_marlins_m665_in_one_line_writing_nothing(tmp_path, capsys):
    settings = MARLIN.save_config(tmp_path / "m503.txt", MARLIN.nominal(load_printer(KOSSEL)), complete=True)
    cal, program, out = tmp_path / "cal.toml", tmp_path / "part.gcode", tmp_path / "out.gcode"
    save_geometry(load_printer(KOSSEL).geometry(), cal)
    program.write_text("G28\nM665 R130 H290\nG1 X0 Y0 Z10\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(settings), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{program}: line 2: M665: it sets Marlin's delta values" in err
    assert CHANGE in err and not out.exists()
