"""A chunk of a G-code program on its way out: lines kept, move points corrected once per chunk.

The G-code reader (:mod:`deltacal.gcode.rewriter`) hands each line to a :class:`Batch`: a line kept as
it is, a move sent whole (:class:`~deltacal.gcode.moves.SingleMove`), or a split move's points with
the text around them (:class:`~deltacal.gcode.moves.MoveText`). When the batch holds
:data:`CHUNK_POINTS` points or :data:`CHUNK_LINES` lines, :meth:`Batch.flush` calls ``correct``
once on all its points and returns the chunk's output text, in the input's order.

Numbers written: XYZ rounded to :data:`XYZ_DECIMALS` decimals as integers of 10^-4 mm, so that
relative (G91) increments are differences of integers and add up exactly to the rounded absolute
positions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain

import numpy as np

from ..controller.limits import CommandLimits, RefusedCommands
from ..exceptions import AssemblyError, InputError, UnreachableError
from .homing import blend_from_home
from .moves import MoveText, SingleMove

#: Points corrected at once (one call of ``correct``).
CHUNK_POINTS = 10_000
#: Lines held at most before they are written (kept lines count too).
CHUNK_LINES = 50_000
#: Decimals of the XYZ written [mm]: 1e-4 mm, rounding within 0.05 µm per axis.
XYZ_DECIMALS = 4
_SCALE = 10**XYZ_DECIMALS
#: Largest coordinate sent to ``correct`` [mm] (1 km: no robot's reach); a point beyond is refused
#: as out of reach before it is computed (the kinematics would overflow on squares of 1e154).
MAX_COORDINATE_MM = 1e6

#: ``correct(points)`` -> targets to send, both (N, 3) [mm].
Correct = Callable[[np.ndarray], np.ndarray]
#: ``progress(fraction, detail)``.
Progress = Callable[[float, str], None]


#: A move sent whole, as the batch holds it: (relative, text before XYZ, text after, line). A plain
#: tuple of strings and numbers, which the garbage collector stops tracking (it keeps tracking a
#: SingleMove: the tens of thousands a batch holds made the filter about 10 % slower).
_Single = tuple[bool, str, str, int]


@dataclass(frozen=True, slots=True)
class _Start:
    """The position where the program starts: one point, corrected but not written (line 0)."""

    line: int = 0


@dataclass(frozen=True, slots=True)
class _Segments:
    """Points k0+1 .. k1 of a move cut into n segments, written with ``text``."""

    text: MoveText
    k0: int
    k1: int
    n: int
    line: int


class Batch:
    """Lines and move points waiting to be corrected and written (see the module's documentation).

    Attributes:
        items: In the output's order: a kept line (str), a move sent whole (``_Single``, one
            point), the points of a split move (``_Segments``), or the start position (``_Start``:
            one point, corrected, not written).
        points: The points of the items [mm], in their order.
        relative: Whether an item writes increments (G91).
        refused: The written commands the controller's limits refuse, or None (no limits known).
    """

    def __init__(self, correct: Correct, source: str, limits: CommandLimits | None = None) -> None:
        self.correct = correct
        self.source = source
        self.refused = None if limits is None else RefusedCommands(limits)
        self.previous: np.ndarray | None = None  # the controller's last position, in 1e-4 mm
        self.items: list[str | _Single | _Segments | _Start] = []
        self.points: list = []
        self.relative = False
        self.home: tuple[int, int, tuple] | None = None  # rows of a move from the home, and the home

    def full(self) -> bool:
        """Whether the batch should be flushed now."""
        return len(self.points) >= CHUNK_POINTS or len(self.items) >= CHUNK_LINES

    def room(self) -> int:
        """Points the batch takes before it is full (at least 1 until it is flushed)."""
        return max(CHUNK_POINTS - len(self.points), 1)

    def anchor(self, point) -> None:
        """The position where the program starts: corrected, not written (G91 increments start there)."""
        self.points.append(tuple(point))
        self.items.append(_Start())

    def home_move(self, home, end: bool = False) -> None:
        """The rows of a move from the controller's home begin (or, ``end``, end) here."""
        if not end:
            self.home = (len(self.points), -1, tuple(home))
        elif self.home is not None:
            self.home = (self.home[0], len(self.points), self.home[2])

    def single(self, move: SingleMove, number: int) -> None:
        """The move of line ``number``, sent whole (``filter_lines`` does this inline)."""
        self.points.append(move.end)
        self.items.append((move.relative, move.prefix, move.suffix, number))
        if move.relative:
            self.relative = True

    def split(self, points: np.ndarray | list, number: int, text: MoveText, k0: int, k1: int, n: int) -> None:
        """Points k0+1 .. k1 [mm] of a move cut into n segments."""
        self.points.extend(points if isinstance(points, list) else points.tolist())
        self.items.append(_Segments(text, k0, k1, n, number))
        if text.relative:
            self.relative = True

    def flush(self) -> str:
        """The output text of the batch, its points corrected; the batch is emptied."""
        xyz: list[str] = []
        increments: list[str] = []
        if self.points:
            flat = chain.from_iterable(self.points)  # faster than np.array of a list of tuples
            points = np.fromiter(flat, dtype=float, count=3 * len(self.points)).reshape(-1, 3)
            units = np.rint(self._corrected(points) * _SCALE).astype(np.int64)
            if self.refused is not None:  # the commands as written, as the controller reads them
                self.refused.check(units / _SCALE, np.array(self._lines()))
            xyz = _xyz(units)
            if self.relative:
                before = units[:1] if self.previous is None else self.previous[None, :]
                increments = _xyz(np.diff(units, axis=0, prepend=before))
            self.previous = units[-1]
        out: list[str] = []
        row = 0
        for item in self.items:  # by class, the commonest first (a match statement costs more here)
            if isinstance(item, tuple):  # _Single
                relative, prefix, suffix, _ = item
                out.append(prefix + (increments if relative else xyz)[row] + suffix)
                row += 1
            elif isinstance(item, str):
                out.append(item)
            elif isinstance(item, _Segments):
                count = item.k1 - item.k0
                texts = increments if item.text.relative else xyz
                out.extend(item.text.segments(texts[row:row + count], item.k0, item.n))
                row += count
            else:  # _Start
                row += 1
        self.items.clear()
        self.points.clear()
        self.relative = False
        self.home = None
        return "".join(out)

    def _corrected(self, points: np.ndarray) -> np.ndarray:
        """``correct(points)``, its refusals named by the lines of the points."""
        far = ~np.all(np.abs(points) <= MAX_COORDINATE_MM, axis=1)
        if np.any(far):
            raise self._refusal(points, list(np.flatnonzero(far)),
                                f"out of reach of the robot (beyond ±{MAX_COORDINATE_MM:g} mm)")
        if self.home is not None:
            return self._corrected_from_home(points)
        try:
            sent = np.asarray(self.correct(points), dtype=float)
        except (UnreachableError, AssemblyError) as exc:
            raise self._refusal(points, [int(i) for i in exc.indices], _words(exc)) from None
        if sent.shape != points.shape:
            raise ValueError(f"correct returned shape {sent.shape} for points of shape {points.shape}")
        bad = ~np.all(np.isfinite(sent), axis=1)
        if np.any(bad):
            raise self._refusal(points, list(np.flatnonzero(bad)), "not corrected (a non-finite target)")
        return sent

    def _corrected_from_home(self, points: np.ndarray) -> np.ndarray:
        """:meth:`_corrected` of a batch with a move from the home (:mod:`.homing`)."""
        assert self.home is not None
        r0, r1, home = self.home
        r1 = len(points) if r1 < 0 else r1
        rows = np.r_[0:r0, r1:len(points)]
        sent = np.empty_like(points)
        try:
            outside = None if self.refused is None else self.refused.limits.outside
            sent[r0:r1] = blend_from_home(self.correct, points[r0:r1], home, outside)
        except (UnreachableError, AssemblyError) as exc:
            raise self._refusal(points, [r0 + int(i) for i in exc.indices], _words(exc)) from None
        if rows.size:
            sent[rows] = self._rows(points, rows)
        return sent

    def _rows(self, points: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``correct`` of some rows of the batch, its refusals named by their lines."""
        try:
            sent = np.asarray(self.correct(points[rows]), dtype=float)
        except (UnreachableError, AssemblyError) as exc:
            raise self._refusal(points, [int(rows[i]) for i in exc.indices], _words(exc)) from None
        bad = ~np.all(np.isfinite(sent), axis=1)
        if np.any(bad):
            raise self._refusal(points, [int(rows[i]) for i in np.flatnonzero(bad)],
                                "not corrected (a non-finite target)")
        return sent

    def _lines(self) -> list[int]:
        """The line of each point of the batch (0: the start position)."""
        lines: list[int] = []
        for item in self.items:
            match item:
                case _Segments(k0=k0, k1=k1, line=line):
                    lines.extend([line] * (k1 - k0))
                case (_, _, _, line) | _Start(line=line):
                    lines.append(line)
        return lines

    def _refusal(self, points: np.ndarray, indices: list[int], what: str) -> InputError:
        """The error naming the line of the first refused point, and how many there are."""
        indices = indices or [0]
        first = indices[0]
        of_point = self._lines()
        number = of_point[first]
        where = f"line {number}" if number else "start position"
        of = "of this move " if number else ""
        detail = f"point {np.round(points[first], 4).tolist()} mm {of}is {what}"
        if len(indices) > 1:
            lines = sorted({of_point[i] for i in indices})
            shown = ", ".join(str(k) for k in lines[:10]) + (", ..." if len(lines) > 10 else "")
            detail += f"; {len(indices)} points in all, on line{'s' if len(lines) > 1 else ''} {shown}"
        return InputError(detail, self.source, where)


def _words(exc: UnreachableError | AssemblyError) -> str:
    """What a refusal says of a point."""
    if isinstance(exc, UnreachableError):
        return UnreachableError.WORDS[exc.reason]
    return "beyond the controller's model (no assembly)"


def _xyz(units: np.ndarray) -> list[str]:
    """``X.. Y.. Z..`` of integer positions in 1e-4 mm (one formatting in C for the whole batch)."""
    n = units.shape[0]
    return ("X%.4f Y%.4f Z%.4f\n" * n % tuple((units / _SCALE).ravel().tolist())).split("\n")[:n]
