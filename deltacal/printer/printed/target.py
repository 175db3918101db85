"""A printer to plan a printed object for: what ``plan --object`` asks of a linear or a rotary Delta printer.

Everything in the firmware's frame, the bed's (the commanded coordinates: what G-code and the
object's STL hold): the printable cylinder from the bed up, the towers' (arms') azimuths that the
object's rims start at, the nominal geometry, the readings the firmware commands for nozzle positions
(its inverse model) and the error model whose rows choose the distances, with the build tolerances
that are its prior.

* :class:`LinearPrinterToPlan`: a linear Delta printer's robot file (already in the bed's frame) and its
  firmware's values; readings in the printer's nominal step distance; the complete ``printer`` model.
* :class:`RotaryPrinterToPlan`: a rotary robot file (in its base frame {O}, the shoulders' centre) and
  its firmware's rotary controller (Klipper's ``rotary_delta``): moved into the bed's frame by the
  controller; readings the arms' angles; the ``rotary_printer`` model, kit tolerances
  (:meth:`~deltacal.geometry.Tolerances.rotary_printer_kit`).

Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from ...errormodels import get_model
from ...geometry import DeltaGeometry, NominalDelta, Tolerances, Workspace
from ..firmware.base import FirmwareModel
from ..firmware.controller import RotaryFirmwareController
from ..identification.errormodels import kit_tolerances
from ..robot import NominalLinearDelta


class PrinterToPlan(Protocol):
    """A printer to plan an object for, in its firmware's frame (the bed's)."""

    @property
    def name(self) -> str:
        """The printer's name (titles)."""

    @property
    def workspace(self) -> Workspace | None:
        """The printable cylinder in the bed's frame (the bed at z = 0), or None (not given)."""

    @property
    def tower_azimuth(self) -> np.ndarray:
        """The towers' (arms') azimuths [rad], (3,): the object's rims start at the first."""

    @property
    def model(self) -> str:
        """The error model whose rows choose the distances (its registered name)."""

    @property
    def tolerances(self) -> Tolerances:
        """The build tolerances: the model's prior."""

    def geometry(self) -> DeltaGeometry:
        """The nominal printer in the bed's frame."""

    def readings(self, commanded: np.ndarray) -> np.ndarray:
        """The readings the firmware commands for nozzle positions [mm], (N, 3) -> (N, 3)."""


@dataclass(frozen=True, eq=False)
class LinearPrinterToPlan:
    """A linear Delta printer and its firmware's values (:class:`PrinterToPlan`).

    Attributes:
        printer: The robot file (in the bed's frame).
        firmware: The firmware's model of its configuration.
    """

    printer: NominalLinearDelta
    firmware: FirmwareModel
    model: str = "printer"

    @property
    def name(self) -> str:
        """The robot file's name."""
        return self.printer.name

    @property
    def workspace(self) -> Workspace | None:
        """The robot file's ``[workspace]``."""
        return self.printer.workspace

    @property
    def tower_azimuth(self) -> np.ndarray:
        """The towers' azimuths [rad]."""
        return self.printer.tower_azimuth

    @property
    def tolerances(self) -> Tolerances:
        """Its model's kit (:func:`~..identification.errormodels.kit_tolerances`: a linear printer kit's)."""
        return kit_tolerances(get_model(self.model))

    def geometry(self) -> DeltaGeometry:
        """The nominal printer."""
        return self.printer.geometry()

    def readings(self, commanded: np.ndarray) -> np.ndarray:
        """The carriages' travels the firmware commands, in the printer's nominal step distance [mm]."""
        return self.firmware.inverse(commanded, self.printer.step_distance)


@dataclass(frozen=True, eq=False)
class RotaryPrinterToPlan:
    """A rotary Delta printer's robot file and its firmware's rotary controller (:class:`PrinterToPlan`).

    Attributes:
        robot: The rotary robot file (in {O}, ``deltacal import`` of the configuration).
        controller: The firmware's model of the configuration (its frame the bed's).
    """

    robot: NominalDelta
    controller: RotaryFirmwareController
    model: str = "rotary_printer"

    @property
    def name(self) -> str:
        """The robot file's name."""
        return self.robot.name

    @property
    def workspace(self) -> Workspace | None:
        """The robot file's ``[workspace]`` moved up into the bed's frame (by the controller's bed height)."""
        workspace = self.robot.workspace
        if workspace is None:
            return None
        return replace(workspace, top_z=workspace.top_z + self.controller.bed_height(self.robot.geometry()))

    @property
    def tower_azimuth(self) -> np.ndarray:
        """The arms' azimuths [rad]."""
        return np.asarray(self.robot.limb_azimuth, dtype=float)

    @property
    def tolerances(self) -> Tolerances:
        """Its model's kit (:func:`~..identification.errormodels.kit_tolerances`: a rotary printer kit's)."""
        return kit_tolerances(get_model(self.model))

    def geometry(self) -> DeltaGeometry:
        """The nominal printer moved into the bed's frame."""
        return self.controller.in_bed_frame(self.robot.geometry())

    def readings(self, commanded: np.ndarray) -> np.ndarray:
        """The arms' readings [rad] the firmware commands for nozzle positions [mm]."""
        return self.controller.inverse(commanded)


def printer_to_plan(printer: NominalLinearDelta | PrinterToPlan,
                    firmware: FirmwareModel | None = None) -> PrinterToPlan:
    """A linear printer's robot file with its firmware's values, or a printer to plan for already made."""
    if isinstance(printer, NominalLinearDelta):
        if firmware is None:
            raise TypeError("a linear printer's robot file is planned for through its firmware's values")
        return LinearPrinterToPlan(printer, firmware)
    return printer
