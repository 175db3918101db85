"""The error-model contract and the elementary geometric moves models are made of.

An error model is a parameterisation of small deviations ``dk`` of a
DeltaGeometry. It states:

* its parameter names and units (:attr:`ErrorModel.names`, :attr:`ErrorModel.units`);
* its sensitivity ``dX = S(q) dk`` (Savoure 2006, Eq. 21-22): the plate's small
  displacement ``dX = (dx, dalpha)`` (position of the plate-frame origin [mm],
  rotation vector in the base frame [rad]) at readings q, around *any*
  geometry (the nominal one or the current estimate);
* the map from a parameter vector back to a DeltaGeometry (:meth:`ErrorModel.apply`),
  so that an identified model feeds the exact kinematics and exact compensation.

Every model here is a linear combination ``e = M(g) dk`` of 63 *elementary moves*
of a geometry g, in this order:

```text
====================  =====  ==============================================
block                 size   meaning
====================  =====  ==============================================
plate balls           18     plate_ball[i, j] moved in the plate frame [mm]
arm balls             18     arm_ball[i, j] moved in the arm frame [mm]
rod lengths           6      rod_length[i, j] [mm]
axis points           9      axis_point[i] moved in {O} [mm]
actuator rotations    9      rigid rotation of actuator frame i about its axis
                             point, components along its own axes (x0, w, z0)
                             [rad]; the w component is the encoder offset
joint scales          3      joint_scale[i]: true joint coordinate per unit
                             reading (a printer's step distance) [-]; a
                             rotary robot's stay 1, a rotary printer's arm
                             turns by its steps times a step angle
====================  =====  ==============================================
```

A linear Delta (a prismatic chain, :mod:`deltacal.chains`) has the same moves: its "arm" balls
are its carriage's, held in the carriage frame; the actuator rotation's two tilts lean its tower
about the carriage frame's origin at the endstop (P_i); and, as for a revolute chain, the w
component is the joint's offset: the endstop's error [mm] (a carriage turned about its tower is
its balls moved, already there). The joint scales are a printer's (linear or rotary: a step
distance's error); a rotary robot's stay at 1.

The rod equations ``|A_ij(q) - (p + R B_ij)| = l_ij`` (Savoure Eq. 2), differentiated,
give ``J_X dX + J_k e = 0`` (Savoure Eq. 12, 17), so ``S = -J_X^-1 J_k M``
(Eq. 22). Evaluated at the exact pose of the current geometry, S is the exact
first-order sensitivity of the exact kinematics; tests check it against
central finite differences through :func:`deltacal.kinematics.exact.forward`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..chains import REVOLUTE, Chain
from ..exceptions import GeometryError
from ..geometry import DeltaGeometry, Tolerances, arm_frame_circle
from ..kinematics import batch3 as b3
from ..kinematics import exact
from ..kinematics.exact import PlatePose, pose_jacobian
from ..rotations import rotation_from_vector

N_ELEMENTARY = 63
PLATE_BALLS = slice(0, 18)
ARM_BALLS = slice(18, 36)
RODS = slice(36, 42)
AXIS_POINTS = slice(42, 51)
ACTUATOR_ROTATIONS = slice(51, 60)
JOINT_SCALES = slice(60, 63)


def plate_ball_index(i: int, j: int, k: int) -> int:
    """Elementary index of coordinate k of plate ball j of limb i (0-based)."""
    return PLATE_BALLS.start + 6 * i + 3 * j + k


def arm_ball_index(i: int, j: int, k: int) -> int:
    """Elementary index of coordinate k of arm ball j of limb i (0-based)."""
    return ARM_BALLS.start + 6 * i + 3 * j + k


def rod_index(i: int, j: int) -> int:
    """Elementary index of the length of rod j of limb i (0-based)."""
    return RODS.start + 2 * i + j


def axis_point_index(i: int, k: int) -> int:
    """Elementary index of coordinate k of the axis point of limb i (0-based)."""
    return AXIS_POINTS.start + 3 * i + k


def actuator_rotation_index(i: int, k: int) -> int:
    """Elementary index of the rotation of actuator i about its axis k (0: x0, 1: w, 2: z0).

    k = 1 is the joint's offset: a revolute encoder offset [rad], a prismatic endstop [mm].
    """
    return ACTUATOR_ROTATIONS.start + 3 * i + k


def joint_scale_index(i: int) -> int:
    """Elementary index of the joint scale of limb i (a printer's step distance, relative)."""
    return JOINT_SCALES.start + i


def elementary_jacobian(
    geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose, moves: np.ndarray | None = None
) -> np.ndarray:
    """J_k: derivative of the rod residuals ``|d_ij| - l_ij`` by the elementary moves.

    The one copy of J_k in deltacal. With ``moves`` it returns ``J_k e`` without
    forming J_k (cheap for many readings): the rod residuals' change for the moves e.

    Args:
        geometry: Geometry around which to differentiate.
        q: Readings [rad], shape (N, 3).
        pose: The plate poses at q (the exact ones of ``geometry``, or any pose at which
            to differentiate, e.g. the plate parallel at a target).
        moves: Elementary moves e, shape (60,): return ``J_k e`` instead of J_k.

    Returns:
        J_k, shape (N, 6, 60), or ``J_k e``, shape (N, 6); rows are rods (1,1), (1,2), (2,1),
        ..., (3,2).
    """
    q = np.atleast_2d(q)
    N = q.shape[0]
    if moves is not None:
        moves = np.asarray(moves, dtype=float)
        if geometry.chain.slides:
            return _moved_rods_along_lines(geometry, q, pose, moves)
        return _moved_rods(geometry, q, pose, moves)
    A = geometry.arm_balls_in_base(q)  # (N, 3, 2, 3)
    Rt = np.swapaxes(pose.rotation, 1, 2)
    B = pose.position[:, None, None, :] + (geometry.plate_ball.reshape(6, 3) @ Rt).reshape(N, 3, 2, 3)
    d = B - A
    n = d / np.sqrt(np.sum(d * d, axis=-1, keepdims=True))  # (N, 3, 2, 3)
    R0 = geometry.actuator_rotation()
    R_arm = geometry.arm_rotation(q)  # (N, 3, 3, 3)
    J = np.zeros((N, 3, 2, N_ELEMENTARY))
    lever = A - geometry.axis_point[None, :, None, :]
    torque = np.cross(lever, n)  # d|d|/d(rotation) = -(lever x n) . omega
    slope = geometry.arm_ball_velocity(q) / geometry.joint_scale[None, :, None, None]  # dA/dθ
    along = np.sum(n * slope, axis=-1)  # (N, 3, 2): n . dA/dθ
    slides = geometry.chain.slides
    for i in range(3):
        for j in range(2):
            s = plate_ball_index(i, j, 0)
            J[:, i, j, s : s + 3] = np.einsum("nk,nkl->nl", n[:, i, j], pose.rotation)
            s = arm_ball_index(i, j, 0)
            J[:, i, j, s : s + 3] = -np.einsum("nk,nkl->nl", n[:, i, j], R_arm[:, i])
            J[:, i, j, rod_index(i, j)] = -1.0
            s = axis_point_index(i, 0)
            J[:, i, j, s : s + 3] = -n[:, i, j]
            s = actuator_rotation_index(i, 0)
            J[:, i, j, s : s + 3] = -torque[:, i, j] @ R0[i]
            if slides:  # the w component: the endstop, a shift along the line of travel
                J[:, i, j, s + 1] = -along[:, i, j]
            # the joint scale: the joint moved by its reading per unit (a step distance's error)
            J[:, i, j, joint_scale_index(i)] = -along[:, i, j] * q[:, i]
    return J.reshape(N, 6, N_ELEMENTARY)


def _moved_rods(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose, e: np.ndarray) -> np.ndarray:
    """``J_k e`` (N, 6) without J_k, component first (the linear compensators' hot path).

    The arm ball's move ``δA = δP_i + R0_i R_y(θ_i) δa + ω_i × (A − P_i)`` is, like the ball
    itself, a point on a circle (:func:`~deltacal.geometry.arm_frame_circle`):
    ``F + cos θ_i G + sin θ_i H``, with constant F, G, H for the moves e; so each rod's change
    is ``n · (R δb − F − cos θ G − sin θ H) − δl`` with n its unit direction.
    """
    R0 = geometry.actuator_rotation()
    omega = np.einsum("ikl,il->ik", R0, e[ACTUATOR_ROTATIONS].reshape(3, 3))[:, None]  # (3, 1, 3)
    moved = arm_frame_circle(e[AXIS_POINTS].reshape(3, 3), R0, e[ARM_BALLS].reshape(3, 2, 3))
    circle = geometry.arm_ball_circle
    lever = (circle[0] - geometry.axis_point[:, None], circle[1], circle[2])  # A - P_i = C' + cos U + sin V
    col = lambda v: np.ascontiguousarray(v.reshape(6, 3).T)[:, :, None]  # noqa: E731  (3, 2, 3) -> (3, 6, 1)
    F, G, H = (col(m + np.cross(omega, v)) for m, v in zip(moved, lever, strict=True))
    C, U, V = (col(v) for v in circle)
    theta = geometry.joint_coordinate(q).T  # (3, N)
    cos, sin = np.repeat(np.cos(theta), 2, axis=0), np.repeat(np.sin(theta), 2, axis=0)  # (6, N)
    R = np.asarray(pose.rotation, dtype=float).transpose(1, 2, 0)  # (3, 3, N)
    d = (np.asarray(pose.position, dtype=float).T[:, None] + np.matmul(geometry.plate_ball.reshape(6, 3), R)
         - C - cos * U - sin * V)
    n = d / np.sqrt(b3.dot(d, d))
    dB = np.matmul(e[PLATE_BALLS].reshape(6, 3), R)
    moved = dB - F - cos * G - sin * H
    if np.any(e[JOINT_SCALES]):  # each arm turned by its reading per unit scale: dA/dθ = −sin U + cos V
        turn = np.repeat(q.T * e[JOINT_SCALES][:, None], 2, axis=0)  # (6, N)
        moved = moved - turn * (cos * V - sin * U)
    change = b3.dot(n, moved) - e[RODS][:, None]
    return np.ascontiguousarray(change.T)


def _moved_rods_along_lines(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose,
                            e: np.ndarray) -> np.ndarray:
    """``J_k e`` (N, 6) of a prismatic chain: each carriage ball's move, then each rod's change.

    ``δA = δP_i + R0_i δa + ω_i × (A − P_i) + (δo_i + q_i δs_i) dA/dθ`` with ω_i the tower's lean
    (the tilts of its actuator rotation), δo_i the endstop (its w component) and δs_i the scale.
    """
    R0 = geometry.actuator_rotation()
    rot = e[ACTUATOR_ROTATIONS].reshape(3, 3)
    omega = np.einsum("ikl,il->ik", R0, rot * np.array([1.0, 0.0, 1.0]))  # (3, 3) in {O}
    A = geometry.arm_balls_in_base(q)  # (N, 3, 2, 3)
    slope = geometry.arm_ball_velocity(q) / geometry.joint_scale[None, :, None, None]
    travel = rot[:, 1][None, :] + q * e[JOINT_SCALES][None, :]  # (N, 3)
    dA = (e[AXIS_POINTS].reshape(3, 1, 3) + np.einsum("ikl,ijl->ijk", R0, e[ARM_BALLS].reshape(3, 2, 3))
          + np.cross(omega[None, :, None, :], A - geometry.axis_point[None, :, None, :])
          + travel[:, :, None, None] * slope)
    B = pose.position[:, None, None, :] + np.einsum("nkl,ijl->nijk", pose.rotation, geometry.plate_ball)
    d = B - A
    n = d / np.linalg.norm(d, axis=-1, keepdims=True)
    dB = np.einsum("nkl,ijl->nijk", pose.rotation, e[PLATE_BALLS].reshape(3, 2, 3))
    change = np.sum(n * (dB - dA), axis=-1) - e[RODS].reshape(3, 2)
    return change.reshape(-1, 6)


def elementary_sensitivity(
    geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose | None = None
) -> np.ndarray:
    """``dX = S_e e`` for the 60 elementary moves, shape (N, 6, 60)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if pose is None:
        pose = exact.forward(geometry, q)
    JX = pose_jacobian(geometry, q, pose)
    Jk = elementary_jacobian(geometry, q, pose)
    return -np.linalg.solve(JX, Jk)


def apply_elementary(geometry: DeltaGeometry, e: np.ndarray) -> DeltaGeometry:
    """The geometry moved by the elementary moves e (63,).

    Actuator rotations are applied as exact rigid rotations of the actuator frame
    (the encoder offset is adjusted so that the arm frames turn rigidly; a prismatic chain's
    carriage balls turn instead, and its w component is added to the endstop [mm]).
    """
    e = np.asarray(e, dtype=float)
    plate_ball = geometry.plate_ball + e[PLATE_BALLS].reshape(3, 2, 3)
    arm_ball = geometry.arm_ball + e[ARM_BALLS].reshape(3, 2, 3)
    rod_length = geometry.rod_length + e[RODS].reshape(3, 2)
    axis_point = geometry.axis_point + e[AXIS_POINTS].reshape(3, 3)
    rot = e[ACTUATOR_ROTATIONS].reshape(3, 3)
    axis_direction = np.array(geometry.axis_direction)
    encoder_offset = np.array(geometry.encoder_offset)
    if np.any(rot):
        R0 = geometry.actuator_rotation()
        # tilts (about x0 and z0) turn the actuator frame rigidly; the w component is then a
        # change of encoder offset about the new axis (applying both as one rotation vector
        # would tilt the axis about a direction turned by half the offset)
        tilt = rot * np.array([1.0, 0.0, 1.0])
        omega = np.einsum("ikl,il->ik", R0, tilt)  # in the base frame
        R0_new = rotation_from_vector(omega) @ R0
        axis_direction = R0_new[:, :, 1] / np.linalg.norm(R0_new[:, :, 1], axis=1, keepdims=True)
        moved = replace(geometry, axis_direction=axis_direction)
        R0_derived = moved.actuator_rotation()
        # the zero direction the geometry derives differs from the rigidly turned one by a
        # rotation about the new axis: fold it into the encoder offset
        rel = np.einsum("ilk,ilm->ikm", R0_derived, R0_new)  # R0_derived^T R0_new, a rotation about y
        if geometry.chain.turns_balls:  # a carriage turned about its tower: its balls turn with it
            arm_ball = np.einsum("ikl,ijl->ijk", rel, arm_ball)
            encoder_offset = encoder_offset + rot[:, 1]
        else:
            encoder_offset = encoder_offset + np.arctan2(rel[:, 0, 2], rel[:, 0, 0]) + rot[:, 1]
    joint_scale = np.array(geometry.joint_scale)
    if np.any(e[JOINT_SCALES]):
        joint_scale = joint_scale + e[JOINT_SCALES]
    return replace(
        geometry,
        plate_ball=plate_ball,
        arm_ball=arm_ball,
        rod_length=rod_length,
        axis_point=axis_point,
        axis_direction=axis_direction,
        encoder_offset=encoder_offset,
        joint_scale=joint_scale,
    )


class ErrorModel(ABC):
    """A parameterisation of small deviations of a DeltaGeometry.

    Subclasses give :attr:`names`, :attr:`units` and :meth:`moves` (the matrix M
    from parameters to elementary moves); the sensitivity and the map back to a
    geometry follow.
    """

    #: Short name used on the command line.
    name: str = ""
    #: The actuated chain the model is written for (:mod:`deltacal.chains`).
    chain: Chain = REVOLUTE
    #: Whether the model moves the plate orientation (False: perfect parallelograms).
    tilts_plate: bool = True
    #: Preference order of the parameters kept when some must be regrouped (None: pivoted QR's).
    preferred: list[str] | None = None
    #: The model holds no rigid motion of the robot (a gauge such as Bai's Eq. 11 removed it):
    #: distances of all pairs are then fitted as positions with a free frame per point.
    rigid_motion_free: bool = False
    #: Where an instrument frame absorbs a rigid motion of the robot, the parameters held for it
    #: are taken among these first: positions of elements, not an axis tilt nor an encoder
    #: offset, whose real deviation a held value would deny.
    frame_held_first: tuple[str, ...] = ()
    #: The parameters that raise the whole robot alike, one unit each (a linear printer's endstops);
    #: none: a rise is the least-squares combination that moves the plate so (a rotary printer's).
    bed_rise: tuple[str, ...] = ()

    @property
    @abstractmethod
    def names(self) -> list[str]:
        """Parameter names, in the order of the parameter vector."""

    @property
    @abstractmethod
    def units(self) -> list[str]:
        """Unit of each parameter: "mm" or "rad"."""

    @abstractmethod
    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """M(g): elementary moves per unit of each parameter, shape (60, n)."""

    @property
    def size(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def sensitivity(
        self, geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose | None = None
    ) -> np.ndarray:
        """S(q): plate displacement (dx [mm], dalpha [rad]) per parameter, (N, 6, n).

        Savoure Eq. 21-22, evaluated at the exact pose of ``geometry``.

        Args:
            geometry: Geometry around which to linearise (nominal or current estimate).
            q: Readings [rad], shape (N, 3).
            pose: Exact poses of ``geometry`` at q, if already known.
        """
        self.check_fits(geometry)
        return elementary_sensitivity(geometry, q, pose) @ self.moves(geometry)

    def prior_sigma(self, tolerances: Tolerances) -> np.ndarray:
        """σ of each parameter before any measurement, from build tolerances (the printer models').

        Raises:
            NotImplementedError: a model that states none.
        """
        raise NotImplementedError(f"the {self.name!r} error model states no prior from tolerances")

    def prior_factor(self, tolerances: Tolerances, geometry: DeltaGeometry,
                     calibrated: bool | Sequence[str] = False) -> np.ndarray:
        """P, the prior covariance's factor ``Σ = P Pᵀ`` (n, n): by default ``diag(prior_sigma)``.

        A model whose parameters share a common mode (a printer's bed) states it here.

        Args:
            tolerances: The build tolerances.
            geometry: The geometry the parameters deviate from.
            calibrated: Whether that geometry's controller values were calibrated from the very
                measurements being fitted (a printer's saved ``DELTA_CALIBRATE``), or the names of
                the values that were.
        """
        return np.diag(self.prior_sigma(tolerances))

    def check_fits(self, geometry: DeltaGeometry) -> None:
        """GeometryError unless the model is written for the geometry's chain (rotary or linear Delta)."""
        if geometry.chain != self.chain:
            raise GeometryError(f"the {self.name!r} error model serves {self.chain.words.robots}; "
                                f"{geometry.name or 'this geometry'!r} is a {geometry.chain.name} chain")

    def pair_rotations(self, geometry: DeltaGeometry) -> np.ndarray | None:
        """Rotations of ball pairs about their midpoints per parameter, (18, n), or None.

        Rows: plate pairs of limbs 1-3 (rotation vectors in the plate frame), then arm
        pairs (in the arm frame) [rad per unit parameter]. :meth:`moves` holds their
        first-order ball moves (:func:`pair_rotation_moves`); :meth:`apply` turns the
        pairs exactly instead, so that a model whose parameters keep parallelograms
        perfect keeps them perfect for finite deviations too.
        """
        return None

    def apply(self, geometry: DeltaGeometry, dk: np.ndarray) -> DeltaGeometry:
        """The geometry with the parameter deviations dk applied."""
        dk = np.asarray(dk, dtype=float)
        if dk.shape != (self.size,):
            raise ValueError(f"{self.name}: expected {self.size} parameters, got shape {dk.shape}")
        self.check_fits(geometry)
        e = self.moves(geometry) @ dk
        P = self.pair_rotations(geometry)
        if P is None:
            return apply_elementary(geometry, e)
        rot = (P @ dk).reshape(2, 3, 3)
        e = e - pair_rotation_moves(geometry, rot[0], rot[1])
        return rotate_pairs(apply_elementary(geometry, e), rot[0], rot[1])

    def without(self, drop: list[str], name: str) -> ErrorModel:
        """This model with some parameters held at zero (e.g. a gauge, Bai Eq. 11)."""
        return SubModel(self, [n for n in self.names if n not in set(drop)], name)


class ListedParameters:
    """An error model whose parameters' names and units are lists it builds once (``_names``, ``_units``).

    Put before :class:`ErrorModel` among a model's bases: its :attr:`names` and :attr:`units` are then
    these lists (copies: a caller's edit does not reach the model).
    """

    _names: list[str]
    _units: list[str]

    @property
    def names(self) -> list[str]:
        """Parameter names, in the order of the parameter vector."""
        return list(self._names)

    @property
    def units(self) -> list[str]:
        """Unit of each parameter: "mm" or "rad"."""
        return list(self._units)


class SubModel(ErrorModel):
    """A model restricted to a subset of another model's parameters."""

    def __init__(self, parent: ErrorModel, keep: list[str], name: str) -> None:
        unknown = set(keep) - set(parent.names)
        if unknown:
            raise ValueError(f"unknown parameters {sorted(unknown)} for model {parent.name}")
        self.parent = parent
        self._index = [parent.names.index(k) for k in keep]
        self.name = name
        self.tilts_plate = parent.tilts_plate
        self.chain = parent.chain
        self.preferred = parent.preferred
        self.frame_held_first = tuple(n for n in parent.frame_held_first if n in keep)
        self.bed_rise = parent.bed_rise if set(parent.bed_rise) <= set(keep) else ()

    @property
    def names(self) -> list[str]:
        """Kept parameter names."""
        return [self.parent.names[k] for k in self._index]

    @property
    def units(self) -> list[str]:
        """Kept parameter units."""
        return [self.parent.units[k] for k in self._index]

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """The parent's moves for the kept parameters."""
        return self.parent.moves(geometry)[:, self._index]

    def pair_rotations(self, geometry: DeltaGeometry) -> np.ndarray | None:
        """The parent's pair rotations for the kept parameters."""
        P = self.parent.pair_rotations(geometry)
        return None if P is None else P[:, self._index]


def pair_frames(geometry: DeltaGeometry) -> dict[str, np.ndarray]:
    """Quantities of each limb's parallelogram used to build model moves.

    Returns:
        ``arm_mid`` (3, 3) arm-pair midpoints (arm frame), ``arm_half`` (3, 3) half pair
        vectors (ball 1 minus midpoint, arm frame), ``plate_mid``/``plate_half`` the same in
        the plate frame, ``spacing`` (3,) arm-pair spacing c, ``arm_length`` (3,) the elbow's
        x in the arm frame (L), and ``R0`` the actuator rotations (3, 3, 3).
    """
    arm_mid = geometry.arm_ball.mean(axis=1)
    plate_mid = geometry.plate_ball.mean(axis=1)
    arm_half = geometry.arm_ball[:, 0] - arm_mid
    plate_half = geometry.plate_ball[:, 0] - plate_mid
    return {
        "arm_mid": arm_mid,
        "arm_half": arm_half,
        "plate_mid": plate_mid,
        "plate_half": plate_half,
        "spacing": 2.0 * np.linalg.norm(arm_half, axis=1),
        "arm_length": arm_mid[:, 0],
        "R0": geometry.actuator_rotation(),
    }


def rotate_pair_moves(half: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Moves (2, 3) of a ball pair rotated about its midpoint by a unit small rotation ``axis``."""
    dv = np.cross(axis, half)
    return np.stack([dv, -dv])


def pair_rotation_moves(geometry: DeltaGeometry, plate: np.ndarray, arm: np.ndarray) -> np.ndarray:
    """First-order elementary moves (60,) of the ball pairs turned about their midpoints.

    Args:
        geometry: The geometry.
        plate: Rotation vector of each limb's plate pair, in the plate frame, (3, 3) [rad].
        arm: Rotation vector of each limb's arm pair, in the arm frame, (3, 3) [rad].
    """
    f = pair_frames(geometry)
    e = np.zeros(N_ELEMENTARY)
    dp = np.cross(plate, f["plate_half"])
    da = np.cross(arm, f["arm_half"])
    e[PLATE_BALLS] = np.stack([dp, -dp], axis=1).reshape(-1)
    e[ARM_BALLS] = np.stack([da, -da], axis=1).reshape(-1)
    return e


def rotate_pairs(geometry: DeltaGeometry, plate: np.ndarray, arm: np.ndarray) -> DeltaGeometry:
    """The geometry with each ball pair turned exactly about its midpoint (see pair_rotation_moves)."""
    out = {}
    for key, rot in (("plate_ball", plate), ("arm_ball", arm)):
        balls = getattr(geometry, key)
        if not np.any(rot):
            out[key] = balls
            continue
        mid = balls.mean(axis=1)
        half = np.einsum("ikl,il->ik", rotation_from_vector(rot), balls[:, 0] - mid)
        out[key] = np.stack([mid + half, mid - half], axis=1)
    return replace(geometry, **out)


__all__ = [
    "ErrorModel",
    "ListedParameters",
    "N_ELEMENTARY",
    "SubModel",
    "apply_elementary",
    "elementary_jacobian",
    "elementary_sensitivity",
    "joint_scale_index",
    "pose_jacobian",
]
