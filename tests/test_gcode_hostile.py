"""The G-code filter under hostile programs and options: each read as the firmware reads it, or refused.

A byte-order mark, a move after another command on its line, a ';' inside a '(...)' comment, a
block-delete line, segments below the output's resolution, absurd start positions, a start above
a printer's towers, and a program corrected twice.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal import InputError, __version__
from deltacal.cli import main
from deltacal.gcode import MARKER, MIN_SEGMENT_MM, filter_gcode, filter_lines, marker_line
from deltacal.io import load_nominal
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer

BOM = "\ufeff"
MOVE = re.compile(r"^G[01] X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})(?: E(-?[\d.]+))?")


def warp(points: np.ndarray) -> np.ndarray:
    """A smooth nonlinear map standing for a controller correction [mm]."""
    x, y, z = points.T
    return points + np.stack([0.3 * np.sin(y / 50.0), 0.2 * np.cos(x / 40.0), 1e-5 * x * y], axis=1)


def run(text: str, correct=lambda p: p.copy(), **kwargs) -> str:
    return "".join(filter_lines(text.splitlines(keepends=True), correct, **kwargs))


def rows(out: str) -> list[tuple[float, ...]]:
    """X, Y, Z (and E, or nan) of every rewritten move line."""
    found = [MOVE.match(line.lstrip(BOM)) for line in out.splitlines()]
    return [tuple(float(v) if v is not None else np.nan for v in m.groups()) for m in found if m]


@pytest.fixture(scope="module")
def rotary(tmp_path_factory):
    """A robot file and its nominal geometry saved as a calibration."""
    robot = MODELS / "bai2015.toml"
    cal = tmp_path_factory.mktemp("rotary") / "cal.toml"
    save_geometry(load_nominal(robot).geometry(), cal)
    return robot, cal


def compensate(capsys, cal, program, controller, out, *extra) -> tuple[int, str]:
    code = main(["compensate", str(cal), str(program), "--controller", str(controller), "-o", str(out),
                 *extra])
    return code, capsys.readouterr().err


# ----------------------------------------------------------------------------- byte-order mark
def test_a_byte_order_mark_is_kept_and_the_line_after_it_read(tmp_path):
    # M83 behind the mark: E is relative, so the 20 mm move's E4 is cut into shares of 1
    src, dst = tmp_path / "bom.gcode", tmp_path / "out.gcode"
    src.write_bytes(b"\xef\xbb\xbfM83\r\nG1 X0 Y0 Z-800 E0\r\nG1 X20 Y0 Z-800 E4\r\n")
    filter_gcode(src, dst, lambda p: p.copy())
    out = dst.read_bytes()
    assert out.startswith(b"\xef\xbb\xbfM83\r\nG1 X0.0000 Y0.0000 Z-800.0000 E0\r\n")
    assert [r[3] for r in rows(out.decode())][1:] == [1.0, 1.0, 1.0, 1.0]


def test_a_relative_mode_or_a_move_behind_the_mark_is_read():
    # G91 behind the mark: the move is an increment, sent as one
    out = run(BOM + "G91\nG1 X1 Y0 Z0\n", start=(0.0, 0.0, -800.0))
    assert out == BOM + "G91\nG1 X1.0000 Y0.0000 Z0.0000\n"
    # a move behind the mark is corrected
    end = np.round(warp(np.array([[10.0, 5.0, -800.0]]))[0], 4) + 0.0
    assert run(BOM + "G1 X10 Y5 Z-800\n", warp) == BOM + "G1 X{:.4f} Y{:.4f} Z{:.4f}\n".format(*end)


# ----------------------------------------------------------------------------- a command, then a move
@pytest.mark.parametrize("line, says", [
    ("M83 G1 X40 Y0 Z-790", "line 2: G1 after M83 on one line"),
    ("M3 S1000 G1 X100 Y0 Z-850", "line 2: G1 after M3 on one line"),
    ("N5 M400 G0 X1 Y0 Z-800", "line 2: G0 after M400 on one line"),
])
def test_a_move_after_another_command_on_its_line_is_refused(line, says):
    with pytest.raises(InputError, match=says):
        run(f"G1 X0 Y0 Z-800\n{line}\nG1 X40 Y10 Z-800\n")


def test_m_codes_with_axis_parameters_or_text_are_kept():
    kept = ["M201 X500 Y500 Z100", "M203 X300 Y300 Z300", "M117 G1 X10 is next", "M118 G28 done",
            "M104 S200 ; G1 X5 in the comment"]
    out = run("G1 X0 Y0 Z-800\n" + "\n".join(kept) + "\nG1 X1 Y0 Z-800\n")
    assert out.splitlines()[1:-1] == kept


# ----------------------------------------------------------------------------- comments, block delete
def test_a_semicolon_inside_parentheses_is_the_comments():
    out = run("G1 X10 Y5 Z-800 (note; here)\n", warp)
    end = np.round(warp(np.array([[10.0, 5.0, -800.0]]))[0], 4) + 0.0
    assert out == "G1 X{:.4f} Y{:.4f} Z{:.4f} (note; here)\n".format(*end)
    assert run("G1 X10 Y5 Z-800 (a) ; b (c\n") == "G1 X10.0000 Y5.0000 Z-800.0000 (a) ; b (c\n"
    with pytest.raises(InputError, match=r"line 1: words after the comment '\(a;b\)': Klipper ends"):
        run("G1 X10 (a;b) Y5 Z-800\n")


def test_a_block_delete_move_is_refused_and_other_block_delete_lines_kept():
    with pytest.raises(InputError, match=r"line 2: a block-delete line \('/'\)"):
        run("G1 X0 Y0 Z-800\n/G1 X10 Y0 Z-800\n")
    with pytest.raises(InputError, match=r"line 1: a block-delete line"):
        run("/ M83\nG1 X0 Y0 Z-800\n")
    assert run("/M117 optional\n/ ; a note\n") == "/M117 optional\n/ ; a note\n"


# ----------------------------------------------------------------------------- segments and starts
def test_segments_below_the_floor_are_refused_and_the_floor_is_taken():
    with pytest.raises(ValueError, match="below 0.01 mm"):
        next(filter_lines(["G1 X0 Y0 Z-800\n", "G1 X1 Y0 Z-800\n"], lambda p: p.copy(), segment_mm=1e-5))
    out = run("G1 X0 Y0 Z-800\nG1 X0.1 Y0 Z-800\n", segment_mm=MIN_SEGMENT_MM)
    assert [r[0] for r in rows(out)] == pytest.approx([0.0] + [0.01 * k for k in range(1, 11)], abs=1e-12)


def test_a_tiny_segment_option_is_refused_in_one_line(rotary, capsys, tmp_path):
    robot, cal = rotary
    program, out = tmp_path / "p.gcode", tmp_path / "o.gcode"
    program.write_text("G1 X0 Y0 Z-800\nG1 X0.001 Y0 Z-800\n")
    code, err = compensate(capsys, cal, program, robot, out, "--segment-mm", "1e-7")
    assert code == 2 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert "--segment-mm 1e-07: below 0.01 mm" in err


@pytest.mark.parametrize("start", ["1e300,0,0", "0,-2e6,0"])
def test_an_absurd_start_is_refused_in_one_line_without_a_warning(rotary, capsys, tmp_path, start):
    robot, cal = rotary
    program, out = tmp_path / "p.gcode", tmp_path / "o.gcode"
    program.write_text("G1 X0 Y0 Z-800\n")
    code, err = compensate(capsys, cal, program, robot, out, "--start", start)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "warning" not in err and not out.exists()
    assert f"--start {start.replace('1e300', '1e+300').replace('2e6', '2e+06')}: beyond ±1e+06 mm" in err


@pytest.mark.parametrize("digits", [300, 400])  # 1e300, and a number float() reads as infinity
def test_a_coordinate_of_hundreds_of_digits_is_refused_by_its_line(rotary, capsys, tmp_path, digits):
    robot, cal = rotary
    program, out = tmp_path / "p.gcode", tmp_path / "o.gcode"
    program.write_text(f"G1 X0 Y0 Z-800\nG1 X1{'0' * digits} Y0\n")
    code, err = compensate(capsys, cal, program, robot, out)
    assert code == 1 and len(err.strip().splitlines()) == 1 and "warning" not in err and not out.exists()
    assert f"{program}: line 2: move from [0.0, 0.0, -800.0] to" in err and "out of reach" in err
    with pytest.raises(InputError, match=r"line 1: point .* out of reach of the robot \(beyond"):
        run(f"G1 X1{'0' * digits} Y0 Z-800\n")  # sent whole: refused before it is corrected


def test_a_start_above_a_printers_towers_is_out_of_reach(capsys, tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    cal, program, out = tmp_path / "cal.toml", tmp_path / "p.gcode", tmp_path / "o.gcode"
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), cal)
    program.write_text("G1 X0 Y0 Z10\n")
    code, err = compensate(capsys, cal, program, cfg, out, "--start", "0,0,1000")
    assert code == 1 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert "start position: point [0.0, 0.0, 1000.0] mm is out of reach of the robot" in err


# ----------------------------------------------------------------------------- corrected twice
def test_a_corrected_program_is_marked_and_refused_when_corrected_again(rotary, capsys, tmp_path):
    robot, cal = rotary
    program, out, again = tmp_path / "p.gcode", tmp_path / "o.gcode", tmp_path / "o2.gcode"
    program.write_bytes(b"\xef\xbb\xbfG21\r\nG1 X0 Y0 Z-800\r\n")
    assert compensate(capsys, cal, program, robot, out)[0] == 0
    text = out.read_bytes().decode()
    assert text.startswith(f"{BOM}; corrected by deltacal {__version__} for {robot} with {cal}\r\nG21\r\n")
    code, err = compensate(capsys, cal, out, robot, again)
    assert code == 1 and len(err.strip().splitlines()) == 1 and not again.exists()
    assert f"{out}: line 1: the program is already corrected ('{MARKER}{__version__} for" in err


def test_the_marker_is_one_line_and_changes_nothing_else():
    program = "G21\nG92 E0\nG1 X0 Y0 Z-800\nG1 X30 Y5 Z-790 E3\n; end\n"
    marker = marker_line("odd\nname.cfg", "cal\r.toml")
    assert marker == f"{MARKER}{__version__} for odd?name.cfg with cal?.toml"
    marked = run(program, warp, marker=marker)
    assert marked == marker + "\n" + run(program, warp)
    with pytest.raises(InputError, match="line 3: the program is already corrected"):
        run("G21\nG1 X0 Y0 Z-800\n  " + marker + "\n")
