"""Nominal and full geometry of a Delta robot.

Units inside the library: millimetres and radians. Files use millimetres and
degrees (see :mod:`deltacal.io`).

Frames (conventions of the project):

* Base frame {O}: origin at the centre of the circle of actuator axes, z up.
  Limb i sits at azimuth ``phi_i``; ``r_i = (cos phi_i, sin phi_i, 0)``,
  ``t_i = (-sin phi_i, cos phi_i, 0)``.
* Actuator frame of limb i (at zero true angle): origin at ``axis_point[i]``,
  y axis along the actuator axis ``w_i = axis_direction[i]``, x axis the
  projection of ``r_i`` orthogonal to ``w_i`` (the arm's zero direction) and
  z = x × y (up for the nominal robot). Its rotation is ``R0_i = [x0 w z0]``.
* Arm frame of limb i: the actuator frame rotated about its y axis by the
  true angle ``theta_i = q_i + encoder_offset[i]``,
  ``R_arm = R0_i @ Ry(theta_i)``. For the nominal robot the arm direction is
  ``u_i(q) = cos(q) r_i - sin(q) z``: ``q > 0`` lowers the arm tip.
* Plate frame {C}: the travelling plate, parallel to {O} for the nominal robot.

Rod j (j = 1, 2) of limb i joins ``arm_ball[i, j]`` (arm frame) to
``plate_ball[i, j]`` (plate frame) and has length ``rod_length[i, j]``.
Rod 1 is on the ``+t_i`` side (``+c/2``), rod 2 on the ``-t_i`` side.
Arrays are indexed from 0 (limb 1 is index 0); names are 1-based.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from .chains import REVOLUTE, Chain, chain_of
from .chains import arm_frame_circle as arm_frame_circle  # re-exported: old import paths
from .exceptions import GeometryError
from .rotations import rotation_about_y as rotation_about_y  # re-exported: old import paths
from .rotations import rotation_from_vector as rotation_from_vector
from .rotations import skew as skew
from .rotations import vector_from_rotation as vector_from_rotation
from .towers import per_tower

#: Names of the three coordinates, used in error names.
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Workspace:
    """Cylindrical task workspace used for planning and validation (Bai Fig. 2, 4).

    Attributes:
        radius: Cylinder radius R [mm].
        height: Cylinder height h [mm].
        top_z: z of the top layer [mm] (the cylinder spans ``top_z - height .. top_z``).
    """

    radius: float
    height: float
    top_z: float

    @property
    def middle_z(self) -> float:
        """Z of the middle layer [mm]."""
        return self.top_z - 0.5 * self.height

    @property
    def bottom_z(self) -> float:
        """Z of the bottom layer [mm]."""
        return self.top_z - self.height

    @property
    def centre(self) -> np.ndarray:
        """Centre of the cylinder [mm], the home pose of Bai's validation."""
        return np.array([0.0, 0.0, self.middle_z])


@dataclass(frozen=True)
class Masses:
    """Masses of the moving bodies [kg] (conventions, "Gravity and payload").

    A payload is not a property of the robot: it is given per measurement or per command.

    Attributes:
        arm: Each arm [kg]; its centre of mass is half-way from its actuator axis to its
            elbow balls' midpoint.
        rod: Each of the six rods [kg], uniform (centre of mass half-way between its balls).
        plate: The travelling plate [kg], at the plate frame's origin.
    """

    arm: float = 0.0
    rod: float = 0.0
    plate: float = 0.0

    def __post_init__(self) -> None:
        for key in ("arm", "rod", "plate"):
            value = float(getattr(self, key))
            if not (math.isfinite(value) and value >= 0.0):
                raise GeometryError(f"mass {key} must be a finite non-negative number [kg], got {value!r}")
            object.__setattr__(self, key, value)

    @property
    def is_zero(self) -> bool:
        """True when no body has mass (a kinematic robot)."""
        return self.arm == 0.0 and self.rod == 0.0 and self.plate == 0.0


