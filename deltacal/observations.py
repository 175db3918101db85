"""Measurements and the rows they contribute to the identification regressor.

Three kinds of observation, in any mix, each row weighted by its own σ:

* **pose**: position of a plate point and orientation of the plate (6 rows);
* **position**: position of one named plate point (3 rows); several named points
  at the same readings are separate measurements;
* **distance**: distance between two measured positions of a same point (1 row;
  Bai 2015, Eq. 12-14). Distances are invariant to the measurement frame, so the
  tracker need not be registered to the robot; the gauge (the rigid motion of the
  base frame that distances cannot see) is left to the base-parameter QR, which
  drops the six directions it cannot identify, or fixed explicitly by the models
  ``bai18``/``bai36``/``bai32`` with Bai's Eq. 11.

Positions and orientations are in the robot base frame; orientation is the
rotation vector of the plate frame {C} in {O}. Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .geometry import DeltaGeometry
from .kinematics import exact
from .kinematics.exact import PlatePose
from .rotations import rotation_from_vector, skew, vector_from_rotation

#: Row kinds.
POSITION, ORIENTATION, DISTANCE = 0, 1, 2

#: Station name of measurements without a station column (one instrument frame).
DEFAULT_STATION = "default"
#: Default σ of a measured coordinate [mm] (a laser tracker), for weighting and simulation.
SIGMA_POSITION = 0.005
#: Default σ of a measured orientation component [deg] (a 6-DoF probe).
SIGMA_ANGLE_DEG = 0.003
#: The same [rad].
SIGMA_ANGLE = math.radians(SIGMA_ANGLE_DEG)


@dataclass(frozen=True)
class Measurements:
    """A set of measurements at joint readings.

    Attributes:
        q: Readings at which the robot stood [rad], shape (M, 3).
        position: Measured position of the reference point [mm], shape (M, 3).
        point: Name of the plate point measured in each row (``"tcp"`` or a named point).
        rotation_vector: Measured plate orientation [rad], shape (M, 3); NaN rows where
            orientation was not measured.
        station: Name of the instrument station of each row (a tracker moved during the
            session has one frame per station); default :data:`DEFAULT_STATION` for all.
        payload: Mass the robot carried at its TCP in each row [kg], shape (M,); default 0.
    """

    q: np.ndarray
    position: np.ndarray
    point: list[str] = field(default_factory=list)
    rotation_vector: np.ndarray | None = None
    station: list[str] = field(default_factory=list)
    payload: np.ndarray | None = None

    def __post_init__(self) -> None:
        q = np.atleast_2d(np.asarray(self.q, dtype=float))
        pos = np.atleast_2d(np.asarray(self.position, dtype=float))
        M = q.shape[0]
        if q.shape != (M, 3) or pos.shape != (M, 3):
            raise ValueError(f"q and position must both be (M, 3), got {q.shape} and {pos.shape}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "position", pos)
        point = list(self.point) if self.point else ["tcp"] * M
        if len(point) != M:
            raise ValueError(f"{len(point)} point names for {M} measurements")
        object.__setattr__(self, "point", point)
        rv = (
            np.full((M, 3), np.nan)
            if self.rotation_vector is None
            else np.atleast_2d(np.asarray(self.rotation_vector, dtype=float))
        )
        object.__setattr__(self, "rotation_vector", rv)
        station = [str(s) for s in self.station] if self.station else [DEFAULT_STATION] * M
        if len(station) != M:
            raise ValueError(f"{len(station)} station names for {M} measurements")
        object.__setattr__(self, "station", station)
        payload = np.zeros(M) if self.payload is None else np.asarray(self.payload, dtype=float).reshape(-1)
        if payload.shape != (M,):
            raise ValueError(f"{payload.size} payloads for {M} measurements")
        bad = np.flatnonzero(~(np.isfinite(payload) & (payload >= 0.0)))
        if bad.size:
            k = int(bad[0])
            raise ValueError(f"payloads must be finite non-negative masses [kg], got {float(payload[k])!r} "
                             f"in row {k} ({bad.size} in all)")
        object.__setattr__(self, "payload", payload)

    def __len__(self) -> int:
        return self.q.shape[0]

    @property
    def has_orientation(self) -> np.ndarray:
        """Rows with a measured orientation, shape (M,)."""
        assert self.rotation_vector is not None
        return np.all(np.isfinite(self.rotation_vector), axis=1)

    @property
    def stations(self) -> list[str]:
        """The station names, in the order they first appear."""
        return list(dict.fromkeys(self.station))

    def subset(self, index: np.ndarray) -> Measurements:
        """The measurements of some rows."""
        index = np.asarray(index)
        assert self.rotation_vector is not None
        rows = np.atleast_1d(np.arange(len(self))[index])
        return Measurements(
            q=self.q[index],
            position=self.position[index],
            point=[self.point[k] for k in rows],
            rotation_vector=self.rotation_vector[index],
            station=[self.station[k] for k in rows],
            payload=self.payload_kg[index],
        )

    @property
    def payload_kg(self) -> np.ndarray:
        """The payload of each row [kg], shape (M,) (typed: never None after construction)."""
        assert self.payload is not None
        return self.payload

    @property
    def loaded(self) -> bool:
        """True when some row carried a payload."""
        return bool(np.any(self.payload_kg))


@dataclass(frozen=True)
class SharedReference:
    """Whitening of distances that share their first position (reference pairs), group by group.

    The rows of a group (distances from one position a to others b_k, unit vectors n_k,
    each divided by its σ = √2 σ_position) have the covariance ``½ (I + G Gᵀ)``, G the rows
    n_kᵀ: they share the noise of a. Its inverse square root is
    ``√2 (I + G M Gᵀ)`` with ``M = V diag(((1 + λ)^(-1/2) − 1) / λ) Vᵀ`` from the 3x3
    ``GᵀG = V diag(λ) Vᵀ`` (the rows of G span at most three directions): whitening at a
    cost linear in the rows, where the SVD of the dense covariance costs the cube.

    Attributes:
        first: Measurement of each row's first position (shared in its group), shape (K,).
        second: Measurement of each row's second position (its own), shape (K,).
        group: Group of each row (rows sharing their first position), shape (K,).
        direction: Unit vector n_k of each row, shape (K, 3).
        core: M of each group, shape (G, 3, 3).
    """

    first: np.ndarray
    second: np.ndarray
    group: np.ndarray
    direction: np.ndarray
    core: np.ndarray

    @classmethod
    def of(cls, first: np.ndarray, second: np.ndarray, direction: np.ndarray) -> SharedReference:
        """The whitening of rows from positions ``first`` to ``second`` (K,), unit vectors (K, 3)."""
        _, group = np.unique(first, return_inverse=True)
        group = group.reshape(-1)
        gram = np.zeros((int(group.max(initial=-1)) + 1, 3, 3))
        np.add.at(gram, group, direction[:, :, None] * direction[:, None, :])
        lam, V = np.linalg.eigh(gram)
        lam = np.clip(lam, 0.0, None)
        small = lam < 1e-12
        f = np.where(small, -0.5, (1.0 / np.sqrt(1.0 + lam) - 1.0) / np.where(small, 1.0, lam))
        core = np.einsum("gij,gj,gkj->gik", V, f, V)
        return cls(first=first, second=second, group=group, direction=direction, core=core)

    def group_sums(self, x: np.ndarray) -> np.ndarray:
        """``Gᵀ x`` of each group: shape (G, 3) for x (K,), (G, 3, n) for x (K, n)."""
        out = np.zeros((self.core.shape[0], 3, *x.shape[1:]))
        for g in range(self.core.shape[0]):  # a loop over the points measured, not the rows
            rows = self.group == g
            out[g] = self.direction[rows].T @ x[rows]
        return out

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """``√2 (I + G M Gᵀ) x`` group by group, for x of shape (K,) or (K, n)."""
        mg = np.einsum("gij,gj...->gi...", self.core, self.group_sums(x))[self.group]  # (K, 3[, n])
        return math.sqrt(2.0) * (x + np.einsum("ki,ki...->k...", self.direction, mg))


@dataclass(frozen=True)
class Rows:
    """Residuals and regressor rows of a set of observations.

    Attributes:
        residual: Measured minus predicted, per row [mm or rad], shape (m,).
        regressor: d(predicted)/d(parameters), shape (m, n).
        sigma: Standard deviation of each row [mm or rad], shape (m,).
        kind: POSITION, ORIENTATION or DISTANCE per row.
        measurement: Index of the measurement (first of the pair for reference distances) per row.
        shared: Reference distances: the rows share the noise of their first position
            (see :class:`SharedReference`). None: rows independent.
        nuisance: Distances of all pairs, stated as positions: each point's positions
            aligned to the model's and their rigid motions projected out; the columns of
            those rigid motions (orthonormal), shape (m, k). None otherwise.
        distances: Number of distances the rows stand for (all pairs), or None.
    """

    residual: np.ndarray
    regressor: np.ndarray
    sigma: np.ndarray
    kind: np.ndarray
    measurement: np.ndarray
    shared: SharedReference | None = None
    nuisance: np.ndarray | None = None
    distances: int | None = None

    @property
    def scaled(self) -> tuple[np.ndarray, np.ndarray]:
        """Residual and regressor divided row by row by σ (correlations ignored)."""
        return self.residual / self.sigma, self.regressor / self.sigma[:, None]

    @cached_property
    def weighted(self) -> tuple[np.ndarray, np.ndarray]:
        """Whitened residual and regressor: uncorrelated rows of unit variance (computed once).

        Rows divided by σ; reference distances whitened by :meth:`SharedReference.whiten`,
        so that least squares on them is the best linear unbiased estimate and its
        covariance is honest. Distances of all pairs are already stated as projected
        positions (see :func:`build_rows`): least squares on them is the generalised least
        squares of the distances to first order.
        """
        rw, Ww = self.scaled
        if self.shared is None:
            return rw, Ww
        return self.shared.whiten(rw), self.shared.whiten(Ww)

    @property
    def independent(self) -> int:
        """Number of independent rows (the rank of their covariance): the rows less the nuisance."""
        return self.residual.size - (0 if self.nuisance is None else self.nuisance.shape[1])


def distance_pairs(measurements: Measurements, pairs: str = "all") -> np.ndarray:
    """Index pairs (a, b) of measurements of a same point (Bai Eq. 12).

    Args:
        measurements: The measurements.
        pairs: ``"all"``: every pair of positions of a point (Bai's C(n, 2));
            ``"reference"``: each position with the first one of its point.

    Returns:
        Pairs, shape (K, 2).
    """
    if pairs not in ("all", "reference"):
        raise ValueError(f"pairs must be 'all' or 'reference', got {pairs!r}")
    names = np.array(measurements.point)
    out = []
    for name in dict.fromkeys(measurements.point):
        idx = np.flatnonzero(names == name)
        if pairs == "all":
            a, b = np.triu_indices(idx.size, k=1)
            out.append(np.stack([idx[a], idx[b]], axis=1))
        else:
            out.append(np.stack([np.full(idx.size - 1, idx[0]), idx[1:]], axis=1))
    ab = np.concatenate(out) if out else np.zeros((0, 2), dtype=int)
    # two positions at the same readings are the same place: no distance to measure
    same = np.all(np.abs(measurements.q[ab[:, 0]] - measurements.q[ab[:, 1]]) < 1e-9, axis=1)
    return ab[~same].reshape(-1, 2)


def distance_residual_stats(
    geometry: DeltaGeometry, measurements: Measurements, pose: PlatePose, pairs: str = "all"
) -> tuple[float, float]:
    """RMS and largest |measured − predicted distance| over the pairs of positions of a same point [mm].

    The C(n, 2) pairs are taken in blocks of about 250,000, never all at once: memory
    stays flat however many positions there are. (nan, nan) without any pair.
    """
    predicted = predicted_points(geometry, measurements, pose)
    if pairs == "reference":
        ab = distance_pairs(measurements, "reference")
        r = (np.linalg.norm(measurements.position[ab[:, 1]] - measurements.position[ab[:, 0]], axis=1)
             - np.linalg.norm(predicted[ab[:, 1]] - predicted[ab[:, 0]], axis=1))
        return (float(np.sqrt(np.mean(r**2))), float(np.max(np.abs(r)))) if r.size else (math.nan, math.nan)
    names = np.array(measurements.point)
    total, count, worst = 0.0, 0, 0.0
    for name in dict.fromkeys(measurements.point):
        idx = np.flatnonzero(names == name)
        # centred, so that the squared distances from dot products lose no digits that matter
        X = measurements.position[idx] - measurements.position[idx].mean(axis=0)
        P = predicted[idx] - predicted[idx].mean(axis=0)
        place = np.unique(measurements.q[idx].round(9), axis=0, return_inverse=True)[1].reshape(-1)
        xx, pp = np.sum(X**2, axis=1), np.sum(P**2, axis=1)
        step = max(1, 250_000 // max(idx.size, 1))
        for start in range(0, idx.size, step):  # blocks of rows of the upper triangle of pairs
            rows, cols = slice(start, min(start + step, idx.size)), slice(start, idx.size)
            dx2 = np.maximum(xx[rows, None] + xx[None, cols] - 2.0 * (X[rows] @ X[cols].T), 0.0)
            dp2 = np.maximum(pp[rows, None] + pp[None, cols] - 2.0 * (P[rows] @ P[cols].T), 0.0)
            upper = np.arange(start, idx.size)[None, :] > np.arange(rows.start, rows.stop)[:, None]
            upper &= place[rows, None] != place[None, cols]  # two positions at the same readings: no pair
            dx, dp = np.sqrt(dx2[upper]), np.sqrt(dp2[upper])
            r = (dx2[upper] - dp2[upper]) / np.maximum(dx + dp, 1e-300)
            total, count = total + float(r @ r), count + r.size
            worst = max(worst, float(np.max(np.abs(r), initial=0.0)))
    return (math.sqrt(total / count), worst) if count else (math.nan, math.nan)


def predicted_points(geometry: DeltaGeometry, measurements: Measurements, pose: PlatePose) -> np.ndarray:
    """Predicted positions of each measurement's point [mm], shape (M, 3)."""
    names, inverse = np.unique(np.array(measurements.point), return_inverse=True)
    local = np.stack([geometry.point(str(p)) for p in names])[inverse.reshape(-1)]
    return pose.point(local)


def _point_rows(geometry: DeltaGeometry, measurements: Measurements, sensitivity, pose: PlatePose | None):
    """Predicted positions of the measured points, their sensitivity JP (M, 3, n), S and the poses."""
    if pose is None:
        pose = exact.forward(geometry, measurements.q)
    S = sensitivity(geometry, measurements.q, pose)  # (M, 6, n)
    predicted = predicted_points(geometry, measurements, pose)
    # dP = dx + dalpha x (R p) = dx - [R p]x dalpha
    return predicted, S[:, :3] - skew(predicted - pose.position) @ S[:, 3:], S, pose


def build_rows(
    geometry: DeltaGeometry,
    measurements: Measurements,
    sensitivity,
    sigma_position: float,
    sigma_angle: float,
    distances: bool = False,
    pairs: str = "all",
    pose: PlatePose | None = None,
) -> Rows:
    """Residuals and regressor of the measurements around a geometry.

    Args:
        geometry: Geometry around which to linearise.
        measurements: The measurements.
        sensitivity: Callable ``(geometry, q, pose) -> S`` of shape (M, 6, n).
        sigma_position: σ of each measured coordinate [mm].
        sigma_angle: σ of each measured orientation component [rad].
        distances: Use distances between positions of a same point instead of the
            positions themselves (no frame needed; orientations are then ignored). All
            pairs are stated as positions with each point's rigid motion projected out
            (:func:`_all_pair_rows`), reference pairs as distances whitened group by group
            (:class:`SharedReference`): both at a cost linear in the positions.
        pairs: Which pairs for distances (see :func:`distance_pairs`).
        pose: Exact poses of ``geometry`` at the readings, if already known.
    """
    if pairs not in ("all", "reference"):
        raise ValueError(f"pairs must be 'all' or 'reference', got {pairs!r}")
    if distances and pairs == "reference":
        return pair_rows(geometry, measurements, sensitivity, sigma_position, "reference", pose)
    predicted, JP, S, pose = _point_rows(geometry, measurements, sensitivity, pose)
    if distances:
        return _all_pair_rows(measurements, predicted, JP, sigma_position)
    M = len(measurements)
    res = [measurements.position - predicted]
    reg = [JP]
    sig = [np.full((M, 3), sigma_position)]
    kind = [np.full((M, 3), POSITION)]
    meas = [np.repeat(np.arange(M)[:, None], 3, axis=1)]
    has = measurements.has_orientation
    if np.any(has):
        assert measurements.rotation_vector is not None
        R_meas = rotation_from_vector(measurements.rotation_vector[has])
        err = vector_from_rotation(R_meas @ np.swapaxes(pose.rotation[has], 1, 2))
        res.append(err)
        reg.append(S[has, 3:])
        sig.append(np.full((int(has.sum()), 3), sigma_angle))
        kind.append(np.full((int(has.sum()), 3), ORIENTATION))
        meas.append(np.repeat(np.flatnonzero(has)[:, None], 3, axis=1))
    n_par = S.shape[2]
    return Rows(
        residual=np.concatenate([r.reshape(-1) for r in res]),
        regressor=np.concatenate([r.reshape(-1, n_par) for r in reg]),
        sigma=np.concatenate([s.reshape(-1) for s in sig]),
        kind=np.concatenate([k.reshape(-1) for k in kind]),
        measurement=np.concatenate([m.reshape(-1) for m in meas]),
    )


def pair_rows(
    geometry: DeltaGeometry,
    measurements: Measurements,
    sensitivity,
    sigma_position: float,
    pairs: str = "all",
    pose: PlatePose | None = None,
) -> Rows:
    """One row per distance between two positions of a same point (Bai 2015, Eq. 12-16).

    These are Bai's rows of H before any whitening: the distances that share a position
    are correlated, which :func:`build_rows` accounts for and these rows do not. For
    pose planning by Bai's condition number (Eq. 21); K = C(n, 2) rows for all pairs.

    Args:
        geometry: Geometry around which to linearise.
        measurements: The measurements.
        sensitivity: Callable ``(geometry, q, pose) -> S`` of shape (M, 6, n).
        sigma_position: σ of each measured coordinate [mm].
        pairs: Which pairs (see :func:`distance_pairs`).
        pose: Exact poses of ``geometry`` at the readings, if already known.
    """
    predicted, JP = _point_rows(geometry, measurements, sensitivity, pose)[:2]
    ab = distance_pairs(measurements, pairs)
    a, b = ab[:, 0], ab[:, 1]
    vec = predicted[b] - predicted[a]
    rho = np.linalg.norm(vec, axis=1)
    n = vec / rho[:, None]
    measured = np.linalg.norm(measurements.position[b] - measurements.position[a], axis=1)
    K = len(ab)
    return Rows(
        residual=measured - rho,
        regressor=np.einsum("kl,kln->kn", n, JP[b] - JP[a]),
        sigma=np.full(K, np.sqrt(2.0) * sigma_position),
        kind=np.full(K, DISTANCE),
        measurement=a,
        shared=SharedReference.of(a, b, n) if pairs == "reference" else None,
    )


def rigid_alignment(measured: np.ndarray, model: np.ndarray) -> np.ndarray:
    """The measured points moved by the rigid motion that best fits them to the model's (Kabsch).

    Args:
        measured: Measured positions [mm], shape (n, 3).
        model: Predicted positions [mm], shape (n, 3).

    Returns:
        ``R measured + t`` with R, t minimising the sum of squared distances to ``model``.
    """
    cm, cp = measured.mean(axis=0), model.mean(axis=0)
    U, _, Vt = np.linalg.svd((measured - cm).T @ (model - cp))
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return (measured - cm) @ R.T + cp


def _rigid_basis(points: np.ndarray) -> np.ndarray:
    """Orthonormal columns of the small rigid motions of a set of points, shape (3n, r), r <= 6."""
    lever = points - points.mean(axis=0)
    T = np.zeros((points.shape[0], 3, 6))
    T[:, :, :3] = np.eye(3)
    T[:, :, 3:] = -skew(lever)  # d(ω x p) = -[p]x ω
    U, sv, _ = np.linalg.svd(T.reshape(-1, 6), full_matrices=False)
    return U[:, sv > sv[0] * 1e-9]


def _all_pair_rows(measurements: Measurements, predicted: np.ndarray, JP: np.ndarray, sigma: float) -> Rows:
    """Rows standing for the distances of all pairs of positions of each point.

    The C(n, 2) distances between n positions of a point say what the positions say up to
    a rigid motion: to first order, their generalised least squares (Bai Eq. 17, the
    distances' covariance ``σ² D Dᵀ``, D their Jacobian in the positions) is least squares
    on the positions with the rigid motions projected out, ``Dᵀ (D Dᵀ)⁺ D = I − Q Qᵀ``
    (Q: orthonormal columns of the rigid motions of the point's positions). So each
    point's measured positions are aligned to the predicted ones (:func:`rigid_alignment`,
    any tracker frame), and their residuals and regressor rows projected: 3n rows, of
    which 3n − 6 independent, instead of C(n, 2) correlated ones.
    """
    M = len(measurements)
    names = np.array(measurements.point)
    residual = np.zeros((M, 3))
    regressor = JP.copy()
    nuisance = []
    distances = 0
    for name in dict.fromkeys(measurements.point):  # a loop over the points, not the positions
        idx = np.flatnonzero(names == name)
        counts = np.unique(measurements.q[idx].round(9), axis=0, return_counts=True)[1]
        distances += (idx.size * (idx.size - 1) - int(np.sum(counts * (counts - 1)))) // 2
        residual[idx] = rigid_alignment(measurements.position[idx], predicted[idx]) - predicted[idx]
        Q = _rigid_basis(predicted[idx])  # (3n, r)
        rows = (3 * idx[:, None] + np.arange(3)).reshape(-1)
        flat = residual[idx].reshape(-1)
        residual[idx] = (flat - Q @ (Q.T @ flat)).reshape(-1, 3)
        block = JP[idx].reshape(-1, JP.shape[2])
        regressor[idx] = (block - Q @ (Q.T @ block)).reshape(idx.size, 3, -1)
        column = np.zeros((3 * M, Q.shape[1]))
        column[rows] = Q
        nuisance.append(column)
    return Rows(
        residual=residual.reshape(-1),
        regressor=regressor.reshape(3 * M, -1),
        sigma=np.full(3 * M, sigma),
        kind=np.full(3 * M, DISTANCE),
        measurement=np.repeat(np.arange(M), 3),
        nuisance=np.hstack(nuisance) if nuisance else np.zeros((3 * M, 0)),
        distances=distances,
    )
