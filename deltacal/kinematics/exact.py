"""Exact kinematics of any DeltaGeometry: a vectorised six-rod Newton solver.

The plate pose (p, R) solves the six rod equations (Savoure 2006, Eq. 2)

    |A_ij(q) - (p + R B_ij)| = l_ij,   i = 1..3, j = 1, 2

for N readings at once, with batched 6x6 Newton steps. Orientation updates are
rotation vectors in the base frame: ``R <- exp(dphi) R``. This solver shares no
code with the Pinocchio model (:mod:`deltacal.kinematics.multibody`); tests hold
the two to each other.

Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import AssemblyError, UnreachableError
from ..geometry import DeltaGeometry
from ..rotations import rotation_from_vector, skew, vector_from_rotation
from .closed_form import VirtualDelta

#: Convergence threshold on the rod residuals [mm].
TOLERANCE = 1e-11
#: Floating-point floor: with coordinates of ~1e3 mm the residual cannot go much
#: below ~1e-12 mm; a Newton step below this size means convergence.
_STEP_FLOOR = 1e-12


@dataclass(frozen=True)
class PlatePose:
    """Poses of the travelling plate in the base frame.

    Attributes:
        position: Plate-frame origin [mm], shape (N, 3).
        rotation: Plate orientation, shape (N, 3, 3).
    """

    position: np.ndarray
    rotation: np.ndarray

    def __len__(self) -> int:
        return self.position.shape[0]

    def point(self, point_in_plate: np.ndarray) -> np.ndarray:
        """Positions in {O} of a point (3,) or per-pose points (N, 3) given in the plate frame."""
        p = np.asarray(point_in_plate, dtype=float)
        if p.ndim == 1:
            return self.position + self.rotation @ p
        return self.position + np.einsum("nkl,nl->nk", self.rotation, p)

    def rotation_vector(self) -> np.ndarray:
        """Orientation as rotation vectors (axis times angle) [rad], shape (N, 3)."""
        return vector_from_rotation(self.rotation)

    def tilt(self) -> np.ndarray:
        """Angle between the plate's z axis and the base's z axis [rad], shape (N,)."""
        return np.arccos(np.clip(self.rotation[:, 2, 2], -1.0, 1.0))

    def __getitem__(self, index) -> PlatePose:
        return PlatePose(self.position[index], self.rotation[index])


def _rod_terms(geometry: DeltaGeometry, q: np.ndarray, p: np.ndarray, R: np.ndarray,
               A: np.ndarray | None = None):
    """Rod vectors d = B - A, their lengths, and R B (plate balls relative to p).

    ``A`` (arm balls in {O}, (N, 6, 3)) may be given when q has not changed.
    """
    if A is None:
        A = geometry.arm_balls_in_base(q).reshape(-1, 6, 3)
    RB = geometry.plate_ball.reshape(6, 3) @ np.swapaxes(R, 1, 2)  # (N, 6, 3), rows R B_j
    d = p[:, None, :] + RB - A
    return A, d, np.sqrt(np.sum(d * d, axis=2)), RB


def rod_pose_jacobian(n: np.ndarray, RB: np.ndarray) -> np.ndarray:
    """J_X from the unit rod directions: d|d|/d(p, phi), rows ``[nᵀ, (R B × n)ᵀ]`` (Savoure Eq. 18).

    The one copy of J_X in deltacal.

    Args:
        n: Unit rod directions (plate ball minus arm ball), shape (..., 6, 3).
        RB: Plate balls relative to the plate's origin, in {O}, shape (..., 6, 3) or (6, 3).

    Returns:
        J_X, shape (..., 6, 6).
    """
    return np.concatenate([n, np.cross(np.broadcast_to(RB, n.shape), n)], axis=-1)


def _pose_jacobian(d: np.ndarray, dist: np.ndarray, RB: np.ndarray) -> np.ndarray:
    return rod_pose_jacobian(d / dist[..., None], RB)


def pose_jacobian(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose) -> np.ndarray:
    """J_X: derivative of the rod residuals by the plate displacement (dx, dalpha), (N, 6, 6).

    Savoure Eq. 18 with the actual (not nominal) rod directions at an assembled pose.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    _, d, dist, RB = _rod_terms(geometry, q, pose.position, pose.rotation)
    return _pose_jacobian(d, dist, RB)


