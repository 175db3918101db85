"""G-code program filtering: every move's XYZ corrected for a controller, streamed line by line.

A controller that runs its own (nominal) model is sent, instead of each target ``x`` of a
program, ``correct(x)``: the target that makes the real robot's TCP land on ``x``. Between two
targets the controller interpolates a straight line in its own model's space, which the real robot
bends; so moves longer than ``segment_mm`` are cut into shorter ones, each corrected, and the real
path follows the intended straight line (the bend of a segment shrinks as its length squared).

The filter reads one line at a time and keeps at most :data:`CHUNK_POINTS` points and
:data:`CHUNK_LINES` lines before it calls ``correct`` once on the chunk's points (an (N, 3) array
[mm]) and writes them out: memory is flat in the program's length, and ``correct`` is vectorised.

What is rewritten, and how:

- **Moves**: G0/G00/G1/G01 (and a line of axis words alone, in the current G0/G1 mode, where the
  dialect reads it so: :class:`~deltacal.gcode.dialect.LineReading`), with X, Y or Z. Written
  ``G0``/``G1`` then ``X Y Z`` (always all three), ``E``, ``F``, ``S``, in that order, upper case,
  XYZ with :data:`XYZ_DECIMALS` decimals (0.1 µm). A move without X, Y or Z (``G1 E-2 F2400``,
  ``G1 F1500``) does not move the TCP and is kept byte for byte.
- **Split moves**: a move longer than ``segment_mm`` (default :data:`DEFAULT_SEGMENT_MM` mm) is
  cut into equal segments. The first segment's line carries what the move line held besides its
  motion: its ``N`` label, its G90/G91/G17/G21 words, ``F`` and ``S`` (modal: they hold for the
  rest), and its comments (``(...)`` then ``;...``, at the end). ``E`` is split in proportion to
  length: in absolute mode (M82) each segment writes its interpolated E, the last the move's own
  value; in relative mode (M83, or G91 with M83) each writes its share, and the shares sum exactly
  to the move's E at the decimals written (at least :data:`E_DECIMALS`, more if the input had more).
- **G91** (relative): the output stays relative: each segment writes its corrected increment,
  the difference of the corrected absolute positions rounded to the output's decimals, so that the
  increments add up, without drift, to the rounded corrected positions of a G90 program.
- **Arcs**: G2 (clockwise)/G3 (counter-clockwise) in the XY plane (G17), centre by ``I J``
  (offsets from the start; ends that coincide make a full circle) or radius ``R`` (R > 0: at most a
  half turn, R < 0: more), Z interpolated linearly (a helix), E split as for lines. Written as G1
  chords (the controller's model is not the robot's, so the arc cannot be sent whole), each no
  longer than ``segment_mm`` and within :data:`ARC_TOLERANCE_RATIO` × ``segment_mm`` of the arc
  (5 µm at the default). The end radius may differ from the start radius by
  :data:`ARC_RADIUS_TOLERANCE_MM` or 0.1 % (the radius is then interpolated and the last point is
  the end as given); more is refused.
- **Kept byte for byte and in order**: every other line: comments, blank lines, M codes (M82 and
  M83 are read), dwell G4, G90/G91/G17/G21 alone, G92 E, T words, firmware commands that are not
  G-code words (``EXCLUDE_OBJECT_START NAME=a``), line endings (LF, CRLF) and bytes that are not
  UTF-8. A UTF-8 byte-order mark is kept at the start, and the line after it read as senders send
  it, without the mark. A ``;`` inside a ``(...)`` comment is the comment's.
- **Lines the controller does not run** (:class:`~deltacal.gcode.dialect.LineReading`): a command
  behind junk (a byte-order mark, a NUL, a digit: ``1G1 X40``), axis words without a G word where
  the firmware answers "Unknown command" (Klipper): kept byte for byte, the position not moved, and a warning
  (:class:`~deltacal.gcode.notes.Notes`) names the first line of each kind at the program's end.

Position: X, Y and Z are unknown at the start unless ``start`` gives them, and again after a
homing or probing line (G28, G29, G30, G38.x): the filter cannot know where the real robot then
stands; except after G28 when ``home`` gives where the controller's homing leaves the TCP (a
printer's firmware, every carriage at its endstop: Klipper's delta homes its three towers on any
G28), where the next move starts (absolute: the controller stands at its own home, not at a
corrected point, so a relative move right after it is refused). A move before all three are
known is refused by its line, except an absolute (G90) move that gives all three: it goes
straight to its corrected end, unsplit (its start is unknown).

Refused, each by its line (:class:`~deltacal.exceptions.InputError` naming the file and line): G20
(inches: convert the program to millimetres); G92 with X, Y or Z, or with no axis (they move the
origin the controller's targets are given in); work offsets and coordinate transforms (G10 L, G52,
G53-G59.x, G92.x, G68, G51); arcs outside the XY plane (G18, G19), with K, or with a P the dialect
does not read (Marlin's: whole circles, 0..100); a G code the dialect refuses (Marlin's G33); a word
the filter would have to carry across a split (A, B, C, U, V, W, H, ...) on a move; a checksum (``*``) on a
line the filter rewrites (checksums and line numbers belong to the serial link, not to a file); M82
or M83 on a line of G words (read by some firmwares, not by others); a number that is not one
(``X1.2.3``, ``X``); a split extruding move where the extruder mode is ambiguous (M83 then G90 with
no M82/M83 since: Marlin 1 and Repetier keep E relative, Marlin 2 and Smoothieware make it absolute; or G91
without M83: firmwares differ on whether G91 makes E relative) or where the extruder position is
not known yet in absolute mode (add ``G92 E0``); a target that ``correct`` refuses (its
:class:`~deltacal.exceptions.UnreachableError`, mapped to the lines), or a coordinate beyond
:data:`MAX_COORDINATE_MM`; a command, as written, that the controller's ``limits`` refuse (a
printer's firmware: Klipper's "Move out of range"), gathered over the whole program and refused at
its end by the first one's line, with the configuration key and the value that admit them all; a G
word after an M code on its line (``M83 G1 X40``: Marlin and Klipper read the first command alone,
LinuxCNC and grbl both); a block-delete line (``/G1 ...``) that would be read (it runs or not by the
controller's switch); words after a ``(...;...)`` comment (Klipper ends the line at the ``;``); a
line that starts with :data:`~deltacal.gcode.marker.MARKER` (the program is already corrected); as
the dialect says (:class:`~deltacal.gcode.dialect.LineReading`): junk before a command where the
controller's reading is not known, axis words alone where the firmware's build or mode decides
(Marlin, RepRapFirmware), a NUL where it ends a line (RepRapFirmware), a blank the firmware does not
skip before a command (a tab, for Marlin).

Units: mm (G21); the file's numbers are written as they are read where they are kept.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from ..exceptions import InputError
from ..io.atomic import atomic_output
from .batch import CHUNK_LINES, CHUNK_POINTS, MAX_COORDINATE_MM, XYZ_DECIMALS, Batch, Correct, Progress
from .dialect import GENERIC, ArcP, CommandRule, Dialect, Unread
from .homing import FromHome
from .macros import apply_macro
from .marker import is_marker
from .moves import E_DECIMALS, KEPT, LimitsChange, MoveText, Plan, SingleMove, SplitMove
from .notes import Notes
from .path import ARC_RADIUS_TOLERANCE_MM, ARC_TOLERANCE_RATIO, ArcPath, StraightPath, arc_path
from .source import SUFFIXES, is_gcode_path, opened_lines, read_lines
from .state import MOTIONS, PLANES, Extrusion, ModalState, Motion, Plane
from .syntax import (
    JUNK,
    M_LINE,
    PARENS,
    READ,
    TEXT_M,
    WORD,
    block_delete_refusal,
    bytes_refusal,
    command_then_g_refusal,
    junk_split,
    line_params,
    mark_refusal,
    semicolon_refusal,
    split_line,
)

if TYPE_CHECKING:
    from ..controller.limits import CommandLimits

__all__ = [
    "ARC_RADIUS_TOLERANCE_MM",
    "ARC_TOLERANCE_RATIO",
    "CHUNK_LINES",
    "CHUNK_POINTS",
    "DEFAULT_SEGMENT_MM",
    "E_DECIMALS",
    "MAX_COORDINATE_MM",
    "MIN_SEGMENT_MM",
    "SUFFIXES",
    "XYZ_DECIMALS",
    "filter_gcode",
    "filter_lines",
    "is_gcode_path",
    "read_lines",
]

#: Longest segment sent to the controller [mm]. The bend of a segment grows as its length squared:
#: on the two demo robots with Bai's errors, the real path strays from the intended line by at most
#: 0.09-0.15 µm at 5 mm (of which 0.07 µm is the output's rounding), 0.3-0.4 µm at 10 mm, 1.2-1.5 µm
#: at 20 mm and 7-9 µm at 50 mm; a program grows by one line per 5 mm of travel at most. Kit printers
#: through Klipper (Tolerances.printer_kit, 3 seeds): 0.3-1.3 µm at 5 mm, 5-15 µm at 20 mm.
DEFAULT_SEGMENT_MM = 5.0
#: Shortest segment asked for [mm]: 100 times the output's resolution (0.1 µm), whose rounding
#: (0.09 µm at most) shorter segments' own bend never reaches (0.1-0.15 µm at 5 mm already, as the
#: length squared); and below it a program grows without useful bound (1e-9 mm: 10^6 lines a µm).
MIN_SEGMENT_MM = 0.01
_LINE = re.compile(r"(?:\s*[A-Za-z]\s*[-+]?[0-9.]*)*\s*")
_NUMBER = re.compile(r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)")
#: A plain move: G0/G1 (or axis words alone) then X, Y, Z, E, F with plain numbers, upper case.
_FAST = re.compile(r"[ \t]*(G0?[01](?=[ \t]))?((?:[ \t]*[XYZEF][-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))+)[ \t]*"
                   r"(;[^\r\n]*)?(\r\n|\n|\r)?")
_NUM = r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)"
#: The plainest move, in the order slicers write it (F first or last).
_PLAIN = re.compile(rf"(G0?[01]) (?:F({_NUM}) )?X({_NUM}) Y({_NUM})(?: Z({_NUM}))?(?: E({_NUM}))?"
                    rf"(?: F({_NUM}))?(\r\n|\n|\r)?")
_FAST_WORD = re.compile(r"([XYZEF])([-+]?[0-9.]+)")
_HOMING = (28.0, 29.0, 30.0, 38.2, 38.3, 38.4, 38.5)
_FRAMES = (52.0, 53.0, 54.0, 55.0, 56.0, 57.0, 58.0, 59.0, 59.1, 59.2, 59.3, 92.1, 92.2, 92.3, 68.0, 51.0)
_MODES = (90.0, 91.0, 17.0, 21.0)  # kept on a move's first segment
_MOVE_WORDS = frozenset("GXYZEFSN")
_ARC_WORDS = frozenset("GXYZEFSNIJR")
# the modes compared on most lines, bound once
_RAPID, _LINEAR = Motion.RAPID, Motion.LINEAR
_ARCS = (Motion.CLOCKWISE, Motion.COUNTER_CLOCKWISE)
_ABSOLUTE, _AMBIGUOUS = Extrusion.ABSOLUTE, Extrusion.AMBIGUOUS
#: Builds a SingleMove without the call of its __new__ (half its cost, on most lines of a program).
_new_tuple = tuple.__new__


def filter_lines(lines: Iterable[str], correct: Correct, segment_mm: float = DEFAULT_SEGMENT_MM,
                 start=None, source: str = "G-code", home=None, dialect: Dialect | None = None,
                 limits: CommandLimits | None = None, marker: str | None = None) -> Iterator[str]:
    """The filtered program, as blocks of text, from its lines (a generator: nothing is read ahead).

    Args:
        lines: The program's lines, each with its line ending (as :func:`read_lines` gives them).
        correct: ``correct(points)`` -> targets to send, both (N, 3) [mm]; may raise
            :class:`~deltacal.exceptions.UnreachableError` naming indices of ``points``.
        segment_mm: Longest segment sent [mm].
        start: TCP position [mm] at the program's start, or None (unknown).
        source: Name of the program in messages.
        home: Where a homing (G28) leaves the TCP [mm] (a printer's firmware: every carriage at
            its endstop), or None: the dialect's (unknown after it, without one).
        dialect: The controller's reading of G-code (:class:`~deltacal.gcode.dialect.Dialect`:
            E under G91, arcs' P, homing, macros); default :data:`~deltacal.gcode.dialect.GENERIC`.
        limits: The controller's limits on its commands (a firmware's), or None: every command, as
            written, is checked; those refused are gathered over the whole program and refused at
            its end, by the first one's line, with the key and value that admit them all.
        marker: A comment written as the output's first line (after a byte-order mark), with the
            first line's ending (:func:`~deltacal.gcode.marker.marker_line`), or None.

    Yields:
        The output text, a chunk at a time.

    Raises:
        InputError: a refused line (see the module's documentation), naming ``source`` and the line.
    """
    if not (isinstance(segment_mm, int | float) and math.isfinite(segment_mm) and segment_mm > 0):
        raise ValueError(f"segment_mm must be a positive number of mm, got {segment_mm!r}")
    if segment_mm < MIN_SEGMENT_MM:
        raise ValueError(f"segment_mm {segment_mm:g} is below {MIN_SEGMENT_MM:g} mm, 100 times the "
                         "output's resolution: shorter segments follow the rounding, not the path")
    if start is not None:
        start = tuple(float(v) for v in start)
        if len(start) != 3 or not all(abs(v) <= MAX_COORDINATE_MM for v in start):
            raise ValueError(f"start must be three finite numbers X, Y, Z within ±{MAX_COORDINATE_MM:g} mm, "
                             f"got {start!r}")
    dialect = GENERIC if dialect is None else dialect
    reader = _Reader(source, float(segment_mm), start, dialect if home is None else dialect.with_home(home))
    read, plain, match_plain = reader.line, reader.plain, _PLAIN.fullmatch
    batch = Batch(correct, source, limits)
    if start is not None:
        batch.anchor(start)
    points, items = batch.points, batch.items
    lines = opened_lines(iter(lines), marker, items,
                         lambda first: reader.refuse(1, mark_refusal(first, dialect.lines, dialect.name)))
    for number, line in enumerate(lines, 1):
        plain_match = match_plain(line)  # the plainest move first, at the least cost
        plan = (plain_match is not None and plain(plain_match)) or read(number, line)
        if isinstance(plan, SingleMove):  # the commonest first; batch.single(plan, number), inline
            points.append(plan.end)
            items.append((plan.relative, plan.prefix, plan.suffix, number))
            if plan.relative:
                batch.relative = True
        elif isinstance(plan, SplitMove):
            yield from _split_out(batch, plan, number)
        elif isinstance(plan, FromHome):  # the first move after a homing, in a chunk of its own
            if items:
                yield batch.flush()
            batch.home_move(plan.home)
            if isinstance(plan.plan, SingleMove):
                batch.single(plan.plan, number)
            else:
                yield from _split_out(batch, plan.plan, number)
            batch.home_move(plan.home, end=True)
        elif isinstance(plan, LimitsChange):  # the commands after it checked against the limits it sets
            items.append(line)
            if batch.refused is not None:
                yield batch.flush()
                batch.refused.switch(plan.limits(batch.refused.limits), plan.by)
        else:  # KEPT
            items.append(line)
        if len(points) >= CHUNK_POINTS or len(items) >= CHUNK_LINES:
            yield batch.flush()
    yield batch.flush()
    refusal = None if batch.refused is None else batch.refused.error(source)
    if refusal is not None:
        raise refusal
    reader.notes.say()


def _split_out(batch: Batch, plan: SplitMove, number: int) -> Iterator[str]:
    """A split move into the batch: a long move goes out in pieces, never more than a chunk at once."""
    path, text = plan.path, plan.text
    k0 = 0
    while k0 < path.n:
        k1 = min(path.n, k0 + batch.room())
        batch.split(path.points(k0, k1), number, text, k0, k1, path.n)
        k0 = k1
        if batch.full():
            yield batch.flush()


def filter_gcode(source: str | Path, destination: str | Path, correct: Correct,
                 segment_mm: float = DEFAULT_SEGMENT_MM, start=None,
                 progress: Progress | None = None, home=None, dialect: Dialect | None = None,
                 limits: CommandLimits | None = None, marker: str | None = None) -> None:
    """Write the program ``source`` with every move corrected to ``destination``, atomically.

    Args:
        source: The G-code program (read as UTF-8; other bytes are kept as they are).
        destination: The corrected program; left untouched if anything fails.
        correct: ``correct(points)`` -> targets to send, both (N, 3) [mm] (see :func:`filter_lines`).
        segment_mm: Longest segment sent [mm] (default :data:`DEFAULT_SEGMENT_MM`).
        start: TCP position [mm] at the program's start (X, Y, Z), or None.
        progress: Called as ``progress(fraction, "")`` after each chunk (the fraction of the file read).
        home: Where a homing (G28) leaves the TCP [mm], or None (see :func:`filter_lines`).
        dialect: The controller's reading of G-code (see :func:`filter_lines`).
        limits: The controller's limits on its commands, or None (see :func:`filter_lines`).
        marker: The output's first line, a comment, or None (see :func:`filter_lines`).

    Raises:
        InputError: a refused line, naming the file and the line.
    """
    opened: list = []
    path = Path(source)
    size = max(path.stat().st_size, 1) if path.is_file() else 1
    blocks = filter_lines(read_lines(source, opened), correct, segment_mm, start, str(source), home, dialect,
                          limits, marker)
    with atomic_output(destination) as tmp, open(tmp, "w", encoding="utf-8", errors="surrogateescape",
                                                 newline="") as out:
        for block in blocks:
            out.write(block)
            if progress is not None and opened:
                done = opened[0].buffer.tell() if not opened[0].closed else size
                progress(min(done / size, 1.0), "")


class _Reader:
    """Reads the program line by line: the state, and the plan of each move."""

    def __init__(self, source: str, segment_mm: float, start, dialect: Dialect = GENERIC) -> None:
        self.source = source
        self.segment_mm = segment_mm
        self.state = ModalState(start, dialect.g91_moves_e, dialect.distance_sets_e, dialect.e_by_m83)
        self.start = start
        self.dialect = dialect
        self.macros = bool(dialect.macros)
        self.home = dialect.home
        self.lines = dialect.lines
        self.modal_axis_words = dialect.lines.axis_words is Unread.MODAL
        self.nul = dialect.lines.nul_ends_line
        self.notes = Notes(source)
        self.g_rules = {float(k[1:]): v for k, v in dialect.rules.items() if k[0] == "G"}
        self.m_rules = {k[1:]: v for k, v in dialect.rules.items() if k[0] == "M"}
        self.newline = "\n"  # the last line ending read: it separates the segments of a last line

    def fail(self, number: int, detail: str) -> InputError:
        """The error for line ``number``."""
        return InputError(detail, self.source, f"line {number}")

    def line(self, number: int, line: str) -> Plan | FromHome:
        """The plan of a line (:meth:`plain` first reads what it can of the plainest moves)."""
        fast = _FAST.fullmatch(line)
        if fast is not None:  # the plain move of most programs, read at once
            g, body, comment, ending = fast.groups()
            if line[0] <= " " or (comment is not None and self.nul):  # blanks first, a NUL in its comment
                self.check_bytes(number, line, line.lstrip())
            st = self.state
            if g is not None:
                st.motion = _LINEAR if g[-1] == "1" else _RAPID
            elif not self.modal_axis_words:  # axis words alone: an unknown command, or refused
                return self.axis_words(number, line, any(c in body for c in "XYZE"))
            if st.motion is _RAPID or st.motion is _LINEAR:
                words = _FAST_WORD.findall(body)
                given = dict(words)
                if len(given) == len(words):  # else a word given twice: refused below
                    return self.plan(number, given, "", comment or "", ending or "")
        s = line.lstrip()
        if len(s) != len(line) or self.nul:
            self.check_bytes(number, line, s)
        if self.macros and s and s[0] != ";":
            effect = self.dialect.macro(s)
            if effect is not None:  # the controller's macro: where it leaves the nozzle
                self.refuse(number, apply_macro(self.state, effect, number, self.home, self.start))
                if effect.warning:
                    self.notes.add(effect.name, number, f"{s.strip()!r}: {effect.warning}")
                return KEPT
        if not s or s[0] not in READ:
            if s[:1] == "/":
                self.refuse(number, block_delete_refusal(s))
            elif is_marker(s):
                raise self.fail(number, f"the program is already corrected ({s.strip()!r}): correct the "
                                        "program it was made from")
            elif s and s[0] != ";" and JUNK.match(s):  # a comment, the commonest, is never junk
                self.junk(number, s)
            return KEPT
        m = M_LINE.match(s)
        if m is not None:  # M codes are kept as they are; M82 and M83 set the extruder's mode
            if ("G" in s or "g" in s) and m.group(1) not in TEXT_M:
                self.refuse(number, command_then_g_refusal(s))
            if m.group(1) in ("82", "83"):
                self.state.set_extruder(m.group(1) == "83")
            elif m.group(1) in self.m_rules:
                return self.rule(number, f"M{m.group(1)}", self.m_rules[m.group(1)], s)
            return KEPT
        code, comment, ending = split_line(line)
        parens = ""
        if "(" in code:
            parens = " ".join(PARENS.findall(code))
            self.refuse(number, semicolon_refusal(code))
            code = PARENS.sub(" ", code)
            if "(" in code:
                raise self.fail(number, "a '(' comment is not closed on its line")
        read = self.words(number, code)
        if read is None:
            return KEPT
        return self.dispatch(number, read, code, " ".join(p for p in (parens, comment) if p), ending)

    def refuse(self, number: int, why: str | None) -> None:
        """Refuse line ``number`` for ``why``, if given."""
        if why is not None:
            raise self.fail(number, why)

    def rule(self, number: int, command: str, rule: CommandRule, code: str) -> Plan:
        """A command the correction cannot follow: refused, said, or limits it sets (``Dialect.rules``)."""
        params = line_params(code)
        if not rule.applies(params):
            return KEPT
        if rule.limits is not None:
            change = rule.limits
            return LimitsChange(lambda before: change(before, params), f"line {number} ({code.strip()})")
        if not rule.warn:
            raise self.fail(number, f"{command}: {rule.why}")
        self.notes.add(command, number, f"{code.strip()!r}: {rule.why}")
        return KEPT

    def check_bytes(self, number: int, line: str, s: str) -> None:
        """Refuse a NUL where the controller ends a line, or a blank before a command it does not skip."""
        self.refuse(number, bytes_refusal(line, s, self.lines, self.dialect.name))

    def junk(self, number: int, s: str) -> None:
        """A line with text before its command's first letter (a byte-order mark, a NUL, ``1G1``)."""
        prefix, command = junk_split(s)
        if self.lines.junk is Unread.REFUSED:
            raise self.fail(number, f"text {prefix!r} before the command {command!r}: controllers differ on "
                                    "whether the line runs (Klipper and Marlin answer 'Unknown command', "
                                    "RepRapFirmware runs what follows a NUL): remove it")
        self.notes.add("junk", number, f"{prefix + command!r}: text {prefix!r} before its command, which "
                       f"{self.dialect.name} answers with '{self.lines.unknown}' and does not run (files "
                       "joined?): kept as it is, the position not moved; remove the text if the line "
                       "should run")

    def axis_words(self, number: int, text: str, moves: bool) -> Plan:
        """A line of axis words without a G word first, as the controller reads it (not as G-code's modal)."""
        if not moves:
            return KEPT  # F, S, T ... alone: nothing moves
        text = text.strip()
        if self.lines.axis_words is Unread.REFUSED:
            why = self.lines.axis_words_why
            raise self.fail(number, f"axis words without G0/G1 first ({text!r}): {why}: write G1 (or G0) "
                                    "before them, or remove the line")
        self.notes.add("axis words", number, f"{text!r}: axis words without G0/G1 first: "
                       f"{self.lines.axis_words_why}: kept as it is, the position not moved; write G1 "
                       "before them if the move is meant")
        return KEPT

    def plain(self, match: re.Match) -> SingleMove | None:
        """A short absolute ``G0/G1 X Y [Z] [E] [F]`` from a known position, sent whole; else None.

        Most lines of a printing program are these: read here at once, as :meth:`plan` would
        (tests/test_gcode.py holds the two to the same output).
        """
        st = self.state
        start = st.pos
        g, f1, x, y, z, e, f2, ending = match.groups()
        if st.relative or start[2] is None or start[0] is None or start[1] is None or \
                (f1 is not None and f2 is not None) or st.homed:
            return None
        end = (float(x), float(y), start[2] if z is None else float(z))
        dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
        if dx * dx + dy * dy + dz * dz > self.segment_mm * self.segment_mm:
            return None
        linear = g[-1] == "1"
        st.motion = _LINEAR if linear else _RAPID
        st.pos = end
        st.fresh = False
        if ending:
            self.newline = ending
        f = f1 if f2 is None else f2
        if e is not None:  # st.extrude(float(e), st.extrusion), inline
            mode = st.extrusion
            st.e_pos = float(e) if mode is _ABSOLUTE else \
                None if mode is _AMBIGUOUS or st.e_pos is None else st.e_pos + float(e)
        suffix = ("" if e is None else " E" + e) + ("" if f is None else " F" + f) + (ending or "")
        return _new_tuple(SingleMove, (end, False, "G1 " if linear else "G0 ", suffix))

    def words(self, number: int, code: str) -> list[tuple[str, str]] | None:
        """The line's (LETTER, number text) words; None where the line is not G-code words."""
        checksum = code.find("*")
        body = code if checksum < 0 else code[:checksum]
        whole = _LINE.fullmatch(body)
        words = WORD.findall(body)
        if not words or not words[0][1]:
            return None  # a firmware command (SET_FAN_SPEED, EXCLUDE_OBJECT_START ...) or a bare letter
        if whole is None:
            end = _LINE.match(body)
            at = end.end() if end is not None else 0
            raise self.fail(number, f"unexpected text {body[at:at + 12].strip()!r} in a G-code line "
                                    "(a decimal comma? a word without its letter?)")
        words = [(letter.upper(), value) for letter, value in words]
        if checksum >= 0:
            words.append(("*", code[checksum:].strip()))
        return words

    def dispatch(self, number: int, words, code: str, comment: str, ending: str) -> Plan | FromHome:
        """Update the state from a line's words; the plan of its move, if it has one."""
        st = self.state
        first = words[1][0] if words[0][0] == "N" and len(words) > 1 else words[0][0]
        if first != "G" and not self.modal_axis_words:  # the controller's command is the first word
            return self.axis_words(number, code, any(w[0] in "XYZEIJR" for w in words))
        gs = [self.number(number, letter, value) for letter, value in words if letter == "G"]
        mode = next((f"M{v}" for letter, v in words if letter == "M" and v.lstrip("0") in ("82", "83")), None)
        if mode is not None:  # G90 M83: Marlin reads one command a line, LinuxCNC both
            raise self.fail(number, f"{mode} on a line of G words: firmwares differ on whether it is read; "
                                    "put it on a line of its own")
        for g in gs:
            if g in self.g_rules:
                self.rule(number, f"G{g:g}", self.g_rules[g], code)
        if any(g in _HOMING for g in gs):
            if self.home is not None and all(g == 28.0 for g in gs if g in _HOMING):
                st.pos, st.homed = self.home, number  # a firmware's homing: every carriage at its endstop
                st.homed_by, st.at_home = "the homing", True
            else:
                st.pos, st.unknown_since, st.unknown_why = (None, None, None), number, ""
            return KEPT
        if not gs and not any(w[0] in "XYZIJRE" for w in words):
            return KEPT  # a numbered line without motion, F alone ...
        return self.g_line(number, gs, words, comment, ending)

    def g_line(self, number: int, gs: list[float], words, comment: str, ending: str) -> Plan | FromHome:
        """A line of G words and axis words: modes, G92, a move, or a line to keep."""
        st = self.state
        axes = {w[0] for w in words} & set("XYZ")
        motion = [g for g in gs if g in MOTIONS]
        for g in gs:
            if g == 20.0:
                raise self.fail(number, "G20 (inches) is not supported: convert the program to "
                                        "millimetres (G21)")
            if g in _FRAMES or (g == 10.0 and any(w[0] == "L" for w in words)):
                raise self.fail(number, f"G{g:g} changes the coordinate system: the filter cannot "
                                        "follow it (remove it, or express the program in one frame)")
        if 92.0 in gs:
            return self.g92(number, words)
        if len(motion) > 1:
            raise self.fail(number, f"two motion codes on one line: G{motion[0]:g} and G{motion[1]:g}")
        for g in gs:
            if g == 90.0 or g == 91.0:
                st.set_distance(g == 91.0)
            elif g in PLANES:
                st.plane = PLANES[g]
        if motion:
            st.motion = MOTIONS[motion[0]]
        other = [g for g in gs if g not in _MODES and g not in MOTIONS]
        arc_words = any(w[0] in "IJR" for w in words)
        if not motion and (other or not (axes or arc_words)):
            if axes and other:
                raise self.fail(number, f"G{other[0]:g} with X, Y or Z is not supported by the filter")
            e_text = next((v for letter, v in words if letter == "E"), None)
            if e_text is not None:
                st.extrude(self.number(number, "E", e_text), st.extrusion)
            return KEPT
        if st.motion is None:
            raise self.fail(number, "X, Y or Z without G0/G1/G2/G3, and no motion mode set before")
        if other:
            raise self.fail(number, f"G{other[0]:g} on a move line is not supported: put it on a line "
                                    "of its own")
        return self.move(number, words, gs, comment, ending)

    def number(self, number: int, letter: str, value: str) -> float:
        """The value of a word, or the error naming it."""
        if not _NUMBER.fullmatch(value):
            raise self.fail(number, f"word {letter}{value!r}: {value or 'nothing'} is not a number"
                            if value else f"word {letter} has no number")
        return float(value)

    def g92(self, number: int, words) -> Plan:
        """G92: E sets the extruder's position (the line is kept); X, Y, Z or nothing are refused."""
        given = {w[0]: w[1] for w in words if w[0] != "G"}
        if set(given) & set("XYZ"):
            raise self.fail(number, "G92 with X, Y or Z is refused: it moves the origin of the "
                                    "controller's targets, which the filter cannot follow")
        if "E" not in given:
            raise self.fail(number, "G92 without axes is refused: it sets X, Y and Z to zero")
        self.state.e_pos = self.number(number, "E", given["E"])
        return KEPT

    def move(self, number: int, words, gs: list[float], comment: str, ending: str) -> Plan | FromHome:
        """The plan of a G0/G1/G2/G3 line, its words checked."""
        arc = self.state.motion in _ARCS
        allowed = _ARC_WORDS if arc else _MOVE_WORDS
        given: dict[str, str] = {}
        for letter, value in words:
            if letter == "*":
                raise self.fail(number, f"checksum {value!r} on a move line: checksums and line numbers "
                                        "belong to the serial link; remove them from the file")
            if letter == "P" and arc and self.dialect.arc_p is not ArcP.REFUSED:
                self.number(number, letter, value)
                if self.dialect.arc_p is ArcP.CIRCLES:
                    given[letter] = self.circles(number, value)
                continue  # Klipper never reads it (gcode_arcs.py)
            if letter not in allowed:
                raise self.fail(number, f"word {letter}{value} on {'an arc' if arc else 'a move'} line "
                                        "is not supported by the filter")
            if letter in given and letter != "G":
                raise self.fail(number, f"word {letter} given twice")
            self.number(number, letter, value)
            given[letter] = value
        head = " ".join(x for x in ((f"N{given['N']}" if "N" in given else ""),
                                    *(f"G{g:g}" for g in gs if g in _MODES)) if x)
        return self.plan(number, given, head, comment, ending)

    def plan(self, number: int, given: dict[str, str], head: str, comment: str,
             ending: str) -> Plan | FromHome:
        """The plan of a move whose numbers are checked: kept (no XYZ), sent whole, or split.

        The first move after a homing is a :class:`~deltacal.gcode.homing.FromHome` of its plan.
        """
        plan = self.plan_move(number, given, head, comment, ending)
        st = self.state
        if st.at_home and plan is not KEPT:
            st.at_home = False
            return FromHome(plan, self.home)  # type: ignore[arg-type]
        return plan

    def plan_move(self, number: int, given: dict[str, str], head: str, comment: str, ending: str) -> Plan:
        """:meth:`plan`, without the homing."""
        st = self.state
        if ending:
            self.newline = ending
        motion = st.motion
        arc = motion in _ARCS
        e_text = given.get("E")
        e_mode = _ABSOLUTE if e_text is None else st.extrusion
        if not arc and "X" not in given and "Y" not in given and "Z" not in given:
            if e_text is not None:
                st.extrude(float(e_text), e_mode)
            return KEPT  # no XYZ: the TCP does not move, the line is kept
        start, e_start = st.pos, st.e_pos
        if st.relative or None in start:
            end = self.target(number, given)
        else:  # the usual case, inline: absolute, position known
            x, y, z = given.get("X"), given.get("Y"), given.get("Z")
            end = st.pos = (start[0] if x is None else float(x), start[1] if y is None else float(y),
                            start[2] if z is None else float(z))
        st.homed = 0
        st.fresh = False
        if e_text is not None:
            st.extrude(float(e_text), e_mode)
        tail = (f" F{given['F']}" if "F" in given else "") + (f" S{given['S']}" if "S" in given else "")
        code = "G0" if motion is _RAPID else "G1"
        path: ArcPath | StraightPath | None = None
        if arc:
            if None in start:
                raise self.fail(number, "arc from an unknown position: give X, Y and Z on a G0/G1 "
                                        "move before it")
            self.far(number, start, end)
            if self.state.plane is not Plane.XY:
                raise self.fail(number, f"arc in the plane of G{self.state.plane.value}: only XY arcs (G17) "
                                        "are supported")
            try:
                path = arc_path(start, end, given, motion is Motion.CLOCKWISE, self.segment_mm)
            except InputError as exc:
                raise self.fail(number, exc.detail) from None
        elif None not in start and math.dist(start, end) > self.segment_mm:  # type: ignore[arg-type]
            self.far(number, start, end)
            path = StraightPath(start, end, self.segment_mm)
        if path is None or path.n == 1:  # sent whole (also when the start is unknown: all XYZ given)
            e = f" E{e_text}" if e_text is not None else ""
            return SingleMove(end, st.relative, f"{head} {code} " if head else code + " ",
                              e + tail + (" " + comment if comment else "") + ending)
        if e_text is not None and e_mode is Extrusion.AMBIGUOUS:
            raise self.fail(number, "E is split here, but its mode is ambiguous (M83 then G90, or G91 "
                                    "without M83: firmwares differ): add M82 or M83 before this line")
        if e_text is not None and e_mode is Extrusion.ABSOLUTE and e_start is None:
            raise self.fail(number, "E is split here, but the extruder's position is not known yet "
                                    "(absolute E, M82): add G92 E0 before the first extruding move")
        text = MoveText.of(st.relative, code, head, tail, comment, (ending, self.newline), e_text, e_mode,
                           e_start)
        return SplitMove(path, text)

    def far(self, number: int, start, end) -> None:
        """Refuse a move to be cut whose ends are beyond any robot's reach.

        A move sent whole is refused with its point, by the batch, before it is corrected.
        """
        if not all(abs(v) <= MAX_COORDINATE_MM for v in (*start, *end)):
            raise self.fail(number, f"move from {list(start)} to {list(end)} mm: beyond "
                                    f"±{MAX_COORDINATE_MM:g} mm, out of reach of any robot")

    def target(self, number: int, given: dict[str, str]) -> tuple[float, float, float]:
        """The move's end [mm]; the position becomes it."""
        st = self.state
        pos = st.pos
        if st.relative and st.homed:  # the controller stands at its own home, not at a corrected point
            raise self.fail(number, f"relative move (G91) right after {st.homed_by} on line {st.homed}: give "
                                    "an absolute move (G90) first")
        if st.relative:
            end = [None if p is None else p + float(given.get(a, 0.0))
                   for p, a in zip(pos, "XYZ", strict=True)]
        else:
            x, y, z = given.get("X"), given.get("Y"), given.get("Z")
            end = [pos[0] if x is None else float(x), pos[1] if y is None else float(y),
                   pos[2] if z is None else float(z)]
        if None in end:
            missing = [axis for axis, v in zip("XYZ", end, strict=True) if v is None]
            since = "at the start" if st.unknown_since == 0 else \
                f"since {st.unknown_why or 'the homing'} on line {st.unknown_since}"
            hint = "give them on the first move, or the start position (--start X,Y,Z)" \
                if st.unknown_since == 0 else "give X, Y and Z on the first move after it (absolute, G90)"
            if st.unknown_why and st.fresh:
                hint += ", or where the macro leaves the nozzle (--start X,Y,Z)"
            raise self.fail(number, f"move before X, Y and Z are all known ({', '.join(missing)} unknown "
                                    f"{since}): {hint}")
        st.pos = tuple(end)
        return st.pos  # type: ignore[return-value]

    def circles(self, number: int, value: str) -> str:
        """An arc's P as full circles (Marlin's ARC_P_CIRCLES): a whole number 0..100."""
        if not (_NUMBER.fullmatch(value) and float(value).is_integer() and 0 <= float(value) <= 100):
            raise self.fail(number, f"word P{value} on an arc: {self.dialect.name} takes P as a whole "
                                    "number of full circles, 0 to 100")
        return str(int(float(value)))
