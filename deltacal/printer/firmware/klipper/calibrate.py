"""Klipper's own delta calibration (``DELTA_CALIBRATE`` and ``DELTA_ANALYZE``), written from its behaviour.

The facts (Klipper's ``docs/Delta_Calibrate.md``, ``klippy/extras/delta_calibrate.py``,
``klippy/kinematics/delta.py``, ``klippy/mathutil.py``):

* **Probing** (basic, ``DELTA_CALIBRATE``): 7 points with ``[delta_calibrate] radius`` r: the
  centre, and 6 at azimuths 90, 150, ... 390 deg at 0.95, 0.90, 0.85, 0.70, 0.75, 0.80 r (nozzle
  coordinates). Each probe gives the toolhead's position at the trigger, stored as a "stable
  position": steps below each endstop through the configuration probed with, so the measurement
  does not depend on the values being fitted. Its goal height is the probe's ``z_offset`` (the
  nozzle's height when the probe triggers; 0 when the nozzle is the probe).
* **Values fitted**: basic: ``delta_radius``, ``angle`` of towers A and B, the three
  ``position_endstop`` (6 values); enhanced (with distances): also the three ``arm_length`` (9).
  Held: tower C's angle and the step distances (``rotation_distance``).
* **The object** (``docs/prints/calibrate_size.stl``, ``SCALE`` 1): pillars at azimuths 210, 270,
  330, 30, 90, 150 deg, 65 mm from the centre, ridges 4.5 mm from each pillar's centre.
  ``DELTA_ANALYZE`` takes ``CENTER_DISTS`` (6: the centre pillar to each outer pillar),
  ``CENTER_PILLAR_WIDTHS`` (3), ``OUTER_DISTS`` (6: each outer pillar to its neighbour 60 deg on) and
  ``OUTER_PILLAR_WIDTHS`` (6); a distance minus the pillar width it includes is the distance
  between two ridges, whose commanded positions (z = 0) Klipper computes from the object's
  layout (:func:`object_pairs`).
* **Objective**: ``w Σ (z_k − z_offset)² + Σ (d_j − D_j)²`` with z_k, d_j the positions of the
  stable positions through the values under test (intersection of three spheres), w = 1 without
  distances and ``M / (0.5 N)`` with M distances and N probe points.
* **Solver**: coordinate descent: each value starts with a step of 1 (mm or deg); a value moves by
  + or − its step when that lowers the objective (its step then grows by 10 %), else its step
  shrinks by 10 %; rounds over the values until the steps sum below 1e-5 or 10000 rounds.

Units: mm; the configuration's angles in rad, Klipper's internal ones in deg.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .model import KlipperDelta

#: The names users read of the basic and the enhanced calibration.
BASIC_TITLE, ENHANCED_TITLE = "Klipper basic", "Klipper enhanced"
#: Scatter of the 6 outer probe points (fractions of the probe radius), azimuths 90 + 60 k deg.
PROBE_SCATTER = (0.95, 0.90, 0.85, 0.70, 0.75, 0.80)
#: Azimuths of the object's outer pillars [deg], in DELTA_ANALYZE's order.
OBJECT_ANGLES_DEG = (210.0, 270.0, 330.0, 30.0, 90.0, 150.0)
#: Distance of the outer pillars from the centre [mm] (SCALE 1).
OBJECT_OUTER_RADIUS = 65.0
#: Distance of a ridge from its pillar's centre [mm] (SCALE 1).
OBJECT_RIDGE_RADIUS = 4.5
#: How much a distance counts against a height (Klipper's MEASURE_WEIGHT).
MEASURE_WEIGHT = 0.5
#: Coordinate descent stops when the steps sum below this [mm, deg], or after so many rounds.
DESCENT_THRESHOLD = 1e-5
DESCENT_ROUNDS = 10000
#: The values of the basic and the enhanced method, as indices into (ρ, α_a..c [deg], ℓ_a..c, e_a..c).
BASIC = (0, 1, 2, 7, 8, 9)
ENHANCED = (0, 1, 2, 7, 8, 9, 4, 5, 6)


def probe_points(radius: float) -> np.ndarray:
    """Klipper's default probe points of ``DELTA_CALIBRATE`` for a probe radius [mm], (7, 2)."""
    phi = np.radians(90.0 + 60.0 * np.arange(6))
    dist = radius * np.asarray(PROBE_SCATTER)
    return np.vstack([[0.0, 0.0], np.column_stack([np.cos(phi) * dist, np.sin(phi) * dist])])


