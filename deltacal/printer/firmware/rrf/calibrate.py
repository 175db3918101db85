"""RepRapFirmware's own delta auto-calibration (``G32`` running ``bed.g``), written from its algorithm.

The facts (RepRapFirmware 3.x, ``src/Movement/Kinematics/LinearDeltaKinematics.cpp``,
``DoAutoCalibration``, ``ComputeDerivative``, ``Adjust``):

* **Probe points**: those of ``bed.g``, each ``G30 Pn X Y Z-99999`` giving the bed's height there
  (the commanded z at the trigger less ``G31 Z``); the last ``G30 ... S<factors>`` runs the
  calibration. deltacal takes the shape of the bed.g RepRapFirmware's configuration tool writes
  for a delta (:func:`bed_points`): 12 points on the probe radius every 30 deg from +Y, 3 halfway
  (at 90, 330 and 210 deg) and the centre.
* **Factors** (``S``): 3 (the endstops, ``M666 X Y Z``), 4 (and the delta radius ``M665 R``), 6
  (and the angle corrections of towers A and B, ``M665 X Y``), 7 (and the diagonal ``M665 L``,
  the three alike), 8 (6 and the bed tilt ``M666 A B``), 9 (7 and the tilt).
* **Solver**: the probe points are turned once into carriage heights (``Transform`` at z 0 with
  the values of the moment); then two Newton-Raphson iterations: derivatives of the nozzle's height
  with respect to each factor at those carriage heights, by central differences of 0.2 mm / 0.2 deg
  through ``ForwardTransform`` (the tilts: ``−x / M665 B`` and ``−y / M665 B``), the normal equations
  of least squares solved for the factors' changes that cancel the probed heights plus the
  corrections of the iteration before; ``Adjust`` adds them (endstops then normalised to average 0,
  ``H`` taking their mean), the carriage heights move by the endstops' changes and the corrections
  are the new forward heights there.
* **Runs**: one ``G32`` probes once. RepRapFirmware's documentation has it run more than once (the
  second run starts nearer); deltacal runs it :data:`DEFAULT_RUNS` times, each probing again through
  the values the run before left.

Every step above is reproduced (in double precision; RRF computes in float, its normal equations
by Gauss-Jordan, here by ``numpy.linalg.solve``). The probe is a callback: the firmware with the
values of the moment probing the real printer. Units: mm; RRF's angle corrections in rad here
(its perturbation and its factors' changes in degrees, as RRF's).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .fit import normalised
from .model import RRFDelta

#: ``ComputeDerivative``'s perturbation [mm or deg].
PERTURB = 0.2
#: ``G32`` runs (each probing ``bed.g``'s points again).
DEFAULT_RUNS = 2
#: Factors of the configuration tool's bed.g (``G30 P15 X0 Y0 Z-99999 S6``).
DEFAULT_FACTORS = 6
#: Factors with the bed's tilt and without the diagonal (``S8``).
TILT_FACTORS = 8
#: bed.g's probe radius is the printable radius less this [mm] (deltacal's choice, as Marlin's
#: ``PROBING_MARGIN``: the configuration tool asks the user for it).
BED_MARGIN = 10.0
#: Newton-Raphson iterations of one ``DoAutoCalibration`` ("two is slightly better than one").
ITERATIONS = 2
#: The numbers of factors RRF accepts.
FACTORS = (3, 4, 6, 7, 8, 9)

#: A probe: the firmware with these values probes the bed at these x, y [mm], (K, 2) -> heights (K,).
Probe = Callable[[RRFDelta, np.ndarray], np.ndarray]


def bed_points(radius: float) -> np.ndarray:
    """The probe points of the configuration tool's delta ``bed.g`` at a probe radius [mm], (16, 2)."""
    outer = np.radians(90.0 - 30.0 * np.arange(12))
    half = np.radians([90.0, 330.0, 210.0])
    return np.vstack([radius * np.column_stack([np.cos(outer), np.sin(outer)]),
                      0.5 * radius * np.column_stack([np.cos(half), np.sin(half)]), [[0.0, 0.0]]])


def _forward(values: RRFDelta, carriages: np.ndarray) -> np.ndarray:
    """``ForwardTransform``: the nozzle at carriage heights [mm], (N, 3) -> (N, 3)."""
    return values.positions((values.carriage_top - carriages) / values.step_distance)


