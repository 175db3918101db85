"""Hostile programs (issue 40) as each firmware reads their lines: kept as it keeps them, or refused.

Junk before a command (a byte-order mark where two files were joined, a NUL, a digit), axis words
without a G word. What each firmware does is from its source: Klipper's ``klippy/gcode.py``
(checked against the real parser when ``KLIPPER_DIR`` names a Klipper checkout), Marlin's
``gcode/parser.cpp``, RepRapFirmware's ``StringParser.cpp``.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal import InputError, InputWarning
from deltacal.cli import main
from deltacal.gcode import filter_lines
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).parent / "data"
XYZ = re.compile(r"^G1 X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})", re.MULTILINE)
START = "G1 X0 Y0 Z10\n"


def shifted(points: np.ndarray) -> np.ndarray:
    return points + np.array([0.1, -0.2, 0.05])


def run(text: str, dialect=None) -> tuple[str, list[str]]:
    """The output and the warnings said."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        out = "".join(filter_lines(text.splitlines(keepends=True), shifted, dialect=dialect))
    return out, [str(w.message) for w in said if issubclass(w.category, InputWarning)]


def sent(out: str) -> np.ndarray:
    return np.array(XYZ.findall(out), dtype=float).reshape(-1, 3)


@pytest.fixture(scope="module")
def dialects():
    return {"klipper": KLIPPER.dialect(DATA / "klipper" / "printer.cfg"),
            "marlin": MARLIN.dialect(DATA / "marlin_m503.txt"),
            "rrf": RRF_FIRMWARE.dialect(DATA / "rrf" / "config.g")}


# ------------------------------------------------------------------------ junk before a command (item 1)
ANSWERS = {"klipper": "Klipper answers with 'Unknown command'",
           "marlin": "Marlin answers with 'Unknown command'",
           "rrf": "RepRapFirmware answers with 'Bad command'"}


@pytest.mark.parametrize("firmware, junk", [(firmware, junk) for firmware in ANSWERS
                                            for junk in ("\ufeff", "\0", "1", "\u00e9")
                                            if (firmware, junk) != ("rrf", "\0")])  # RRF: refused below
def test_a_command_behind_junk_is_kept_unrun_and_named(dialects, firmware, junk):
    answer = ANSWERS[firmware]
    program = START + junk + "G1 X40 Y0 Z10\nG1 X3.49 Y3.32\n"
    out, said = run(program, dialects[firmware])
    lines = out.splitlines(keepends=True)
    assert lines[1] == junk + "G1 X40 Y0 Z10\n"  # kept byte for byte: the firmware does not run it
    assert_moves_from_the_start(out)
    assert len(said) == 1 and said[0].startswith(f"G-code: line 2: {junk + 'G1 X40 Y0 Z10'!r}: text {junk!r}")
    assert answer in said[0] and "the position not moved" in said[0]


def assert_moves_from_the_start(out: str) -> None:
    """The move after the junk line starts where the firmware stands: X0 Y0, 4.8 mm away: not cut."""
    points = sent(out)
    assert len(points) == 2
    np.testing.assert_allclose(points[1], shifted(np.array([[3.49, 3.32, 10.0]]))[0], atol=1e-4)


def test_a_nul_is_refused_where_repraps_firmware_ends_the_line_at_it(dialects):
    for text in ("\0G1 X40 Y0 Z10", "G1 X4 ; a\0G1 X50"):  # RRF runs what follows the NUL
        with pytest.raises(InputError, match=r"^G-code: line 2: a NUL byte in the line: RepRapFirmware ends "
                                             "a line there and runs what follows it as a line of its own"):
            run(START + text + "\n", dialects["rrf"])
    assert run(START + "G1 X4 ; a\0G1 X50\n", dialects["klipper"])[1] == []  # a comment's, elsewhere


def test_junk_before_a_command_is_refused_by_a_controller_of_unknown_reading():
    with pytest.raises(InputError, match=r"^G-code: line 2: text '\\ufeff' before the command 'G1 X40 Y0 "
                                         "Z10': controllers differ on whether the line runs"):
        run(START + "\ufeffG1 X40 Y0 Z10\n")
    # not junk: a comment, a number alone, a host's @command, a line number before a command
    out, said = run(START + "\ufeff; joined here\n12345\n@pause\nN10 G1 X1\n")
    assert said == [] and out.endswith("@pause\nN10 G1 X1.1000 Y-0.2000 Z10.0500\n")


@pytest.mark.parametrize("firmware", ["klipper", "marlin", "rrf"])
def test_a_command_right_after_the_opening_byte_order_mark_is_refused_by_a_firmware(dialects, firmware):
    # read from the firmware's own card the mark is text before the command; OctoPrint strips it
    answer = "Bad command" if firmware == "rrf" else "Unknown command"
    with pytest.raises(InputError, match=rf"^G-code: line 1: a byte-order mark before the first command "
                                         rf"\('G28'\): .* answers '{answer}' and does not run the line"):
        run("\ufeffG28\n" + START, dialects[firmware])
    out, said = run("\ufeff; sliced by ...\n" + START, dialects[firmware])  # slicers begin with a comment
    assert out.startswith("\ufeff; sliced by ...\nG1 X") and said == []
    assert run("\ufeffG28\n" + START)[0].startswith("\ufeffG28\n")  # unknown reading: as a host sends it