def _joint_jacobian(geometry: DeltaGeometry, A: np.ndarray, d: np.ndarray, dist: np.ndarray):
    """d(|d_ij|)/dq, shape (N, 6, 3): only the rod's own actuator moves its arm ball."""
    n = d / dist[..., None]
    w = geometry.axis_direction / np.linalg.norm(geometry.axis_direction, axis=1, keepdims=True)
    arm = A.reshape(-1, 3, 2, 3) - geometry.axis_point[None, :, None, :]
    dA = np.cross(w[None, :, None, :], arm).reshape(-1, 6, 3)
    out = np.zeros(d.shape[:2] + (3,))
    limb = np.repeat(np.arange(3), 2)
    out[:, np.arange(6), limb] = -np.sum(n * dA, axis=2)
    return out


def initial_pose(geometry: DeltaGeometry, q: np.ndarray) -> PlatePose:
    """Starting pose: the virtual (perfect parallelogram) model's plate, parallel to the base."""
    x = VirtualDelta.from_geometry(geometry).forward(q, check=False)
    return PlatePose(x, np.broadcast_to(np.eye(3), (x.shape[0], 3, 3)).copy())


def forward(
    geometry: DeltaGeometry,
    q: np.ndarray,
    start: PlatePose | None = None,
    tol: float = TOLERANCE,
    max_iter: int = 30,
) -> PlatePose:
    """Plate poses of the real robot at readings q, by batched Newton on the six rods.

    Args:
        geometry: The robot.
        q: Joint readings [rad], shape (N, 3) or (3,).
        start: Warm start (defaults to the virtual model's pose, plate parallel).
        tol: Convergence threshold on the rod residuals [mm].
        max_iter: Newton iterations at most.

    Returns:
        The plate poses.

    Raises:
        AssemblyError: naming the readings where no assembly exists, Newton failed,
            or the solution is on the wrong branch (plate above the actuators).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pose = initial_pose(geometry, q) if start is None else start
    p = np.array(pose.position, dtype=float)
    R = np.array(pose.rotation, dtype=float)
    N = q.shape[0]
    done = np.zeros(N, dtype=bool)
    active = np.all(np.isfinite(p), axis=1)
    A_all = geometry.arm_balls_in_base(q).reshape(-1, 6, 3)  # q is fixed: the arm balls too
    for _ in range(max_iter):
        idx = np.flatnonzero(active & ~done)
        if idx.size == 0:
            break
        A, d, dist, RB = _rod_terms(geometry, q[idx], p[idx], R[idx], A_all[idx])
        r = dist - geometry.rod_length.reshape(1, 6)
        res = np.max(np.abs(r), axis=1)
        conv = res <= tol
        done[idx[conv]] = True
        todo = ~conv
        if not np.any(todo):
            break
        idx = idx[todo]
        J = _pose_jacobian(d[todo], dist[todo], RB[todo])
        try:
            step = -np.linalg.solve(J, r[todo][..., None])[..., 0]
        except np.linalg.LinAlgError:
            # a singular pose in the batch: minimum-norm steps for all of them
            step = -(np.linalg.pinv(J) @ r[todo][..., None])[..., 0]
        p[idx] += step[:, :3]
        R[idx] = rotation_from_vector(step[:, 3:]) @ R[idx]
        tiny = np.max(np.abs(step), axis=1) < _STEP_FLOOR
        done[idx[tiny & (res[todo] < 1e3 * tol)]] = True
    # final residual of the poses that stopped on the step floor
    A, d, dist, RB = _rod_terms(geometry, q, p, R, A_all)
    with np.errstate(invalid="ignore"):
        residual = np.max(np.abs(dist - geometry.rod_length.reshape(1, 6)), axis=1)
    z_axis = geometry.axis_point[:, 2].min()
    bad = ~(done & np.isfinite(residual) & (residual < 1e3 * tol) & (p[:, 2] < z_axis))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise AssemblyError(
            f"no assembly found at {int(bad.sum())} reading(s), first: q = "
            f"{np.round(np.degrees(q[i]), 6).tolist()} deg (index {i}, "
            + (f"rod residual {residual[i]:.3g} mm)" if np.isfinite(residual[i]) else
               "the rods cannot reach the plate)"),
            np.flatnonzero(bad),
            q[bad],
            float(np.max(np.where(bad, residual, 0.0))),
        )
    return PlatePose(p, R)


def forward_jacobian(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose) -> np.ndarray:
    """Plate twist per joint rate at an assembled pose: ``dX = J dq`` with X = (p, phi).

    From the differentiated rod equations ``J_X dX = J_q dq`` (Savoure Eq. 17).

    Returns:
        J [mm/rad and rad/rad], shape (N, 6, 3).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    A, d, dist, RB = _rod_terms(geometry, q, pose.position, pose.rotation)
    JX = _pose_jacobian(d, dist, RB)
    Jq = _joint_jacobian(geometry, A, d, dist)
    return -np.linalg.solve(JX, Jq)


