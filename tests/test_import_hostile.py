"""Issue 40, "nothing silently wrong, round 4": the firmware configurations a hostile user gave ``import``.

Each test failed on the main of the issue: a value no printer has read on (or overflowing into an
internal error), an M503 capture in inches read as millimetres, includes that are not files, files
told apart by a ``//`` line. Each is now read as the firmware reads it or refused in one line
naming the file, the line or key and the value, with exit 1 and nothing written.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from deltacal.cli import main

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
