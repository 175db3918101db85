"""Klipper's SAVE_GCODE_STATE / RESTORE_GCODE_STATE (issue 40 item 3), in a program and in macros.

Klipper's ``gcode_move.py``: a state, by its ``NAME`` (case kept, ``default`` without one), holds
G90/G91, M82/M83, the position and the extruder's; RESTORE sets the modes and the extruder's
G-code position back, and the position only with ``MOVE=1``; restoring a state never saved stops
the print. Where ``KLIPPER_DIR`` names a Klipper checkout, the corrected program is run through
Klipper's own parser and ``gcode_move.py`` (tests/klipper_gcode.py) beside the original: after
every line the corrected program's position is the correction of the original's, its extruder
position the same, and the segments of a cut move on the original's straight line, E in between.
"""

from __future__ import annotations

import math
import re
from decimal import Decimal

import numpy as np
import pytest
from conftest import kossel_printer_cfg
from klipper_gcode import Klipper
from numpy.testing import assert_allclose

from deltacal import InputError
from deltacal.gcode import filter_lines
from deltacal.printer.firmware.klipper.firmware import KLIPPER

XYZ = re.compile(r"^G1 X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})(?: E(-?[\d.]+))?", re.MULTILINE)
SCALE, SHIFT = 1.002, np.array([0.1, -0.2, 0.05])
MACROS = """
[gcode_macro TWO_STATES]
gcode:
    SAVE_GCODE_STATE NAME=abs
    G91
    SAVE_GCODE_STATE NAME=ABS
    RESTORE_GCODE_STATE NAME=abs

[gcode_macro PURGE_LINE]
gcode:
    SAVE_GCODE_STATE NAME=purge
    G92 E0
    G1 X-40 Y-40 Z0.3 F6000
    G1 X40 E20 F1200
    RESTORE_GCODE_STATE NAME=purge

[gcode_macro NAMED_BY_EXPRESSION]
gcode:
    SAVE_GCODE_STATE NAME={params.N}

[gcode_macro MAYBE_SAVE]
gcode:
    {% if params.S %}
    SAVE_GCODE_STATE NAME=maybe
    {% endif %}

[gcode_macro BACK]
gcode:
    RESTORE_GCODE_STATE NAME=maybe

[gcode_macro MAYBE_BACK]
gcode:
    {% if params.B %}
    RESTORE_GCODE_STATE NAME=maybe
    {% endif %}
"""


def correct(points: np.ndarray) -> np.ndarray:
    """A correction that is not a shift (an increment written for a position shows) [mm]."""
    return points * SCALE + SHIFT


def run(lines: list[str], dialect) -> str:
    return "".join(filter_lines([line + "\n" for line in lines], correct, dialect=dialect))


def moves(out: str) -> np.ndarray:
    """X, Y, Z, E (nan without E) of every rewritten move."""
    return np.array([[float(v) if v else np.nan for v in m] for m in XYZ.findall(out)]).reshape(-1, 4)


@pytest.fixture(scope="module")
def klipper(tmp_path_factory):
    cfg = kossel_printer_cfg(tmp_path_factory.mktemp("states") / "printer.cfg")
    cfg.write_text(cfg.read_text() + MACROS)
    return KLIPPER.dialect(cfg)


# ------------------------------------------------------------------------------ a program's own states
PURGE = ["G1 X0 Y0 Z10", "M82", "G92 E0", "SAVE_GCODE_STATE NAME=purge", "G91", "G1 Z5", "G90",
         "G1 X20 Y20 Z0.3 E4", "RESTORE_GCODE_STATE NAME=purge", "G1 X0 Y0 E2"]
LIFT = ["G1 X0 Y0 Z10", "SAVE_GCODE_STATE", "G91", "G1 Z2", "RESTORE_GCODE_STATE", "G1 X10 Y10 Z0.2"]
BACK = ["G1 X0 Y0 Z10", "SAVE_GCODE_STATE NAME=s", "G1 X3 Y0 Z10", "RESTORE_GCODE_STATE NAME=s MOVE=1",
        "G1 X10 Y3"]
CASES = ["G1 X0 Y0 Z10", "save_gcode_state name=abs", "G91", "SAVE_GCODE_STATE NAME=ABS",
         "RESTORE_GCODE_STATE NAME=abs", "G1 X5 Y5 Z5", "RESTORE_GCODE_STATE NAME='ABS' ; relative", "G1 X1"]


def test_restore_brings_back_the_extruder_position_saved(klipper):
    points = moves(run(PURGE, klipper))
    after = points[-math.ceil(math.dist((20, 20), (0, 0)) / 5.0):]  # the last move, cut
    e = [Decimal(f"{v:.5f}") for v in after[:, 3]]
    assert len(e) == 6 and e == sorted(e) and e[0] == Decimal("0.33333") and e[-1] == Decimal("2")  # from 0


def test_relative_mode_ends_where_the_state_is_restored(klipper):
    out = run(LIFT, klipper)
    assert_allclose(moves(out)[-1, :3], correct(np.array([10.0, 10.0, 0.2])), atol=1e-4)  # absolute again
    assert "G1 X0.0000 Y0.0000 Z2.0040" in out  # the lift, an increment


def test_move_1_goes_back_to_the_point_saved(klipper):
    points = moves(run(BACK, klipper))[:, :3]
    start, end = np.array([0.0, 0.0, 10.0]), np.array([10.0, 3.0, 10.0])  # from the saved point
    cut = math.ceil(math.dist(start, end) / 5.0)
    assert_allclose(points[-cut:], correct(start + np.outer(np.arange(1, cut + 1) / cut, end - start)),
                    atol=1e-4)


