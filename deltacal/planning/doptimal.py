"""D-optimal selection: seeded candidate pools away from singularities, greedy exchange."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errormodels import ErrorModel
from ..exceptions import PlanningError
from ..geometry import NominalDelta
from ..identifiability import base_parameters
from ..kinematics.closed_form import VirtualDelta
from ..kinematics.singularity import PLANNING_MARGIN, SingularityMargin
from ..observations import SIGMA_ANGLE, SIGMA_POSITION
from .poses import PoseSet, poses_from_reference, require_workspace
from .regressor import _RTOL, default_points, planning_model, pose_blocks


# --------------------------------------------------------------------------- candidates
def candidate_pool(
    nominal: NominalDelta,
    count: int,
    rng: np.random.Generator,
    margin: SingularityMargin | None = None,
    tool: np.ndarray | None = None,
    max_draws: int = 50,
) -> PoseSet:
    """Seeded random candidate poses, uniform in the workspace cylinder, away from singularities.

    Reference points (the file's tool) are drawn uniformly in the cylinder's volume;
    those the nominal robot cannot reach or that violate the margin are rejected,
    and drawing goes on until ``count`` are kept.

    Args:
        nominal: The robot, with a workspace.
        count: Candidates wanted.
        rng: Random generator.
        margin: Singularity margin (default :data:`~deltacal.kinematics.singularity.PLANNING_MARGIN`).
        tool: TCP for the targets (see the module docstring).
        max_draws: Give up after drawing ``max_draws * count`` points.

    Raises:
        PlanningError: too few admissible points in the cylinder.
    """
    ws = require_workspace(nominal)
    margin = PLANNING_MARGIN if margin is None else margin
    virtual = VirtualDelta.from_nominal(nominal)
    kept: list[np.ndarray] = []
    have = drawn = 0
    while have < count:
        if drawn >= max_draws * count:
            raise PlanningError(
                f"only {have} of {drawn} random points of the workspace are reachable with the "
                f"singularity margin ({math.degrees(margin.min_arm_rod_angle):g} deg, "
                f"condition {margin.max_condition:g}); {count} wanted"
            )
        m = max(count - have, 16) * 2
        radius = ws.radius * np.sqrt(rng.random(m))
        azimuth = rng.uniform(0.0, 2.0 * np.pi, m)
        z = ws.top_z - ws.height * rng.random(m)
        ref = np.stack([radius * np.cos(azimuth), radius * np.sin(azimuth), z], axis=1)
        drawn += m
        q = virtual.inverse(ref - nominal.tool, check=False)
        ok = np.all(np.isfinite(q), axis=1)
        ok &= margin.admits(virtual, np.where(ok[:, None], q, 0.0))
        kept.append(ref[ok])
        have += int(ok.sum())
    return poses_from_reference(nominal, np.concatenate(kept)[:count], tool)


def _log_det(M: np.ndarray) -> float:
    sign, value = np.linalg.slogdet(M)
    return float(value) if sign > 0 else -math.inf


@dataclass(frozen=True)
class DOptimalDesign:
    """A D-optimal selection of poses from a candidate pool.

    Attributes:
        poses: The selected poses, in selection order.
        pool: The candidate pool.
        selected: Indices of the selected poses in the pool, shape (count,).
        log_det: log det(Wᵀ W) of the selected poses' column-scaled base regressor
            (-inf if the selection does not identify every base parameter).
        base_names: Base parameters the regressor is restricted to.
        model: Error model name.
        measurement: ``pose`` or ``position``.
        points: Plate points measured.
        blocks: Column-scaled base regressor rows of every candidate, (N, b, r).
    """

    poses: PoseSet
    pool: PoseSet
    selected: np.ndarray
    log_det: float
    base_names: list[str]
    model: str
    measurement: str
    points: list[str]
    blocks: np.ndarray = field(repr=False)

    def log_det_of(self, index: np.ndarray) -> float:
        """Log-determinant of Wᵀ W for any subset of the pool (same scaling), e.g. a random one."""
        W = self.blocks[np.asarray(index)]
        return _log_det(np.einsum("kbi,kbj->ij", W, W))


def _greedy_exchange(blocks: np.ndarray, count: int, max_passes: int) -> np.ndarray:
    """Greedy forward selection then Fedorov exchanges maximising log det(Σ W_kᵀ W_k).

    A small ridge keeps the information matrix invertible while fewer poses than
    parameters are chosen; it is tiny next to the information of one pose, so it
    only breaks ties among rank-deficient selections.
    """
    N, b, r = blocks.shape
    info = np.einsum("kbi,kbj->kij", blocks, blocks)  # (N, r, r)
    ridge = 1e-9 * float(np.trace(info.mean(axis=0))) / r
    eye_b = np.eye(b)

    def gains(M: np.ndarray) -> np.ndarray:
        # log det(M + W_kᵀ W_k) - log det M = log det(I_b + W_k M⁻¹ W_kᵀ)  (determinant lemma)
        X = np.linalg.solve(M, blocks.reshape(-1, r).T).T.reshape(N, b, r)
        sign, value = np.linalg.slogdet(eye_b + np.einsum("kbi,kci->kbc", X, blocks))
        return np.where(sign > 0, value, -np.inf)

    M = ridge * np.eye(r)
    chosen: list[int] = []
    taken = np.zeros(N, dtype=bool)
    for _ in range(count):
        g = np.where(taken, -np.inf, gains(M))
        k = int(np.argmax(g))
        chosen.append(k)
        taken[k] = True
        M = M + info[k]
    for _ in range(max_passes):
        improved = False
        for slot in range(count):
            k = chosen[slot]
            M_minus = M - info[k]
            g = np.where(taken, -np.inf, gains(M_minus))
            g_k = _log_det(M) - _log_det(M_minus)
            j = int(np.argmax(g))
            if g[j] > g_k + 1e-9:
                chosen[slot] = j
                taken[k], taken[j] = False, True
                M = M_minus + info[j]
                improved = True
        if not improved:
            break
    return np.array(chosen, dtype=int)


def d_optimal(
    nominal: NominalDelta,
    model: str | ErrorModel,
    count: int,
    rng: np.random.Generator | None = None,
    pool: PoseSet | None = None,
    pool_size: int = 1000,
    measurement: str = "pose",
    points: Sequence[str] | None = None,
    margin: SingularityMargin | None = None,
    tool: np.ndarray | None = None,
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
    max_passes: int = 10,
) -> DOptimalDesign:
    """Select ``count`` poses maximising log det(Wᵀ W) of the column-scaled base regressor.

    W stacks the weighted regressor rows (:func:`pose_blocks`) of the selected
    poses, restricted to the base parameters found on the whole pool, with each
    column divided by its RMS over the pool (so the criterion does not depend on
    the parameters' units). Greedy forward selection, then exchange passes that
    swap a selected pose for the best candidate while log det increases.

    Args:
        nominal: The robot, with a workspace.
        model: Error model or name (:data:`PLAN_MODELS`).
        count: Poses to select.
        rng: Random generator for the pool (needed when ``pool`` is not given).
        pool: Candidate poses (default: :func:`candidate_pool` of ``pool_size``).
        pool_size: Candidates drawn when no pool is given.
        measurement: ``pose`` or ``position`` (distance rows are not additive per pose).
        points: Plate points measured (default: :func:`default_points`).
        margin: Singularity margin of the drawn pool.
        tool: TCP for the targets.
        sigma_position: σ of a position coordinate [mm].
        sigma_angle: σ of an orientation component [rad].
        max_passes: Exchange passes at most.

    Raises:
        PlanningError: more poses asked than candidates.
    """
    error_model = planning_model(model) if isinstance(model, str) else model
    if pool is None:
        if rng is None:
            raise ValueError("d_optimal needs a seeded rng to draw its candidate pool")
        pool = candidate_pool(nominal, pool_size, rng, margin, tool)
    if count < 1 or count > len(pool):
        raise PlanningError(f"cannot select {count} poses from {len(pool)} candidates")
    geometry = nominal.geometry()
    pts = default_points(geometry, error_model, measurement) if points is None else list(points)
    raw = pose_blocks(geometry, error_model, pool.q, measurement, pts, sigma_position, sigma_angle)
    N, b, n = raw.shape
    base = base_parameters(raw.reshape(N * b, n), error_model.names, rtol=_RTOL)
    scale = np.linalg.norm(raw.reshape(N * b, n), axis=0) / math.sqrt(N)
    blocks = raw[:, :, base.base] / np.where(scale > 0.0, scale, 1.0)[base.base]
    chosen = _greedy_exchange(blocks, count, max_passes)
    W = blocks[chosen]
    return DOptimalDesign(
        poses=pool[chosen],
        pool=pool,
        selected=chosen,
        log_det=_log_det(np.einsum("kbi,kbj->ij", W, W)),
        base_names=base.base_names,
        model=error_model.name,
        measurement=measurement,
        points=pts,
        blocks=blocks,
    )