def object_pairs(scale: float = 1.0) -> np.ndarray:
    """Commanded positions of the ridges whose distances DELTA_ANALYZE uses [mm], (12, 6).

    Rows 0-5: the centre pillar's ridge toward each outer pillar and that pillar's far ridge
    (``CENTER_DISTS``); rows 6-11: from each outer pillar's ridge to the far ridge of the pillar
    60 deg on, along the azimuth two places on in the list (``OUTER_DISTS``). z = 0 as Klipper
    takes them.
    """
    phi = np.radians(OBJECT_ANGLES_DEG)
    u = np.column_stack([np.cos(phi), np.sin(phi)])
    inner, outer = OBJECT_RIDGE_RADIUS * scale, (OBJECT_OUTER_RADIUS + OBJECT_RIDGE_RADIUS) * scale
    start = OBJECT_OUTER_RADIUS * scale * u
    shifted = np.roll(u, -2, axis=0)
    first = np.vstack([inner * u, start + inner * shifted])
    second = np.vstack([outer * u, start + outer * shifted])
    zeros = np.zeros((12, 1))
    return np.hstack([first, zeros, second, zeros])


def delta_analyze_distances(center_dists: np.ndarray, center_pillar_widths: np.ndarray,
                            outer_dists: np.ndarray, outer_pillar_widths: np.ndarray) -> np.ndarray:
    """DELTA_ANALYZE's caliper readings as distances between the ridges of :func:`object_pairs` [mm], (12,).

    A centre distance includes the width of the centre pillar's side it starts from (widths of the
    sides facing 210/30, 330/150 and 270/90 deg); an outer distance includes its pillar's width.
    """
    cpw = np.asarray(center_pillar_widths, dtype=float).reshape(3)
    widths = cpw[[0, 2, 1, 0, 2, 1]]
    center = np.asarray(center_dists, dtype=float).reshape(6) - widths
    outer = (np.asarray(outer_dists, dtype=float).reshape(6)
             - np.asarray(outer_pillar_widths, dtype=float).reshape(6))
    return np.concatenate([center, outer])


def _pack(config: KlipperDelta) -> np.ndarray:
    """(ρ, α_a..c [deg], ℓ_a..c, e_a..c) as Klipper's calibration holds them."""
    return np.concatenate([[config.delta_radius], np.degrees(config.angle), config.arm_length,
                           config.position_endstop])


def _unpack(config: KlipperDelta, v: np.ndarray) -> KlipperDelta:
    return replace(config, delta_radius=float(v[0]), angle=np.radians(v[1:4]), arm_length=v[4:7],
                   position_endstop=v[7:10])


