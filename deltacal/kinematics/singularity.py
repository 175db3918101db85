"""Singularities: one set of measures, and one margin type whose policies say how far to stay.

A Delta (virtual, perfect-parallelogram model) has two kinds of singularity:

* serial (inverse-kinematics): an arm and its rod aligned; measured by the least
  **transmission angle** over the limbs, ``asin |n̂ · (w × û)|`` between the rod n̂ and
  the arm's direction of motion (w: actuator axis, û: arm), 90° when the rod pulls along
  the elbow's velocity, 0 at the singularity;
* parallel (forward-kinematics): the rods coplanar; measured by the **rod conditioning**,
  the inverse condition number of the matrix of unit rod directions (0 at the singularity),
  and, more strictly, by the **condition number κ of J_S** (``xdot = J_S qdot``, Savoure
  Table 1), which grows without bound near both kinds.

:class:`SingularityMargin` holds thresholds on the three; its :meth:`~SingularityMargin.margin`
is always the smallest ratio measure/threshold (κ as threshold/κ): below 1 a pose is refused.
Two policies: :data:`COMMAND_MARGIN` (what compensation refuses to command) and
:data:`PLANNING_MARGIN` (where measurement poses are drawn: far from both).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .closed_form import VirtualDelta


def singularity_measures(virtual: VirtualDelta, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least transmission angle over the limbs [rad] and rod conditioning at readings q, each (N,)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    x = virtual.forward(q)
    E = virtual.elbows(q)
    w = virtual.actuator_rotation[:, :, 1]
    arm = E - virtual.axis_point[None]
    u = arm / np.linalg.norm(arm, axis=2, keepdims=True)
    rod = x[:, None, :] + virtual.plate_attachment[None] - E
    rod /= np.linalg.norm(rod, axis=2, keepdims=True)
    sin_t = np.abs(np.sum(rod * np.cross(w[None], u), axis=2))
    angle = np.arcsin(np.clip(sin_t, 0.0, 1.0)).min(axis=1)
    s = np.linalg.svd(rod, compute_uv=False)
    return angle, s[:, -1] / s[:, 0]


def jacobian_condition(virtual: VirtualDelta, q: np.ndarray) -> np.ndarray:
    """Condition number κ of the virtual J_S at readings q, (N,)."""
    return np.linalg.cond(virtual.jacobian(np.atleast_2d(np.asarray(q, dtype=float))))


@dataclass(frozen=True)
class SingularityMargin:
    """How far from singularities a pose must be (see the module docstring).

    Attributes:
        min_arm_rod_angle: Least transmission angle [rad].
        min_rod_conditioning: Least inverse condition number of the unit rod directions.
        max_condition: Largest condition number of J_S (inf: not checked).
    """

    min_arm_rod_angle: float = math.radians(3.0)
    min_rod_conditioning: float = 0.0
    max_condition: float = math.inf

    def margin(self, virtual: VirtualDelta, q: np.ndarray) -> np.ndarray:
        """Smallest ratio of a measure to its threshold at readings q, (N,): below 1, refused."""
        angle, conditioning = singularity_measures(virtual, q)
        no_limit = np.full_like(angle, np.inf)
        ratios = [angle / self.min_arm_rod_angle if self.min_arm_rod_angle > 0 else no_limit]
        if self.min_rod_conditioning > 0:
            ratios.append(conditioning / self.min_rod_conditioning)
        if math.isfinite(self.max_condition):
            ratios.append(self.max_condition / jacobian_condition(virtual, q))
        return np.minimum.reduce(ratios)

    def admits(self, virtual: VirtualDelta, q: np.ndarray) -> np.ndarray:
        """Readings at least this far from every singularity, (N,) bool."""
        return self.margin(virtual, q) >= 1.0


#: What compensation refuses to command: arm and rod within 3° of alignment, or rods nearly
#: coplanar (inverse condition of their directions below 0.02).
COMMAND_MARGIN = SingularityMargin(min_arm_rod_angle=math.radians(3.0), min_rod_conditioning=0.02)
#: Where measurement poses are drawn: transmission angle of 20° at least and κ(J_S) at most 10.
PLANNING_MARGIN = SingularityMargin(min_arm_rod_angle=math.radians(20.0), max_condition=10.0)
