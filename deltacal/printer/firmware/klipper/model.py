"""Klipper's model of a linear Delta printer (``[printer] kinematics: delta``): the firmware as a controller.

Klipper's meaning of its values (Config Reference, ``klippy/kinematics/delta.py``), in its frame
(the bed's, the nozzle's coordinates):

* ``delta_radius`` ρ: horizontal distance from each tower's carriage point to the effector point
  when the effector is centred; tower i is at ``ρ (cos α_i, sin α_i)`` with ``angle`` α_i
  (210, 330 and 90 deg unless given);
* ``arm_length`` ℓ_i: the rod from the carriage point to the effector point (a point effector, one
  rod per tower);
* ``position_endstop`` e_i: the nozzle's height when the nozzle is centred and the carriage at its
  endstop, so the carriage point's height at the endstop is ``E_i = e_i + sqrt(ℓ_i² − ρ²)``;
* the step distance ``d_i = rotation_distance / (full_steps_per_rotation × microsteps × gear
  ratio)``.

Inverse kinematics: carriage height ``h_i = sqrt(ℓ_i² − (x − X_i)² − (y − Y_i)²) + z`` and steps
below the endstop ``(E_i − h_i) / d_i``. Forward: the trilateration of the three spheres of radii
ℓ_i about ``(X_i, Y_i, E_i − n_i d_i)``, the solution below them. deltacal's readings of a printer
are travels below the endstops counted in its nominal step distance (:mod:`deltacal.printer.robot`):
reading = steps × that step distance. Units: mm (angles of the dataclass in rad).

In deltacal's terms Klipper's model is the perfect printer (:meth:`KlipperDelta.from_printer`) with
``ρ = R − a`` (tower radius minus effector radius), ``ℓ = l``, ``E = H + nozzle_z`` and no
horizontal nozzle offset.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ....chains import PRISMATIC
from ....exceptions import GeometryError, UnreachableError
from ....geometry import DeltaGeometry, radial_vectors
from ....kinematics.closed_form import VirtualDelta
from ....towers import per_tower
from ...robot import NominalLinearDelta

#: Klipper's tower angles when a ``[stepper_*]`` gives none [deg] (towers A, B, C).
DEFAULT_ANGLES_DEG = (210.0, 330.0, 90.0)
#: Klipper's full steps per rotation when a ``[stepper_*]`` gives none.
DEFAULT_FULL_STEPS = 200


@dataclass(frozen=True, eq=False)
class KlipperDelta:
    """Klipper's delta kinematics with its configuration's values.

    Attributes:
        delta_radius: ρ [mm].
        angle: Tower angles α_i [rad], (3,).
        arm_length: ℓ_i [mm], (3,).
        position_endstop: e_i [mm], (3,).
        step_distance: d_i, carriage travel per (micro)step [mm], (3,).
        name: A name (the configuration file).
    """

    delta_radius: float
    angle: np.ndarray
    arm_length: np.ndarray
    position_endstop: np.ndarray
    step_distance: np.ndarray = field(default_factory=lambda: np.full(3, 0.0125))
    name: str = ""

    def __post_init__(self) -> None:
        for key in ("angle", "arm_length", "position_endstop", "step_distance"):
            value = np.array(getattr(self, key), dtype=float).reshape(-1)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be 3 finite values, got {getattr(self, key)!r}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        if not np.isfinite(self.delta_radius) or self.delta_radius <= 0.0:
            raise GeometryError(f"delta_radius must be a positive length, got {self.delta_radius!r}")
        if np.any(self.arm_length <= self.delta_radius):
            raise GeometryError(f"arm_length must be above delta_radius {self.delta_radius}, "
                                f"got {self.arm_length.tolist()}")
        if np.any(self.step_distance <= 0.0):
            raise GeometryError(f"step_distance must be positive, got {self.step_distance.tolist()}")

    @classmethod
    def from_printer(cls, printer: NominalLinearDelta, name: str = "") -> KlipperDelta:
        """The configuration that makes Klipper's model the perfect printer built to these values.

        Raises:
            GeometryError: the nozzle is off the effector's axis (Klipper's point effector has no
                horizontal nozzle offset).
        """
        if np.any(printer.tool[:2] != 0.0):
            raise GeometryError(f"Klipper's model has no horizontal nozzle offset; the nozzle is at "
                                f"{printer.tool.tolist()} mm in the effector frame")
        radius = printer.tower_radius - printer.effector_radius
        carriage_top = printer.endstop_height + float(printer.tool[2])  # per tower
        endstop = carriage_top - np.sqrt(printer.rod_length**2 - radius**2)
        return cls(radius, np.array(printer.tower_azimuth), np.array(printer.rod_length), endstop,
                   np.array(printer.step_distance), name or printer.name)

    @classmethod
    def from_geometry(cls, geometry: DeltaGeometry, name: str = "") -> KlipperDelta:
        """Klipper's values of a printer's geometry at its tolerances' centre (a fit's start).

        Each tower's carriage point is its ball-pair midpoint less the effector's, plus the
        nozzle: the radius and angle of its horizontal part, its height at the endstop ``E_i``
        (``position_endstop = E_i − sqrt(ℓ_i² − ρ²)``); ℓ_i the mean of the pair's rods; the
        geometry's nominal step distance. Exact for a perfect printer (as :meth:`from_printer`);
        for a real one a start that :func:`~deltacal.printer.firmware.klipper.fit.fit_klipper` refines.

        Raises:
            GeometryError: not a printer (a prismatic chain), no step distance, or a nozzle off
                the effector's axis.
        """
        if not geometry.chain.firmware or geometry.step_distance is None:
            raise GeometryError("Klipper's values need a printer's geometry (a prismatic chain) with its "
                                "step distance")
        if np.any(geometry.tool[:2] != 0.0):
            raise GeometryError(f"Klipper's model has no horizontal nozzle offset; the nozzle is at "
                                f"{geometry.tool.tolist()} mm in the effector frame")
        rotation = geometry.actuator_rotation()
        carriage = geometry.axis_point + np.einsum("ikl,il->ik", rotation, geometry.arm_ball.mean(axis=1))
        point = carriage - geometry.plate_ball.mean(axis=1) + geometry.tool
        radius = float(np.mean(np.linalg.norm(point[:, :2], axis=1)))
        arm = geometry.rod_length.mean(axis=1)
        return cls(radius, np.mod(np.arctan2(point[:, 1], point[:, 0]), 2.0 * np.pi), arm,
                   point[:, 2] - np.sqrt(arm**2 - radius**2), np.array(geometry.step_distance),
                   name or geometry.name)

    @cached_property
    def towers(self) -> np.ndarray:
        """Tower positions ``(X_i, Y_i)`` [mm], (3, 2)."""
        towers = self.delta_radius * radial_vectors(self.angle)[:, :2]
        towers.setflags(write=False)
        return towers

    @cached_property
    def carriage_top(self) -> np.ndarray:
        """Carriage point heights at the endstops, ``E_i = e_i + sqrt(ℓ_i² − ρ²)`` [mm], (3,)."""
        top = self.position_endstop + np.sqrt(self.arm_length**2 - self.delta_radius**2)
        top.setflags(write=False)
        return top

    def carriage_heights(self, targets: np.ndarray) -> np.ndarray:
        """Klipper's carriage heights ``h_i`` for nozzle targets [mm], (N, 3) -> (N, 3); NaN out of reach."""
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        dx = targets[:, None, 0] - self.towers[None, :, 0]
        dy = targets[:, None, 1] - self.towers[None, :, 1]
        with np.errstate(invalid="ignore"):
            return np.sqrt(self.arm_length**2 - dx * dx - dy * dy) + targets[:, 2:3]

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps below the endstops Klipper commands for nozzle targets [mm], (N, 3) -> (N, 3).

        Raises:
            UnreachableError: a target no rod reaches (``check``; else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        steps = (self.carriage_top - self.carriage_heights(targets)) / self.step_distance
        if check:
            bad = ~np.all(np.isfinite(steps), axis=1)
            if np.any(bad):
                raise UnreachableError.from_mask(bad, targets)
        return steps

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Deltacal's readings (steps × the printer's nominal ``step_distance``) for targets, (N, 3) [mm].

        ``step_distance`` is each tower's (3,), or one number for the three.
        """
        return self.steps(targets, check) * step_distance

    @cached_property
    def virtual(self) -> VirtualDelta:
        """Klipper's model as a prismatic :class:`VirtualDelta` whose readings are steps.

        Carriage point ``(X_i, Y_i, E_i)`` at the endstop, sliding down z by ``d_i`` per step,
        a point effector (attachment and elbow at the origins), rods ℓ_i.
        """
        r = radial_vectors(self.angle)
        z = np.tile([0.0, 0.0, 1.0], (3, 1))
        axis_point = np.column_stack([self.towers, self.carriage_top])
        return VirtualDelta(
            axis_point=axis_point,
            actuator_rotation=np.stack([r, z, np.cross(r, z)], axis=-1),
            encoder_offset=np.zeros(3),
            elbow=np.zeros((3, 3)),
            plate_attachment=np.zeros((3, 3)),
            rod_length=np.array(self.arm_length),
            chain=PRISMATIC,
            joint_scale=np.array(self.step_distance),
        )

    def positions(self, steps: np.ndarray, check: bool = True) -> np.ndarray:
        """Klipper's nozzle positions at steps below the endstops, (N, 3) -> (N, 3) [mm] (trilateration).

        Raises:
            AssemblyError: steps where the three spheres do not meet (``check``; else NaN rows).
        """
        return self.virtual.forward(steps, check=check)

    def forward(self, readings: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Nozzle positions at deltacal's readings (travels in the towers' ``step_distance``), (N, 3) [mm]."""
        return self.positions(np.atleast_2d(np.asarray(readings, dtype=float)) / step_distance, check)


