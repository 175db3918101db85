"""``--firmware NAME``: which firmware's settings a printer's ``--controller`` file is.

Without it the firmware is told from the file's content (:func:`~deltacal.printer.firmware.config_firmware`);
with it, the firmware of that name among :func:`~deltacal.printer.firmware.firmwares`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..exceptions import UsageError
from ..printer.firmware import config_firmware, firmwares
from ..printer.firmware.base import Firmware


def firmware_names() -> tuple[str, ...]:
    """The names ``--firmware`` takes."""
    return tuple(firmware.name for firmware in firmwares())


def add_firmware_argument(p: argparse.ArgumentParser) -> None:
    """Register ``--firmware``."""
    names = firmware_names()
    p.add_argument("--firmware", choices=names, default=None,
                   help=f"a printer: the firmware whose settings --controller is ({'|'.join(names)}; "
                        "default: told from the file's content)")


def controller_firmware(path: str | Path, name: str | None) -> Firmware[Any]:
    """The firmware of ``--controller PATH``: the one named, else the one whose settings the file is.

    Raises:
        UsageError: no name and a file no firmware recognises.
    """
    if name is not None:
        return next(firmware for firmware in firmwares() if firmware.name == name)
    firmware = config_firmware(path)
    if firmware is None:
        raise UsageError(f"--controller {path}: not a firmware's settings that deltacal recognises (a "
                         "Klipper printer.cfg, a Marlin M503 capture...): give --firmware "
                         f"{'|'.join(firmware_names())}")
    return firmware
