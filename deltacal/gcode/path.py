"""The intended path of a G-code move, cut into the points a controller is sent (lines and XY arcs).

A straight move is cut into ``n = ceil(length / segment_mm)`` equal segments; an arc (G2/G3 in the
XY plane, Z interpolated linearly: a helix) into ``n`` chords of equal angle, enough that each
chord is no longer than ``segment_mm`` and strays from the arc by at most ``tolerance`` (its
sagitta ``r (1 - cos(alpha / 2))``). Both hand their points out piece by piece, so a very long
move never needs its whole list in memory. Point ``k`` (``k = 1..n``) is at fraction ``k / n``
of the move; the last point is the move's end, exactly as given.

Units: mm and rad.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..exceptions import InputError

#: Chord error allowed when an arc is cut, as a fraction of the segment length (5 µm at 5 mm).
ARC_TOLERANCE_RATIO = 1e-3
#: Difference between an arc's start and end radii refused beyond this [mm] (or 0.1 % of the radius).
ARC_RADIUS_TOLERANCE_MM = 0.0127


class StraightPath:
    """A straight move from ``start`` to ``end`` [mm], cut into ``n`` equal segments.

    Plain Python, not numpy: a move is cut into a few segments, where numpy's call costs more
    than the arithmetic.
    """

    __slots__ = ("start", "end", "n")

    def __init__(self, start, end, segment_mm: float) -> None:
        self.start = tuple(float(v) for v in start)
        self.end = tuple(float(v) for v in end)
        self.n = max(1, math.ceil(math.dist(self.start, self.end) / segment_mm - 1e-9))

    def points(self, k0: int, k1: int) -> list[tuple[float, ...]]:
        """Points k0+1 .. k1 of the n [mm]; point n is ``end`` exactly."""
        (x0, y0, z0), (x1, y1, z1), n = self.start, self.end, self.n
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        out: list[tuple[float, ...]] = [(x0 + dx * (k / n), y0 + dy * (k / n), z0 + dz * (k / n))
                                        for k in range(k0 + 1, k1 + 1)]
        if k1 == n:
            out[-1] = self.end
        return out


class ArcPath:
    """An arc in the XY plane about ``centre`` (Z and the radius interpolated linearly), as chords.

    Attributes:
        start, end: The move's ends [mm], (3,).
        centre: Arc centre in XY [mm], (2,).
        sweep: Signed angle swept [rad]: negative clockwise (G2), positive counter-clockwise (G3).
        n: Number of chords.
    """

    __slots__ = ("start", "end", "centre", "sweep", "n", "_a0", "_r0", "_r1")

    def __init__(self, start, end, centre, sweep: float, segment_mm: float, tolerance: float) -> None:
        self.start = np.array(start, dtype=float)
        self.end = np.array(end, dtype=float)
        self.centre = np.array(centre, dtype=float)
        self.sweep = float(sweep)
        d0 = self.start[:2] - self.centre
        self._a0 = math.atan2(d0[1], d0[0])
        self._r0 = math.hypot(d0[0], d0[1])
        self._r1 = float(np.hypot(*(self.end[:2] - self.centre)))
        r = max(self._r0, self._r1)
        # the angle of one chord: sagitta r (1 - cos(alpha/2)) <= tolerance
        alpha = 2.0 * math.acos(1.0 - tolerance / r) if tolerance < r else math.pi
        length = math.hypot(r * abs(self.sweep), self.end[2] - self.start[2])
        self.n = max(1, math.ceil(abs(self.sweep) / alpha - 1e-9), math.ceil(length / segment_mm - 1e-9))

    def points(self, k0: int, k1: int) -> np.ndarray:
        """Points k0+1 .. k1 of the n [mm], shape (k1 - k0, 3); point n is ``end`` exactly."""
        t = np.arange(k0 + 1, k1 + 1, dtype=float) / self.n
        angle = self._a0 + self.sweep * t
        radius = self._r0 + (self._r1 - self._r0) * t
        out = np.empty((t.size, 3))
        out[:, 0] = self.centre[0] + radius * np.cos(angle)
        out[:, 1] = self.centre[1] + radius * np.sin(angle)
        out[:, 2] = self.start[2] + (self.end[2] - self.start[2]) * t
        if k1 == self.n:
            out[-1] = self.end
        return out


def arc_sweep(start_xy, end_xy, centre, clockwise: bool) -> float:
    """Signed angle [rad] from start to end about centre: in (-2 pi, 0) clockwise, (0, 2 pi) else.

    Ends that coincide give a full circle (-2 pi or 2 pi), as G2/G3 with I, J read them.
    """
    a0 = math.atan2(start_xy[1] - centre[1], start_xy[0] - centre[0])
    a1 = math.atan2(end_xy[1] - centre[1], end_xy[0] - centre[0])
    if start_xy[0] == end_xy[0] and start_xy[1] == end_xy[1]:
        return -2.0 * math.pi if clockwise else 2.0 * math.pi
    sweep = a1 - a0
    if clockwise:
        sweep = sweep - 2.0 * math.pi if sweep >= 0.0 else sweep
        return sweep if sweep > -2.0 * math.pi else sweep + 2.0 * math.pi
    sweep = sweep + 2.0 * math.pi if sweep <= 0.0 else sweep
    return sweep if sweep < 2.0 * math.pi else sweep - 2.0 * math.pi


def centre_from_radius(start_xy, end_xy, radius: float, clockwise: bool) -> tuple[float, float] | None:
    """Centre of the arc of signed radius R (R > 0: at most a half turn; R < 0: more) from start to end.

    None when the ends are further apart than the diameter (beyond a rounding of 1e-9 relative).
    """
    dx, dy = end_xy[0] - start_xy[0], end_xy[1] - start_xy[1]
    chord = math.hypot(dx, dy)
    half = chord / 2.0
    r = abs(radius)
    if chord == 0.0 or half > r * (1.0 + 1e-9):
        return None
    h = math.sqrt(max(r * r - half * half, 0.0))
    # left of the chord's direction for a counter-clockwise short arc, right for a clockwise one
    side = (-1.0 if clockwise else 1.0) * (1.0 if radius > 0.0 else -1.0)
    mx, my = start_xy[0] + dx / 2.0, start_xy[1] + dy / 2.0
    return mx - side * h * dy / chord, my + side * h * dx / chord


def arc_path(start, end, given: Mapping[str, str], clockwise: bool, segment_mm: float) -> ArcPath:
    """The chords of a G2/G3 arc in the XY plane from ``start`` to ``end`` [mm].

    Args:
        start: The arc's start (X, Y, Z) [mm].
        end: Its end [mm].
        given: Its words' texts: the centre by ``I J`` (offsets from the start) or the radius ``R``
            (> 0: at most a half turn), ``P`` whole turns first (Marlin's), all checked numbers.
        clockwise: G2 (else G3).
        segment_mm: Longest chord [mm]; each strays from the arc by :data:`ARC_TOLERANCE_RATIO` times it
            at most.

    Raises:
        InputError: (without a place: the reader names the line) the arc cannot be drawn: R with
            I/J, neither, a radius that cannot join the ends, an end off the start's circle by more
            than :data:`ARC_RADIUS_TOLERANCE_MM` or 0.1 %.
    """
    values = {k: float(v) for k, v in given.items() if k in "IJR"}
    if "R" in values:
        if "I" in values or "J" in values:
            raise InputError("arc with both R and I/J")
        centre = centre_from_radius(start, end, values["R"], clockwise)
        if centre is None:
            raise InputError(f"arc of radius R{values['R']:g} cannot join its ends (they coincide, or are "
                             "further apart than the diameter)")
    elif "I" in values or "J" in values:
        centre = (start[0] + values.get("I", 0.0), start[1] + values.get("J", 0.0))
    else:
        raise InputError("arc without I, J or R")
    r0 = math.hypot(start[0] - centre[0], start[1] - centre[1])
    r1 = math.hypot(end[0] - centre[0], end[1] - centre[1])
    if r0 == 0.0 or abs(r1 - r0) > max(ARC_RADIUS_TOLERANCE_MM, 1e-3 * r0):
        raise InputError(f"arc's end is not on its circle: radius {r0:.4f} mm at the start, {r1:.4f} mm at "
                         "the end")
    sweep = arc_sweep(start, end, centre, clockwise)
    sweep += math.copysign(2.0 * math.pi * int(given.get("P", "0")), sweep)  # Marlin's P circles first
    return ArcPath(start, end, centre, sweep, segment_mm, ARC_TOLERANCE_RATIO * segment_mm)
