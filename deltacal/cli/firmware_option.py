"""``--firmware``: the firmware a printer's ``--controller`` file is the configuration of.

The commands that take a printer's firmware configuration (plan, simulate, identify, compensate)
take ``--firmware NAME`` (one of :func:`~deltacal.printer.firmware.firmwares`, by its name); without
it the firmware is the one whose configuration the file is by its content
(:func:`~deltacal.printer.firmware.config_firmware`).
"""

from __future__ import annotations

import argparse
from typing import Any

from ..exceptions import UsageError
from ..printer.firmware import config_firmware, firmwares
from ..printer.firmware.base import Firmware


def firmware_names() -> tuple[str, ...]:
    """The names ``--firmware`` takes."""
    return tuple(firmware.name for firmware in firmwares())


def add_firmware_option(p: argparse.ArgumentParser) -> None:
    """Add ``--firmware`` (default None: from the configuration's content)."""
    p.add_argument("--firmware", choices=firmware_names(),
                   help="a printer: the firmware --controller configures (default: told from the file's "
                        "content: klipper's printer.cfg, rrf's config.g)")


def controller_firmware(args: argparse.Namespace) -> Firmware[Any]:
    """The firmware of ``--controller``: ``--firmware``'s, else the one the file's content says.

    Raises:
        UsageError: no ``--firmware`` and a file no firmware recognises.
    """
    name = getattr(args, "firmware", None)
    if name is not None:
        return next(firmware for firmware in firmwares() if firmware.name == name)
    firmware = config_firmware(args.controller)
    if firmware is None:
        raise UsageError(f"--controller {args.controller}: not a firmware configuration deltacal "
                         f"recognises by its content; give --firmware {'|'.join(firmware_names())}")
    return firmware
