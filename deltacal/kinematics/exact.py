"""Exact kinematics of any DeltaGeometry: a vectorised six-rod Newton solver.

The plate pose (p, R) solves the six rod equations (Savoure 2006, Eq. 2)

    |A_ij(q) - (p + R B_ij)| = l_ij,   i = 1..3, j = 1, 2

for N readings at once, with batched Newton steps. Orientation updates are
rotation vectors in the base frame: ``R <- exp(dphi) R``. This solver shares no
code with the Pinocchio model (:mod:`deltacal.kinematics.multibody`); tests hold
the two to each other.

Speed: the poses are solved in blocks of :data:`BLOCK` with the pose index
last (:mod:`~deltacal.kinematics.batch3`), each 6x6 Newton step in closed form (the FK
through the limbs' pair sums and differences and a 3x3 Schur complement, the IK with the
plate origin eliminated), and a pose leaves the iteration once converged. On the bench's
2-core machine, for 10,000 poses, this is about 3x faster for the FK and 4x for the IK than
batched ``np.linalg.solve`` on (N, 6, 6) and (N, 9, 9) stacks, whose per-matrix overhead
dominated (a single pose is slower: more numpy calls per step); the closed-form steps give
the same poses to 2e-11 mm (the tolerance is 1e-11 mm).

Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..chains import Chain
from ..exceptions import AssemblyError, UnreachableError
from ..geometry import DeltaGeometry
from ..rotations import vector_from_rotation
from . import batch3 as b3
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


def _rod_terms(geometry: DeltaGeometry, q: np.ndarray, p: np.ndarray, R: np.ndarray):
    """Arm balls A (N, 6, 3), rod vectors d = B - A, their lengths, and R B (plate balls relative to p)."""
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


def plate_displacement(
    geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose, rod_change: np.ndarray
) -> np.ndarray:
    """``δX = −J_X⁻¹ δr``: the plate displacement (δp, δφ) that absorbs rod-residual changes δr, (N, 6).

    Savoure Eq. 17 with the joints fixed: the first-order plate motion that keeps the rods
    closed when their residuals ``|d_k| − l_k`` change by δr at readings q and plate poses
    ``pose``. The same closed-form solve as the FK's Newton steps, in blocks of :data:`BLOCK`:
    what ``-np.linalg.solve(pose_jacobian(...), δr)`` gives, several times faster.

    Args:
        geometry: The robot.
        q: Readings [rad], shape (N, 3).
        pose: Plate poses at which to differentiate.
        rod_change: δr [mm], shape (N, 6), rods (1,1), (1,2), (2,1), ..., (3,2).

    Returns:
        δX = (δp [mm], δφ [rad]), shape (N, 6).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    rods = _Rods.of(geometry)
    out = np.empty((q.shape[0], 6))
    for s in range(0, q.shape[0], BLOCK):
        b = slice(s, s + BLOCK)
        R = np.asarray(pose.rotation[b], dtype=float).transpose(1, 2, 0)
        RB = np.matmul(rods.plate, R)
        _, n = rods.rods(RB + np.asarray(pose.position[b], dtype=float).T[:, None] - rods.arm_balls(q[b].T))
        dp, dphi = _pose_step(n, b3.cross(RB, n), np.asarray(rod_change[b], dtype=float).T)
        out[b, :3], out[b, 3:] = dp.T, dphi.T
    return out


def _joint_jacobian(geometry: DeltaGeometry, q: np.ndarray, d: np.ndarray, dist: np.ndarray):
    """d(|d_ij|)/dq, shape (N, 6, 3): only the rod's own actuator moves its arm ball."""
    n = d / dist[..., None]
    dA = geometry.arm_ball_velocity(q).reshape(-1, 6, 3)  # the chain's motion (deltacal.chains)
    out = np.zeros(d.shape[:2] + (3,))
    limb = np.repeat(np.arange(3), 2)
    out[:, np.arange(6), limb] = -np.sum(n * dA, axis=2)
    return out