@dataclass(frozen=True)
class NominalDelta:
    """Nominal (design) parameters of a Delta robot, as in a robot file.

    Attributes:
        name: Robot name.
        base_radius: b, radius of the circle of actuator axes [mm].
        plate_radius: a, radius of the circle of plate ball-pair midpoints [mm].
        arm_length: L, from actuator axis to elbow midpoint [mm].
        rod_length: l, rod length [mm].
        rod_spacing: c, distance between the two balls of a pair [mm].
        limb_azimuth: phi_i, azimuth of each limb [rad], shape (3,).
        tool: TCP in the plate frame [mm], shape (3,).
        points: Named reference points in the plate frame [mm].
        workspace: Cylinder for planning and validation, or None.
        description: Free text.
        masses: Masses of the moving bodies (all zero: not given).
    """

    name: str
    base_radius: float
    plate_radius: float
    arm_length: float
    rod_length: float
    rod_spacing: float
    limb_azimuth: np.ndarray
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    points: dict[str, np.ndarray] = field(default_factory=dict)
    workspace: Workspace | None = None
    description: str = ""
    masses: Masses = field(default_factory=Masses)

    def __post_init__(self) -> None:
        object.__setattr__(self, "limb_azimuth", np.asarray(self.limb_azimuth, dtype=float))
        object.__setattr__(self, "tool", np.asarray(self.tool, dtype=float))
        pts = {k: np.asarray(v, dtype=float) for k, v in self.points.items()}
        object.__setattr__(self, "points", pts)
        for key, value in (
            ("base_radius", self.base_radius),
            ("plate_radius", self.plate_radius),
            ("arm_length", self.arm_length),
            ("rod_length", self.rod_length),
            ("rod_spacing", self.rod_spacing),
        ):
            if not math.isfinite(value) or value <= 0.0:
                raise GeometryError(f"{key} must be a positive finite length, got {value!r}")
        if self.limb_azimuth.shape != (3,) or not np.all(np.isfinite(self.limb_azimuth)):
            raise GeometryError(f"limb_azimuth must be 3 finite angles, got {self.limb_azimuth}")
        if self.tool.shape != (3,) or not np.all(np.isfinite(self.tool)):
            raise GeometryError(f"tool must be 3 finite coordinates, got {self.tool}")
        if self.rod_length <= self.arm_length * 0.25:
            raise GeometryError(
                f"rod_length {self.rod_length} is too short for arm_length {self.arm_length}"
            )

    @property
    def radial(self) -> np.ndarray:
        """Radial unit vectors r_i, shape (3, 3) (one row per limb)."""
        return radial_vectors(self.limb_azimuth)

    @property
    def tangent(self) -> np.ndarray:
        """Tangent unit vectors t_i (actuator axis directions), shape (3, 3)."""
        return tangent_vectors(self.limb_azimuth)

    def geometry(self) -> DeltaGeometry:
        """Full geometry of the perfect robot built to these nominal values."""
        r, t = self.radial, self.tangent
        half = 0.5 * self.rod_spacing
        arm_ball = np.zeros((3, 2, 3))
        arm_ball[:, 0] = [self.arm_length, half, 0.0]
        arm_ball[:, 1] = [self.arm_length, -half, 0.0]
        plate_ball = np.stack(
            [self.plate_radius * r + half * t, self.plate_radius * r - half * t], axis=1
        )
        return DeltaGeometry(
            limb_azimuth=self.limb_azimuth.copy(),
            axis_point=self.base_radius * r,
            axis_direction=t.copy(),
            encoder_offset=np.zeros(3),
            arm_ball=arm_ball,
            plate_ball=plate_ball,
            rod_length=np.full((3, 2), float(self.rod_length)),
            tool=self.tool.copy(),
            points={k: v.copy() for k, v in self.points.items()},
            name=self.name,
            masses=self.masses,
        )