@dataclass(frozen=True, eq=False)
class KlipperController:
    """Klipper as a controller of a printer whose readings count steps in ``step_distance``.

    The firmware (:class:`KlipperDelta`) commands steps; deltacal's readings of a printer are
    travels below the endstops counted in the printer's nominal step distance
    (:mod:`deltacal.printer.robot`), reading = steps × ``step_distance``. This pairs the two, so that
    Klipper serves :func:`~deltacal.controller.corrected_targets` and the G-code route as a
    rotary :class:`~deltacal.controller.Controller` does.

    Attributes:
        firmware: Klipper's model, from its configuration.
        step_distance: The step distance each tower's readings count in [mm], (3,) (a number
            broadcasts): the printer's nominal ones, ``NominalLinearDelta.step_distance``, those its
            identification read measurements in.
    """

    firmware: KlipperDelta
    step_distance: np.ndarray

    #: How the controller moves between two targets: Klipper plans each move as a straight line
    #: in its Cartesian frame and its kinematics maps every step on the way (delta.py).
    interpolation = "cartesian"

    def __post_init__(self) -> None:
        object.__setattr__(self, "step_distance", per_tower("step_distance", self.step_distance))

    @property
    def name(self) -> str:
        """The configuration's name."""
        return self.firmware.name

    @property
    def tool(self) -> np.ndarray:
        """Klipper's targets are the nozzle's: no tool offset on its model [mm], (3,)."""
        return np.zeros(3)

    @cached_property
    def virtual(self) -> VirtualDelta:
        """Klipper's model as a prismatic :class:`VirtualDelta` whose readings are deltacal's [mm]."""
        return replace(self.firmware.virtual, joint_scale=self.firmware.step_distance / self.step_distance)

    @cached_property
    def home(self) -> np.ndarray:
        """Where Klipper puts the nozzle after homing: every carriage at its endstop [mm], (3,)."""
        return self.firmware.positions(np.zeros((1, 3)))[0]

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """The readings Klipper commands for nozzle targets [mm], (N, 3) -> (N, 3) [mm]."""
        return self.firmware.inverse(targets, self.step_distance, check)

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """The nozzle position Klipper's model puts at readings [mm], (N, 3) -> (N, 3) [mm]."""
        return self.firmware.forward(readings, self.step_distance, check)
