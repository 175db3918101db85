"""The plan of a G-code line, as the reader (:mod:`deltacal.gcode.rewriter`) hands it out.

Every line read has one plan, of one of four types (told apart by their class):

* :data:`KEPT` (:class:`KeptLine`): the line is written as it is, byte for byte.
* :class:`SingleMove`: a move sent whole: its end is corrected, the text around it kept.
* :class:`SplitMove`: a move cut into segments along its path (a long line or an arc), each
  segment's end corrected and written with the move's words (:class:`MoveText`).
* :class:`LimitsChange`: a line kept that changes the controller's limits on its commands.

Numbers written: a split E is written with at least :data:`E_DECIMALS` decimals as integers of
10^-d (d decimals) that add up exactly to the move's E. Units: mm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

from .path import ArcPath, StraightPath
from .state import Extrusion

#: Fewest decimals of a split E.
E_DECIMALS = 5


def _share(total: int, k: int, n: int) -> int:
    """round(total k / n), halves away from zero, in integers (exact: the n-th share is total)."""
    whole = (2 * abs(total) * k + n) // (2 * n)
    return whole if total >= 0 else -whole


@dataclass(frozen=True, slots=True)
class MoveText:
    """The text of a split move around its segments' XYZ (built by :meth:`of`).

    Attributes:
        relative: Whether XYZ are written as increments (G91).
        code: ``G0 `` or ``G1 ``: the head of every segment but the first.
        first: The first segment's head: the line's ``N`` label and mode words, then ``code``.
        after: The first segment's text after XYZ and E: ``F``, ``S`` and the comments.
        ending: The line's ending (LF, CR LF, CR, or "" on a last line without one).
        sep: The ending between segments (``ending``, or the file's on a last line without one).
        e_text: The E word's number as given, or None.
        e_mode: How E is read (never ambiguous: such a move is refused).
        e_start: Extruder position before the move [mm] (absolute E), or None.
    """

    relative: bool
    code: str
    first: str
    after: str
    ending: str
    sep: str
    e_text: str | None
    e_mode: Extrusion
    e_start: float | None

    @classmethod
    def of(cls, relative: bool, code: str, head: str, tail: str, comment: str, ending: tuple[str, str],
           e_text: str | None, e_mode: Extrusion, e_start: float | None) -> MoveText:
        """The text of a move line.

        Args:
            relative: Whether XYZ are written as increments (G91).
            code: ``G0`` or ``G1``.
            head: ``N`` label and mode words (G90, G91, G17, G21) of the line, or "".
            tail: `` F...`` and `` S...`` as given, or "".
            comment: The line's comments, or "".
            ending: The line's ending and the ending that separates its segments.
            e_text: The E word's number as given, or None.
            e_mode: How E is read (absolute or relative).
            e_start: Extruder position before the move [mm] (absolute mode), or None.
        """
        return cls(relative, code + " ", f"{head} {code} " if head else code + " ",
                   tail + (" " + comment if comment else ""), ending[0], ending[1], e_text, e_mode, e_start)

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
        if self.e_mode is Extrusion.RELATIVE:
            values = [_share(total, k, n) - _share(total, k - 1, n) for k in range(k0 + 1, k1 + 1)]
        else:
            assert self.e_start is not None  # the reader refuses a split without it
            begin = round(self.e_start * scale)
            values = [begin + _share(total - begin, k, n) for k in range(k0 + 1, k1 + 1)]
        return [f" E{v / scale:.{decimals}f}" for v in values]


@dataclass(frozen=True, slots=True)
class KeptLine:
    """A line written as it is read (comments, M codes, modes alone, moves without X, Y or Z ...)."""


#: The plan of every line that is kept.
KEPT = KeptLine()


class SingleMove(NamedTuple):
    """A move sent whole: one corrected point, written ``prefix + "X.. Y.. Z.." + suffix``.

    Most lines of a program are these, so it is a named tuple: immutable like the other plans, and
    built in a third of a frozen dataclass's time (as one, it made the filter 8 % slower); its
    fields are read by name, never by position.

    Attributes:
        end: The move's end (X, Y, Z) [mm], corrected before it is written.
        relative: Whether XYZ are written as increments (G91).
        prefix: The text before XYZ: ``N`` label and mode words, then ``G0 `` or ``G1 ``.
        suffix: The text after XYZ: `` E``, `` F``, `` S`` words, the comments and the line ending.
    """

    end: tuple[float, float, float]
    relative: bool
    prefix: str
    suffix: str


@dataclass(frozen=True, slots=True)
class SplitMove:
    """A move cut into ``path.n`` segments, each written with the move's text.

    Attributes:
        path: The move's intended path, cut into the points sent [mm].
        text: The words around each segment's XYZ.
    """

    path: StraightPath | ArcPath
    text: MoveText


@dataclass(frozen=True, slots=True)
class LimitsChange:
    """A line kept that changes the controller's limits: the commands after it are checked against the new.

    Attributes:
        limits: ``limits(before)`` -> the limits after the line.
        by: The line, as messages name it (``line 3 (M211 S1)``).
    """

    limits: Callable[[Any], Any]
    by: str


#: The plan of a line.
Plan = KeptLine | SingleMove | SplitMove | LimitsChange
