"""Klipper's own ``DELTA_CALIBRATE`` on a rotary Delta (``kinematics: rotary_delta``), from its behaviour.

The driver is the linear Delta's (``klippy/extras/delta_calibrate.py``, :mod:`.calibrate`): the same
probe points, the same object and ``DELTA_ANALYZE`` distances, the same objective and coordinate
descent. What the rotary kinematics changes (``klippy/kinematics/rotary_delta.py``,
``RotaryDeltaCalibration``):

* **Stable positions**: an arm's steps from its endstop, ``(θ_end − θ) / d`` with θ_end the arm's
  angle for the nozzle at ``(0, 0, position_endstop)`` through the values probed with
  (``calc_stable_position``); through the values under test a stable position is the forward
  kinematics of ``θ_end' − steps × d`` with their own endstop angles (``get_position_from_stable``).
* **Values fitted** (``coordinate_descent_params``), in Klipper's order: basic ``shoulder_height``,
  ``endstop_a..c`` (4 values); extended also ``shoulder_radius``, ``angle_a``, ``angle_b`` [deg]
  (7). Held: the arms' lengths, arm C's angle, the step distances.
* **Heights**: the manual heights (``DELTA_ANALYZE MANUAL_HEIGHT``) come first and count in the
  objective, but the distances' weight ``M / (0.5 N)`` counts the probe points alone.

Units: mm; the dataclass's angles in rad, Klipper's calibration's in deg.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .calibrate import MEASURE_WEIGHT, coordinate_descent
from .rotary_model import KlipperRotaryDelta, arm_angles, trilaterate

#: The values of the basic and the extended method, as indices into
#: (shoulder_height, endstop_a..c, shoulder_radius, angle_a..c [deg]), Klipper's order.
ROTARY_BASIC = (0, 1, 2, 3)
ROTARY_EXTENDED = (0, 1, 2, 3, 4, 5, 6)


def _pack(config: KlipperRotaryDelta) -> np.ndarray:
    """(H, e_a..c, ρ, α_a..c [deg]) as Klipper's rotary calibration holds them."""
    return np.concatenate([[config.shoulder_height], config.position_endstop, [config.shoulder_radius],
                           np.degrees(config.angle)])


def _unpack(config: KlipperRotaryDelta, v: np.ndarray) -> KlipperRotaryDelta:
    return replace(config, shoulder_height=float(v[0]), position_endstop=v[1:4], shoulder_radius=float(v[4]),
                   angle=np.radians(v[5:8]))


def stable_positions(config: KlipperRotaryDelta, steps: np.ndarray) -> np.ndarray:
    """Nozzle positions of arms' steps from their endstops through these values [mm], (N, 3) -> (N, 3).

    Klipper's ``get_position_from_stable``: the values' own endstop angles less steps × d; NaN rows
    where an endstop or a position is out of the arms' reach.
    """
    return _stable_positions(_pack(config), config, np.atleast_2d(np.asarray(steps, dtype=float)))


def _stable_positions(v: np.ndarray, config: KlipperRotaryDelta, steps: np.ndarray) -> np.ndarray:
    """:func:`stable_positions` through packed values, the arms and step distances ``config``'s."""
    height, endstops, radius, angle = v[0], v[1:4], v[4], np.radians(v[5:8])
    upper, lower = config.upper_arm, config.lower_arm
    centre = np.zeros((3, 3))
    centre[:, 2] = endstops
    ends = np.diagonal(arm_angles(radius, height, angle, upper, lower, centre))
    theta = ends - steps * config.step_distance
    out = radius + upper * np.cos(theta)
    elbows = np.stack([out * np.cos(angle), out * np.sin(angle), height + upper * np.sin(theta)], axis=-1)
    return trilaterate(elbows, lower)


