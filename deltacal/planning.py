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
  pool of reachable candidates kept away from singularities (:func:`candidate_pool`).

The POSES file (:func:`deltacal.io.write_poses`, :func:`deltacal.io.read_poses`) has the header
``q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm``: the readings to command, then the
nominal TCP target they reach. Units: mm and rad inside, mm and deg in files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .errormodels import MODEL_NAMES, ErrorModel, get_model
from .exceptions import PlanningError
from .geometry import DeltaGeometry, NominalDelta, Workspace, skew
from .identifiability import base_parameters
from .kinematics import exact
from .kinematics.closed_form import VirtualDelta
from .kinematics.singularity import PLANNING_MARGIN, SingularityMargin
from .observations import SIGMA_ANGLE, SIGMA_POSITION, Measurements, build_rows

#: Measurement kinds a regressor can be built for.
MEASUREMENTS = ("pose", "position", "distance")
#: Name of the 3-parameter encoder-offset model of the rough step (Bai §5.1).
ROUGH = "rough"
#: Model names :func:`planning_model` accepts.
PLAN_MODELS = (*MODEL_NAMES, ROUGH)
#: Relative rank tolerance of the scaled regressors (as :func:`base_parameters`).
_RTOL = 1e-8


# --------------------------------------------------------------------------- pose sets
@dataclass(frozen=True)
class PoseSet:
    """Poses to measure: readings to command and the nominal TCP targets they reach.

    Attributes:
        q: Joint readings [rad], shape (N, 3).
        targets: Nominal TCP positions in {O} [mm], shape (N, 3).
    """

    q: np.ndarray
    targets: np.ndarray

    def __post_init__(self) -> None:
        q = np.atleast_2d(np.asarray(self.q, dtype=float))
        t = np.atleast_2d(np.asarray(self.targets, dtype=float))
        if q.shape != t.shape or q.ndim != 2 or q.shape[1] != 3:
            raise ValueError(f"q and targets must both be (N, 3), got {q.shape} and {t.shape}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "targets", t)

    def __len__(self) -> int:
        return self.q.shape[0]

    def __getitem__(self, index) -> PoseSet:
        return PoseSet(self.q[index], self.targets[index])


def require_workspace(nominal: NominalDelta) -> Workspace:
    """The robot's workspace cylinder; PlanningError if the robot file has none."""
    if nominal.workspace is None:
        raise PlanningError(f"robot {nominal.name!r} has no [workspace] cylinder to plan in")
    return nominal.workspace


def circle(radius: float, z: float, n: int, phase: float = 0.0) -> np.ndarray:
    """N evenly spaced points of a horizontal circle about the z axis [mm], shape (n, 3).

    Args:
        radius: Circle radius [mm].
        z: Height of the circle [mm].
        n: Number of points.
        phase: Azimuth of the first point [rad] (Bai's swing angle ψ of the first pose).
    """
    angle = phase + 2.0 * np.pi * np.arange(n) / n
    return np.stack([radius * np.cos(angle), radius * np.sin(angle), np.full(n, float(z))], axis=1)


def poses_from_reference(
    nominal: NominalDelta, reference: np.ndarray, tool: np.ndarray | None = None
) -> PoseSet:
    """Poses putting the plate's reference point (the file's tool) at cylinder points.

    Args:
        nominal: The robot.
        reference: Positions of the file's tool [mm], shape (N, 3).
        tool: TCP in the plate frame [mm] whose targets to report (default: the file's tool).

    Returns:
        The readings (nominal inverse kinematics) and the TCP targets
        ``reference + tool - nominal.tool``.

    Raises:
        UnreachableError: naming the points the nominal robot cannot reach.
    """
    reference = np.atleast_2d(np.asarray(reference, dtype=float))
    shift = np.zeros(3) if tool is None else np.asarray(tool, dtype=float) - nominal.tool
    q = VirtualDelta.from_nominal(nominal).inverse(reference - nominal.tool)
    return PoseSet(q, reference + shift)


def bai_poses(
    nominal: NominalDelta, n: int, tool: np.ndarray | None = None, phase: float = 0.0
) -> PoseSet:
    """Bai's pose set of the fine calibration (Bai 2015, §3.3, Fig. 4): 2n + 1 poses.

    The centre of the cylinder (``P_0``) first, then n evenly spaced poses on the
    top circle and n on the bottom circle (radius R, same azimuths).

    Args:
        nominal: The robot, with a workspace.
        n: Poses per circle (>= 1).
        tool: TCP for the targets (see the module docstring).
        phase: Azimuth of the first pose of each circle [rad].
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    ws = require_workspace(nominal)
    ref = np.concatenate(
        [ws.centre[None], circle(ws.radius, ws.top_z, n, phase), circle(ws.radius, ws.bottom_z, n, phase)]
    )
    return poses_from_reference(nominal, ref, tool)


def rough_poses(
    nominal: NominalDelta,
    n: int,
    tool: np.ndarray | None = None,
    phase: float = 0.0,
    centre: bool = True,
) -> PoseSet:
    """Poses of the rough (encoder offset) step (Bai 2015, §5.1): the middle circle.

    Args:
        nominal: The robot, with a workspace.
        n: Poses on the middle circle of radius R (>= 1).
        tool: TCP for the targets (see the module docstring).
        phase: Azimuth of the first pose [rad].
        centre: Put the centre of the cylinder first (Bai: K = C(n+1, 2) distances).
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    ws = require_workspace(nominal)
    parts = [ws.centre[None]] if centre else []
    parts.append(circle(ws.radius, ws.middle_z, n, phase))
    return poses_from_reference(nominal, np.concatenate(parts), tool)


# --------------------------------------------------------------------------- regressors
def planning_model(name: str) -> ErrorModel:
    """An error model by name; ``rough`` is the classical model's three encoder offsets."""
    if name == ROUGH:
        classical = get_model("classical")
        keep = {"offset1", "offset2", "offset3"}
        return classical.without([k for k in classical.names if k not in keep], ROUGH)
    return get_model(name)


def default_points(geometry: DeltaGeometry, model: ErrorModel, measurement: str) -> list[str]:
    """Reference points measured by default.

    Pose measurements see the plate's orientation: the TCP suffices. Positions and
    distances of a model that tilts the plate need several points (Bai §3.2: two
    reflectors for model 32): every named point of the robot, or the TCP if none.
    """
    if measurement == "pose" or not model.tilts_plate or not geometry.points:
        return ["tcp"]
    return list(geometry.points)


def _check_measurement(measurement: str) -> None:
    if measurement not in MEASUREMENTS:
        raise ValueError(f"measurement must be one of {', '.join(MEASUREMENTS)}, got {measurement!r}")


def identification_matrix(
    geometry: DeltaGeometry,
    model: ErrorModel,
    q: np.ndarray,
    measurement: str = "pose",
    points: Sequence[str] = ("tcp",),
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
) -> np.ndarray:
    """The identification matrix H (weighted regressor) of measurements at readings q.

    Rows as in :func:`deltacal.observations.build_rows`, divided by their σ:
    ``pose``: TCP position and plate orientation of each pose (6 rows), only the
    first point's position if several are named; ``position``: 3 rows per point and
    pose; ``distance``: one row per pair of positions of a same point, all pairs
    (Bai Eq. 12-16, K = C(N, 2) per point).

    Args:
        geometry: Geometry to linearise around (the nominal one).
        model: Error model.
        q: Readings [rad], shape (N, 3).
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured.
        sigma_position: σ of a position coordinate [mm].
        sigma_angle: σ of an orientation component [rad].

    Returns:
        H, shape (rows, model.size).
    """
    _check_measurement(measurement)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    names = list(points)[:1] if measurement == "pose" else list(points)
    Q = np.concatenate([q] * len(names))
    pose = exact.forward(geometry, Q)
    rotvec = np.full(Q.shape, np.nan)
    if measurement == "pose":
        rotvec = pose.rotation_vector()
    meas = Measurements(
        q=Q,
        position=np.zeros_like(Q),
        point=[p for p in names for _ in range(q.shape[0])],
        rotation_vector=rotvec,
    )
    rows = build_rows(
        geometry,
        meas,
        model.sensitivity,
        sigma_position,
        sigma_angle,
        distances=measurement == "distance",
        pose=pose,
    )
    return rows.scaled[1]  # Bai's H: rows divided by σ, not whitened


def _scaled_condition(H: np.ndarray, scaled: bool) -> float:
    """Condition number of H (columns to unit norm first if ``scaled``); inf if rank deficient."""
    if scaled:
        norms = np.linalg.norm(H, axis=0)
        H = H / np.where(norms > 0.0, norms, 1.0)
    sv = np.linalg.svd(H, compute_uv=False)
    if sv.size == 0 or sv[-1] <= _RTOL * sv[0] or H.shape[0] < H.shape[1]:
        return math.inf
    return float(sv[0] / sv[-1])


# --------------------------------------------------------------------------- κ(n) rule
@dataclass(frozen=True)
class ConditionCurve:
    """κ(n) of Bai's pose sets and its relative change (Bai 2015, Eq. 21, Fig. 6-7).

    Attributes:
        model: Error model name.
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured.
        layers: ``"top-bottom"`` (fine step, 2n + 1 poses) or ``"middle"`` (rough step, n + 1).
        n: Poses per circle, shape (k,), consecutive.
        kappa: κ_n, condition number of H(n) restricted to the identifiable columns, (k,);
            inf where H(n) does not identify them all.
        epsilon: ε_n = |κ_n − κ_{n−1}| / κ_n (a fraction, not %), (k,); NaN for the first n,
            inf where κ_n or κ_{n−1} is inf.
        base_names: Identifiable (base) parameters, found on the largest pose set.
        scaled: Whether the columns were scaled to unit norm before taking κ.
    """

    model: str
    measurement: str
    points: list[str]
    layers: str
    n: np.ndarray
    kappa: np.ndarray
    epsilon: np.ndarray
    base_names: list[str]
    scaled: bool

    def least_n(self, epsilon0: float, n_min: int = 3) -> int:
        """Bai's Eq. 21: the least n >= n_min with ε_n <= ε0.

        Args:
            epsilon0: Threshold ε0 as a fraction (Bai's 1 % is 0.01).
            n_min: Least n allowed (Bai: 3).

        Raises:
            PlanningError: no n of the curve satisfies the rule.
        """
        ok = (self.n >= n_min) & (self.epsilon <= epsilon0)
        if not np.any(ok):
            raise PlanningError(
                f"no n in {int(self.n[0])}..{int(self.n[-1])} has a relative change of κ below "
                f"{100.0 * epsilon0:g} % for model {self.model} ({self.measurement}); "
                f"smallest: {100.0 * float(np.nanmin(self.epsilon[self.n >= n_min])):.3g} %"
            )
        return int(self.n[np.argmax(ok)])

    def table(self) -> str:
        """The curve as aligned text: n, poses, κ_n, ε_n [%]."""
        per = 2 if self.layers == "top-bottom" else 1
        lines = [f"{'n':>4} {'poses':>6} {'kappa':>12} {'eps %':>10}"]
        for n, k, e in zip(self.n, self.kappa, self.epsilon, strict=True):
            lines.append(f"{int(n):>4} {per * int(n) + 1:>6} {k:>12.6g} {100.0 * e:>10.4g}")
        return "\n".join(lines)


def condition_curve(
    nominal: NominalDelta,
    model: str | ErrorModel,
    measurement: str = "distance",
    points: Sequence[str] | None = None,
    n_max: int = 20,
    layers: str | None = None,
    scaled: bool = True,
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
) -> ConditionCurve:
    """κ(n) of Bai's pose sets for n = 2..n_max (Bai 2015, Eq. 21, Fig. 6-7).

    H(n) is the weighted identification matrix (:func:`identification_matrix`) of
    the pose set with n poses per circle. κ_n is the condition number of H(n)
    restricted to the model's identifiable columns, which are found once, by
    :func:`deltacal.identifiability.base_parameters`, on the largest set, so that
    every κ_n measures the same parameters.

    Which κ: with ``scaled`` (default) each column is scaled to unit norm first;
    κ is then independent of the parameters' units, which matters for the models
    that mix mm and rad (``classical``, ``complete``), and restricting to the
    identifiable columns keeps it finite for models that distances cannot fully
    identify. Bai's curves are the plain κ of H (``scaled=False``); his models
    18 and 32 have their position parameters in mm (``L Δθ``...), so the two agree
    in spirit, not to the digit.

    Args:
        nominal: The robot, with a workspace.
        model: Error model or name (:data:`PLAN_MODELS`; ``rough`` for the encoder offsets).
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured (default: :func:`default_points`).
        n_max: Largest n.
        layers: ``"top-bottom"`` or ``"middle"``; default ``middle`` for the rough model.
        scaled: Scale columns to unit norm before taking κ (see above).
        sigma_position: σ of a position coordinate [mm] (weights pose rows).
        sigma_angle: σ of an orientation component [rad].
    """
    _check_measurement(measurement)
    error_model = planning_model(model) if isinstance(model, str) else model
    if layers is None:
        layers = "middle" if error_model.name == ROUGH else "top-bottom"
    if layers not in ("top-bottom", "middle"):
        raise ValueError(f"layers must be 'top-bottom' or 'middle', got {layers!r}")
    if n_max < 3:
        raise ValueError(f"n_max must be at least 3, got {n_max}")
    geometry = nominal.geometry()
    pts = default_points(geometry, error_model, measurement) if points is None else list(points)
    make = bai_poses if layers == "top-bottom" else rough_poses
    ns = np.arange(2, n_max + 1)
    H = [
        identification_matrix(
            geometry, error_model, make(nominal, int(n)).q, measurement, pts, sigma_position, sigma_angle
        )
        for n in ns
    ]
    base = base_parameters(H[-1], error_model.names, rtol=_RTOL)
    kappa = np.array([_scaled_condition(h[:, base.base], scaled) for h in H])
    epsilon = np.full(ns.size, np.nan)
    with np.errstate(invalid="ignore"):
        change = np.abs(np.diff(kappa)) / kappa[1:]
    finite = np.isfinite(kappa[1:]) & np.isfinite(kappa[:-1])
    epsilon[1:] = np.where(finite, change, np.inf)
    return ConditionCurve(
        model=error_model.name,
        measurement=measurement,
        points=pts,
        layers=layers,
        n=ns,
        kappa=kappa,
        epsilon=epsilon,
        base_names=base.base_names,
        scaled=scaled,
    )


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


# --------------------------------------------------------------------------- D-optimal
def pose_blocks(
    geometry: DeltaGeometry,
    model: ErrorModel,
    q: np.ndarray,
    measurement: str = "pose",
    points: Sequence[str] = ("tcp",),
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
) -> np.ndarray:
    """Weighted regressor rows of each pose, stacked per pose, shape (N, b, n).

    ``pose``: 3 position rows of the first point and 3 orientation rows (b = 6);
    ``position``: 3 rows per point (b = 3 × points). Rows divided by σ as in
    :func:`deltacal.observations.build_rows`.
    """
    if measurement not in ("pose", "position"):
        raise ValueError(f"per-pose blocks exist for pose or position measurements, not {measurement!r}")
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)  # (N, 6, n)
    names = list(points)[:1] if measurement == "pose" else list(points)
    blocks = []
    for name in names:
        lever = pose.rotation @ geometry.point(name)  # (N, 3)
        blocks.append((S[:, :3] - skew(lever) @ S[:, 3:]) / sigma_position)  # dP = dx + dα × (R p)
    if measurement == "pose":
        blocks.append(S[:, 3:] / sigma_angle)
    return np.concatenate(blocks, axis=1)


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
