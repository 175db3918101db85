"""Issue 40, "nothing silently wrong, round 4": the firmware configurations a hostile user gave ``import``.

Each test failed on the main of the issue: a value no printer has read on (or overflowing into an
internal error), an M503 capture in inches read as millimetres, includes that are not files, files
told apart by a ``//`` line. Each is now read as the firmware reads it or refused in one line
naming the file, the line or key and the value, with exit 1 and nothing written.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from deltacal.cli import main
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer

DATA = Path(__file__).resolve().parent / "data"
KLIPPER = (DATA / "klipper" / "printer.cfg").read_text()
MARLIN = (DATA / "marlin_m503.txt").read_text()
RRF = (DATA / "rrf" / "config.g").read_text()


def refused(capsys, tmp_path: Path, name: str, text: str) -> str:
    """``import`` of ``text`` saved as ``name``: exit 1, one line, no traceback, no folder; the line."""
    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["import", str(path), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert not out.exists()
    return err


def edited(text: str, pattern: str, new: str) -> str:
    changed, count = re.subn(pattern, new, text, count=1, flags=re.MULTILINE)
    assert count == 1, pattern
    return changed


# ------------------------------------------------------------------ 14: values no printer has
KLIPPER_CASES = [
    (r"^delta_radius: 174.75", "delta_radius: 1e307", "section [printer], key delta_radius: value '1e307'"),
    (r"^position_endstop: 297.05", "position_endstop: 1e308",
     "section [stepper_a], key position_endstop: value '1e308'"),
    (r"^position_endstop: 297.05", "position_endstop: -1e308",
     "section [stepper_a], key position_endstop: value '-1e308'"),
    (r"^rotation_distance: 40", "rotation_distance: 1e308",
     "section [stepper_a], key rotation_distance: value '1e308'"),
    (r"^arm_length: 333.0", "arm_length: 333.0\nangle: 1e308",
     "section [stepper_a], key angle: value '1e308'"),
    (r"^delta_radius: 174.75", "delta_radius: 174.75\nminimum_z_position: -1e308",
     "section [printer], key minimum_z_position: value '-1e308'"),
    (r"^microsteps: 16", "microsteps: 100000000000000000000000",
     "section [stepper_a], key microsteps: value '100000000000000000000000'"),
]
MARLIN_CASES = [
    (r"H295.60", "H1e308", "line 13, M665 H: value '1e308'"),
    (r"Z-1.20 ; \(mm\)", "Z1e308 ; (mm)", "line 15, M851 Z: value '1e308'"),
    (r"M92 X80.00", "M92 X1e-300", "line 7, M92 X: value '1e-300'"),
    (r"M666 X-0.41", "M666 X-500", "line 11, M666 X: value '-500'"),
    (r"S200.00 X0.12", "S200.00 X170", "line 13, M665 X: value '170'"),
]
RRF_CASES = [
    (r"H295.6", "H1e308", "line 7, M665 H: value '1e308'"),
    (r"M92 X80", "M92 X1e-300", "line 11, M92 X: value '1e-300'"),
    (r"X0.1 Y-0.2 Z0 ;", "X170 Y-0.2 Z0 ;", "line 7, M665 X: value '170'"),
    (r"M666 X0.2", "M666 X-500", "line 8, M666 X: value '-500'"),
]


@pytest.mark.parametrize("pattern, new, says", KLIPPER_CASES)
def test_a_klipper_value_no_printer_has_is_refused_naming_its_key(capsys, tmp_path, pattern, new, says):
    err = refused(capsys, tmp_path, "printer.cfg", edited(KLIPPER, pattern, new))
    assert says in err and "is beyond what a printer's" in err


@pytest.mark.parametrize("pattern, new, says", MARLIN_CASES)
def test_a_marlin_value_no_printer_has_is_refused_naming_its_line(capsys, tmp_path, pattern, new, says):
    err = refused(capsys, tmp_path, "m503.txt", edited(MARLIN, pattern, new))
    assert says in err and "is beyond what a printer's" in err


@pytest.mark.parametrize("pattern, new, says", RRF_CASES)
def test_an_rrf_value_no_printer_has_is_refused_naming_its_line_and_key(capsys, tmp_path, pattern, new, says):
    (tmp_path / "config-override.g").write_text((DATA / "rrf" / "config-override.g").read_text())
    err = refused(capsys, tmp_path, "config.g", edited(RRF, pattern, new))
    assert says in err and "is beyond what a printer's" in err


# ------------------------------------------------------------------ 7: Marlin in inches
def test_an_m503_capture_in_inches_is_refused_naming_the_g20(capsys, tmp_path):
    inches = MARLIN.replace("G21 ; (mm)", "G20 ; (in)").replace("M665 L269.00 R134.40 H295.60",
                                                                "M665 L10.59 R5.29 H11.64")
    err = refused(capsys, tmp_path, "m503.txt", inches)
    assert "line 7, M92: reported in inches (G20, line 3)" in err and "send G21, then M503" in err


def test_an_m503_capture_back_in_millimetres_is_read(capsys, tmp_path):
    path = tmp_path / "m503.txt"
    path.write_text("Recv: echo:  G20 ; (in)\nRecv: echo:  G21 ; (mm)\n" + MARLIN)
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 0
    assert "rod_length_mm" in (tmp_path / "out" / "printer.toml").read_text()


# ------------------------------------------------------------------ 15: includes that are not files
def test_an_include_of_a_device_is_refused_naming_the_line(capsys, tmp_path):
    err = refused(capsys, tmp_path, "printer.cfg", "[include /dev/zero]\n" + KLIPPER)
    assert "printer.cfg: line 1: [include /dev/zero]: /dev/zero: not a file (a device)" in err


def test_an_include_of_a_fifo_is_refused_without_waiting_for_a_writer(capsys, tmp_path):
    os.mkfifo(tmp_path / "pipe.cfg")
    err = refused(capsys, tmp_path, "printer.cfg", KLIPPER + "\n[include pipe.cfg]\n")
    assert "line 154: [include pipe.cfg]" in err and "not a file (a FIFO (named pipe))" in err
    (tmp_path / "macros").mkdir()
    os.mkfifo(tmp_path / "macros" / "z.cfg")  # a pattern matching one
    err = refused(capsys, tmp_path, "printer.cfg", KLIPPER + "\n[include macros/*.cfg]\n")
    assert "[include macros/*.cfg]" in err and "z.cfg: not a file (a FIFO" in err


# ------------------------------------------------------------------ 16: Klipper's wording and loops
SAVED = ("\n#*# <---------------------- SAVE_CONFIG ---------------------->\n"
         "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n"
         "#*# [printer]\n#*# delta_radius = 175.000000\n#*#\n")


def test_a_second_save_config_block_is_ignored_as_klipper_does_naming_the_files_line(capsys, tmp_path):
    path = tmp_path / "printer.cfg"
    path.write_text(KLIPPER + SAVED + "#*# [stepper_a]\n#*# angle = 210.5\n" + SAVED)
    second = len((KLIPPER + SAVED + "#*# [stepper_a]\n#*# angle = 210.5\n").split("\n")) + 1
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert f"printer.cfg: line {second}: a second SAVE_CONFIG block: Klipper ignores both" in err
    assert "tower_radius_mm = 204.75" in (tmp_path / "out" / "printer.toml").read_text()  # 174.75 + 30


def test_an_error_in_the_save_config_block_names_the_files_line(capsys, tmp_path):
    text = KLIPPER + SAVED.replace("[printer]\n#*# delta_radius = 175.000000", "[stepper_a]\n#*# angle 210.5")
    err = refused(capsys, tmp_path, "printer.cfg", text)
    line = len(text.split("\n")) - 2  # the block's last line but its closing '#*#'
    assert f"printer.cfg: line {line}: not an option" in err and "'angle 210.5'" in err


def test_an_include_through_a_link_to_its_own_folder_is_a_recursive_include(capsys, tmp_path):
    (tmp_path / "sub").symlink_to(".")
    err = refused(capsys, tmp_path, "printer.cfg", "[include sub/printer.cfg]\n" + KLIPPER)
    assert "printer.cfg: recursive include of this file (through a link" in err
    assert "by [include sub/printer.cfg] at line 1" in err


HOMING = "\n[homing_override]\ngcode:\n  G28\n  G1 Z-10 F3000\n"
MESH = "\n#*# [bed_mesh default]\n#*# version = 1\n#*# points =\n#*# \t0.01, 0.02\n#*# \t0.00, 0.03\n"


def test_homing_override_and_a_saved_mesh_are_said_once(capsys, tmp_path):
    path = tmp_path / "printer.cfg"
    path.write_text(KLIPPER + HOMING + SAVED + MESH.lstrip("\n"))
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err.splitlines()
    override = [line for line in err if "[homing_override]" in line]
    mesh = [line for line in err if "[bed_mesh default]" in line]
    assert len(override) == 1 and "G28 runs its gcode, which deltacal does not follow" in override[0]
    assert len(mesh) == 1 and "BED_MESH_CLEAR" in mesh[0] and "BED_MESH_PROFILE REMOVE=default" in mesh[0]
    program, cal = tmp_path / "part.gcode", tmp_path / "geometry.toml"
    program.write_text("G28\nG1 X10 Y10 Z5 F3000\nG1 X20 Y0 Z5\n")
    save_geometry(load_printer(tmp_path / "out" / "printer.toml").geometry(), cal)
    assert main(["compensate", str(cal), str(program), "--controller", str(path), "-o",
                 str(tmp_path / "corrected.gcode")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert sum("[homing_override]" in line for line in err) == 1
    assert sum("[bed_mesh default]" in line for line in err) == 1


def test_export_says_the_missing_includes_once(capsys, tmp_path):
    """Issue 39, item 7: export read the configuration twice and said its missing includes twice."""
    found = DATA / "klipper" / "flsun-qqs-as-found.cfg"
    assert main(["import", str(found), "-o", str(tmp_path / "qqs")]) == 0
    save_geometry(load_printer(tmp_path / "qqs" / "printer.toml").geometry(), tmp_path / "geometry.toml")
    capsys.readouterr()
    assert main(["export", str(tmp_path / "geometry.toml"), "--controller", "klipper", "--config", str(found),
                 "-o", str(tmp_path / "calibrated.cfg")]) == 0
    err = capsys.readouterr().err
    assert err.count("include files not found, skipped") == 1
