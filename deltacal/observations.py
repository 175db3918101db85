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
    """

    q: np.ndarray
    position: np.ndarray
    point: list[str] = field(default_factory=list)
    rotation_vector: np.ndarray | None = None
    station: list[str] = field(default_factory=list)

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
        )


@dataclass(frozen=True)
class Rows:
    """Residuals and regressor rows of a set of observations.

    Attributes:
        residual: Measured minus predicted, per row [mm or rad], shape (m,).
        regressor: d(predicted)/d(parameters), shape (m, n).
        sigma: Standard deviation of each row [mm or rad], shape (m,).
        kind: POSITION, ORIENTATION or DISTANCE per row.
        measurement: Index of the measurement (first of the pair for distances) per row.
        mixing: For distances, d(rows / σ)/d(measured positions / σ_position), shape
            (m, 3M): distances that share a measured position are correlated, and this
            gives their covariance ``mixing mixingᵀ`` (in units of σ²). None: rows independent.
    """

    residual: np.ndarray
    regressor: np.ndarray
    sigma: np.ndarray
    kind: np.ndarray
    measurement: np.ndarray
    mixing: np.ndarray | None = None

    @property
    def scaled(self) -> tuple[np.ndarray, np.ndarray]:
        """Residual and regressor divided row by row by σ (correlations ignored)."""
        return self.residual / self.sigma, self.regressor / self.sigma[:, None]

    @property
    def weighted(self) -> tuple[np.ndarray, np.ndarray]:
        """Whitened residual and regressor: uncorrelated rows of unit variance.

        Rows divided by σ; for correlated rows (distances sharing positions) the
        generalised least-squares whitening ``S⁻¹ Uᵀ`` of the mixing matrix's SVD
        ``U S Vᵀ``, so that least squares on them is the best linear unbiased estimate
        and its covariance is honest. Their number is the rank of the mixing (at most
        3M − 6: distances cannot see a rigid motion of all positions).
        """
        rw, Ww = self.scaled
        if self.mixing is None:
            return rw, Ww
        U, S, _ = np.linalg.svd(self.mixing, full_matrices=False)
        keep = S > S[0] * 1e-10
        T = U[:, keep].T / S[keep, None]
        return T @ rw, T @ Ww


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


def distance_residuals(geometry: DeltaGeometry, measurements: Measurements, pose: PlatePose) -> np.ndarray:
    """Measured minus predicted distance of every pair of positions of a same point [mm], (K,).

    Memory linear in the number of pairs (no regressor): for the report of large sets.
    """
    predicted = predicted_points(geometry, measurements, pose)
    ab = distance_pairs(measurements, "all")
    a, b = ab[:, 0], ab[:, 1]
    measured = np.linalg.norm(measurements.position[b] - measurements.position[a], axis=1)
    return measured - np.linalg.norm(predicted[b] - predicted[a], axis=1)


def predicted_points(geometry: DeltaGeometry, measurements: Measurements, pose: PlatePose) -> np.ndarray:
    """Predicted positions of each measurement's point [mm], shape (M, 3)."""
    names, inverse = np.unique(np.array(measurements.point), return_inverse=True)
    local = np.stack([geometry.point(str(p)) for p in names])[inverse.reshape(-1)]
    return pose.point(local)


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
            positions themselves (no frame needed; orientations are then ignored).
        pairs: Which pairs for distances (see :func:`distance_pairs`).
        pose: Exact poses of ``geometry`` at the readings, if already known.
    """
    q = measurements.q
    if pose is None:
        pose = exact.forward(geometry, q)
    S = sensitivity(geometry, q, pose)  # (M, 6, n)
    predicted = predicted_points(geometry, measurements, pose)
    lever = predicted - pose.position
    # dP = dx + dalpha x (R p) = dx - [R p]x dalpha
    JP = S[:, :3] - skew(lever) @ S[:, 3:]
    if distances:
        ab = distance_pairs(measurements, pairs)
        a, b = ab[:, 0], ab[:, 1]
        vec = predicted[b] - predicted[a]
        rho = np.linalg.norm(vec, axis=1)
        n = vec / rho[:, None]
        measured = np.linalg.norm(measurements.position[b] - measurements.position[a], axis=1)
        regressor = np.einsum("kl,kln->kn", n, JP[b] - JP[a])
        # each distance is n . (P_b - P_a): its noise comes from two positions, shared with
        # the other pairs of those positions
        K, M = len(ab), len(measurements)
        mixing = np.zeros((K, M, 3))
        mixing[np.arange(K), b] = n / np.sqrt(2.0)
        mixing[np.arange(K), a] = -n / np.sqrt(2.0)
        return Rows(
            residual=measured - rho,
            regressor=regressor,
            sigma=np.full(K, np.sqrt(2.0) * sigma_position),
            kind=np.full(K, DISTANCE),
            measurement=a,
            mixing=mixing.reshape(K, 3 * M),
        )
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