def initial_pose(geometry: DeltaGeometry, q: np.ndarray) -> PlatePose:
    """Starting pose: the virtual (perfect parallelogram) model's plate, parallel to the base."""
    x = VirtualDelta.from_geometry(geometry).forward(q, check=False)
    return PlatePose(x, np.broadcast_to(np.eye(3), (x.shape[0], 3, 3)).copy())


#: Poses solved together. The working arrays of a block (up to 150 kB) stay in cache and
#: near glibc's 128 kB threshold for memory maps: with 2048, a fresh process mapped and
#: unmapped its temporaries at every operation and solved 420k poses/s against 600k here.
BLOCK = 1024


@dataclass(frozen=True, eq=False)
class _Rods:
    """A geometry's rods in the solvers' component-first layout (rod k = 2 i + j, limb i).

    The arm ball of rod k at reading q_i is ``base_k + f(θ_i) along_f_k + g(θ_i) along_g_k`` with
    ``θ_i = scale_i q_i + encoder_offset_i`` and f, g the chain's (:attr:`DeltaGeometry.arm_ball_path`).
    """

    chain: Chain  # the actuated chain
    base: np.ndarray  # (3, 6, 1)
    along_f: np.ndarray  # (3, 6, 1)
    along_g: np.ndarray  # (3, 6, 1)
    offset: np.ndarray  # (3, 1)
    scale: np.ndarray  # (3, 1)
    plate: np.ndarray  # (6, 3): plate balls in the plate frame
    length: np.ndarray  # (6, 1)
    axis_z: float  # the lowest axis point's z [mm]: a rotary Delta's assembled plates are below it

    @classmethod
    def of(cls, geometry: DeltaGeometry) -> _Rods:
        centre, along_f, along_g = geometry.arm_ball_path
        col = lambda v: np.ascontiguousarray(v.reshape(6, 3).T)[:, :, None]  # noqa: E731  -> (3, 6, 1)
        return cls(
            chain=geometry.chain,
            base=col(centre),
            along_f=col(along_f),
            along_g=col(along_g),
            offset=np.asarray(geometry.encoder_offset, dtype=float)[:, None],
            scale=np.asarray(geometry.joint_scale, dtype=float)[:, None],
            plate=np.array(geometry.plate_ball.reshape(6, 3)),
            length=geometry.rod_length.reshape(6, 1),
            axis_z=float(geometry.axis_point[:, 2].min()),
        )

    def _theta(self, q: np.ndarray) -> np.ndarray:
        return self.chain.coordinate(q, self.scale, self.offset)

    def arm_balls(self, q: np.ndarray) -> np.ndarray:
        """Arm balls A_k in {O} at readings q (3, N), shape (3, 6, N)."""
        f, g = self.chain.path_terms(self._theta(q))
        return self.base + np.repeat(f, 2, axis=0) * self.along_f + np.repeat(g, 2, axis=0) * self.along_g

    def arm_ball_slopes(self, q: np.ndarray) -> np.ndarray:
        """dA_k/dq_i of each rod's arm ball by its own reading at readings q (3, N), shape (3, 6, N)."""
        f, g = self.chain.path_slopes(self._theta(q))
        f, g = (np.repeat(self.scale * v, 2, axis=0) for v in (f, g))
        return f * self.along_f + g * self.along_g

    def rods(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residuals ``|d_k| - l_k`` (6, N) and unit directions (3, 6, N) of rod vectors d (3, 6, N)."""
        dist = np.sqrt(b3.dot(d, d))
        return dist - self.length, d / dist


def _pairs(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of each limb's two rods, (3, 6, N) -> two (3, 3, N) matrices indexed [limb, component]."""
    return v[:, 0::2].transpose(1, 0, 2), v[:, 1::2].transpose(1, 0, 2)


def _fallback(rows: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Minimum-norm solutions of (n, 6, 6) systems (near a singularity), shape (n, 6)."""
    return (np.linalg.pinv(rows) @ rhs[..., None])[..., 0]


def _pose_step(n: np.ndarray, m: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The solution (dp (3, N), dphi (3, N)) of ``J_X (dp, dphi) = -r`` for rod rows ``[n_kᵀ, m_kᵀ]``.

    J_X's six rows ``[n_kᵀ, (R B_k × n_k)ᵀ]`` (Savoure Eq. 18; n, m (3, 6, N), r (6, N)) are
    combined per limb into their sum and difference: the sums carry the translation (U: about
    twice the virtual rods), the differences the rotation; the 6x6 solve is then two 3x3
    solves through the Schur complement ``S = W - V U⁻¹ M`` of ``[[U, M], [V, W]]``. Where
    it gives no finite solution (a singular J_X), the pivoted minimum-norm one.
    """
    n1, n2 = _pairs(n)
    m1, m2 = _pairs(m)
    U, M, V, W = n1 + n2, m1 + m2, n1 - n2, m1 - m2
    rs, rd = r[0::2] + r[1::2], r[0::2] - r[1::2]
    adj, det_u = b3.adjugate(U)
    with np.errstate(divide="ignore", invalid="ignore"):
        Z = b3.matmul(adj, np.concatenate([M, rs[:, None]], axis=1)) / det_u  # U⁻¹ [M, rs]
    X, y = Z[:, :3], Z[:, 3]
    S = W - b3.matmul(V, X)
    dphi, _ = b3.solve(S, b3.matmul(V, y) - rd)
    dp = -y - b3.matmul(X, dphi)
    # no finite closed-form step where the rows and right-hand side are finite: J_X is singular
    singular = ~(np.isfinite(dp).all(axis=0) & np.isfinite(dphi).all(axis=0))
    if np.any(singular):
        singular &= (np.isfinite(r).all(axis=0) & np.isfinite(n).all(axis=(0, 1))
                     & np.isfinite(m).all(axis=(0, 1)))
    if np.any(singular):
        rows = np.concatenate([n[:, :, singular], m[:, :, singular]]).transpose(2, 1, 0)
        step = _fallback(rows, -r[:, singular].T)
        dp[:, singular], dphi[:, singular] = step[:, :3].T, step[:, 3:].T
    return dp, dphi


def _forward_step(rods: _Rods, A: np.ndarray, p: np.ndarray, R: np.ndarray, tol: float):
    """Rod residuals (6, N) and the Newton step (dp (3, N), dphi (3, N)) of the FK at poses (p, R).

    The step (:func:`_pose_step`) is None when every residual is within tol already.
    """
    RB = np.matmul(rods.plate, R)  # (3, 6, N): R B_k
    r, n = rods.rods(RB + p[:, None] - A)
    if np.all(np.abs(r) <= tol):
        return r, None
    return r, _pose_step(n, b3.cross(RB, n), r)


def _newton(step, state: list[np.ndarray], fixed: list[np.ndarray], tol: float, max_iter: int,
            live: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Batched Newton of one block: iterate the poses still moving, retire the converged ones.

    Args:
        step: ``step(*fixed, *state) -> (residual (K, N), new state, largest step (N,))``; the
            new state is used for the poses not converged only, and is None (as the step) when
            every pose is within tol.
        state: Unknowns, arrays with the pose last (updated in place and returned).
        fixed: Data per pose, arrays with the pose last.
        tol: Convergence threshold on the largest residual.
        max_iter: Iterations at most.
        live: Poses to solve (indices into the block).

    Returns:
        The state, the largest residual of each pose at that state (inf where never computed:
        a pose not solved or a diverged start) and which poses converged (residual below tol,
        or a step below the floating-point floor with the residual below 1e3 tol).
    """
    N = state[0].shape[-1]
    err_out = np.full(N, np.inf)
    done = np.zeros(N, dtype=bool)
    cur = [s[..., live] for s in state]
    fix = [f[..., live] for f in fixed]
    # diverging poses (a far start, a trial geometry) overflow: non-finite values are checked, not warned
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for _ in range(max_iter):
            if live.size == 0:
                break
            r, new, moved = step(*fix, *cur)
            err = np.max(np.abs(r), axis=0)
            conv = err <= tol
            lost = ~np.isfinite(err)  # diverged: no step can bring it back
            if new is None:  # all converged
                finished = conv
            else:
                tiny = ~conv & (moved < _STEP_FLOOR) & (err < 1e3 * tol)
                finished = conv | tiny | lost
                cur = [np.where(conv, c, n_) for c, n_ in zip(cur, new, strict=True)] if np.any(conv) else new
            if np.any(finished):
                k = live[finished]
                for s, c in zip(state, cur, strict=True):
                    s[..., k] = c[..., finished]
                err_out[k] = err[finished]
                done[k] = ~lost[finished]
                keep = ~finished
                live = live[keep]
                cur = [c[..., keep] for c in cur]
                fix = [f[..., keep] for f in fix]
        if live.size:  # out of iterations: their state as left, and its residual
            for s, c in zip(state, cur, strict=True):
                s[..., live] = c
            err_out[live] = np.max(np.abs(step(*fix, *cur)[0]), axis=0)
    return state, err_out, done


def _forward_block(rods: _Rods, q: np.ndarray, p: np.ndarray, R: np.ndarray, tol: float, max_iter: int):
    """FK of one block in component-first layout: q (3, N), p (3, N), R (3, 3, N) -> p, R, residual, ok."""

    def step(A, p, R):
        r, solved = _forward_step(rods, A, p, R, tol)
        if solved is None:
            return r, None, None
        dp, dphi = solved
        moved = np.maximum(np.max(np.abs(dp), axis=0), np.max(np.abs(dphi), axis=0))
        return r, [p + dp, b3.matmul(b3.rotation_from_vector(dphi), R)], moved

    live = np.flatnonzero(np.isfinite(p).all(axis=0))
    (p, R), err, done = _newton(step, [p, R], [rods.arm_balls(q)], tol, max_iter, live)
    return p, R, err, done


def forward(
    geometry: DeltaGeometry,
    q: np.ndarray,
    start: PlatePose | None = None,
    tol: float = TOLERANCE,
    max_iter: int = 30,
) -> PlatePose:
    """Plate poses of the real robot at readings q, by batched Newton on the six rods.

    Each Newton step solves the six rod equations' linearisation (Savoure Eq. 17-18) in
    closed form, in blocks of :data:`BLOCK` poses with the pose index last
    (:mod:`~deltacal.kinematics.batch3`); poses leave the iteration as they converge.

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
    N = q.shape[0]
    rods = _Rods.of(geometry)
    position = np.empty((N, 3))
    rotation = np.empty((N, 3, 3))
    residual = np.empty(N)
    done = np.empty(N, dtype=bool)
    for s in range(0, N, BLOCK):
        b = slice(s, s + BLOCK)
        p0 = np.array(pose.position[b], dtype=float).T
        R0 = np.array(np.asarray(pose.rotation[b], dtype=float).transpose(1, 2, 0))
        p, R, residual[b], done[b] = _forward_block(rods, q[b].T, p0, R0, tol, max_iter)
        position[b] = p.T
        rotation[b] = R.transpose(2, 0, 1)
    bad = ~(done & (residual < 1e3 * tol) & (position[:, 2] < _ceiling(geometry, rods, q)))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        known = residual[bad & np.isfinite(residual)]
        raise AssemblyError(
            f"no assembly found at {int(bad.sum())} reading(s), first: q = "
            f"{np.round(geometry.chain.reading_to_file(q[i]), 6).tolist()} "
            f"{geometry.chain.words.reading_unit} (index {i}, "
            + (f"rod residual {residual[i]:.3g} mm)" if np.isfinite(residual[i]) else
               "the rods cannot reach the plate)"),
            np.flatnonzero(bad),
            q[bad],
            float(np.max(known)) if known.size else float("nan"),
        )
    return PlatePose(position, rotation)


def _ceiling(geometry: DeltaGeometry, rods: _Rods, q: np.ndarray) -> np.ndarray | float:
    """Height the plate origin of the working assembly stays below [mm].

    The actuator axes of a rotary Delta; each pose's lowest carriage ball of a linear one (the
    effector hangs below its carriages).
    """
    if not rods.chain.plate_below_balls:
        return rods.axis_z
    return geometry.arm_balls_in_base(q)[..., 2].reshape(q.shape[0], -1).min(axis=1)


def forward_jacobian(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose) -> np.ndarray:
    """Plate twist per joint rate at an assembled pose: ``dX = J dq`` with X = (p, phi).

    From the differentiated rod equations ``J_X dX = J_q dq`` (Savoure Eq. 17).

    Returns:
        J [mm/rad and rad/rad], shape (N, 6, 3).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    _, d, dist, RB = _rod_terms(geometry, q, pose.position, pose.rotation)
    JX = _pose_jacobian(d, dist, RB)
    Jq = _joint_jacobian(geometry, q, d, dist)
    return -np.linalg.solve(JX, Jq)


def _inverse_step(rods: _Rods, target: np.ndarray, lever: np.ndarray, q: np.ndarray, R: np.ndarray,
                  tol: float):
    """Rod residuals (6, N) and the Newton step (dq (3, N), dphi (3, N)) of the IK (None: all within tol).

    The plate origin is eliminated, ``p = target - R t`` (t: the point in the plate frame), so the
    unknowns are the readings and the plate rotation, and the equations the six rods
    ``|target + R (B_k - t) - A_k(q_i)| = l_k``. A reading moves only its limb's two rods
    (rows ``g_k dq_i + m_kᵀ dphi = -r_k``): eliminating dq_i between them leaves a 3x3 system in
    dphi; dq_i then follows from both rows by least squares (they agree once dphi solves).
    """
    A = rods.arm_balls(q)
    RB = np.matmul(lever, R)  # (3, 6, N): R (B_k - t)
    r, n = rods.rods(RB + target[:, None] - A)
    if np.all(np.abs(r) <= tol):
        return r, None
    g = -b3.dot(n, rods.arm_ball_slopes(q))  # d r_k / d q_i
    m = b3.cross(RB, n)
    g1, g2, r1, r2 = g[0::2], g[1::2], r[0::2], r[1::2]
    m1, m2 = m[:, 0::2], m[:, 1::2]  # (component, limb, N)
    C = (g2 * m1 - g1 * m2).transpose(1, 0, 2)
    dphi, _ = b3.solve(C, g1 * r2 - g2 * r1)
    gg = g1 * g1 + g2 * g2
    with np.errstate(divide="ignore", invalid="ignore"):
        dq = -(g1 * (r1 + b3.dot(m1, dphi[:, None])) + g2 * (r2 + b3.dot(m2, dphi[:, None]))) / gg
    singular = ~(np.isfinite(dq).all(axis=0) & np.isfinite(dphi).all(axis=0))
    if np.any(singular):
        singular &= np.isfinite(r).all(axis=0) & np.isfinite(g).all(axis=0) & np.isfinite(m).all(axis=(0, 1))
    if np.any(singular):
        rows = np.zeros((int(singular.sum()), 6, 6))
        rows[:, np.arange(6), np.repeat(np.arange(3), 2)] = g[:, singular].T
        rows[:, :, 3:] = m[:, :, singular].transpose(2, 1, 0)
        step = _fallback(rows, -r[:, singular].T)
        dq[:, singular], dphi[:, singular] = step[:, :3].T, step[:, 3:].T
    return r, (dq, dphi)


def inverse(
    geometry: DeltaGeometry,
    target: np.ndarray,
    point_in_plate: np.ndarray | None = None,
    start: np.ndarray | None = None,
    tol: float = TOLERANCE,
    max_iter: int = 30,
    check: bool = True,
) -> np.ndarray:
    """Readings that put a plate point (default: the TCP) of the real robot at targets.

    Batched Newton on the six rod equations with the plate origin eliminated by the point's
    position (6 unknowns: q and the plate rotation; see :func:`_inverse_step`), in blocks of
    :data:`BLOCK` targets. Joint steps are limited to 0.2 rad, so a far start cannot jump to
    another branch (a prismatic chain's: :attr:`~deltacal.chains.Chain.max_step`).

    Args:
        geometry: The robot.
        target: Desired positions in {O} [mm], shape (N, 3) or (3,).
        point_in_plate: The point in the plate frame [mm] (default: the tool).
        start: Warm-start readings [rad], shape (N, 3).
        tol: Threshold on the rod residuals [mm].
        max_iter: Newton iterations at most.
        check: Raise for the targets not reached (else their rows are NaN).

    Returns:
        Readings [rad], shape (N, 3) ([mm] for a prismatic chain).

    Raises:
        UnreachableError: naming the targets out of reach or where Newton failed (with ``check``).
    """
    target = np.atleast_2d(np.asarray(target, dtype=float))
    tool = geometry.tool if point_in_plate is None else np.asarray(point_in_plate, dtype=float)
    if start is None:
        start = VirtualDelta.from_geometry(geometry).inverse(target - tool[None], check=False)
    out, _, reached = _solve_inverse(geometry, target, tool, start, None, tol, max_iter)
    if not np.all(reached):
        if check:
            raise UnreachableError.from_mask(~reached, target)
        out[~reached] = np.nan
    return out


def inverse_with_rotation(
    geometry: DeltaGeometry, target: np.ndarray, start: np.ndarray, rotation: np.ndarray,
    tol: float = TOLERANCE, max_iter: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`inverse` of the TCP started from a whole pose, readings and plate rotation.

    Newton from readings alone starts the plate parallel to the base; near the rim, where the
    plate of the working assembly tilts, that start can lead to another assembly's readings.
    Continuation (:mod:`~deltacal.kinematics.continuation`) starts each step from the last one's
    rotation as well.

    Args:
        geometry: The robot.
        target: Desired TCP positions in {O} [mm], (N, 3).
        start: Warm-start readings [rad], (N, 3).
        rotation: Warm-start plate rotations in {O}, (N, 3, 3).
        tol: Threshold on the rod residuals [mm].
        max_iter: Newton iterations at most.

    Returns:
        Readings [rad] (N, 3) and plate rotations (N, 3, 3); NaN rows where Newton failed.
    """
    target = np.atleast_2d(np.asarray(target, dtype=float))
    q, R, reached = _solve_inverse(geometry, target, geometry.tool, start, rotation, tol, max_iter)
    q[~reached] = np.nan
    R[~reached] = np.nan
    return q, R


def _solve_inverse(geometry: DeltaGeometry, target: np.ndarray, tool: np.ndarray, start: np.ndarray,
                   rotation: np.ndarray | None, tol: float, max_iter: int,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched Newton of :func:`inverse`: readings (N, 3), plate rotations (N, 3, 3), reached (N,)."""
    N = target.shape[0]
    rods = _Rods.of(geometry)
    lever = rods.plate - tool[None]
    q_all = np.array(start, dtype=float).reshape(N, 3)
    residual = np.empty(N)
    done = np.empty(N, dtype=bool)
    max_step = geometry.chain.max_step

    def step(t, q, R):
        r, solved = _inverse_step(rods, t, lever, q, R, tol)
        if solved is None:
            return r, None, None
        dq, dphi = solved
        limit = np.minimum(1.0, max_step / np.maximum(np.max(np.abs(dq), axis=0), 1e-300))
        dq *= limit
        dphi *= limit
        moved = np.maximum(np.max(np.abs(dq), axis=0), np.max(np.abs(dphi), axis=0))
        return r, [q + dq, b3.matmul(b3.rotation_from_vector(dphi), R)], moved

    out = np.empty((N, 3))
    out_rotation = np.empty((N, 3, 3))
    for s in range(0, N, BLOCK):
        b = slice(s, s + BLOCK)
        q0 = q_all[b].T.copy()
        n = q0.shape[1]
        if rotation is None:  # the plate parallel to the base
            R0 = np.zeros((3, 3, n))
            R0[0, 0] = R0[1, 1] = R0[2, 2] = 1.0
        else:
            R0 = np.array(rotation[b], dtype=float).transpose(1, 2, 0)
        live = np.flatnonzero(np.isfinite(q0).all(axis=0) & np.isfinite(R0).all(axis=(0, 1)))
        (q, R), residual[b], done[b] = _newton(step, [q0, R0], [target[b].T], tol, max_iter, live)
        out[b] = q.T
        out_rotation[b] = R.transpose(2, 0, 1)
    return out, out_rotation, done & (residual < 1e3 * tol)
