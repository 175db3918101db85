"""D-optimal selection: seeded candidate pools away from singularities, greedy exchange."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Unpack

import numpy as np
from scipy.linalg import solve_triangular

from ..errormodels import ErrorModel
from ..exceptions import PlanningError
from ..geometry import DeltaGeometry, NominalDelta
from ..identifiability import BaseParameters, base_parameters
from ..identification.columns import COMPLIANCE_NAMES
from ..kinematics.closed_form import VirtualDelta
from ..kinematics.singularity import PLANNING_MARGIN, SingularityMargin
from ..resources import require_memory
from .options import PlanOptions, PlanOverrides, plan_options
from .poses import PoseSet, poses_from_reference, require_workspace
from .regressor import RANK_RTOL, default_points, planning_model, pose_blocks

#: Candidate poses processed at once: the work arrays of the selection take a few times
#: ``CHUNK × rows × parameters`` numbers, whatever the pool (about 10 MB each for the complete
#: model's 51 parameters and pose measurements).
CHUNK = 4096

#: Work arrays of one chunk, in units of its regressor blocks (the kinematics' and sensitivity's
#: intermediates of :func:`~deltacal.planning.regressor.pose_blocks`), measured.
CHUNK_WORK = 6.0


#: Seconds of one selection step per candidate and per number of its scaled regressor
#: (rows × base parameters), measured on one core of the development machine: 84 steps over
#: 50,000 candidates of the complete model (6 × 42) in 19 s, 4.6 µs a candidate and step
#: (the whole command: ``cli_plan_doptimal_pool*`` in scripts/bench.py).
STEP_SECONDS = 1.8e-8


@dataclass(frozen=True)
class PoolCost:
    """What a D-optimal selection from a pool costs, estimated before it starts.

    Attributes:
        memory: Peak memory beyond the pool itself [bytes] (:func:`pool_memory`).
        step: Time of one selection step (every candidate's gain) [s].
        steps_min: Steps if the greedy selection needs no exchange (``count``).
        steps_max: Steps if every exchange pass is run (``count × (1 + max_passes)``).
    """

    memory: float
    step: float
    steps_min: int
    steps_max: int


def pool_cost(pool_size: int, rows: int, parameters: int, base: int, count: int,
              max_passes: int = 10) -> PoolCost:
    """The memory and time of selecting ``count`` poses from ``pool_size`` candidates, estimated.

    Args:
        pool_size: Candidates.
        rows: Regressor rows per candidate.
        parameters: Parameters of the error model.
        base: Its base parameters for these measurements.
        count: Poses to select.
        max_passes: Exchange passes at most.
    """
    return PoolCost(memory=pool_memory(pool_size, rows, parameters, base),
                    step=STEP_SECONDS * pool_size * rows * base,
                    steps_min=count, steps_max=count * (1 + max_passes))


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
        parts = _chunks(ref - nominal.tool, CHUNK)
        ok = np.concatenate([_admissible(virtual, margin, part) for part in parts])
        kept.append(ref[ok])
        have += int(ok.sum())
    return poses_from_reference(nominal, np.concatenate(kept)[:count], tool)


def _admissible(virtual: VirtualDelta, margin: SingularityMargin, reference: np.ndarray) -> np.ndarray:
    """Which plate reference points [mm] the robot reaches with the singularity margin, shape (N,)."""
    q = virtual.inverse(reference, check=False)
    ok = np.all(np.isfinite(q), axis=1)
    return ok & margin.admits(virtual, np.where(ok[:, None], q, 0.0))


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


def _greedy_exchange(blocks: np.ndarray, count: int, max_passes: int, chunk: int | None = None) -> np.ndarray:
    """Greedy forward selection then Fedorov exchanges maximising log det(Σ W_kᵀ W_k).

    A small ridge keeps the information matrix invertible while fewer poses than
    parameters are chosen; it is tiny next to the information of one pose, so it
    only breaks ties among rank-deficient selections. The candidates' gains are
    computed ``chunk`` candidates at a time, so the work arrays do not grow with the pool.
    """
    N, b, r = blocks.shape
    chunk = CHUNK if chunk is None else chunk
    total = sum(float(np.einsum("kbi,kbi->", W, W)) for W in _chunks(blocks, chunk))
    ridge = 1e-9 * total / N / r  # 1e-9 × the mean information per parameter of one candidate
    eye_b = np.eye(b)

    def info(k: int) -> np.ndarray:
        return blocks[k].T @ blocks[k]

    def gains(M: np.ndarray) -> np.ndarray:
        # log det(M + W_kᵀ W_k) - log det M = log det(I_b + W_k M⁻¹ W_kᵀ)  (determinant lemma),
        # with M = L Lᵀ: W_k M⁻¹ W_kᵀ = Y_k Y_kᵀ, Y_k = W_k L⁻ᵀ (L⁻ᵀ once, then one product per chunk)
        inv_lt = solve_triangular(np.linalg.cholesky(M), np.eye(r), lower=True).T
        out = np.empty(N)
        start = 0
        for W in _chunks(blocks, chunk):
            Y = (W.reshape(-1, r) @ inv_lt).reshape(W.shape)
            sign, value = np.linalg.slogdet(eye_b + Y @ Y.transpose(0, 2, 1))
            out[start:start + len(W)] = np.where(sign > 0, value, -np.inf)
            start += len(W)
        return out

    M = ridge * np.eye(r)
    chosen: list[int] = []
    taken = np.zeros(N, dtype=bool)
    for _ in range(count):
        g = np.where(taken, -np.inf, gains(M))
        k = int(np.argmax(g))
        chosen.append(k)
        taken[k] = True
        M = M + info(k)
    for _ in range(max_passes):
        improved = False
        for slot in range(count):
            k = chosen[slot]
            M_minus = M - info(k)
            g = np.where(taken, -np.inf, gains(M_minus))
            g_k = _log_det(M) - _log_det(M_minus)
            j = int(np.argmax(g))
            if g[j] > g_k + 1e-9:
                chosen[slot] = j
                taken[k], taken[j] = False, True
                M = M_minus + info(j)
                improved = True
        if not improved:
            break
    return np.array(chosen, dtype=int)


def _chunks(a: np.ndarray, size: int) -> Iterator[np.ndarray]:
    """Consecutive slices of ``a`` along its first axis, ``size`` rows each (views, no copies)."""
    for start in range(0, len(a), size):
        yield a[start:start + size]


def pool_memory(pool_size: int, rows: int, parameters: int, base: int | None = None) -> float:
    """Peak memory [bytes] of a D-optimal selection beyond the pool itself, estimated.

    The column-scaled base regressor of every candidate is kept, ``rows × base`` numbers each
    (the gains of every candidate are computed at each step); the rest works on
    :data:`CHUNK` candidates at a time.

    Args:
        pool_size: Candidates.
        rows: Regressor rows per candidate (6 for pose measurements, 3 per point for positions).
        parameters: Parameters of the error model.
        base: Base parameters, if known (default: ``parameters``, an upper bound).
    """
    kept = 8.0 * pool_size * rows * (parameters if base is None else base)
    work = 8.0 * min(pool_size, CHUNK) * rows * parameters * CHUNK_WORK
    return kept + work


def require_pool_memory(pool_size: int, rows: int, parameters: int) -> float:
    """Refuse a pool whose selection cannot fit in memory; else its estimated peak [bytes].

    Raises:
        ResourceError: :func:`pool_memory` exceeds what the process may allocate.
    """
    needed = pool_memory(pool_size, rows, parameters)
    require_memory(needed, f"a D-optimal selection from {pool_size:,} candidates",
                   "draw a smaller candidate pool (plan --pool)")
    return needed


def scaled_base_blocks(
    geometry: DeltaGeometry, error_model: ErrorModel, q: np.ndarray, points: list[str], options: PlanOptions,
    chunk: int | None = None,
) -> tuple[np.ndarray, BaseParameters]:
    """The column-scaled base regressor blocks of candidate poses, and the base parameters.

    Two passes over the candidates, ``chunk`` poses at a time, so that nothing but the result
    grows with the pool: the first finds the base parameters (from the triangular factor of
    the whole regressor, updated chunk by chunk: the columns' inner products are all the
    pivoted QR needs) and the columns' RMS; the second keeps each pose's rows of the base
    parameters, divided by their column's RMS over the pool.

    The options give the measurement, the σ of its rows and the payloads: with payloads, each
    pose measured at each and the compliances c1..c3 fitted too (:func:`pose_blocks`).

    Returns:
        Blocks of shape (N, b, r) and the base parameters (r of the model's n).
    """
    measurement, payloads = options.measurement, options.payloads
    names = list(error_model.names) + (list(COMPLIANCE_NAMES) if payloads else [])
    n = len(names)
    size = CHUNK if chunk is None else chunk
    R = np.zeros((0, n))
    squares = np.zeros(n)

    def raw_chunks() -> Iterator[np.ndarray]:
        for qc in _chunks(q, size):
            yield pose_blocks(geometry, error_model, qc, measurement, points, options.sigma_position,
                              options.sigma_angle, payloads)

    for raw in raw_chunks():
        A = raw.reshape(-1, n)
        squares += np.einsum("ij,ij->j", A, A)
        R = np.asarray(np.linalg.qr(np.concatenate([R, A]), mode="r"))
    base = base_parameters(R, names, rtol=RANK_RTOL)
    scale = np.sqrt(squares / len(q))[base.base]
    scale = np.where(scale > 0.0, scale, 1.0)
    blocks = np.empty((len(q), _rows(measurement, points) * max(len(payloads), 1), len(base.base)))
    start = 0
    for raw in raw_chunks():
        blocks[start:start + len(raw)] = raw[:, :, base.base] / scale
        start += len(raw)
    return blocks, base


def _rows(measurement: str, points: list[str]) -> int:
    """Regressor rows of one pose (:func:`~deltacal.planning.regressor.pose_blocks`)."""
    return 6 if measurement == "pose" else 3 * len(points)


def d_optimal(
    nominal: NominalDelta,
    model: str | ErrorModel,
    count: int,
    rng: np.random.Generator | None = None,
    pool: PoseSet | None = None,
    *,
    options: PlanOptions | None = None,
    **overrides: Unpack[PlanOverrides],
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
        pool: Candidate poses (default: :func:`candidate_pool` of ``options.pool_size``).
        options: How to select (:class:`PlanOptions`: the pool drawn, the measurement and its
            points and σ, the exchange passes, the payloads; default: its defaults).
        **overrides: Fields of :class:`PlanOptions` by name (``pool_size=400``,
            ``measurement="position"``, ``payloads=(0.0, 3.0)`` [kg], ...); they win over the
            same fields of ``options``.

    Raises:
        PlanningError: more poses asked than candidates.
        TypeError: an override that names no option, or ``options`` not a :class:`PlanOptions`.
        ValueError: an option out of its range, or no ``rng`` to draw the pool with.
    """
    options = plan_options(options, overrides)
    error_model = planning_model(model) if isinstance(model, str) else model
    if pool is None:
        if rng is None:
            raise ValueError("d_optimal needs a seeded rng to draw its candidate pool")
        pool = candidate_pool(nominal, options.pool_size, rng, options.margin, options.tool_array)
    if count < 1 or count > len(pool):
        raise PlanningError(f"cannot select {count} poses from {len(pool)} candidates")
    geometry = nominal.geometry()
    measurement, payloads = options.measurement, options.payloads
    given = options.points
    pts = default_points(geometry, error_model, measurement) if given is None else list(given)
    loads = max(len(payloads), 1)
    require_pool_memory(len(pool), _rows(measurement, pts) * loads, error_model.size + 3 * bool(payloads))
    blocks, base = scaled_base_blocks(geometry, error_model, pool.q, pts, options)
    chosen = _greedy_exchange(blocks, count, options.max_passes)
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
