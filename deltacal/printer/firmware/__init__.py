"""The firmwares that run a linear Delta printer, one subpackage each behind one interface.

A firmware holds its own (classical) model of the printer: vertical towers, one rod length per
tower, a point effector. Each implements :class:`~.base.Firmware` (its configuration file read and
written, its model, its controller, its values fitted to an identified printer), and its
subpackage has the same parts:

* ``config``: its configuration file read and written (values in the firmware's own words);
* ``model``: its kinematic model (commanded position to steps and back) and its limits, and the
  firmware as a controller of the printer's readings;
* ``fit``: the values that fit an identified printer best over the printable volume;
* ``calibrate``: its own calibration, emulated from its algorithm, for the comparison (Klipper's);
* ``probing``: its program that probes the bed at given points, its results on the console;
* ``firmware``: the :class:`~.base.Firmware` that delegates to the parts above.

What the firmwares share is written once beside :mod:`.base`: the classical delta maths of their
models (:mod:`.classical`), the fit's loop (:mod:`.fitting`), the probe program (:mod:`.probing`)
and a log's probe results (:mod:`.probe_log`).

Klipper (:mod:`.klipper`), RepRapFirmware (:mod:`.rrf`) and Marlin (:mod:`.marlin`). :func:`firmwares`
lists them; :func:`config_firmware`
finds the one whose configuration a file is, :func:`config_files` every file that configuration reads,
:func:`log_firmware` the one whose probe results a log holds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...exceptions import DeltacalError
from .base import Firmware


def firmwares() -> tuple[Firmware[Any], ...]:
    """Every firmware deltacal knows, in the order their configuration files are recognised."""
    from .klipper.firmware import KLIPPER
    from .marlin.firmware import MARLIN
    from .rrf.firmware import RRF_FIRMWARE

    return (KLIPPER, RRF_FIRMWARE, MARLIN)  # RRF's config.g (by its name) before Marlin's M503 (by content)


def firmware_named(name: str) -> Firmware[Any] | None:
    """The firmware whose name (``--firmware``, ``--controller`` of export) is ``name``, or None."""
    return next((firmware for firmware in firmwares() if firmware.name == name), None)


def log_firmware(text: str) -> Firmware[Any] | None:
    """The firmware whose probe results (or log) a file's text is, or None."""
    return next((firmware for firmware in firmwares() if firmware.is_probe_log(text)), None)


def config_firmware(path: str | Path) -> Firmware[Any] | None:
    """The firmware whose configuration file ``path`` is, or None (a file of deltacal's own)."""
    return next((firmware for firmware in firmwares() if firmware.is_config(path)), None)


def config_files(path: str | Path, name: str | None = None) -> tuple[Path, ...]:
    """Every file a firmware's configuration reads (:meth:`~.base.Firmware.config_files`), itself first.

    Args:
        path: The configuration (a command's ``--controller`` or ``--config``).
        name: The firmware's name (``--firmware``), or None: told from the file. A file no firmware
            recognises, or that its firmware cannot read, is itself alone (its reader names the
            problem when the command reads it).
    """
    firmware = firmware_named(name) if name is not None else config_firmware(path)
    if firmware is None:
        return (Path(path),)
    try:
        return firmware.config_files(path)
    except (DeltacalError, OSError):
        return (Path(path),)
