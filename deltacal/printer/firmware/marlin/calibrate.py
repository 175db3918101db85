"""Marlin's own delta auto-calibration (``G33``), written from its algorithm.

The facts (Marlin 2.x, ``Marlin/src/gcode/calibrate/G33.cpp``; ``module/delta.cpp``):

* **Probe radius**: ``dcr = DELTA_PRINTABLE_RADIUS − PROBING_MARGIN`` (the nozzle is the probe: no
  XY offset), here the printable radius less :data:`PROBING_MARGIN`.
* **Probe points** (``G33 Pn``, ``DELTA_CALIBRATION_DEFAULT_POINTS`` 4): seven calibration points,
  the centre and six on the circle ``dcr`` at 210 + 60 k deg (towers A, B, C and their opposites).
  ``P1`` probes the centre, ``P2`` the centre and the towers, ``P3`` the seven (the centre as the
  mean of three probes at 0.1 ``dcr``); ``P4``-``P10`` add intermediate probes, each shared between
  its two neighbouring calibration points by cos² / sin² of its fraction of the 60 deg, and extra
  centre probes (``P4``: 16 probes; ``P7``: 49), averaged (:func:`g33_probe_weights`).
* **Factors**: endstops (``M666``, 3), delta radius (``M665 R``), tower angle trims (``M665 X Y Z``,
  with ``P3`` and up, unless ``T``) and the height (``M665 H``, through the endstops' common part).
  Marlin 2.x's ``G33`` does not calibrate the diagonal rod (``M665 L``) nor the step distances.
* **Corrections**: not a least-squares fit but ``G33``'s fixed convergence matrices applied to the
  seven calibration points' heights, scaled by ``h_factor = (2/3) R / dcr`` and by ``r_factor`` and
  ``a_factor``, found each iteration from Marlin's own kinematics (``auto_tune_r``, ``auto_tune_a``:
  the approximate forward kinematics of ``forward_kinematics_probe_points`` on the carriage-height
  differences of a 0.01 mm / 0.01 deg change). After each correction the angle trims are made to sum
  0 and the largest endstop adjustment is taken into ``H`` (every ``M666`` <= 0).
* **Iterations**: each iteration homes and probes again with the new values. Its "std dev" is the
  RMS of the calibration points' heights, rounded to 0.001 mm (+ 1e-5). A correction is applied while
  it is below the mean of the two before; when it is not, the values of the best iteration are
  restored ("rolling back") and ``G33`` ends; 31 iterations at most (``C`` 0, ``F`` 0: the defaults).

Every step above is reproduced (in double precision; Marlin computes in float). The probe is a
callback: the firmware with the values of the moment probing the real printer (the commanded z at
which the probe triggers, the bed's height as Marlin sees it). Units: mm; Marlin's trims in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .model import MarlinDelta

#: ``PROBING_MARGIN`` of Marlin's example configurations [mm].
PROBING_MARGIN = 10.0
#: ``DELTA_CALIBRATION_DEFAULT_POINTS`` of Marlin's example delta configurations.
DEFAULT_POINTS = 4
#: Iterations at most (``iterations < 31``).
MAX_ITERATIONS = 31
#: The calibration points' indices: centre, A, AB, B, BC, C, CA (``CalEnum``).
CEN, A, AB, B, BC, C, CA = range(7)
#: The change ``auto_tune_r`` and ``auto_tune_a`` make [mm, deg].
TUNE_DIFF = 0.01
#: ``forward_kinematics_probe_points``: the multiples of the radius quotient per point and tower.
_FORWARD = np.array([[0, 0, 0], [2, -1, -1], [1, 1, -2], [-1, 2, -1], [-2, 1, 1], [-1, -1, 2], [1, -2, 1]])

#: A probe: the firmware with these values probes the bed at these x, y [mm], (K, 2) -> heights (K,).
Probe = Callable[[MarlinDelta, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class G33Result:
    """What ``G33`` leaves.

    Attributes:
        values: The calibrated values (as ``M500`` would save them).
        iterations: Iterations run (each a homing and a probing).
        std_dev: The lowest "std dev" reached [mm].
    """

    values: MarlinDelta
    iterations: int
    std_dev: float


def calibration_angle(index: float) -> float:
    """Azimuth of calibration point ``index`` (1: tower A ... 6; fractions between) [rad]."""
    return math.radians(210.0 + 60.0 * (index - 1.0))


def _radius_steps(points: int) -> float:
    """The step between radius probes in calibration points (``probe_calibration_points``)."""
    return {10: 1 / 15, 9: 1 / 12, 8: 1 / 9, 7: 1 / 7, 6: 1 / 5, 5: 1 / 3, 4: 1 / 2, 3: 1.0}.get(points, 2.0)


def g33_probe_weights(points: int, dcr: float, towers: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``G33 Pn``'s probes and how they make the seven calibration points' heights.

    Args:
        points: ``P`` (1 to 10).
        dcr: The calibration radius [mm].
        towers: Without ``T`` (``P2`` then probes the towers, else their opposites).

    Returns:
        The probes' x, y [mm], (K, 2), and the weights (7, K): the calibration points' heights are the
        weights times the probed heights.
    """
    xy: list[tuple[float, float]] = []
    rows: list[np.ndarray] = []

    def add(angle: float, r: float, weights: dict[int, float]) -> None:
        xy.append((r * math.cos(angle), r * math.sin(angle)))
        row = np.zeros(7)
        for k, w in weights.items():
            row[k] += w
        rows.append(row)

    if points not in (3, 6, 9):
        add(0.0, 0.0, {CEN: 1.0})
    if points >= 3:
        start = CA + 1 / 3 if points >= 8 else (float(CA) if 5 <= points <= 7 else float(C))
        step = 2 / 3 if points >= 8 else (1.0 if 5 <= points <= 7 else 2.0)
        k = 0
        while start - k * step > 0.9999:
            add(calibration_angle(start - k * step), 0.1 * dcr, {CEN: 1.0})
            k += 1
        divisor = 7.0 if points == 5 else float(points)
        for row in rows:
            row[CEN] /= divisor
    if points != 1:
        step = _radius_steps(points)
        offset = 2 if points >= 8 else 0
        stride = step * 3 if points >= 8 else step
        first = float(AB) if points == 2 and not towers else float(A)
        k, zig_zag = 0, True
        while first + k * stride < 6.9999:
            rad = first + k * stride
            fraction = math.fmod(rad, 1.0)
            whole = round(rad - fraction)
            for circle in range(offset + 1):
                r = dcr * (1.0 - 0.1 * (offset - circle if zig_zag else circle))
                share = math.radians(fraction * 90.0)  # split between the two neighbouring points
                add(calibration_angle(rad), r, {(whole + 5) % 6 + 1: math.cos(share) ** 2,
                                                whole % 6 + 1: math.sin(share) ** 2})
            zig_zag = not zig_zag
            k += 1
        if points >= 4:  # the radius points' sums made means
            for row in rows:
                row[1:] *= step
    return np.array(xy), np.array(rows).T