def stable_positions(v: np.ndarray, step_distance: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Nozzle positions of steps below the endstops through packed values (three spheres' meeting) [mm].

    Args:
        v: (ρ, α_a..c [deg], ℓ_a..c, e_a..c).
        step_distance: The three step distances [mm].
        steps: Steps below each endstop, (N, 3).

    Returns:
        (N, 3) positions; NaN where the spheres do not meet.
    """
    phi = np.radians(v[1:4])
    towers = v[0] * np.column_stack([np.cos(phi), np.sin(phi)])
    arms = v[4:7]
    top = v[7:10] + np.sqrt(arms**2 - v[0] ** 2)
    z = top - steps * step_distance  # (N, 3) sphere centres' heights
    c = np.concatenate([np.broadcast_to(towers, steps.shape[:1] + (3, 2)), z[:, :, None]], axis=2)
    s21, s31 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    d = np.linalg.norm(s21, axis=1)
    ex = s21 / d[:, None]
    i = np.einsum("nk,nk->n", ex, s31)
    ey = s31 - ex * i[:, None]
    ey /= np.linalg.norm(ey, axis=1)[:, None]
    ez = np.cross(ex, ey)
    j = np.einsum("nk,nk->n", ey, s31)
    r2 = arms**2
    x = (r2[0] - r2[1] + d**2) / (2.0 * d)
    y = (r2[0] - r2[2] - x**2 + (x - i) ** 2 + j**2) / (2.0 * j)
    with np.errstate(invalid="ignore"):
        h = -np.sqrt(r2[0] - x**2 - y**2)
    return c[:, 0] + ex * x[:, None] + ey * y[:, None] + ez * h[:, None]


def coordinate_descent(error: Callable[[np.ndarray], float], values: np.ndarray,
                       adjust: tuple[int, ...]) -> np.ndarray:
    """Klipper's coordinate descent of ``error(values)`` over the values at indices ``adjust``.

    Args:
        error: The objective of a values vector.
        values: Start values.
        adjust: Indices of the values to adjust, in Klipper's order.

    Returns:
        The values found.
    """
    values = np.array(values, dtype=float)
    dp = {k: 1.0 for k in adjust}
    best = error(values)
    rounds = 0
    while sum(dp.values()) > DESCENT_THRESHOLD and rounds < DESCENT_ROUNDS:
        rounds += 1
        for k in adjust:
            orig = values[k]
            for trial in (orig + dp[k], orig - dp[k]):
                values[k] = trial
                err = error(values)
                if err < best:
                    best = err
                    dp[k] *= 1.1
                    break
            else:
                values[k] = orig
                dp[k] *= 0.9
    return values


def _calibrate(config: KlipperDelta, probe_commanded: np.ndarray, z_offset: float, adjust: tuple[int, ...],
               pairs: np.ndarray | None = None, distances: np.ndarray | None = None) -> KlipperDelta:
    """Klipper's objective over stable positions (steps through ``config``), minimised by its descent."""
    probe = np.atleast_2d(np.asarray(probe_commanded, dtype=float))
    heights = config.steps(probe)
    step = np.asarray(config.step_distance)
    if pairs is None or distances is None or len(distances) == 0:
        first = second = np.empty((0, 3))
        dist = np.empty(0)
        weight = 1.0
    else:
        pairs = np.atleast_2d(np.asarray(pairs, dtype=float))
        first, second = config.steps(pairs[:, :3]), config.steps(pairs[:, 3:])
        dist = np.asarray(distances, dtype=float).reshape(-1)
        weight = len(dist) / (MEASURE_WEIGHT * len(probe))
    both = np.vstack([heights, first, second])
    n, m = len(heights), len(dist)

    def error(v: np.ndarray) -> float:
        p = stable_positions(v, step, both)
        total = weight * float(np.sum((p[:n, 2] - z_offset) ** 2))
        if m:
            d = np.linalg.norm(p[n:n + m] - p[n + m:], axis=1)
            total += float(np.sum((d - dist) ** 2))
        return total if np.isfinite(total) else np.inf

    return _unpack(config, coordinate_descent(error, _pack(config), adjust))


def klipper_basic(config: KlipperDelta, probe_commanded: np.ndarray, z_offset: float = 0.0) -> KlipperDelta:
    """Klipper's basic calibration (``DELTA_CALIBRATE``): 6 values refitted to put the probes at z_offset.

    Args:
        config: The configuration the probing was done with (its values are the start).
        probe_commanded: Commanded nozzle positions at the probe's triggers [mm], (N, 3) (N >= 3).
        z_offset: The probe's ``z_offset``: the nozzle's height when it triggers [mm].

    Returns:
        The new configuration (delta_radius, angles A and B, endstops changed).
    """
    return _calibrate(config, probe_commanded, z_offset, BASIC)


def klipper_enhanced(config: KlipperDelta, probe_commanded: np.ndarray, pairs: np.ndarray,
                     distances: np.ndarray, z_offset: float = 0.0) -> KlipperDelta:
    """Klipper's enhanced calibration (``DELTA_ANALYZE CALIBRATE=extended``): also the arm lengths.

    Args:
        config: The configuration both the probing and the object's print were done with.
        probe_commanded: Commanded nozzle positions at the probe's triggers [mm], (N, 3).
        pairs: Commanded positions of the features measured [mm], (M, 6) (:func:`object_pairs`).
        distances: Their measured distances [mm], (M,) (:func:`delta_analyze_distances`).
        z_offset: The probe's ``z_offset`` [mm].

    Returns:
        The new configuration (9 values changed).
    """
    return _calibrate(config, probe_commanded, z_offset, ENHANCED, pairs, distances)
