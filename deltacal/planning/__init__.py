"""Measurement pose planning: Bai's pose sets, the κ(n) rule and D-optimal selection.

Where the poses go (project convention): the ``[workspace]`` cylinder of a
robot file is where the plate's reference point (the file's tool) goes. With
another tool attached (:meth:`DeltaGeometry.with_tool`), the robot makes the
same motions and the TCP targets are the cylinder's points shifted by
``tool - file tool``. Readings come from the nominal (closed-form) inverse
kinematics, knee-out branch.

Three ways of choosing poses:

* **Bai's pose sets** (Bai 2015, §3.3, Fig. 4): ``n`` evenly spaced poses on
  each of the top and bottom circles of the cylinder (radius R) and the centre
  ``P_0`` first, ``2n + 1`` poses (:func:`bai_poses`); for the rough step, the
  centre and ``n`` poses on the middle circle (§5.1, :func:`rough_poses`).
* **The κ(n) rule** (Bai Eq. 21): the least ``n >= 3`` whose relative change of
  the condition number of the identification matrix, ``|κ_n − κ_{n−1}| / κ_n``,
  is at most ε0 (:func:`condition_curve`, :meth:`ConditionCurve.least_n`).
* **D-optimal selection** (:func:`d_optimal`): a greedy then exchange (Fedorov)
  maximisation of ``log det(Wᵀ W)`` of the column-scaled base regressor over a
  pool of reachable candidates kept away from singularities (:func:`candidate_pool`); its
  options are one value, :class:`PlanOptions`.

The POSES file (:func:`deltacal.io.write_poses`, :func:`deltacal.io.read_poses`) has the header
``q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm``: the readings to command, then the
nominal TCP target they reach. Units: mm and rad inside, mm and deg in files.
"""

from ..exceptions import PlanningError
from ..kinematics.singularity import PLANNING_MARGIN, SingularityMargin
from .condition import ConditionCurve, condition_curve
from .doptimal import (
    DOptimalDesign,
    PoolCost,
    candidate_pool,
    d_optimal,
    pool_cost,
    pool_memory,
    require_pool_memory,
)
from .options import PlanOptions
from .poses import (
    PoseSet,
    bai_poses,
    circle,
    poses_from_reference,
    require_workspace,
    rough_poses,
)
from .regressor import (
    MEASUREMENTS,
    PLAN_MODELS,
    ROUGH,
    default_points,
    identification_matrix,
    planning_model,
    pose_blocks,
)

__all__ = [
    "PlanningError",
    "PLANNING_MARGIN",
    "SingularityMargin",
    "ConditionCurve",
    "DOptimalDesign",
    "PlanOptions",
    "MEASUREMENTS",
    "PLAN_MODELS",
    "PoseSet",
    "ROUGH",
    "bai_poses",
    "candidate_pool",
    "circle",
    "condition_curve",
    "d_optimal",
    "PoolCost",
    "pool_cost",
    "pool_memory",
    "require_pool_memory",
    "default_points",
    "identification_matrix",
    "planning_model",
    "pose_blocks",
    "poses_from_reference",
    "require_workspace",
    "rough_poses",
]