def _carriages(values: MarlinDelta, heights: np.ndarray, dcr: float) -> np.ndarray:
    """``reverse_kinematics_probe_points``: carriage heights at the seven points at ``heights``, (7, 3)."""
    angle = np.array([calibration_angle(k) for k in range(7)])
    r = np.where(np.arange(7) == CEN, 0.0, dcr)
    return values.carriage_heights(np.column_stack([r * np.cos(angle), r * np.sin(angle), heights]))


def _kinematics_diff(values: MarlinDelta, heights: np.ndarray, dcr: float, delta_r: float,
                     delta_t: np.ndarray) -> np.ndarray:
    """``calc_kinematics_diff_probe_points``: the heights' change for a radius and trims' change, (7,)."""
    changed = replace(values, radius=values.radius + delta_r, angle_trim=values.angle_trim + delta_t)
    diff = _carriages(values, heights, dcr) - _carriages(changed, heights, dcr)
    quotient = dcr / changed.radius  # delta_radius is still the changed one there
    z = np.sum((1.0 + quotient * _FORWARD) / 3.0 * diff, axis=1)
    z[1:] -= z[CEN] - heights[CEN]
    z[CEN] = heights[CEN]
    return z


def g33_factors(values: MarlinDelta, dcr: float) -> tuple[float, float, float]:
    """``auto_tune_h``, ``auto_tune_r``, ``auto_tune_a`` of the values at calibration radius ``dcr``."""
    h_factor = (2.0 / 3.0) / (dcr / values.radius)
    z = _kinematics_diff(values, np.zeros(7), dcr, TUNE_DIFF, np.zeros(3))
    r_factor = TUNE_DIFF / (-np.sum(z[1:]) / 6.0) / 3.0
    z, a_sum = np.zeros(7), 0.0
    for axis in range(3):  # G33 feeds each axis the heights the one before left
        delta_t = np.zeros(3)
        delta_t[axis] = TUNE_DIFF
        z = _kinematics_diff(values, z, dcr, 0.0, delta_t)
        a_sum += z[(axis * 2 - 1 + 6) % 6 + 1] / 6.0 - z[axis * 2 + 2] / 6.0
    return h_factor, float(r_factor), float(TUNE_DIFF / a_sum / 3.0)


