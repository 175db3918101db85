"""The readings a robot reaches by moving its TCP along a straight line: continuation.

Near the rim of its reach a Delta robot's six rods close in more than one assembly (the plate
tilted the other way, a parallelogram folded through one of its own singularities). One Newton
solve from a far start, the inverse's or the forward kinematics', converges to whichever the
readings close. The robot itself is in the assembly it was led into: from its workspace, along
its path. :func:`inverse_along` follows that path, a straight segment from a start to each
target, in steps of at most :data:`STEP` for all targets at once, each step's Newton started
from the last pose (readings and plate rotation: started from the plate parallel to the base,
Newton reached the other assembly within 1 mm steps near the rim, where Pinocchio's closed loop
followed the working one smoothly); a target is lost where a step finds no assembly near the last one (the
segment leaves the working assembly's reach) or the readings jump (a step changed them much
more than the previous one: Newton crossed over to another assembly). Units: mm and rad.
"""

from __future__ import annotations

import numpy as np

from ..geometry import DeltaGeometry
from . import exact

#: Longest step along a path [mm]: a fiftieth of Bai's 950 mm rods (the lost assemblies measured
#: on robots of that size lie 30-60 mm off the working one's reach along their segments).
STEP = 20.0
#: A step's readings may change at most this many times the previous step's change (plus
#: :data:`JUMP_FLOOR`): a straight path at constant speed changes them smoothly.
JUMP_RATIO = 3.0
#: Change of readings always allowed in one step [rad] (a printer's readings: mm).
JUMP_FLOOR = 1e-3


def inverse_along(geometry: DeltaGeometry, start: np.ndarray, targets: np.ndarray,
                  step: float = STEP) -> np.ndarray:
    """Readings that put the TCP on targets when it comes along straight lines from ``start``.

    Args:
        geometry: The robot.
        start: Where the TCP starts, in its working assembly [mm], (3,).
        targets: TCP targets [mm], (N, 3).
        step: Longest step along a segment [mm].

    Returns:
        Readings [rad; a printer's: mm], (N, 3); NaN rows for the targets the working assembly
        does not reach along its segment (or where its readings jump).

    Raises:
        UnreachableError: the start itself is out of reach.
    """
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    start = np.asarray(start, dtype=float).reshape(3)
    n = targets.shape[0]
    q0, R0 = exact.inverse_with_rotation(geometry, start[None], exact.inverse(geometry, start[None]),
                                         np.eye(3)[None])
    q, R = np.repeat(q0, n, axis=0), np.repeat(R0, n, axis=0)
    if n == 0:
        return q
    length = np.linalg.norm(targets - start, axis=1)
    steps = max(1, int(np.ceil(float(length.max()) / step)))
    live = np.ones(n, dtype=bool)
    last = np.zeros(n)  # the previous step's largest change of readings
    for k in range(1, steps + 1):
        idx = np.flatnonzero(live)
        if idx.size == 0:
            break
        x = start + (k / steps) * (targets[idx] - start)
        new, R[idx] = exact.inverse_with_rotation(geometry, x, q[idx], R[idx])  # the whole pose carried on
        change = np.max(np.abs(new - q[idx]), axis=1)
        with np.errstate(invalid="ignore"):
            lost = ~np.isfinite(change) | ((k > 1) & (change > JUMP_RATIO * last[idx] + JUMP_FLOOR))
        q[idx] = new
        last[idx] = change
        live[idx[lost]] = False
        q[idx[lost]] = np.nan
    return q
