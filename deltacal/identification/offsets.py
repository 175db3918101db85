"""Encoder offsets first: where the robot is, before the base parameters are chosen.

Bai et al. (2015, Sec. 4) identify the encoder offsets first, then the rest. deltacal fits every
parameter at once, but chooses the base parameters (and, with a free instrument frame, which
combinations of the geometry the frames absorb) from the regressor at the start. Encoder offsets
are the one error that can be degrees: at a start that far from the robot the choice misses a
rotation the frames would absorb, and the fit drifts along it (0.4 mm in z with offsets of 7°),
or the start's residuals (87-132 mm at 8° and more) read as wrong units.

:func:`encoder_offsets` fits the three offsets alone to the measured positions, each station's
frame refitted in closed form at every step when it is free (variable projection): Gauss-Newton on
three parameters with central differences and step halving, from zero offsets. Measured on Bai's
robot with two free stations: offsets of 40°, -35°, 30° are found within 0.7° (the rest of the
geometry, still nominal, takes the remainder), which the full fit then takes up. Units: rad and mm.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..exceptions import AssemblyError
from ..geometry import DeltaGeometry
from ..kinematics import exact
from ..observations import Measurements, predicted_points
from .frames import rigid_fit

#: Gauss-Newton iterations at most, and the central-difference step [rad].
_MAX_ITER, _STEP = 30, 1e-6


def _residual(start: DeltaGeometry, measurements: Measurements, offsets: np.ndarray,
              free: bool) -> np.ndarray:
    """Measured minus predicted positions at ``offsets`` (each station aligned when free), (3M,)."""
    geometry = replace(start, encoder_offset=start.encoder_offset + offsets)
    predicted = predicted_points(geometry, measurements, exact.forward(geometry, measurements.q))
    measured = measurements.position
    if not free:
        return (measured - predicted).ravel()
    out = np.empty_like(measured)
    station = np.array(measurements.station)
    for name in measurements.stations:
        rows = station == name
        R, t = rigid_fit(predicted[rows], measured[rows])
        out[rows] = measured[rows] - (predicted[rows] @ R.T + t)
    return out.ravel()


def _cost(start: DeltaGeometry, measurements: Measurements, offsets: np.ndarray, free: bool) -> float:
    try:
        r = _residual(start, measurements, offsets, free)
    except AssemblyError:
        return np.inf
    return float(r @ r)


def encoder_offsets(start: DeltaGeometry, measurements: Measurements, free: bool) -> np.ndarray:
    """The encoder offsets [rad] that best fit the measured positions with the rest of ``start``.

    Gauss-Newton from zero offsets, with step halving.

    Args:
        start: The start geometry (its own offsets are the origin of the result).
        measurements: Positions, in {O} or, with ``free``, in each station's frame.
        free: Each station's frame is refitted (rigid motion, closed form) at every step.

    Returns:
        The offsets to add to ``start``'s, (3,).
    """
    return _gauss_newton(start, measurements, free, np.zeros(3))[0]


def _gauss_newton(start: DeltaGeometry, measurements: Measurements, free: bool,
                  x: np.ndarray) -> tuple[np.ndarray, float]:
    cost = _cost(start, measurements, x, free)
    if not np.isfinite(cost):
        return x, cost
    for _ in range(_MAX_ITER):
        r = _residual(start, measurements, x, free)
        J = np.empty((r.size, 3))
        for k in range(3):
            h = np.zeros(3)
            h[k] = _STEP
            ahead, behind = (_residual(start, measurements, x + s * h, free) for s in (1.0, -1.0))
            J[:, k] = ahead - behind
        step = np.linalg.lstsq(J / (2 * _STEP), -r, rcond=None)[0]
        t = 1.0
        while t > 1e-4:
            trial = _cost(start, measurements, x + t * step, free)
            if trial < cost:
                break
            t *= 0.5
        else:
            break
        x, previous, cost = x + t * step, cost, trial
        if np.max(np.abs(t * step)) < 1e-9 or previous - cost <= 1e-12 * previous:
            break
    return x, cost
