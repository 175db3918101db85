"""Klipper's model of a rotary Delta printer (``[printer] kinematics: rotary_delta``).

Klipper's meaning of its values (``klippy/kinematics/rotary_delta.py``, ``klippy/chelper/
kin_rotary_delta.c``, Config Reference "Rotary delta Kinematics"), in its frame (the bed's, the
nozzle's coordinates, z up, z = 0 the bed):

* ``shoulder_radius`` ρ: the horizontal circle of the three shoulder joints *minus* the effector
  joints' circle (a point effector, as the linear ``delta_radius``); shoulder i is at
  ``ρ (cos α_i, sin α_i, 0) + H z`` with ``angle`` α_i (30, 150, 270 deg unless given; stepper A
  rear right);
* ``shoulder_height`` H: the shoulders above the bed *minus* the effector's toolhead height (the
  nozzle below the effector joints);
* ``upper_arm_length`` L_i (stepper A's is every stepper's default) from the shoulder axis to the
  elbow, turning in the vertical plane through the shoulder and the z axis (the shoulder axis is
  horizontal, tangent to the circle); ``lower_arm_length`` l_i (A's the default) from the elbow to
  the effector point, which is the nozzle;
* the arm angle θ_i (the stepper's position, in radians): ``atan2`` of the elbow's height above the
  shoulder and its outward radial distance, so θ = 0 is the arm horizontal pointing outward and
  θ > 0 raises the elbow; of the two elbows that reach a point, the outer one (the larger
  ``cos θ``);
* ``position_endstop`` e_i [mm] (stepper A's the default for B and C): not an angle. The arm's
  endstop angle is the one Klipper's inverse kinematics gives for the nozzle at ``(0, 0, e_i)``;
  homing leaves every arm at its endstop angle, the nozzle at the forward kinematics of those
  angles (``home_position``); Klipper's top is ``max_z = min(e_i)``;
* the step distance ``d_i = 2π / (full_steps_per_rotation × microsteps × gear ratio)`` [rad]
  (``gear_ratio`` is required, ``rotation_distance`` not allowed); a stepper's steps from its
  endstop are ``(θ_end,i − θ_i) / d_i``: positive steps lower the arm.

Limits (``RotaryDeltaKinematics``): ``max_xy = min(min(ρ + L_i), min(l_i − ρ))`` (the radius),
``limit_z = min(elbow height at the endstop − l_i)`` above which the radius tapers to ``max_z − Z``,
``minimum_z_position`` (default 0, at most ``max_z``).

deltacal's rotary frame (conventions) and Klipper's, for the perfect printer built to these values
with effector radius a, rod spacing c and nozzle drop h:

* base radius ``b = ρ + a``, plate radius a, arm length ``L_i``, rod length ``l_i``, limb azimuth
  α_i, tool ``(0, 0, −h)``;
* deltacal's base frame {O} has its origin at the shoulders' centre, Klipper's bed frame is {O}
  moved down by ``H + h``: a point ``x_K`` in Klipper's frame is ``x_K − (H + h) z`` in {O};
* deltacal's arm angle q (``q > 0`` lowers the arm tip) is ``−θ``; both pick the outer elbow.

Units: mm; angles of the dataclass in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ....exceptions import AssemblyError, GeometryError, UnreachableError
from ....geometry import DeltaGeometry, radial_vectors, tangent_vectors
from ....kinematics.closed_form import VirtualDelta
from .model import limits_refusal, move_check

#: Klipper's arm angles when a ``[stepper_*]`` gives none [deg] (steppers A, B, C).
ROTARY_ANGLES_DEG = (30.0, 150.0, 270.0)


def arm_angles(radius: float, height: float, angle: np.ndarray, upper: np.ndarray, lower: np.ndarray,
               targets: np.ndarray) -> np.ndarray:
    """Klipper's arm angles θ_i of nozzle targets for these values [rad], (N, 3) -> (N, 3), NaN out of reach.

    Each target in the shoulder's frame: ``sjx`` outward from the shoulder, ``sjy`` up from it,
    ``sjz`` along its axis; the lower arm's reach in the arm's plane is then ``sqrt(l² − sjz²)``
    and the elbow the outer intersection of the two circles (``kin_rotary_delta.c``).
    """
    x, y, z = (targets[:, k : k + 1] for k in range(3))
    cos, sin = np.cos(angle), np.sin(angle)
    sjz = y * cos - x * sin
    sjx = x * cos + y * sin - radius
    sjy = z - height
    upper2 = upper**2
    lower2 = lower**2 - sjz * sjz
    with np.errstate(invalid="ignore", divide="ignore"):
        inv_dy = 1.0 / sjy
        c1 = 0.5 * inv_dy * (sjx * sjx + sjy * sjy + upper2 - lower2)
        c2 = sjx * inv_dy
        scale = c2 * c2 + 1.0
        scaled_x = c1 * c2 + np.sqrt(scale * upper2 - c1 * c1)
        scaled_y = c1 * scale - c2 * scaled_x
        theta = np.arctan2(scaled_y, scaled_x)
    return np.where(np.isfinite(scaled_x) & np.isfinite(scaled_y), theta, np.nan)


def trilaterate(elbows: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """The point at the lower arms' lengths from the elbows [mm], (N, 3 limbs, 3) -> (N, 3), NaN where none.

    Klipper's ``mathutil.trilateration``: the solution on the side of ``(e2 − e1) × (e3 − e1)``
    taken negative.
    """
    e = elbows
    r2 = lower**2
    s21, s31 = e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]
    d = np.linalg.norm(s21, axis=1, keepdims=True)
    ex = s21 / d
    i = np.sum(ex * s31, axis=1, keepdims=True)
    ey = s31 - ex * i
    ey /= np.linalg.norm(ey, axis=1, keepdims=True)
    ez = np.cross(ex, ey)
    j = np.sum(ey * s31, axis=1, keepdims=True)
    px = (r2[0] - r2[1] + d**2) / (2.0 * d)
    py = (r2[0] - r2[2] - px**2 + (px - i) ** 2 + j**2) / (2.0 * j)
    with np.errstate(invalid="ignore"):
        pz = -np.sqrt(r2[0] - px**2 - py**2)
    return e[:, 0] + ex * px + ey * py + ez * pz


@dataclass(frozen=True, eq=False)
class KlipperRotaryDelta:
    """Klipper's rotary delta kinematics with its configuration's values.

    Attributes:
        shoulder_radius: ρ [mm].
        shoulder_height: H [mm].
        angle: The arms' azimuths α_i [rad], (3,).
        upper_arm: L_i [mm], (3,).
        lower_arm: l_i [mm], (3,).
        position_endstop: e_i [mm] (a height, not an angle), (3,).
        step_distance: d_i, arm rotation per (micro)step [rad], (3,).
        name: A name (the configuration file).
        minimum_z_position: ``[printer] minimum_z_position`` [mm] (Klipper's default 0).
    """

    shoulder_radius: float
    shoulder_height: float
    angle: np.ndarray
    upper_arm: np.ndarray
    lower_arm: np.ndarray
    position_endstop: np.ndarray
    step_distance: np.ndarray
    name: str = ""
    minimum_z_position: float = 0.0

    def __post_init__(self) -> None:
        for key in ("angle", "upper_arm", "lower_arm", "position_endstop", "step_distance"):
            value = np.array(getattr(self, key), dtype=float).reshape(-1)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be 3 finite values, got {getattr(self, key)!r}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        for key in ("shoulder_radius", "shoulder_height"):
            value = getattr(self, key)
            if not (math.isfinite(value) and value > 0.0):
                raise GeometryError(f"{key} must be a positive length, got {value!r}")
        for key in ("upper_arm", "lower_arm", "step_distance"):
            if np.any(getattr(self, key) <= 0.0):
                raise GeometryError(f"{key} must be positive, got {getattr(self, key).tolist()}")
        if not math.isfinite(self.minimum_z_position):
            raise GeometryError(f"minimum_z_position must be finite, got {self.minimum_z_position!r}")

    # ----------------------------------------------------------- kinematics
    def shoulder_angles(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Klipper's arm angles θ_i for nozzle targets [rad], (N, 3) -> (N, 3) (:func:`arm_angles`).

        Raises:
            UnreachableError: a target no arm reaches (``check``; else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        theta = arm_angles(self.shoulder_radius, self.shoulder_height, self.angle, self.upper_arm,
                           self.lower_arm, targets)
        if check:
            bad = ~np.all(np.isfinite(theta), axis=1)
            if np.any(bad):
                raise UnreachableError.from_mask(bad, targets)
        return theta

    def elbows(self, angles: np.ndarray) -> np.ndarray:
        """Elbow positions at arm angles θ [mm], (N, 3) -> (N, 3 limbs, 3) (``elbow_coord``)."""
        angles = np.atleast_2d(np.asarray(angles, dtype=float))
        out = self.shoulder_radius + self.upper_arm * np.cos(angles)
        up = self.shoulder_height + self.upper_arm * np.sin(angles)
        return np.stack([out * np.cos(self.angle), out * np.sin(self.angle), up], axis=-1)

    def positions(self, angles: np.ndarray, check: bool = True) -> np.ndarray:
        """Klipper's nozzle positions at arm angles θ [mm], (N, 3) -> (N, 3) (:func:`trilaterate`).

        The three spheres of radii l_i about the elbows (the solution below the elbows for arms in
        counter-clockwise order).

        Raises:
            AssemblyError: angles where the spheres do not meet (``check``; else NaN rows).
        """
        angles = np.atleast_2d(np.asarray(angles, dtype=float))
        x = trilaterate(self.elbows(angles), self.lower_arm)
        if check:
            bad = ~np.all(np.isfinite(x), axis=1)
            if np.any(bad):
                idx = np.flatnonzero(bad)
                raise AssemblyError(f"no assembly at {idx.size} arm angle(s), first: "
                                    f"{np.degrees(angles[idx[0]]).round(6).tolist()} deg", idx, angles[idx])
        return x

    @cached_property
    def endstop_angles(self) -> np.ndarray:
        """Each arm's angle at its endstop: its θ_i for the nozzle at ``(0, 0, e_i)`` [rad], (3,)."""
        centre = np.zeros((3, 3))
        centre[:, 2] = self.position_endstop
        return np.diagonal(self.shoulder_angles(centre)).copy()

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps from the endstops Klipper commands for nozzle targets, ``(θ_end − θ) / d``, (N, 3)."""
        return (self.endstop_angles - self.shoulder_angles(targets, check)) / self.step_distance

    def step_positions(self, steps: np.ndarray, check: bool = True) -> np.ndarray:
        """Klipper's nozzle positions at steps from the endstops [mm], (N, 3) -> (N, 3)."""
        steps = np.atleast_2d(np.asarray(steps, dtype=float))
        return self.positions(self.endstop_angles - steps * self.step_distance, check)

    # --------------------------------------------------------------- limits
    @cached_property
    def home_position(self) -> np.ndarray:
        """Where homing leaves the nozzle: every arm at its endstop angle [mm], (3,)."""
        return self.positions(self.endstop_angles)[0]

    @cached_property
    def max_z(self) -> float:
        """Klipper's highest Z: the lowest ``position_endstop`` [mm]."""
        return float(np.min(self.position_endstop))

    @cached_property
    def max_radius(self) -> float:
        """Klipper's radius ``max_xy = min(min(ρ + L_i), min(l_i − ρ))`` [mm]."""
        rho = self.shoulder_radius
        return float(min(np.min(rho + self.upper_arm), np.min(self.lower_arm - rho)))

    @cached_property
    def limit_z(self) -> float:
        """Z above which Klipper tapers the radius: ``min(elbow height at the endstop − l_i)`` [mm]."""
        elbows = self.elbows(self.endstop_angles)[0]
        return float(np.min(elbows[:, 2] - self.lower_arm))

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which limit each command (a move's end, as Klipper reads it) breaks: 0 none, else a code.

        ``RotaryDeltaKinematics.check_move`` of a homed printer: the codes of
        :func:`~.model.move_check` with :attr:`max_radius` and :attr:`limit_z`.
        """
        return move_check(commands, self.minimum_z_position, self.max_z, self.max_radius, self.limit_z,
                          self.home_position)

    def refusal(self, commands: np.ndarray) -> str:
        """What Klipper refuses of commands outside its limits, and the key and value that admit them.

        Names the first command's limit (and then each other limit broken).

        Args:
            commands: Commands :meth:`outside` refuses [mm], (N, 3), the first the one to name.
        """
        return limits_refusal(self, commands, self._beyond_radius)

    def _beyond_radius(self, commands: np.ndarray, of: str) -> str:
        """The radius limit's refusal: the arms' reach, which no key admits."""
        return (f"corrected point's radius {math.hypot(*commands[0, :2]):.4f} mm is beyond "
                f"{self.max_radius:.2f} mm, Klipper's rotary max_xy{of} (the arms' reach: "
                "min(shoulder_radius + upper_arm_length, lower_arm_length - shoulder_radius)): no key admits "
                "it: keep the program within it")

    # ---------------------------------------------------- as a controller
    @cached_property
    def virtual(self) -> VirtualDelta:
        """Klipper's model as a revolute :class:`VirtualDelta` in its own frame (the bed's), readings q = −θ.

        Shoulder axes through ``ρ r_i + H z`` along ``t_i``, elbows at ``L_i`` on the arms, a point
        effector (the nozzle) on rods ``l_i``: :meth:`geometry` with no effector and no nozzle drop,
        moved up by ``H``.
        """
        virtual = VirtualDelta.from_geometry(self.geometry(0.0, 1.0, 0.0))
        axis = np.array(virtual.axis_point)
        axis[:, 2] += self.shoulder_height
        return replace(virtual, axis_point=axis)

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Deltacal's readings ``q = −θ`` Klipper commands for nozzle targets in its frame [rad], (N, 3)."""
        return self.readings(self.shoulder_angles(targets, check))

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """Klipper's nozzle positions at deltacal's readings ``q = −θ`` [mm], (N, 3) (its trilateration)."""
        return self.positions(self.readings(readings), check)

    # ----------------------------------------------------- deltacal's terms
    def base_height(self, nozzle_drop: float) -> float:
        """The shoulders' plane above Klipper's bed, ``H + h`` [mm]: {O} is the bed frame moved up by it."""
        return self.shoulder_height + float(nozzle_drop)

    def to_base(self, points: np.ndarray, nozzle_drop: float) -> np.ndarray:
        """Points of Klipper's frame in deltacal's base frame {O} [mm], (N, 3)."""
        points = np.array(np.atleast_2d(points), dtype=float)
        points[:, 2] -= self.base_height(nozzle_drop)
        return points

    @staticmethod
    def readings(angles: np.ndarray) -> np.ndarray:
        """Deltacal's arm readings q of Klipper's angles θ: ``q = −θ`` [rad] (q > 0 lowers the arm)."""
        return -np.asarray(angles, dtype=float)

    def geometry(self, effector_radius: float, rod_spacing: float, nozzle_drop: float) -> DeltaGeometry:
        """The perfect rotary Delta whose nozzle Klipper's model describes exactly, in {O}.

        Shoulder axes through ``(ρ + a) r_i`` along ``t_i``, elbows' ball pair at ``L_i`` on the arm
        (``± c/2`` along the axis), the effector's at ``a r_i ± c/2 t_i``, rods l_i, the nozzle
        ``h`` below the effector's ball plane.
        """
        a, half = float(effector_radius), 0.5 * float(rod_spacing)
        r, t = radial_vectors(self.angle), tangent_vectors(self.angle)
        arm_ball = np.zeros((3, 2, 3))
        arm_ball[:, 0, 0] = arm_ball[:, 1, 0] = self.upper_arm
        arm_ball[:, 0, 1], arm_ball[:, 1, 1] = half, -half
        return DeltaGeometry(
            limb_azimuth=np.array(self.angle), axis_point=(self.shoulder_radius + a) * r,
            axis_direction=t, encoder_offset=np.zeros(3), arm_ball=arm_ball,
            plate_ball=np.stack([a * r + half * t, a * r - half * t], axis=1),
            rod_length=np.repeat(self.lower_arm[:, None], 2, axis=1),
            tool=np.array([0.0, 0.0, -float(nozzle_drop)]),
            name=self.name)