def rotary_from_stable(config: KlipperRotaryDelta, heights: np.ndarray, height_steps: np.ndarray,
                       extended: bool = False, distances: np.ndarray | None = None,
                       first_steps: np.ndarray | None = None, second_steps: np.ndarray | None = None,
                       probe_count: int | None = None) -> KlipperRotaryDelta:
    """Klipper's ``calculate_params`` on stable positions (the data its SAVE_CONFIG block keeps).

    Args:
        config: The values the calibration starts from (the printer's current ones).
        heights: Each stable position's goal height [mm], (N,) (the probe's ``z_offset``, or a
            manual height).
        height_steps: Their stable positions, (N, 3).
        extended: The extended method's 7 values (else the basic 4).
        distances: Measured distances [mm], (M,) (none: heights alone).
        first_steps: The stable positions of each distance's first end, (M, 3).
        second_steps: Of its second end, (M, 3).
        probe_count: How many of the heights are probe points (the last ones; default all): the
            distances' weight is ``M / (0.5 × probe_count)``.

    Returns:
        The new values.
    """
    z = np.asarray(heights, dtype=float).reshape(-1)
    both = [np.atleast_2d(np.asarray(height_steps, dtype=float))]
    dist = np.empty(0) if distances is None else np.asarray(distances, dtype=float).reshape(-1)
    weight = 1.0
    if dist.size:
        both += [np.atleast_2d(np.asarray(first_steps, dtype=float)),
                 np.atleast_2d(np.asarray(second_steps, dtype=float))]
        weight = dist.size / (MEASURE_WEIGHT * (len(z) if probe_count is None else probe_count))
    steps = np.vstack(both)
    n, m = len(z), dist.size

    def error(v: np.ndarray) -> float:
        p = _stable_positions(v, config, steps)
        total = weight * float(np.sum((p[:n, 2] - z) ** 2))
        if m:
            total += float(np.sum((np.linalg.norm(p[n:n + m] - p[n + m:], axis=1) - dist) ** 2))
        return total if np.isfinite(total) else np.inf

    adjust = ROTARY_EXTENDED if extended else ROTARY_BASIC
    return _unpack(config, coordinate_descent(error, _pack(config), adjust))


def klipper_rotary_basic(config: KlipperRotaryDelta, probe_commanded: np.ndarray,
                         z_offset: float | np.ndarray = 0.0) -> KlipperRotaryDelta:
    """Klipper's basic rotary calibration (``DELTA_CALIBRATE``): shoulder height and the three endstops.

    Args:
        config: The values the probing was done with (the start).
        probe_commanded: Commanded nozzle positions at the probe's triggers [mm], (N, 3) (N >= 3).
        z_offset: The probe's ``z_offset``: the nozzle's height when it triggers [mm] (one, or (N,)).

    Returns:
        The new values.
    """
    probe = np.atleast_2d(np.asarray(probe_commanded, dtype=float))
    heights = np.broadcast_to(np.asarray(z_offset, dtype=float), (len(probe),))
    return rotary_from_stable(config, heights, config.steps(probe))


def klipper_rotary_extended(config: KlipperRotaryDelta, probe_commanded: np.ndarray, pairs: np.ndarray,
                            distances: np.ndarray, z_offset: float | np.ndarray = 0.0) -> KlipperRotaryDelta:
    """Klipper's extended rotary calibration (``DELTA_ANALYZE CALIBRATE=extended``): 7 values.

    Args:
        config: The values both the probing and the object's print were done with.
        probe_commanded: Commanded nozzle positions at the probe's triggers [mm], (N, 3).
        pairs: Commanded positions of the features measured [mm], (M, 6)
            (:func:`~.calibrate.object_pairs`).
        distances: Their measured distances [mm], (M,) (:func:`~.calibrate.delta_analyze_distances`).
        z_offset: The probe's ``z_offset`` [mm].

    Returns:
        The new values (shoulder height, endstops, shoulder radius, angles A and B).
    """
    probe = np.atleast_2d(np.asarray(probe_commanded, dtype=float))
    pairs = np.atleast_2d(np.asarray(pairs, dtype=float))
    heights = np.broadcast_to(np.asarray(z_offset, dtype=float), (len(probe),))
    return rotary_from_stable(config, heights, config.steps(probe), True, distances,
                              config.steps(pairs[:, :3]), config.steps(pairs[:, 3:]))
