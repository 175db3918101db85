"""Robot files and controllers of either kind: a rotary Delta's or a linear Delta printer's.

Above the engine, which reads a rotary Delta's robot file and deltacal's controller files
(:mod:`deltacal.io`), and the printer's wing, which reads a printer's robot file
(:mod:`deltacal.printer.files.robot_file`) and its firmware's configuration
(:mod:`deltacal.printer.firmware`): the command line (and a program that takes either kind) reads
a file by its kind here. Files are in millimetres and degrees.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .chains import PRISMATIC
from .controller import CommandModel, Controller
from .geometry import NominalDelta
from .io.controller_file import load_controller_file
from .io.robot import load_nominal, robot_kind
from .io.toml import read_toml
from .printer.files.robot_file import load_printer
from .printer.firmware import config_firmware
from .printer.robot import NominalLinearDelta


def load_robot(path: str | Path) -> NominalDelta | NominalLinearDelta:
    """Read a robot file of either kind: a rotary Delta or (``kind = "linear"``) a Delta printer.

    The file is parsed once: its ``kind`` tells the reader, which takes the parsed TOML.

    Raises:
        InputError: naming the file and the key of the first problem found.
    """
    data = read_toml(path)
    if robot_kind(data, str(path)) == PRISMATIC.robot_kind:
        return load_printer(path, data)
    return load_nominal(path, data)


def load_controller(path: str | Path,
                    step_distance: np.ndarray | float | None = None) -> Controller | CommandModel:
    """Read a controller file, a robot file as its nominal controller, or a printer's firmware configuration.

    A firmware's configuration (Klipper's ``printer.cfg``: a name ending in ``.cfg``, or a
    ``[printer]`` section) gives the firmware as the controller of the printer's readings
    (:meth:`~deltacal.printer.firmware.base.Firmware.load_controller`, for Klipper a
    :class:`~deltacal.printer.firmware.klipper.model.KlipperController`).

    Args:
        path: The file.
        step_distance: For a firmware's configuration: the step distance a printer's readings count
            in [mm] (the printer's nominal one: each tower's (3,), or one number for the three); by
            default the configuration's own, which must then be the same on the three towers.

    Raises:
        InputError: naming the file and the key (and value) of the first problem found.
    """
    firmware = config_firmware(path)
    if firmware is not None:
        return firmware.load_controller(path, step_distance)
    return load_controller_file(path)


__all__ = ["load_controller", "load_printer", "load_robot"]
