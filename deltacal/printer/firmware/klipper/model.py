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

Klipper's limits (``DeltaKinematics.check_move``): a move is refused ("Move out of range") when its
end, as Klipper parsed it, has Z below ``minimum_z_position`` (default 0), Z above ``max_z``, the lowest
``position_endstop``, or a horizontal radius beyond ``max_xy = min(print_radius (default
delta_radius), min ℓ_i − ρ, ratio_to_xy(12))``, tapered above ``limit_z = min(E_i − ℓ_i)`` (where the
arms stand vertical) to ``max_z − Z``. A move that ends at the home position's X, Y exactly, between
``minimum_z_position`` and the home's Z, is a homing move and passes. Only a move's end is checked,
and only a move that changes X, Y or Z (by 1e-9 mm or more). Before homing Klipper refuses every
such move ("Must home first"): a program's commands are judged as a homed printer takes them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Protocol

import numpy as np

from ....exceptions import GeometryError
from ....geometry import DeltaGeometry
from ....kinematics.closed_form import VirtualDelta
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

#: Klipper's tower angles when a ``[stepper_*]`` gives none [deg] (towers A, B, C).
DEFAULT_ANGLES_DEG = (210.0, 330.0, 90.0)
#: Klipper's full steps per rotation when a ``[stepper_*]`` gives none.
DEFAULT_FULL_STEPS = 200
#: Klipper's ``SLOW_RATIO``: the radius is limited where a tower moves 4 × this much faster than XY.
SLOW_RATIO = 3.0
#: The step of a limit's value a refusal asks for [mm] (rounded away from the commands).
LIMIT_STEP_MM = 0.01
#: Codes of :meth:`KlipperDelta.outside`: the limit a command breaks (0: none), in the order checked.
BELOW_MIN_Z, ABOVE_MAX_Z, BEYOND_RADIUS, BEYOND_TAPER = 1, 2, 3, 4


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
        print_radius: ``[printer] print_radius`` [mm], or None (Klipper's default: ``delta_radius``).
        minimum_z_position: ``[printer] minimum_z_position`` [mm] (Klipper's default 0).
    """

    delta_radius: float
    angle: np.ndarray
    arm_length: np.ndarray
    position_endstop: np.ndarray
    step_distance: np.ndarray = field(default_factory=lambda: np.full(3, 0.0125))
    name: str = ""
    print_radius: float | None = None
    minimum_z_position: float = 0.0

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
        radius = self.print_radius
        if radius is not None and not (math.isfinite(radius) and radius > 0.0):
            raise GeometryError(f"print_radius must be a positive length, got {self.print_radius!r}")
        if not math.isfinite(self.minimum_z_position):
            raise GeometryError(f"minimum_z_position must be finite, got {self.minimum_z_position!r}")

    @classmethod
    def from_printer(cls, printer: NominalLinearDelta, name: str = "") -> KlipperDelta:
        """The configuration that makes Klipper's model the perfect printer built to these values.

        Raises:
            GeometryError: the nozzle is off the effector's axis (Klipper's point effector has no
                horizontal nozzle offset).
        """
        on_axis(printer.tool, "Klipper")
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
        point, radius = carriage_points(geometry, "Klipper")
        arm = geometry.rod_length.mean(axis=1)
        return cls(radius, np.mod(np.arctan2(point[:, 1], point[:, 0]), 2.0 * np.pi), arm,
                   point[:, 2] - np.sqrt(arm**2 - radius**2), np.array(geometry.step_distance),
                   name or geometry.name)

    @cached_property
    def towers(self) -> np.ndarray:
        """Tower positions ``(X_i, Y_i)`` [mm], (3, 2)."""
        return tower_positions(self.delta_radius, self.angle)

    @cached_property
    def carriage_top(self) -> np.ndarray:
        """Carriage point heights at the endstops, ``E_i = e_i + sqrt(ℓ_i² − ρ²)`` [mm], (3,)."""
        return carriage_tops(self.position_endstop, self.arm_length, self.delta_radius)

    def carriage_heights(self, targets: np.ndarray) -> np.ndarray:
        """Klipper's carriage heights ``h_i`` for nozzle targets [mm], (N, 3) -> (N, 3); NaN out of reach."""
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        return rod_rise(self.towers, self.arm_length, targets) + targets[:, 2:3]

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps below the endstops Klipper commands for nozzle targets [mm], (N, 3) -> (N, 3).

        Raises:
            UnreachableError: a target no rod reaches (``check``; else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        return checked_steps((self.carriage_top - self.carriage_heights(targets)) / self.step_distance,
                             targets, check)

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
        return point_effector(self.angle, self.towers, self.carriage_top, self.arm_length, self.step_distance)

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

    @cached_property
    def max_z(self) -> float:
        """Klipper's highest Z: the lowest ``position_endstop`` [mm]."""
        return float(np.min(self.position_endstop))

    @cached_property
    def limit_z(self) -> float:
        """Z above which Klipper tapers the radius: ``min(E_i − ℓ_i)`` [mm]."""
        return float(np.min(self.carriage_top - self.arm_length))

    def ratio_radius(self, ratio: float) -> float:
        """Klipper's ``ratio_to_xy(ratio)``: the radius where a tower moves ``ratio`` times faster [mm].

        ``r sqrt(min ℓ² / (r² + 1) − h²) + h − ρ``, h half the smallest step distance (delta.py):
        ratio 3 (``SLOW_RATIO``) is where Klipper halves a move's speed, 12 its build radius's bound.
        """
        arm, half = float(np.min(self.arm_length)), 0.5 * float(np.min(self.step_distance))
        return ratio * math.sqrt(arm**2 / (ratio**2 + 1.0) - half**2) + half - self.delta_radius

    @cached_property
    def reach_radius(self) -> float:
        """The radius the arms allow Klipper, print_radius aside [mm]: ``min(min ℓ − ρ, ratio_to_xy(12))``."""
        return min(float(np.min(self.arm_length)) - self.delta_radius, self.ratio_radius(4.0 * SLOW_RATIO))

    @cached_property
    def max_radius(self) -> float:
        """Klipper's build radius: ``min(print_radius, reach_radius)`` [mm]."""
        return min(self.delta_radius if self.print_radius is None else self.print_radius, self.reach_radius)

    @cached_property
    def home_position(self) -> np.ndarray:
        """Where homing leaves the nozzle: every carriage at its endstop [mm], (3,)."""
        return home_position(self.positions)

    def with_minimum_z(self, minimum_z: float) -> KlipperDelta:
        """The same values with ``minimum_z_position`` = ``minimum_z`` [mm]."""
        return replace(self, minimum_z_position=float(minimum_z))

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which limit each command (a move's end, as Klipper reads it) breaks: 0 none, else a code.

        Klipper's ``check_move``, vectorised: :data:`BELOW_MIN_Z`, :data:`ABOVE_MAX_Z`,
        :data:`BEYOND_RADIUS`, :data:`BEYOND_TAPER` (the first that applies, in that order).

        Args:
            commands: Nozzle commands [mm], (N, 3).

        Returns:
            The codes, (N,) integers.
        """
        return move_check(commands, self.minimum_z_position, self.max_z, self.max_radius, self.limit_z,
                          self.home_position)

    def refusal(self, commands: np.ndarray) -> str:
        """What Klipper refuses of commands outside its limits, and the key and value that admit them.

        Names the first command's limit (and then each other limit broken); a value to set admits
        every command given that breaks its limit, rounded to :data:`LIMIT_STEP_MM` away from them.

        Args:
            commands: Commands :meth:`outside` refuses [mm], (N, 3), the first the one to name.
        """
        return limits_refusal(self, commands, self._beyond_radius)

    def _beyond_radius(self, commands: np.ndarray, of: str) -> str:
        """The radius limit's refusal: print_radius to set, or the arms' reach no key admits."""
        radius = math.hypot(*commands[0, :2])
        need = -step_below(-float(np.max(np.hypot(commands[:, 0], commands[:, 1]))))
        if need <= self.reach_radius:
            now = f"{self.print_radius:g}" if self.print_radius is not None else \
                f"{self.delta_radius:g} (delta_radius, the default)"
            return (f"corrected point's radius {radius:.4f} mm is beyond print_radius {now}{of}: "
                    f"set [printer] print_radius: {need:.2f}")
        return (f"corrected point's radius {radius:.4f} mm is beyond {self.reach_radius:.2f} mm, the "
                f"arms' reach in Klipper's model{of}: no key admits it: keep the program within it")


class KlipperLimits(Protocol):
    """What :func:`limits_refusal` reads of a Klipper model (linear or rotary)."""

    @property
    def name(self) -> str: ...  # noqa: D102

    @property
    def minimum_z_position(self) -> float: ...  # noqa: D102

    @property
    def max_z(self) -> float: ...  # noqa: D102

    @property
    def limit_z(self) -> float: ...  # noqa: D102

    def outside(self, commands: np.ndarray) -> np.ndarray: ...  # noqa: D102


def limits_refusal(model: KlipperLimits, commands: np.ndarray,
                   beyond_radius: Callable[[np.ndarray, str], str]) -> str:
    """What Klipper refuses of commands, each limit broken once (the first command's first), in one line.

    Args:
        model: The Klipper model (linear or rotary).
        commands: Commands its ``outside`` refuses [mm], (N, 3).
        beyond_radius: The radius limit's words for the commands that break it and `` of NAME``.
    """
    commands = np.atleast_2d(np.asarray(commands, dtype=float))
    codes = model.outside(commands)
    of = f" of {model.name}" if model.name else ""
    parts = []
    for code in dict.fromkeys(codes[codes != 0].tolist()):
        broken = commands[codes == code]
        x, y, z = broken[0]
        if code == BELOW_MIN_Z:
            need = step_below(float(np.min(broken[:, 2])))
            parts.append(f"corrected Z {z:.4f} mm is below minimum_z_position {model.minimum_z_position:g}"
                         f"{of}: set [printer] minimum_z_position: {need:.2f}")
        elif code == ABOVE_MAX_Z:
            parts.append(f"corrected Z {z:.4f} mm is above {model.max_z:g}, the lowest "
                         f"position_endstop{of} (Klipper's top): no key admits it (position_endstop is the "
                         "printer's height): lower the program's moves")
        elif code == BEYOND_RADIUS:
            parts.append(beyond_radius(broken, of))
        else:
            parts.append(f"corrected point at radius {math.hypot(x, y):.4f} mm, Z {z:.4f} mm is beyond "
                         f"Klipper's radius taper near the top{of} (radius at most {model.max_z:g} - Z above "
                         f"Z {model.limit_z:.2f}): no key admits it: lower the move or bring it nearer the "
                         "centre")
    return "; also ".join(parts) if parts else "inside Klipper's limits"


def move_check(commands: np.ndarray, minimum_z: float, max_z: float, max_radius: float, limit_z: float,
               home: np.ndarray) -> np.ndarray:
    """Klipper's ``check_move`` of a homed Delta (linear or rotary), vectorised: the code each command breaks.

    :data:`BELOW_MIN_Z`, :data:`ABOVE_MAX_Z`, :data:`BEYOND_RADIUS` (``max_radius``), :data:`BEYOND_TAPER`
    (above ``limit_z`` the radius at most ``max_z − Z``): the first that applies, in that order, 0 none;
    a move that ends at the ``home`` position's X, Y exactly, between ``minimum_z`` and the home's Z,
    is a homing move and passes (``delta.py``, ``rotary_delta.py``).

    Args:
        commands: Nozzle commands [mm], (N, 3).
        minimum_z: ``minimum_z_position`` [mm].
        max_z: The top: the lowest ``position_endstop`` [mm].
        max_radius: The build radius [mm].
        limit_z: The height above which the radius tapers [mm].
        home: Where homing leaves the nozzle [mm], (3,).
    """
    commands = np.atleast_2d(np.asarray(commands, dtype=float))
    x, y, z = commands.T
    xy2 = x**2 + y**2
    max_xy2 = max_radius**2
    limit_xy2 = np.where(z > limit_z, np.minimum(max_xy2, (max_z - z) ** 2), max_xy2)
    homing = (x == home[0]) & (y == home[1]) & (z >= minimum_z) & (z <= home[2])
    codes = np.select([z < minimum_z, z > max_z, xy2 > max_xy2, xy2 > limit_xy2],
                      [BELOW_MIN_Z, ABOVE_MAX_Z, BEYOND_RADIUS, BEYOND_TAPER], 0)
    codes[homing & (codes != BELOW_MIN_Z)] = 0
    return codes


def step_below(value: float) -> float:
    """The multiple of :data:`LIMIT_STEP_MM` at or below ``value``, as its 2-decimal text reads back."""
    need = math.floor(value / LIMIT_STEP_MM) * LIMIT_STEP_MM
    while float(f"{need:.2f}") > value:
        need -= LIMIT_STEP_MM
    return float(f"{need:.2f}")


class KlipperController(FirmwareController[KlipperDelta]):
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