def test_blanks_marlin_does_not_skip_before_a_command_are_refused(dialects):
    with pytest.raises(InputError, match=r"^G-code: line 2: '\\t' before the command: Marlin reads the line "
                                         r"as an unknown command from its own card, a host \(OctoPrint\)"):
        run(START + "\tG1 X4\n", dialects["marlin"])
    for firmware in ("klipper", "rrf"):  # Klipper strips every blank, RRF indents with tabs
        assert len(sent(run(START + "\tG1 X4\n", dialects[firmware])[0])) == 2


def test_junk_lines_are_said_once_with_their_count(dialects):
    program = START + "".join(f"\ufeffG1 X{k} Y0 Z10\n" for k in range(12)) + "G1 X3.49 Y3.32\n"
    out, said = run(program, dialects["klipper"])
    assert_moves_from_the_start(out)
    assert len(said) == 1 and "(also lines 3, 4, 5, 6, ...: 12 lines in all)" in said[0]


# --------------------------------------------------------------------- axis words without G0/G1 (item 2)
def test_axis_words_alone_are_klippers_unknown_command(dialects):
    out, said = run(START + "X40 Y0 Z10\nG1 X3.49 Y3.32\nE5\nN3 X1 G1 Y1\nF1200\n", dialects["klipper"])
    assert out.splitlines()[1] == "X40 Y0 Z10" and out.splitlines()[3:] == ["E5", "N3 X1 G1 Y1", "F1200"]
    assert_moves_from_the_start(out)
    assert len(said) == 1
    assert said[0].startswith("G-code: line 2: 'X40 Y0 Z10': axis words without G0/G1 first: Klipper answers "
                              "'Unknown command' and does not move: kept as it is, the position not moved")
    assert "(also lines 4, 5: 3 lines in all)" in said[0]  # F alone moves nothing: not said


@pytest.mark.parametrize("firmware, why", [
    ("marlin", "Marlin repeats the last G0/G1 only when built with GCODE_MOTION_MODES"),
    ("rrf", r"RepRapFirmware repeats the last G0/G1 in CNC or laser mode \(M453, M452\)"),
])
def test_axis_words_alone_are_refused_where_the_firmwares_build_decides(dialects, firmware, why):
    for line in ("X40 Y0 Z10", "x40", "E5"):
        with pytest.raises(InputError, match=rf"^G-code: line 2: axis words without G0/G1 first "
                                             rf"\('{line}'\): {why}"):
            run(START + line + "\n", dialects[firmware])


def test_axis_words_alone_follow_the_motion_mode_of_a_generic_controller():
    out, said = run(START + "X40 Y0 Z10\n")
    assert said == [] and len(sent(out)) == 1 + 8  # G1's mode: 40 mm in segments of 5


# ------------------------------------------------------------------------------------- the command line
def test_compensate_says_a_klipper_line_it_keeps_unrun_on_one_line(capsys, tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    cal, program, out = tmp_path / "cal.toml", tmp_path / "p.gcode", tmp_path / "o.gcode"
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), cal)
    program.write_bytes(b"G1 X0 Y0 Z10\n\xef\xbb\xbfG1 X40 Y0 Z10\nX40 Y0 Z10\nG1 X3.49 Y3.32\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(cfg), "-o", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and err[0].startswith(f"warning: {program}: line 2: '\\ufeffG1 X40 Y0 Z10': text")
    assert err[1].startswith(f"warning: {program}: line 3: 'X40 Y0 Z10': axis words without G0/G1")
    assert out.read_bytes().split(b"\n")[2:4] == [b"\xef\xbb\xbfG1 X40 Y0 Z10", b"X40 Y0 Z10"]


# --------------------------------------------------------------------------------- Klipper's own parser
@pytest.fixture(scope="module")
def klipper_parser(tmp_path_factory):
    """Klipper's ``GCodeDispatch._process_commands`` (``KLIPPER_DIR``'s gcode.py, copied): line -> command."""
    source = os.environ.get("KLIPPER_DIR")
    if not source or not (Path(source) / "klippy" / "gcode.py").is_file():
        pytest.skip("KLIPPER_DIR does not name a Klipper checkout")
    copy = tmp_path_factory.mktemp("klippy") / "gcode.py"
    shutil.copy(Path(source) / "klippy" / "gcode.py", copy)
    spec = importlib.util.spec_from_file_location("klipper_gcode", copy)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    dispatch = object.__new__(module.GCodeDispatch)
    ran: list[str] = []
    dispatch.gcode_handlers = {"G1": lambda gcmd: ran.append(gcmd.get_command())}
    dispatch.cmd_default = lambda gcmd: ran.append("unknown " + gcmd.get_command())

    def command(line: str) -> str:
        ran.clear()
        dispatch._process_commands([line], need_ack=False)
        return ran[0]

    return command


@pytest.mark.parametrize("line", ["\ufeffG1 X40 Y0 Z10", "\0G1 X40 Y0 Z10", "1G1 X40 Y0 Z10", "X40 Y0 Z10",
                                  "E5", "N3 X1 G1 Y1"])
def test_klippers_own_parser_does_not_run_the_lines_kept(klipper_parser, line):
    assert klipper_parser(line).startswith("unknown ")
    assert klipper_parser("\tg1 x40") == "G1" and klipper_parser("N10 G1 X4") == "G1"
