"""A rotary Delta printer's printed object: ``plan --object --controller printer.cfg`` of a rotary robot file.

The robot file (``deltacal import`` of a ``kinematics: rotary_delta`` configuration, in its base frame
{O}) and its firmware's rotary controller (:meth:`~deltacal.printer.firmware.base.Firmware.rotary_controller`)
make the printer to plan for in the bed's frame
(:class:`~deltacal.printer.printed.target.RotaryPrinterToPlan`); the object, its probe grid, the
distances and the sheet are then the linear printer's files
(:func:`deltacal.wings.printer.plan.write_object_plan`), in the firmware's commanded coordinates,
chosen with the rotary printer model's rows.
"""

from __future__ import annotations

from typing import Any

from ...exceptions import UsageError
from ...geometry import NominalDelta
from ...printer.firmware.base import Firmware
from ...printer.firmware.controller import RotaryFirmwareController
from ...printer.printed.target import RotaryPrinterToPlan
from ..base import Done
from ..printer.plan import object_firmware, write_object_plan
from ..requests import PlanRequest


def plan_rotary_object(request: PlanRequest, robot: NominalDelta) -> Done:
    """``deltacal plan --object`` of a rotary Delta printer: the object's five files written, what was said.

    Raises:
        UsageError: a linear Delta printer's configuration (or a firmware that runs no rotary Delta).
    """
    firmware = object_firmware(request)
    controller = rotary_controller_of(firmware, request.controller, request.nominal, robot)
    return write_object_plan(request, firmware, RotaryPrinterToPlan(robot, controller))


def rotary_controller_of(firmware: Firmware[Any], config: Any, robot_path: Any,
                         robot: NominalDelta) -> RotaryFirmwareController:
    """The firmware's rotary controller of the configuration ``config``; a linear printer's refused.

    Args:
        firmware: The firmware told of ``config``.
        config: The configuration (``--controller``).
        robot_path: The rotary robot file, for the messages.
        robot: The robot it holds: another printer's than the configuration's values is refused.

    Raises:
        UsageError: ``config`` configures a linear Delta printer (or the firmware runs no rotary Delta).
        InputError: the robot file and the configuration are of different printers, naming the value.
    """
    controller = firmware.rotary_controller(config)
    if controller is None:
        raise UsageError(f"--controller {config}: not {firmware.title}'s configuration of a rotary Delta "
                         f"printer (a linear Delta's?), but {robot_path} is a rotary Delta's robot file: "
                         "give the rotary printer's configuration (kinematics: rotary_delta)")
    controller.check_same_printer(robot, str(robot_path), str(config))
    return controller