def _derivative(values: RRFDelta, factor: int, carriages: np.ndarray) -> np.ndarray:
    """``ComputeDerivative``: d(height)/d(factor) at carriage heights, (N,); factor as RRF numbers them.

    0-2: the endstops; 3: the delta radius; 4, 5: towers A and B's angle corrections [deg]; 6: the
    diagonals together; 7, 8: the tilts, scaled by the print radius.
    """
    if factor >= 7:
        return -_forward(values, carriages)[:, factor - 7] / values.print_radius
    hi_h, lo_h = carriages.copy(), carriages.copy()
    hi, lo = values, values
    if factor < 3:
        hi_h[:, factor] += PERTURB
        lo_h[:, factor] -= PERTURB
    elif factor == 3:
        hi = replace(values, radius=values.radius + PERTURB)
        lo = replace(values, radius=values.radius - PERTURB)
    elif factor in (4, 5):
        change = np.zeros(3)
        change[factor - 4] = math.radians(PERTURB)
        hi = replace(values, angle_correction=values.angle_correction + change)
        lo = replace(values, angle_correction=values.angle_correction - change)
    else:
        hi = replace(values, diagonal=values.diagonal + PERTURB)
        lo = replace(values, diagonal=values.diagonal - PERTURB)
    return (_forward(hi, hi_h)[:, 2] - _forward(lo, lo_h)[:, 2]) / (2.0 * PERTURB)


def _columns(factors: int) -> list[int]:
    """RRF's derivative numbers of the factors (8 factors skip the diagonal)."""
    return [j + 1 if factors == 8 and j >= 6 else j for j in range(factors)]


def adjust(values: RRFDelta, factors: int, v: np.ndarray) -> RRFDelta:
    """``Adjust``: the values changed by the solution ``v`` (RRF's units: mm, deg, mm over ``M665 B``)."""
    values = normalised(replace(values, endstop_adjustment=values.endstop_adjustment + v[:3]))
    if factors < 4:
        return values
    values = replace(values, radius=values.radius + float(v[3]))
    if factors < 6:
        return values
    values = replace(values, angle_correction=values.angle_correction + np.radians([v[4], v[5], 0.0]))
    if factors in (7, 9):
        values = replace(values, diagonal=values.diagonal + float(v[6]))
    if factors >= 8:
        tilt = v[6:8] if factors == 8 else v[7:9]
        values = replace(values, tilt=values.tilt + np.asarray(tilt) / values.print_radius)
    return values


def rrf_auto_calibration(values: RRFDelta, points: np.ndarray, heights: np.ndarray,
                         factors: int = DEFAULT_FACTORS) -> RRFDelta:
    """RRF's ``DoAutoCalibration`` of probed heights (module docstring).

    Args:
        values: The values the probing was done with.
        points: The probe points' x, y [mm], (N, 2).
        heights: The bed's height probed at each (``G30``'s) [mm], (N,).
        factors: ``S``: 3, 4, 6, 7, 8 or 9.

    Returns:
        The calibrated values.

    Raises:
        ValueError: another number of factors, or fewer points than factors.
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    heights = np.asarray(heights, dtype=float).reshape(-1)
    if factors not in FACTORS or len(points) < factors:
        raise ValueError(f"delta calibration with {factors} factors on {len(points)} points: RRF supports "
                         f"{', '.join(map(str, FACTORS))} factors, with at least as many points")
    carriages = values.carriage_heights(np.column_stack([points, np.zeros(len(points))]))
    corrections = np.zeros(len(points))
    for _ in range(ITERATIONS):
        derivative = np.column_stack([_derivative(values, j, carriages) for j in _columns(factors)])
        solution = np.linalg.solve(derivative.T @ derivative, derivative.T @ -(heights + corrections))
        values = adjust(values, factors, solution)
        carriages = carriages + solution[:3]
        corrections = _forward(values, carriages)[:, 2]
    return values


def rrf_g32(values: RRFDelta, probe: Probe, radius: float, factors: int = DEFAULT_FACTORS,
            runs: int = DEFAULT_RUNS) -> RRFDelta:
    """``G32`` run ``runs`` times: bed.g's points (:func:`bed_points`) probed, then auto-calibrated.

    Args:
        values: The values the first run starts from.
        probe: The firmware with given values probing the real printer (:data:`Probe`).
        radius: bed.g's probe radius [mm].
        factors: ``S`` of bed.g's last ``G30``.
        runs: How many times ``G32`` is run.
    """
    points = bed_points(radius)
    for _ in range(runs):
        values = rrf_auto_calibration(values, points, probe(values, points), factors)
    return values
