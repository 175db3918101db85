"""RepRapFirmware's model of a linear Delta printer (``M665``/``M666``): the firmware as a controller.

RepRapFirmware 3.x's meaning of its values (``src/Movement/Kinematics/LinearDeltaKinematics.cpp``
and ``.h``), in its frame (the bed's, the nozzle's coordinates):

* ``M665 L`` ℓ_i: the diagonal rod of tower i, from the carriage point to the effector point (a
  point effector; ``L a:b:c`` per tower, one number for the three);
* ``M665 R`` ρ: the delta radius, horizontal distance from each carriage point to the effector
  point when the effector is centred;
* ``M665 X Y Z`` δ_i: tower angle corrections [deg]; ``Recalc()`` puts tower A at
  ``-ρ (cos(30 + δ_a), sin(30 + δ_a))``, B at ``ρ (cos(30 − δ_b), −sin(30 − δ_b))``, C at
  ``ρ (−sin δ_c, cos δ_c)``: each at azimuth (210, 330, 90) deg + δ_i, counter-clockwise positive;
* ``M665 H``: the homed height, the nozzle's height with every carriage at its endstop (towers
  and endstops equal); ``M666 X Y Z`` e_i: endstop adjustments [mm], either sign, added to the
  tower's carriage height at its endstop: ``homedCarriageHeights[i] = H + sqrt(ℓ_i² − ρ²) + e_i``
  (RRF's ``M666 X+a`` raises tower A's endstop: Marlin's ``M666 X-a``);
* ``M666 A B``: the bed tilt in percent, ``xTilt = A / 100``, ``yTilt = B / 100``: how much Z is
  raised per unit of movement in +X and +Y (``Transform()`` adds ``x xTilt + y yTilt`` to every
  carriage height, ``ForwardTransform()`` subtracts it from z);
* ``M665 B``: the print radius, beyond which ``LimitPosition()`` scales X, Y back onto it (it
  also sets the X, Y axis limits that DWC shows);
* ``M92 X Y Z``: steps per mm of each tower's motor (``Platform::SetDriveStepsPerUnit``), the
  step distance ``d_i = 1 / M92``;
* ``M208 Z`` (its minimum, ``S1`` or ``Zmin:max``): the lowest Z ``LimitPosition()`` allows;
  ``M564 S0`` turns those limits (print radius and Z minimum) off.

Inverse kinematics (``Transform``): carriage height ``h_i = sqrt(ℓ_i² − (x − X_i)² − (y − Y_i)²)
+ z + x xTilt + y yTilt``; the motor stands at ``h_i × M92_i`` steps, at
``homedCarriageHeights[i] × M92_i`` on its endstop (``OnHomingSwitchTriggered``), so the steps
below the endstop are ``(homedCarriageHeights[i] − h_i) / d_i``. Forward (``ForwardTransform``):
the trilateration of the three spheres of radii ℓ_i about ``(X_i, Y_i, h_i)``, the solution below
them, less the tilt. After homing every carriage is at its endstop (``G1 H1`` in ``homedelta.g``)
and the nozzle where the forward transform puts those heights. deltacal's readings of a printer
are travels below the endstops counted in its nominal step distance: reading = steps × that step
distance. Units: mm (the dataclass's angles in rad; the configuration's in degrees).

In deltacal's terms RRF's model of the perfect printer (:meth:`RRFDelta.from_printer`) has
``ρ = R − a``, ``ℓ = l``, ``H + sqrt(ℓ² − ρ²) + e_i = H_i + nozzle_z``, no tilt and no horizontal
nozzle offset: with equal towers and no tilt it is Klipper's model.

RRF's limits (``LimitPosition``, with ``M564 S1``, the default): a move beyond the print radius is
scaled back onto it, below the ``M208`` Z minimum raised to it, and one that would lift a carriage
above its endstop lowered: RRF moves elsewhere rather than refusing, so deltacal refuses such a
corrected command itself (:meth:`RRFDelta.outside`), naming the key that admits it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ....exceptions import GeometryError
from ....geometry import DeltaGeometry
from ....kinematics.closed_form import VirtualDelta
from ....towers import per_tower
from ...robot import NominalLinearDelta
from ..classical import (
    carriage_points,
    carriage_tops,
    checked_steps,
    home_position,
    on_axis,
    point_effector,
    rod_rise,
    tower_positions,
)
from ..controller import FirmwareController

#: RRF's tower azimuths before the angle corrections [deg] (towers A, B, C: ``Recalc()``).
BASE_ANGLES_DEG = (210.0, 330.0, 90.0)
#: RRF's defaults (``LinearDeltaKinematics.h``): diagonal, delta radius, print radius, homed height [mm].
DEFAULT_DIAGONAL = 215.0
DEFAULT_RADIUS = 105.6
DEFAULT_PRINT_RADIUS = 80.0
DEFAULT_HOMED_HEIGHT = 240.0
#: RRF's default microstepping (``Platform::Init``: x16 with interpolation).
DEFAULT_MICROSTEPPING = 16
#: Codes of :meth:`RRFDelta.outside`: the limit a command breaks (0: none), in the order checked.
BELOW_MIN_Z, BEYOND_RADIUS, ABOVE_ENDSTOP = 1, 2, 3
#: The step of a limit's value a refusal asks for [mm] (rounded away from the commands).
LIMIT_STEP_MM = 0.01


@dataclass(frozen=True, eq=False)
class RRFDelta:
    """RepRapFirmware's linear delta kinematics with its configuration's values.

    Attributes:
        diagonal: ``M665 L``: ℓ_i [mm], (3,).
        radius: ``M665 R``: ρ [mm].
        homed_height: ``M665 H`` [mm].
        angle_correction: ``M665 X Y Z``: δ_i [rad], (3,).
        endstop_adjustment: ``M666 X Y Z``: e_i [mm], (3,).
        tilt: ``M666 A B`` / 100: (xTilt, yTilt), Z raised per mm of +X and +Y, (2,).
        step_distance: ``1 / M92 X Y Z``: d_i, carriage travel per (micro)step [mm], (3,).
        print_radius: ``M665 B`` [mm].
        z_min: ``M208`` Z minimum [mm].
        limit_axes: ``M564 S`` (default on): whether RRF limits moves to B and the Z minimum.
        name: A name (the configuration file).
    """

    diagonal: np.ndarray
    radius: float
    homed_height: float
    angle_correction: np.ndarray = field(default_factory=lambda: np.zeros(3))
    endstop_adjustment: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tilt: np.ndarray = field(default_factory=lambda: np.zeros(2))
    step_distance: np.ndarray = field(default_factory=lambda: np.full(3, 0.0125))
    print_radius: float = DEFAULT_PRINT_RADIUS
    z_min: float = 0.0
    limit_axes: bool = True
    name: str = ""

    def __post_init__(self) -> None:
        for key, size in (
            ("diagonal", 3),
            ("angle_correction", 3),
            ("endstop_adjustment", 3),
            ("tilt", 2),
            ("step_distance", 3),
        ):
            value = np.array(getattr(self, key), dtype=float).reshape(-1)
            if value.size == 1 and key == "diagonal":
                value = np.repeat(value, 3)
            if value.shape != (size,) or not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be {size} finite values, got {getattr(self, key)!r}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        for key in ("radius", "print_radius"):
            value = getattr(self, key)
            if not (math.isfinite(value) and value > 0.0):
                raise GeometryError(f"{key} must be a positive length, got {value!r}")
        for key in ("homed_height", "z_min"):
            if not math.isfinite(getattr(self, key)):
                raise GeometryError(f"{key} must be finite, got {getattr(self, key)!r}")
        if np.any(self.diagonal <= self.radius):
            raise GeometryError(
                f"the diagonals must be longer than the delta radius {self.radius}, "
                f"got {self.diagonal.tolist()}"
            )
        if np.any(self.step_distance <= 0.0):
            raise GeometryError(f"step_distance must be positive, got {self.step_distance.tolist()}")

    @classmethod
    def from_carriages(
        cls,
        radius: float,
        angle: np.ndarray,
        diagonal: np.ndarray,
        carriage_top: np.ndarray,
        step_distance: np.ndarray,
        name: str = "",
        **limits,
    ) -> RRFDelta:
        """The values whose towers stand at ``angle`` [rad], carriage points at ``carriage_top`` [mm].

        The endstop adjustments are made to average zero, as RRF's ``NormaliseEndstopAdjustments()``
        leaves them, the homed height taking their mean; no tilt.
        """
        diagonal = per_tower("diagonal", diagonal)
        base = np.asarray(carriage_top, dtype=float) - np.sqrt(diagonal**2 - radius**2)
        height = float(np.mean(base))
        correction = np.radians(np.asarray(BASE_ANGLES_DEG))
        correction = np.mod(np.asarray(angle, dtype=float) - correction + np.pi, 2.0 * np.pi) - np.pi
        return cls(
            diagonal,
            float(radius),
            height,
            correction,
            base - height,
            step_distance=step_distance,
            name=name,
            **limits,
        )

    @classmethod
    def from_printer(cls, printer: NominalLinearDelta, name: str = "") -> RRFDelta:
        """The values that make RRF's model the perfect printer built to these values.

        The print radius is the printer's printable radius (``[workspace] radius_mm``), else RRF's
        default.

        Raises:
            GeometryError: the nozzle is off the effector's axis (RRF's point effector has none).
        """
        on_axis(printer.tool, "RepRapFirmware")
        radius = printer.tower_radius - printer.effector_radius
        top = printer.endstop_height + float(printer.tool[2])
        limits = {"print_radius": printer.workspace.radius} if printer.workspace is not None else {}
        return cls.from_carriages(
            radius,
            np.array(printer.tower_azimuth),
            np.array(printer.rod_length),
            np.broadcast_to(top, 3),
            np.array(printer.step_distance),
            name or printer.name,
            **limits,
        )

    @classmethod
    def from_geometry(cls, geometry: DeltaGeometry, name: str = "") -> RRFDelta:
        """RRF's values of a printer's geometry at its tolerances' centre (a fit's start).

        As :meth:`KlipperDelta.from_geometry <..klipper.model.KlipperDelta.from_geometry>`: each
        tower's carriage point is its ball-pair midpoint less the effector's, plus the nozzle; ρ the
        mean radius of their horizontal parts, the angle corrections their azimuths less (210, 330,
        90) deg, ℓ_i the pair's mean rod; no tilt.

        Raises:
            GeometryError: not a printer (a prismatic chain), no step distance, or a nozzle off
                the effector's axis.
        """
        point, radius = carriage_points(geometry, "RepRapFirmware")
        return cls.from_carriages(
            radius,
            np.arctan2(point[:, 1], point[:, 0]),
            geometry.rod_length.mean(axis=1),
            point[:, 2],
            np.array(geometry.step_distance),
            name or geometry.name,
        )

    @cached_property
    def angle(self) -> np.ndarray:
        """Tower azimuths, (210, 330, 90) deg + the corrections [rad], (3,)."""
        angle = np.radians(np.asarray(BASE_ANGLES_DEG)) + self.angle_correction
        angle.setflags(write=False)
        return angle

    @cached_property
    def towers(self) -> np.ndarray:
        """Tower positions ``(X_i, Y_i)`` (``towerX``, ``towerY``) [mm], (3, 2)."""
        return tower_positions(self.radius, self.angle)

    @cached_property
    def carriage_top(self) -> np.ndarray:
        """``homedCarriageHeights``: ``H + sqrt(ℓ_i² − ρ²) + e_i`` [mm], (3,)."""
        return carriage_tops(self.homed_height, self.diagonal, self.radius, self.endstop_adjustment)

    @property
    def steps_per_mm(self) -> np.ndarray:
        """``M92 X Y Z``: 1 / d_i [steps/mm], (3,)."""
        return 1.0 / self.step_distance

    def carriage_heights(self, targets: np.ndarray) -> np.ndarray:
        """RRF's carriage heights ``h_i`` (``Transform``) for nozzle targets [mm], (N, 3); NaN: no reach."""
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        lift = targets[:, 2:3] + targets[:, 0:1] * self.tilt[0] + targets[:, 1:2] * self.tilt[1]
        return rod_rise(self.towers, self.diagonal, targets) + lift

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps below the endstops RRF commands for nozzle targets [mm], (N, 3) -> (N, 3).

        Raises:
            UnreachableError: a target no rod reaches (``check``; else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        return checked_steps(
            (self.carriage_top - self.carriage_heights(targets)) / self.step_distance, targets, check
        )

    def inverse(
        self, targets: np.ndarray, step_distance: np.ndarray | float, check: bool = True
    ) -> np.ndarray:
        """Deltacal's readings (steps × the printer's nominal ``step_distance``) for targets, (N, 3) [mm]."""
        return self.steps(targets, check) * step_distance

    @cached_property
    def virtual(self) -> VirtualDelta:
        """RRF's model without its tilt as a prismatic :class:`VirtualDelta` whose readings are steps.

        Carriage point ``(X_i, Y_i, homedCarriageHeights[i])`` at the endstop, sliding down z by
        ``d_i`` per step, a point effector, rods ℓ_i. Its plate point is RRF's ``(x, y, z + x xTilt
        + y yTilt)``.
        """
        return point_effector(self.angle, self.towers, self.carriage_top, self.diagonal, self.step_distance)

    def untilted(self, points: np.ndarray) -> np.ndarray:
        """RRF's nozzle positions of the untilted model's points: z less ``x xTilt + y yTilt`` [mm]."""
        points = np.array(np.atleast_2d(points), dtype=float)
        points[:, 2] -= points[:, 0] * self.tilt[0] + points[:, 1] * self.tilt[1]
        return points

    def positions(self, steps: np.ndarray, check: bool = True) -> np.ndarray:
        """RRF's nozzle positions at steps below the endstops (``ForwardTransform``), (N, 3) -> (N, 3) [mm].

        Raises:
            AssemblyError: steps where the three spheres do not meet (``check``; else NaN rows).
        """
        return self.untilted(self.virtual.forward(steps, check=check))

    def forward(
        self, readings: np.ndarray, step_distance: np.ndarray | float, check: bool = True
    ) -> np.ndarray:
        """Nozzle positions at deltacal's readings (travels in the towers' ``step_distance``), (N, 3) [mm]."""
        return self.positions(np.atleast_2d(np.asarray(readings, dtype=float)) / step_distance, check)

    @cached_property
    def home_position(self) -> np.ndarray:
        """Where homing (``G1 H1``) leaves the nozzle: every carriage on its endstop [mm], (3,)."""
        return home_position(self.positions)

    def with_minimum_z(self, minimum_z: float) -> RRFDelta:
        """The same values with the ``M208`` Z minimum = ``minimum_z`` [mm]."""
        return replace(self, z_min=float(minimum_z))

    def with_limits(self, limit_axes: bool) -> RRFDelta:
        """The same values with RRF's limits on (``M564 S1``) or off (``M564 S0``)."""
        return replace(self, limit_axes=bool(limit_axes))

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which of RRF's limits each command breaks (``LimitPosition``): 0 none, else a code.

        :data:`BELOW_MIN_Z` (under the ``M208`` Z minimum), :data:`BEYOND_RADIUS` (beyond ``M665
        B``), both only with ``M564 S1``; :data:`ABOVE_ENDSTOP` (a carriage above its endstop, which
        RRF limits always). The first that applies, in that order.

        Args:
            commands: Nozzle commands [mm], (N, 3).

        Returns:
            The codes, (N,) integers.
        """
        commands = np.atleast_2d(np.asarray(commands, dtype=float))
        x, y, z = commands.T
        with np.errstate(invalid="ignore"):
            high = np.any(self.carriage_heights(commands) > self.carriage_top + 1e-9, axis=1)
        limited = self.limit_axes
        return np.select(
            [limited & (z < self.z_min), limited & (x * x + y * y > self.print_radius**2), high],
            [BELOW_MIN_Z, BEYOND_RADIUS, ABOVE_ENDSTOP],
            0,
        )

    def refusal(self, commands: np.ndarray) -> str:
        """What RRF would move elsewhere of commands outside its limits, and the key and value admitting them.

        Args:
            commands: Commands :meth:`outside` refuses [mm], (N, 3), the first the one to name.
        """
        commands = np.atleast_2d(np.asarray(commands, dtype=float))
        codes = self.outside(commands)
        of = f" of {self.name}" if self.name else ""
        parts = []
        for code in dict.fromkeys(codes[codes != 0].tolist()):
            these = commands[codes == code]
            x, y, z = these[0]
            if code == BELOW_MIN_Z:
                need = math.floor(float(np.min(these[:, 2])) / LIMIT_STEP_MM) * LIMIT_STEP_MM
                parts.append(
                    f"corrected Z {z:.4f} mm is below the M208 Z minimum {self.z_min:g}{of} (RRF would "
                    f"raise it): set M208 S1 Z{need:.2f}"
                )
            elif code == BEYOND_RADIUS:
                radius = float(np.max(np.hypot(these[:, 0], these[:, 1])))
                need = math.ceil(radius / LIMIT_STEP_MM) * LIMIT_STEP_MM
                parts.append(
                    f"corrected point's radius {math.hypot(x, y):.4f} mm is beyond the print radius "
                    f"M665 B{self.print_radius:g}{of} (RRF would pull it in): set M665 B{need:.2f}"
                )
            else:
                parts.append(
                    f"corrected point {np.round(these[0], 4).tolist()} mm lifts a carriage above its "
                    f"endstop{of} (RRF would lower it): no key admits it: lower the program's moves"
                )
        return "; also ".join(parts) if parts else "inside RepRapFirmware's limits"


class RRFController(FirmwareController[RRFDelta]):
    """RepRapFirmware as a controller of a printer whose readings count steps in ``step_distance``.

    As :class:`~..klipper.model.KlipperController`: the firmware (:class:`RRFDelta`) commands
    steps, deltacal's readings are steps × the printer's nominal step distance.

    Attributes:
        firmware: RRF's model, from its configuration.
        step_distance: The step distance each tower's readings count in [mm], (3,) (a number
            broadcasts): the printer's nominal ones.
    """
