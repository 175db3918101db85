"""A firmware with its values as the controller of a printer's readings, whatever the firmware.

A firmware commands steps below each tower's endstop; deltacal's readings of a printer are the
carriages' travels counted in the printer's nominal step distance (:mod:`deltacal.printer.robot`),
reading = steps × that step distance. :class:`FirmwareController` pairs the two, so that a
firmware's model serves :func:`~deltacal.controller.corrected_targets` and the G-code route as a
rotary :class:`~deltacal.controller.Controller` does: its targets are the nozzle's (no tool), its
home is where a homing leaves the nozzle (every carriage at its endstop, in its model), its limits
are its model's. Each firmware's controller (Klipper's, Marlin's, RepRapFirmware's) is this class
over its own model; a firmware's model of a rotary Delta printer is a :class:`RotaryFirmwareController`
(its readings the arms' angles, its frame the bed's). Units: mm.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

from ...controller.targets import CommandModel
from ...geometry import DeltaGeometry, NominalDelta
from ...kinematics.closed_form import VirtualDelta
from ...towers import per_tower


class ControlledModel(Protocol):
    """What a firmware's model gives its controller."""

    @property
    def name(self) -> str: ...  # noqa: D102

    @property
    def step_distance(self) -> np.ndarray: ...  # noqa: D102

    @property
    def virtual(self) -> VirtualDelta: ...  # noqa: D102

    @property
    def home_position(self) -> np.ndarray: ...  # noqa: D102

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """The readings for nozzle targets, (N, 3) [mm]."""

    def forward(self, readings: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Nozzle positions at readings, (N, 3) [mm]."""

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which limit each command breaks, (N,) (0: none)."""

    def refusal(self, commands: np.ndarray) -> str:
        """One line on refused commands."""


ModelT = TypeVar("ModelT", bound=ControlledModel)


class NozzleCommands:
    """What every firmware controller shares: its targets are the nozzle's, in its frame, on straight lines.

    For a controller holding its model as ``firmware`` (a linear or a rotary Delta's): the name, no
    tool, the home and the limits are the model's.
    """

    firmware: Any

    #: How the controller moves between two targets: each firmware plans a move as a straight line
    #: in its Cartesian frame and maps every step (or short segment) on the way through its model.
    interpolation = "cartesian"

    @property
    def name(self) -> str:
        """The configuration's name."""
        return str(self.firmware.name)

    @property
    def tool(self) -> np.ndarray:
        """A firmware's targets are the nozzle's: no tool offset on its model [mm], (3,)."""
        return np.zeros(3)

    @cached_property
    def home(self) -> np.ndarray:
        """Where the firmware puts the nozzle after homing: every carriage (arm) at its endstop [mm], (3,)."""
        return np.asarray(self.firmware.home_position, dtype=float)

    @property
    def limits(self) -> Any:
        """The firmware's limits on its commands: its model's (``outside``, ``refusal``)."""
        return self.firmware


@dataclass(frozen=True, eq=False)
class FirmwareController(NozzleCommands, Generic[ModelT]):
    """A firmware as a controller of a printer whose readings count steps in ``step_distance``.

    Attributes:
        firmware: The firmware's model, from its configuration.
        step_distance: The step distance each tower's readings count in [mm], (3,) (a number
            broadcasts): the printer's nominal ones, ``NominalLinearDelta.step_distance``, those its
            identification read measurements in.
    """

    firmware: ModelT
    step_distance: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "step_distance", per_tower("step_distance", self.step_distance))

    @cached_property
    def virtual(self) -> VirtualDelta:
        """The firmware's model as a prismatic :class:`VirtualDelta` whose readings are deltacal's [mm]."""
        return replace(self.firmware.virtual, joint_scale=self.firmware.step_distance / self.step_distance)

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """The readings the firmware commands for nozzle targets [mm], (N, 3) -> (N, 3) [mm]."""
        return self.firmware.inverse(targets, self.step_distance, check)

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """The nozzle position the firmware's model puts at readings [mm], (N, 3) -> (N, 3) [mm]."""
        return self.firmware.forward(readings, self.step_distance, check)


class RotaryFirmwareController(CommandModel, Protocol):
    """A firmware's model of a rotary Delta printer as the controller of its readings (arm angles, rad).

    Its frame is the firmware's (the bed's); a rotary robot's geometry, in its base frame {O}, is
    moved into it by :meth:`in_bed_frame`.
    """

    @property
    def firmware(self) -> object: ...  # noqa: D102

    def in_bed_frame(self, geometry: DeltaGeometry,
                     nozzle_drop_of: DeltaGeometry | None = None) -> DeltaGeometry:
        """The robot moved from its {O} into the firmware's frame (the bed's)."""

    def bed_height(self, geometry: DeltaGeometry) -> float:
        """How far the firmware's bed is below the robot's {O} [mm]."""

    def check_same_printer(self, robot: NominalDelta, our_source: str, their_source: str) -> None:
        """Refuse a rotary robot file of another printer than the configuration's values (one line)."""

    @property
    def reach_radius(self) -> float:
        """The radius out to which the firmware commands the nozzle [mm]."""

    def values_read(self) -> dict[str, float]:
        """Every value of the configuration that moves the nozzle, by the firmware's keys (a record's)."""

    def with_values(self, values: Mapping[str, float]) -> RotaryFirmwareController:
        """The controller of these values by the firmware's keys (a record's), the others this one's."""

    def check_same_values(self, other: RotaryFirmwareController, other_source: str, source: str) -> None:
        """Refuse ``other``'s values (``other_source``'s) of another printer than these (``source``'s)."""

    def recounted(self, readings: np.ndarray, counted_by: RotaryFirmwareController) -> np.ndarray:
        """The readings these values count where ``counted_by``'s count ``readings`` (the same steps)."""
