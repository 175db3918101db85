"""A chunk of a G-code program on its way out: lines kept, move points corrected once per chunk.

The G-code reader (:mod:`deltacal.gcode.rewriter`) hands each line to a :class:`Batch`: a line kept as
it is, or a move's points with the text around them (:class:`MoveText`). When the batch holds
:data:`CHUNK_POINTS` points or :data:`CHUNK_LINES` lines, :meth:`Batch.flush` calls ``correct``
once on all its points and returns the chunk's output text, in the input's order.

Numbers written: XYZ rounded to :data:`XYZ_DECIMALS` decimals as integers of 10^-4 mm, so that
relative (G91) increments are differences of integers and add up exactly to the rounded absolute
positions; split E values and shares are integers of 10^-d (d decimals) that add up exactly.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..exceptions import AssemblyError, InputError, UnreachableError

#: Points corrected at once (one call of ``correct``).
CHUNK_POINTS = 10_000
#: Lines held at most before they are written (kept lines count too).
CHUNK_LINES = 50_000
#: Decimals of the XYZ written [mm]: 1e-4 mm, rounding within 0.05 µm per axis.
XYZ_DECIMALS = 4
#: Fewest decimals of a split E.
E_DECIMALS = 5

_SCALE = 10**XYZ_DECIMALS

#: ``correct(points)`` -> targets to send, both (N, 3) [mm].
Correct = Callable[[np.ndarray], np.ndarray]
#: ``progress(fraction, detail)``.
Progress = Callable[[float, str], None]


def _share(total: int, k: int, n: int) -> int:
    """round(total k / n), halves away from zero, in integers (exact: the n-th share is total)."""
    whole = (2 * abs(total) * k + n) // (2 * n)
    return whole if total >= 0 else -whole


class MoveText:
    """The text of a move line around its XYZ: what its first segment and the others write.

    Args:
        relative: Whether XYZ are written as increments (G91).
        code: ``G0`` or ``G1``.
        head: ``N`` label and mode words (G90, G91, G17, G21) of the line, or "".
        tail: `` F...`` and `` S...`` as given, or "".
        comment: The line's comments, or "".
        ending: The line's ending (LF, CR LF, CR, or "" on a last line without one) and the ending
            that separates its segments (the same, or the file's on a last line without one).
        e_text: The E word's number as given, or None.
        e_mode: ``absolute``, ``relative`` or ``ambiguous`` (never split).
        e_start: Extruder position before the move (absolute mode), or None.
    """

    __slots__ = ("relative", "code", "first", "after", "ending", "sep", "e_text", "e_mode", "e_start")

    def __init__(self, relative: bool, code: str, head: str, tail: str, comment: str, ending: tuple[str, str],
                 e_text: str | None, e_mode: str, e_start: float | None) -> None:
        self.relative = relative
        self.code = code + " "
        self.first = f"{head} {code} " if head else self.code
        self.after = tail + (" " + comment if comment else "")
        self.ending, self.sep = ending
        self.e_text = e_text
        self.e_mode = e_mode
        self.e_start = e_start

    def segments(self, xyz: list[str], k0: int, n: int) -> list[str]:
        """Lines of segments k0+1 .. k0+len(xyz) of n: the first carries the line's words."""
        e = self.e_words(k0, k0 + len(xyz), n)
        sep = self.sep
        out = []
        for j, text in enumerate(xyz):
            k = k0 + j + 1
            head = self.first if k == 1 else self.code
            after = self.after if k == 1 else ""
            out.append(f"{head}{text}{e[j]}{after}{self.ending if k == n else sep}")
        return out

    def e_words(self, k0: int, k1: int, n: int) -> list[str]:
        """`` E...`` of segments k0+1 .. k1 of n (absolute: interpolated; relative: shares)."""
        if self.e_text is None:
            return [""] * (k1 - k0)
        decimals = max(E_DECIMALS, len(self.e_text.partition(".")[2]))
        scale = 10**decimals
        total = round(float(self.e_text) * scale)
        if self.e_mode == "relative":
            values = [_share(total, k, n) - _share(total, k - 1, n) for k in range(k0 + 1, k1 + 1)]
        else:
            assert self.e_start is not None  # the reader refuses a split without it
            begin = round(self.e_start * scale)
            values = [begin + _share(total - begin, k, n) for k in range(k0 + 1, k1 + 1)]
        return [f" E{v / scale:.{decimals}f}" for v in values]


class Batch:
    """Lines and move points waiting to be corrected and written (see the module's documentation).

    Items, in the output's order: a kept line (str), or a tuple ``(count, relative, prefix, rest,
    line)``: a move sent whole (``prefix`` and ``rest`` the text around its XYZ), ``count`` points
    of a split move (``prefix`` None, ``rest`` its ``(MoveText, k0, n)``), or the start position
    (``relative`` None: corrected, not written).
    """

    def __init__(self, correct: Correct, source: str) -> None:
        self.correct = correct
        self.source = source
        self.previous: np.ndarray | None = None  # the controller's last position, in 1e-4 mm
        self.items: list = []
        self.points: list = []
        self.relative = False

    def full(self) -> bool:
        """Whether the batch should be flushed now."""
        return len(self.points) >= CHUNK_POINTS or len(self.items) >= CHUNK_LINES

    def room(self) -> int:
        """Points the batch takes before it is full (at least 1 until it is flushed)."""
        return max(CHUNK_POINTS - len(self.points), 1)

    def anchor(self, point) -> None:
        """The position where the program starts: corrected, not written (G91 increments start there)."""
        self.points.append(tuple(point))
        self.items.append((1, None, None, None, 0))

    def single(self, number: int, plan: tuple) -> None:
        """A move sent whole: ``plan`` is (end [mm], relative, text before XYZ, text after)."""
        self.points.append(plan[0])
        self.items.append((1, plan[1], plan[2], plan[3], number))
        if plan[1]:
            self.relative = True

    def split(self, points: np.ndarray | list, number: int, text: MoveText, k0: int, k1: int, n: int) -> None:
        """Points k0+1 .. k1 [mm] of a move cut into n segments."""
        self.points.extend(points if isinstance(points, list) else points.tolist())
        self.items.append((k1 - k0, text.relative, None, (text, k0, n), number))
        if text.relative:
            self.relative = True

    def flush(self) -> str:
        """The output text of the batch, its points corrected; the batch is emptied."""
        xyz: list[str] = []
        increments: list[str] = []
        if self.points:
            points = np.array(self.points, dtype=float).reshape(-1, 3)
            units = np.rint(self._corrected(points) * _SCALE).astype(np.int64)
            xyz = _xyz(units)
            if self.relative:
                before = units[:1] if self.previous is None else self.previous[None, :]
                increments = _xyz(np.diff(units, axis=0, prepend=before))
            self.previous = units[-1]
        out: list[str] = []
        row = 0
        for item in self.items:
            if item.__class__ is str:
                out.append(item)
                continue
            count, relative, prefix, rest, _ = item
            if relative is not None:
                texts = increments if relative else xyz
                if prefix is not None:
                    out.append(prefix + texts[row] + rest)
                else:
                    text, k0, n = rest
                    out.extend(text.segments(texts[row:row + count], k0, n))
            row += count
        self.items.clear()
        self.points.clear()
        self.relative = False
        return "".join(out)

    def _corrected(self, points: np.ndarray) -> np.ndarray:
        """``correct(points)``, its refusals named by the lines of the points."""
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

    def _lines(self) -> list[int]:
        """The line of each point of the batch (0: the start position)."""
        lines: list[int] = []
        for item in self.items:
            if item.__class__ is not str:
                lines.extend([item[4]] * item[0])
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