def radial_vectors(azimuth: np.ndarray) -> np.ndarray:
    """Radial unit vectors ``(cos phi, sin phi, 0)``, one row per azimuth."""
    azimuth = np.asarray(azimuth, dtype=float)
    return np.stack([np.cos(azimuth), np.sin(azimuth), np.zeros_like(azimuth)], axis=-1)


def tangent_vectors(azimuth: np.ndarray) -> np.ndarray:
    """Tangent unit vectors ``(-sin phi, cos phi, 0)``, one row per azimuth."""
    azimuth = np.asarray(azimuth, dtype=float)
    return np.stack([-np.sin(azimuth), np.cos(azimuth), np.zeros_like(azimuth)], axis=-1)


@dataclass(frozen=True)
class Tolerances:
    """Standard deviations of the manufacturing errors of each class.

    Every error of a class is drawn independently from a normal law of this
    standard deviation (per coordinate for points).

    Attributes:
        ball_centre: Ball centres in their body (arm or plate), per coordinate [mm].
        rod_length: Rod lengths [mm].
        axis_position: Actuator axis point, per coordinate [mm].
        axis_direction: Actuator axis direction, each of its two tilts [rad].
        encoder_offset: Encoder zero [rad] (a prismatic chain's endstop [mm]).
        tool: TCP in the plate frame, per coordinate [mm] (0: the tool is known).
        joint_scale: Relative error of a prismatic chain's step distance (the scale's
            deviation from 1); revolute chains have none.
    """

    ball_centre: float = 0.05
    rod_length: float = 0.05
    axis_position: float = 0.2
    axis_direction: float = math.radians(0.05)
    encoder_offset: float = math.radians(0.3)
    tool: float = 0.0
    joint_scale: float = 0.0

    @classmethod
    def printer_kit(cls) -> Tolerances:
        """Errors of a typical linear Delta printer kit.

        Towers placed to 0.3 mm and leaning 0.15 deg, endstops to 0.5 mm, step distances to
        0.3 %, balls to 0.05 mm and rods to 0.1 mm (the two rods of a pair differ).
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.3,
            axis_direction=math.radians(0.15),
            encoder_offset=0.5,
            joint_scale=0.003,
        )

    @classmethod
    def rotary_printer_kit(cls) -> Tolerances:
        """Errors of a typical rotary Delta printer kit: the prior of a rotary printer's identification.

        The rotary robot's shoulders (axes placed to 0.2 mm, tilted 0.1 deg), balls to 0.05 mm and
        rods to 0.1 mm as a linear printer kit's, the arms' endstop angles to 0.3 deg and their gear
        ratios (step angles) to 0.2 %.
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.2,
            axis_direction=math.radians(0.1),
            encoder_offset=math.radians(0.3),
            joint_scale=0.002,
        )

    @classmethod
    def bai2015(cls) -> Tolerances:
        """Errors of the size Bai et al. identified on their prototype (Tables 2-4).

        Encoder offsets about 1 deg (Table 2), actuator positions and lengths about
        0.1-0.3 mm, axis tilts about ``0.8 mm / L`` (Table 3), ball-pair
        discrepancies about 0.05 mm and pair misalignments about 0.2 mm / c (Table 4).
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.15,
            axis_direction=math.radians(0.1),
            encoder_offset=math.radians(1.0),
        )


_NAME_RE = re.compile(
    r"^limb(?P<limb>[123])\."
    r"(?:(?P<kind>axis_point|arm_ball(?P<ab>[12])|plate_ball(?P<pb>[12]))\.(?P<axis>[xyz])"
    r"|rod(?P<rod>[12])\.length"
    r"|(?P<offset>encoder_offset)"
    r"|joint_scale"
    r"|axis_tilt_(?P<tilt>[rzt]))$"
    r"|^tool\.(?P<taxis>[xyz])$"
)


def error_names(chain: Chain | str = REVOLUTE) -> list[str]:
    """All names accepted by :meth:`DeltaGeometry.with_errors` of a chain (or its word), in a fixed order.

    Units: [mm] for positions and lengths, [rad] for the two axis tilts (``axis_tilt_r`` about
    r_i, then ``axis_tilt_z`` about z for a revolute axis or ``axis_tilt_t`` about t_i for a
    tower: a positive one moves its top outward) and a revolute ``encoder_offset``; a prismatic
    chain's ``encoder_offset`` (its endstop) is in [mm] and its ``joint_scale`` (true over
    nominal step distance) has no unit.
    """
    chain = chain_of(chain)
    names = []
    for i in range(1, 4):
        names += [f"limb{i}.axis_point.{a}" for a in AXES]
        names += [f"limb{i}.axis_tilt_r", f"limb{i}.axis_tilt_{chain.tilt_letter}",
                  f"limb{i}.encoder_offset"]
        if chain.counts_steps:
            names.append(f"limb{i}.joint_scale")
        for j in (1, 2):
            names += [f"limb{i}.arm_ball{j}.{a}" for a in AXES]
        for j in (1, 2):
            names += [f"limb{i}.plate_ball{j}.{a}" for a in AXES]
        names += [f"limb{i}.rod{j}.length" for j in (1, 2)]
    names += [f"tool.{a}" for a in AXES]
    return names


@dataclass(frozen=True, eq=False)
class DeltaGeometry:
    """Full geometry of a real Delta robot: every element on its own.

    Attributes:
        limb_azimuth: phi_i [rad], shape (3,): defines r_i, the zero direction of each arm.
        axis_point: A point of each actuator axis, in {O} [mm], shape (3, 3).
        axis_direction: Unit direction of each actuator axis, in {O}, shape (3, 3).
        encoder_offset: True arm angle minus reading [rad], shape (3,); for a prismatic chain
            the carriage's true travel minus its scaled reading [mm] (the endstop's error).
        arm_ball: Arm-side ball centres in the arm frame [mm], shape (3, 2, 3).
        plate_ball: Plate-side ball centres in the plate frame [mm], shape (3, 2, 3).
        rod_length: Rod lengths [mm], shape (3, 2).
        tool: TCP in the plate frame [mm], shape (3,).
        points: Named reference points in the plate frame [mm].
        name: Robot name.
        chain: The actuated chain (:mod:`deltacal.chains`): :data:`~deltacal.chains.REVOLUTE` (a
            rotary Delta's arms) or :data:`~deltacal.chains.PRISMATIC` (a linear Delta's carriages:
            axis point = carriage frame origin at the endstop, axis direction = up the tower,
            reading = travel below the endstop [mm]); :attr:`joint` is its word in files.
        joint_scale: True joint coordinate per unit reading, shape (3,): a printer's true over
            nominal step distance (a carriage's, or a rotary printer's arm's step angle); 1 for a
            rotary robot.
        masses: Masses of the moving bodies (all zero: a kinematic robot).
        compliance: Compliance c_i of each actuator [rad/N m], (3,): the true arm angle is ``reading +
            encoder_offset + c_i tau_i``, tau_i the gravity torque (:mod:`~.kinematics.statics`); 0: rigid.
        step_distance: A prismatic chain's nominal step distance of each tower [mm], (3,) (a number
            broadcasts): a tower's reading is its steps below the endstop times its own (None: not
            known; always None for a revolute chain).
    """

    limb_azimuth: np.ndarray
    axis_point: np.ndarray
    axis_direction: np.ndarray
    encoder_offset: np.ndarray
    arm_ball: np.ndarray
    plate_ball: np.ndarray
    rod_length: np.ndarray
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    points: dict[str, np.ndarray] = field(default_factory=dict)
    name: str = ""
    chain: Chain = REVOLUTE
    joint_scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    masses: Masses = field(default_factory=Masses)
    compliance: np.ndarray = field(default_factory=lambda: np.zeros(3))
    step_distance: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.chain, Chain):
            raise GeometryError(f"chain must be a deltacal.chains.Chain, got {self.chain!r}")
        shapes = {
            "joint_scale": (3,),
            "limb_azimuth": (3,),
            "axis_point": (3, 3),
            "axis_direction": (3, 3),
            "encoder_offset": (3,),
            "arm_ball": (3, 2, 3),
            "plate_ball": (3, 2, 3),
            "rod_length": (3, 2),
            "tool": (3,),
            "compliance": (3,),
        }
        for key, shape in shapes.items():
            value = np.array(getattr(self, key), dtype=float)
            if value.shape != shape:
                raise GeometryError(f"{key} must have shape {shape}, got {value.shape}")
            if not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be finite, got {value.tolist()}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        pts = {}
        for k, v in self.points.items():
            arr = np.array(v, dtype=float)
            if arr.shape != (3,) or not np.all(np.isfinite(arr)):
                raise GeometryError(f"point {k!r} must be 3 finite coordinates, got {v!r}")
            arr.setflags(write=False)
            pts[str(k)] = arr
        object.__setattr__(self, "points", pts)
        norms = np.linalg.norm(self.axis_direction, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-9):
            raise GeometryError(f"axis_direction rows must be unit vectors, norms {norms}")
        if np.any(self.rod_length <= 0.0):
            raise GeometryError(f"rod lengths must be positive, got {self.rod_length.tolist()}")
        if "tcp" in pts:
            raise GeometryError("'tcp' is reserved for the tool centre point")
        if np.any(self.joint_scale <= 0.0):
            raise GeometryError(f"joint_scale must be positive, got {self.joint_scale.tolist()}")
        if self.step_distance is not None:
            if not self.chain.counts_steps:
                raise GeometryError(f"step_distance must be a prismatic chain's positive length, got "
                                    f"{self.step_distance!r} ({self.chain.name})")
            object.__setattr__(self, "step_distance", per_tower("step_distance", self.step_distance))

    @property
    def joint(self) -> str:
        """The chain's word in files: ``"revolute"`` or ``"prismatic"``."""
        return self.chain.name

    # ------------------------------------------------------------------ frames
    @property
    def radial(self) -> np.ndarray:
        """Nominal radial unit vectors r_i, shape (3, 3)."""
        return radial_vectors(self.limb_azimuth)

    @property
    def tangent(self) -> np.ndarray:
        """Nominal tangent unit vectors t_i, shape (3, 3)."""
        return tangent_vectors(self.limb_azimuth)

    def actuator_rotation(self) -> np.ndarray:
        """Rotation of each actuator frame at zero true angle, ``R0_i = [x0 w z0]``, (3, 3, 3).

        The y axis is the actuator axis; x is r_i made orthogonal to it. A fresh copy of the
        rotations computed once per geometry (the solvers and sensitivities ask for them often).
        """
        return self._actuator_rotation.copy()

    @cached_property
    def _actuator_rotation(self) -> np.ndarray:
        w = self.axis_direction / np.linalg.norm(self.axis_direction, axis=1, keepdims=True)
        r = self.radial
        x0 = r - np.sum(r * w, axis=1, keepdims=True) * w
        x0 /= np.linalg.norm(x0, axis=1, keepdims=True)
        z0 = np.cross(x0, w)
        rotation = np.stack([x0, w, z0], axis=-1)
        rotation.setflags(write=False)  # cached by a frozen geometry: not to be changed through it
        return rotation

    def joint_coordinate(self, q: np.ndarray) -> np.ndarray:
        """True joint coordinates ``θ = joint_scale q + encoder_offset`` [rad or mm], (N, 3)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return self.chain.coordinate(q, self.joint_scale, self.encoder_offset)

    def arm_rotation(self, q: np.ndarray) -> np.ndarray:
        """Rotation of each arm (or carriage) frame in {O} at readings q.

        Args:
            q: Joint readings [rad or mm], shape (N, 3).

        Returns:
            Rotations, shape (N, 3, 3, 3) (pose, limb, 3x3).
        """
        return self.chain.carrier_rotation(self.actuator_rotation(), self.joint_coordinate(q))

    def arm_balls_in_base(self, q: np.ndarray) -> np.ndarray:
        """Arm-side ball centres in {O} at readings q.

        Args:
            q: Joint readings [rad or mm], shape (N, 3).

        Returns:
            Ball centres A_ij [mm], shape (N, 3, 2, 3).
        """
        # each ball on its path (chains.carried_points): elementwise products are several times
        # faster than a batched (N, 3, 3, 3) matrix product and einsum
        theta = self.joint_coordinate(q)[:, :, None, None]  # (N, 3, 1, 1)
        centre, along_f, along_g = self.arm_ball_path
        f, g = self.chain.path_terms(theta)
        return centre + f * along_f + g * along_g

    def arm_ball_velocity(self, q: np.ndarray) -> np.ndarray:
        """dA_ij/dq_i: each arm ball's motion per unit of its own reading [mm/rad or mm/mm], (N, 3, 2, 3)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        theta = self.joint_coordinate(q)[:, :, None, None]
        _, along_f, along_g = self.arm_ball_path
        f, g = self.chain.path_slopes(theta)
        return self.joint_scale[None, :, None, None] * (f * along_f + g * along_g)

    @cached_property
    def arm_ball_path(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The arm balls' paths, ``A_ij = C_ij + f(θ_i) U_ij + g(θ_i) V_ij``: C, U, V, each (3, 2, 3).

        f and g are the chain's (:mod:`deltacal.chains`): cos and sin, or θ and 0.
        """
        path = self.chain.carried_points(self.axis_point, self._actuator_rotation, self.arm_ball)
        for v in path:
            v.setflags(write=False)  # cached by a frozen geometry: not to be changed through it
        return path

    @property
    def arm_ball_circle(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A revolute chain's arm-ball circles, ``A_ij = C_ij + cos θ_i U_ij + sin θ_i V_ij``: C, U, V.

        Raises:
            GeometryError: the chain is prismatic (its balls move on lines: :attr:`arm_ball_path`).
        """
        if self.chain.slides:
            raise GeometryError("a prismatic chain's balls move on lines, not circles: use arm_ball_path")
        return self.arm_ball_path

    def point(self, name: str) -> np.ndarray:
        """A named point of the plate in the plate frame [mm]; ``"tcp"`` is the tool."""
        if name == "tcp":
            return self.tool
        try:
            return self.points[name]
        except KeyError:
            known = ", ".join(["tcp", *self.points])
            raise GeometryError(f"unknown point {name!r}; known points: {known}") from None

    @property
    def point_names(self) -> list[str]:
        """Names of the plate points: ``tcp`` then the named points."""
        return ["tcp", *self.points]

    def moved_rigidly(self, rotation: np.ndarray, translation: np.ndarray) -> DeltaGeometry:
        """The same robot moved as one rigid body in {O}: ``x -> rotation @ x + translation``.

        The actuator axes (points and directions) turn and shift; each actuator frame
        turns rigidly, so where the derived zero direction (``r_i`` made orthogonal to the
        new axis) differs from the turned one, the difference goes into the encoder
        offset (a prismatic chain: into its carriage's balls, which a slide does not turn).
        Everything else held in the arm and plate frames is unchanged. At the same readings
        the plate of the moved robot is the moved plate.
        """
        R = np.asarray(rotation, dtype=float).reshape(3, 3)
        t = np.asarray(translation, dtype=float).reshape(3)
        turned = np.einsum("kl,ilm->ikm", R, self.actuator_rotation())
        moved = replace(self, axis_point=self.axis_point @ R.T + t, axis_direction=turned[:, :, 1])
        rel = np.einsum("ilk,ilm->ikm", moved.actuator_rotation(), turned)  # a rotation about y
        if self.chain.turns_balls:  # a carriage turned about its tower: its balls turn with it
            return replace(moved, arm_ball=np.einsum("ikl,ijl->ijk", rel, self.arm_ball))
        return replace(moved, encoder_offset=self.encoder_offset + np.arctan2(rel[:, 0, 2], rel[:, 0, 0]))

    # ------------------------------------------------------------ perturbation
    def with_tool(self, tool: np.ndarray) -> DeltaGeometry:
        """The same robot with another TCP in the plate frame [mm]."""
        return replace(self, tool=np.asarray(tool, dtype=float))

    def with_errors(self, errors: dict[str, float]) -> DeltaGeometry:
        """The robot with individual errors added, by name (see :func:`error_names` of its chain).

        Args:
            errors: Name to deviation, in [mm] or [rad] (``joint_scale``: no unit).

        Returns:
            A new geometry.
        """
        known = set(error_names(self.chain))
        wrong = [n for n in errors if _NAME_RE.match(n) is not None and n not in known]
        if wrong:
            raise GeometryError(f"error name {wrong[0]!r} does not apply to a {self.chain.name} chain")
        joint_scale = np.array(self.joint_scale)
        axis_point = np.array(self.axis_point)
        axis_direction = np.array(self.axis_direction)
        encoder_offset = np.array(self.encoder_offset)
        arm_ball = np.array(self.arm_ball)
        plate_ball = np.array(self.plate_ball)
        rod_length = np.array(self.rod_length)
        tool = np.array(self.tool)
        tilts = np.zeros((3, 2))
        for name, value in errors.items():
            m = _NAME_RE.match(name)
            if m is None:
                raise GeometryError(f"unknown error name {name!r}")
            value = float(value)
            if m.group("taxis"):
                tool[AXES.index(m.group("taxis"))] += value
                continue
            i = int(m.group("limb")) - 1
            if m.group("kind"):
                k = AXES.index(m.group("axis"))
                if m.group("kind") == "axis_point":
                    axis_point[i, k] += value
                elif m.group("ab"):
                    arm_ball[i, int(m.group("ab")) - 1, k] += value
                else:
                    plate_ball[i, int(m.group("pb")) - 1, k] += value
            elif m.group("rod"):
                rod_length[i, int(m.group("rod")) - 1] += value
            elif m.group("tilt"):
                tilts[i, 0 if m.group("tilt") == "r" else 1] += value
            elif m.group("offset"):
                encoder_offset[i] += value
            else:
                joint_scale[i] += value
        if np.any(tilts):
            r = self.radial
            second = self.chain.second_tilt_axis(self.tangent)
            rotvec = tilts[:, :1] * r + tilts[:, 1:] * second
            axis_direction = np.einsum("ikl,il->ik", rotation_from_vector(rotvec), axis_direction)
            axis_direction /= np.linalg.norm(axis_direction, axis=1, keepdims=True)
        return replace(
            self,
            axis_point=axis_point,
            axis_direction=axis_direction,
            encoder_offset=encoder_offset,
            arm_ball=arm_ball,
            plate_ball=plate_ball,
            rod_length=rod_length,
            tool=tool,
            joint_scale=joint_scale,
        )

    def perturbed(self, tolerances: Tolerances, rng: np.random.Generator) -> DeltaGeometry:
        """A random real robot around this one.

        Args:
            tolerances: Standard deviation of each class of error.
            rng: Random generator (pass a seeded one for reproducible robots).

        Returns:
            A new geometry.
        """
        errors: dict[str, float] = {}
        for name in error_names(self.chain):
            if name.startswith("tool."):
                sigma = tolerances.tool
            elif ".axis_point." in name:
                sigma = tolerances.axis_position
            elif ".axis_tilt_" in name:
                sigma = tolerances.axis_direction
            elif name.endswith("encoder_offset"):
                sigma = tolerances.encoder_offset
            elif name.endswith("joint_scale"):
                sigma = tolerances.joint_scale
            elif "_ball" in name:
                sigma = tolerances.ball_centre
            else:
                sigma = tolerances.rod_length
            errors[name] = float(rng.normal(0.0, sigma)) if sigma > 0.0 else 0.0
        return self.with_errors(errors)

    def deviation_from(self, other: DeltaGeometry) -> dict[str, float]:
        """Errors, by name, that turn ``other`` into this geometry (axis tilts to first order)."""
        out: dict[str, float] = {}
        dw = self.axis_direction - other.axis_direction
        r = other.radial
        w = other.axis_direction
        tilt = other.chain.tilt_letter
        second = other.chain.second_tilt_axis(other.tangent)
        for i in range(3):
            n = f"limb{i + 1}"
            for k, a in enumerate(AXES):
                out[f"{n}.axis_point.{a}"] = float(self.axis_point[i, k] - other.axis_point[i, k])
            # dw = (tilt_r r + tilt_2 s) x w to first order (s: z, or t_i for a tower)
            out[f"{n}.axis_tilt_r"] = float(np.dot(np.cross(w[i], dw[i]), r[i]))
            out[f"{n}.axis_tilt_{tilt}"] = float(np.dot(np.cross(w[i], dw[i]), second[i]))
            out[f"{n}.encoder_offset"] = float(self.encoder_offset[i] - other.encoder_offset[i])
            if other.chain.counts_steps:
                out[f"{n}.joint_scale"] = float(self.joint_scale[i] - other.joint_scale[i])
            for j in range(2):
                for k, a in enumerate(AXES):
                    out[f"{n}.arm_ball{j + 1}.{a}"] = float(
                        self.arm_ball[i, j, k] - other.arm_ball[i, j, k]
                    )
            for j in range(2):
                for k, a in enumerate(AXES):
                    out[f"{n}.plate_ball{j + 1}.{a}"] = float(
                        self.plate_ball[i, j, k] - other.plate_ball[i, j, k]
                    )
            for j in range(2):
                out[f"{n}.rod{j + 1}.length"] = float(
                    self.rod_length[i, j] - other.rod_length[i, j]
                )
        for k, a in enumerate(AXES):
            out[f"tool.{a}"] = float(self.tool[k] - other.tool[k])
        return out

    def is_perfect(self, atol: float = 1e-12) -> bool:
        """True if every parallelogram is perfect, so the plate never tilts."""
        R0 = self.actuator_rotation()
        arm_pair = np.einsum("ikl,il->ik", R0, self.arm_ball[:, 0] - self.arm_ball[:, 1])
        plate_pair = self.plate_ball[:, 0] - self.plate_ball[:, 1]
        return bool(
            np.allclose(arm_pair, plate_pair, rtol=0.0, atol=atol)
            and np.allclose(self.rod_length[:, 0], self.rod_length[:, 1], rtol=0.0, atol=atol)
        )

    def allclose(self, other: DeltaGeometry, atol: float = 0.0) -> bool:
        """True if every element equals the other's within ``atol`` (0: bit for bit)."""
        keys = (
            "limb_azimuth",
            "axis_point",
            "axis_direction",
            "encoder_offset",
            "arm_ball",
            "plate_ball",
            "rod_length",
            "tool",
            "joint_scale",
            "compliance",
        )
        if set(self.points) != set(other.points) or self.chain != other.chain or self.masses != other.masses:
            return False
        same = all(np.allclose(getattr(self, k), getattr(other, k), atol=atol, rtol=0) for k in keys)
        return same and all(
            np.allclose(self.points[k], other.points[k], atol=atol, rtol=0) for k in self.points
        )