def g33_corrections(z: np.ndarray, points: int, towers: bool, factors: tuple[float, float, float]
                    ) -> tuple[np.ndarray, float, np.ndarray]:
    """``G33``'s convergence matrices: endstop, radius and trim changes of the seven heights z [mm], (7,)."""
    h, r, a = factors
    c, za, zab, zb, zbc, zc, zca = z
    if points == 1:
        return np.full(3, c), 0.0, np.zeros(3)
    if points == 2:  # the towers, or (T) their opposites
        p, q, s = (za, zb, zc) if towers else (-zbc, -zca, -zab)
        e = np.array([p - (q + s) / 2, q - (p + s) / 2, s - (p + q) / 2]) * h + c
        outer = za + zb + zc if towers else zbc + zca + zab
        return e, float((outer - 3 * c) * r), np.zeros(3)
    e = np.array([(2 * za - zb - zc - 2 * zbc + zca + zab) / 4,
                  (-za + 2 * zb - zc + zbc - 2 * zca + zab) / 4,
                  (-za - zb + 2 * zc + zbc + zca - 2 * zab) / 4]) * h + c
    radius = ((za + zb + zc + zbc + zca + zab) / 2 - 3 * c) * r
    trims = np.zeros(3)
    if towers:
        trims = np.array([-zb + zc - zca + zab, za - zc + zbc - zab, -za + zb - zbc + zca]) * a
    return e, float(radius), trims


def _corrected(values: MarlinDelta, endstops: np.ndarray, radius: float, trims: np.ndarray,
               angles: bool) -> MarlinDelta:
    """The values changed by ``G33``'s corrections, then normalised as it does after each iteration.

    With ``angles`` the trims are made to sum 0 ("normalize angles to least squares"); the largest
    endstop adjustment is taken into ``H`` ("adjust delta_height and endstops by the max amount").
    """
    trim = values.angle_trim + trims
    trim = trim - trim.mean() if angles else trim
    adj = values.endstop_adj + endstops
    top = float(np.max(adj))
    return replace(values, radius=values.radius + radius, angle_trim=trim, endstop_adj=adj - top,
                   height=values.height - top)


def _std_dev(z: np.ndarray, points: int, towers: bool) -> float:
    """``std_dev_points``: RMS of the calibration points' heights, rounded to 0.001 mm, + 1e-5."""
    if points == 1:
        return 0.00001
    used = list(range(7)) if points >= 3 else ([CEN, A, B, C] if towers else [CEN, AB, BC, CA])
    return round(math.sqrt(float(np.mean(z[used] ** 2))) * 1000.0) / 1000.0 + 0.00001


def marlin_g33(values: MarlinDelta, probe: Probe, printable_radius: float, points: int = DEFAULT_POINTS,
               towers: bool = True) -> G33Result:
    """Marlin's ``G33 Pn`` (module docstring): probe and correct until the std dev stops falling.

    Args:
        values: The settings ``G33`` starts from.
        probe: The firmware with given values probing the real printer (:data:`Probe`).
        printable_radius: ``DELTA_PRINTABLE_RADIUS`` [mm] (the calibration radius is it less
            :data:`PROBING_MARGIN`).
        points: ``P`` (1 to 10).
        towers: Calibrate the tower angle trims (no ``T``).

    Returns:
        The values ``G33`` leaves, its iterations and its best std dev.
    """
    if not 1 <= points <= 10:
        raise ValueError(f"G33 P must be 1 to 10, got {points}")
    dcr = printable_radius - PROBING_MARGIN
    xy, weights = g33_probe_weights(points, dcr, towers)
    angles = points >= 3 and towers
    std_dev = std_min = std_old = 999.0
    best = values
    iterations = 0
    while True:
        precision = (std_dev + std_old) / 2.0 if std_old != 999.0 else std_dev
        iterations += 1
        std_old = std_dev
        z = weights @ np.asarray(probe(values, xy), dtype=float)
        std_dev = _std_dev(z, points, towers)
        if std_dev < precision:
            if std_dev < std_min:
                best = values
            scale = 0.9 if points >= 8 else 1.0
            e, r, t = g33_corrections(z, points, towers, g33_factors(values, dcr * scale))
            values = _corrected(values, e, r, t, angles)
        else:
            values = best
        std_min = min(std_min, std_dev)
        if not (std_dev < precision and iterations < MAX_ITERATIONS):
            return G33Result(values, iterations, std_min)