def inverse(
    geometry: DeltaGeometry,
    target: np.ndarray,
    point_in_plate: np.ndarray | None = None,
    start: np.ndarray | None = None,
    tol: float = TOLERANCE,
    max_iter: int = 30,
) -> np.ndarray:
    """Readings that put a plate point (default: the TCP) of the real robot at targets.

    Batched Newton on 9 unknowns (q, p, phi) and 9 equations (six rods and the
    point's three coordinates).

    Args:
        geometry: The robot.
        target: Desired positions in {O} [mm], shape (N, 3) or (3,).
        point_in_plate: The point in the plate frame [mm] (default: the tool).
        start: Warm-start readings [rad], shape (N, 3).
        tol: Threshold on the rod and point residuals [mm].
        max_iter: Newton iterations at most.

    Returns:
        Readings [rad], shape (N, 3).

    Raises:
        UnreachableError: naming the targets out of reach or where Newton failed.
    """
    target = np.atleast_2d(np.asarray(target, dtype=float))
    tool = geometry.tool if point_in_plate is None else np.asarray(point_in_plate, dtype=float)
    N = target.shape[0]
    virtual = VirtualDelta.from_geometry(geometry)
    p = target - tool[None]
    q = virtual.inverse(p, check=False) if start is None else np.array(start, dtype=float)
    R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
    done = np.zeros(N, dtype=bool)
    active = np.all(np.isfinite(q), axis=1)
    for _ in range(max_iter):
        idx = np.flatnonzero(active & ~done)
        if idx.size == 0:
            break
        A, d, dist, RB = _rod_terms(geometry, q[idx], p[idx], R[idx])
        r_rod = dist - geometry.rod_length.reshape(1, 6)
        r_pt = p[idx] + R[idx] @ tool - target[idx]
        r = np.concatenate([r_rod, r_pt], axis=1)
        res = np.max(np.abs(r), axis=1)
        conv = res <= tol
        done[idx[conv]] = True
        todo = ~conv
        if not np.any(todo):
            break
        idx = idx[todo]
        n = idx.size
        J = np.zeros((n, 9, 9))
        J[:, :6, :3] = _joint_jacobian(geometry, A[todo], d[todo], dist[todo])
        J[:, :6, 3:] = _pose_jacobian(d[todo], dist[todo], RB[todo])
        J[:, 6:, 3:6] = np.eye(3)
        Rt = R[idx] @ tool
        J[:, 6:, 6:] = -skew(Rt)
        step = -np.linalg.solve(J, r[todo][..., None])[..., 0]
        # limit joint steps so a far start cannot jump to another branch
        scale = np.minimum(1.0, 0.2 / np.maximum(np.max(np.abs(step[:, :3]), axis=1), 1e-300))
        step *= scale[:, None]
        q[idx] += step[:, :3]
        p[idx] += step[:, 3:6]
        R[idx] = rotation_from_vector(step[:, 6:]) @ R[idx]
        tiny = np.max(np.abs(step), axis=1) < _STEP_FLOOR
        done[idx[tiny & (res[todo] < 1e3 * tol)]] = True
    A, d, dist, RB = _rod_terms(geometry, q, p, R)
    r_rod = np.abs(dist - geometry.rod_length.reshape(1, 6))
    r_pt = np.abs(p + R @ tool - target)
    residual = np.max(np.concatenate([r_rod, r_pt], axis=1), axis=1)
    bad = ~(done & np.isfinite(residual) & (residual < 1e3 * tol))
    if np.any(bad):
        raise UnreachableError.from_mask(bad, target)
    return q