def test_state_names_are_case_sensitive_and_quoted_as_klipper_reads_them(klipper):
    out = run(CASES, klipper)
    assert out.splitlines()[-1] == "G1 X1.0020 Y0.0000 Z0.0000"  # 'ABS': relative, an increment written
    assert_allclose(moves(out)[-2, :3], correct(np.array([5.0, 5.0, 5.0])), atol=1e-4)  # 'abs': absolute


@pytest.mark.parametrize("line, says", [
    ("RESTORE_GCODE_STATE NAME=never", r"RESTORE_GCODE_STATE NAME=never: no state 'never' saved before it in "
                                       r"the program \(Klipper stops the print with 'Unknown g-code state'"),
    ("RESTORE_GCODE_STATE NAME=Purge", r"RESTORE_GCODE_STATE NAME=Purge: no state 'Purge' saved"),
    ("RESTORE_GCODE_STATE NAME=purge MOVE=1.0", r"RESTORE_GCODE_STATE MOVE=1.0: not an integer"),
    ("SAVE_GCODE_STATE NAME=a b", r"'SAVE_GCODE_STATE NAME=a b': Klipper answers 'Malformed command'"),
])
def test_a_state_klipper_cannot_restore_is_refused_by_its_line(klipper, line, says):
    with pytest.raises(InputError, match=rf"^G-code: line 3: {says}"):
        run(["G1 X0 Y0 Z10", "SAVE_GCODE_STATE NAME=purge", line], klipper)


# ---------------------------------------------------------------------------------------- in macros
def test_macros_states_are_told_apart_by_their_names(klipper):
    out = run(["G1 X0 Y0 Z10", "TWO_STATES", "G1 X1 Y1 Z5"], klipper)  # 'abs' restored: absolute
    assert_allclose(moves(out)[-1, :3], correct(np.array([1.0, 1.0, 5.0])), atol=1e-4)


def test_a_purge_macro_gives_the_extruder_position_back(klipper):
    out = run(["G1 X0 Y0 Z10", "M82", "G92 E5", "PURGE_LINE", "G1 X40 Y-30 E6"], klipper)
    assert [f"{v:.5f}" for v in moves(out)[-2:, 3]] == ["5.50000", "6.00000"]  # from 5, not from 20


@pytest.mark.parametrize("program, says", [
    (["NAMED_BY_EXPRESSION N=x"],
     r"line 2: the macro NAMED_BY_EXPRESSION: SAVE_GCODE_STATE NAME=\{\.\.\.\}: a Jinja expression gives the "
     "state's name"),
    (["MAYBE_SAVE S=1", "BACK"],
     r"line 3: the macro BACK: RESTORE_GCODE_STATE NAME=maybe: the state was saved under a Jinja condition"),
    (["SAVE_GCODE_STATE NAME=maybe", "G91", "MAYBE_BACK B=1"],
     r"line 4: the macro MAYBE_BACK: RESTORE_GCODE_STATE NAME=maybe under a Jinja condition: G90/G91, "
     "M82/M83 or E after it depend on the condition"),
])
def test_macro_states_that_cannot_be_followed_are_refused(klipper, program, says):
    with pytest.raises(InputError, match=rf"^G-code: {says}"):
        run(["G1 X0 Y0 Z10", *program], klipper)
    assert run(["G1 X0 Y0 Z10", "SAVE_GCODE_STATE NAME=maybe", "MAYBE_BACK", "G1 X1"], klipper)  # same modes


# ------------------------------------------------------------------------------ Klipper's own reading
def klipper_trace(machine: Klipper, text: str) -> tuple[dict, dict, dict]:
    """At each ``;@k`` mark: Klipper's G-code position, its toolhead's E, the toolhead's moves since."""
    at, e_at, between, since = {}, {}, {}, 0
    for line in text.splitlines():
        if line.startswith(";@"):
            at[line], between[line] = machine.position(), machine.toolhead.moves[since:]
            e_at[line], since = machine.toolhead.position[3], len(machine.toolhead.moves)
        else:
            machine.run(line)
    return at, e_at, between


@pytest.mark.parametrize("program", [PURGE, LIFT, BACK, CASES,
                                     ["G1 X0 Y0 Z10", "M83", "\ufeffG1 X40 Y0 Z10", "X40", "G1 X9 Y4 E1"]])
def test_klipper_runs_the_corrected_program_on_the_programs_points(klipper, tmp_path, program):
    marked = [x for k, line in enumerate(program) for x in (line, f";@{k}")]
    out = run(marked, klipper)
    meant, _, _ = klipper_trace(Klipper(tmp_path / "a"), "\n".join(marked))
    sent, e_sent, segments = klipper_trace(Klipper(tmp_path / "b"), out)
    assert list(sent) == list(meant)
    for mark, position in meant.items():
        assert_allclose(sent[mark][:3], correct(np.array(position[:3])), atol=2e-4)
        assert sent[mark][3] == pytest.approx(position[3], abs=1e-5)
    previous = None
    for mark, position in meant.items():  # each cut move's segments on the line meant, E in between
        if previous is not None and len(segments[mark]) > 1:
            points = (np.array(segments[mark])[:, :3] - SHIFT) / SCALE
            a, b = np.array(meant[previous][:3]), np.array(position[:3])
            along = (points - a) @ (b - a) / np.dot(b - a, b - a)
            assert_allclose(points, a + np.outer(along, b - a), atol=1e-3)
            e = np.array([e_sent[previous], *np.array(segments[mark])[:, 3]])
            assert np.all(np.diff(e) * np.sign(e[-1] - e[0] or 1.0) >= -1e-9)  # from the E before, monotonic
        previous = mark
