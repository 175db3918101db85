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
lists them; :func:`config_firmware` finds the one whose configuration a file is, :func:`log_firmware` the
one whose probe results a log holds, :func:`input_firmware` which of the two a file given to ``import``
is, told by what it holds; :func:`check_config_firmware` refuses a file named as one firmware's
configuration that another firmware's content claims; :func:`config_files` every file a configuration
reads.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...exceptions import DeltacalError, InputError, UsageError
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
    """The firmware whose configuration file ``path`` is, or None (a file of deltacal's own).

    Told by what the file holds (:meth:`~.base.Firmware.is_config`), else by its name alone
    (:meth:`~.base.Firmware.is_config_name`: a ``*.cfg`` is Klipper's).
    """
    return (next((firmware for firmware in firmwares() if firmware.is_config(path)), None)
            or next((firmware for firmware in firmwares() if firmware.is_config_name(path)), None))


def input_firmware(path: str | Path, text: str, name: str | None = None) -> tuple[Firmware[Any], bool]:
    """The firmware whose file ``path`` (of ``text``) is, and whether it is a log of its probe results.

    Told by what the file holds, in this order: a firmware's probe results or marks only its log has
    (:meth:`~.base.Firmware.is_probe_log`) make a log; a firmware's configuration by its content
    (:meth:`~.base.Firmware.is_config`: Klipper's ``[printer]``, RepRapFirmware's ``config.g``,
    Marlin's ``M503`` capture or ``Configuration.h``); a console's marks that other files may share
    (:meth:`~.base.Firmware.is_console`: Klipper's ``// `` lines, which a ``config.g`` or a
    ``Configuration.h`` may hold too) make a log; a configuration by its name (``*.cfg``). With
    ``name`` (``--firmware``), that firmware's: its log when its log's marks are there, else (unless
    another firmware's configuration it is by its content: :func:`check_config_firmware`) its console
    or its configuration.

    Raises:
        UsageError: no firmware recognises the file (and no ``name``).
        InputError: ``name`` given for another firmware's configuration.
    """
    names = "|".join(firmware.name for firmware in firmwares())
    if name is not None:
        named = firmware_named(name)
        if named is None:
            raise UsageError(f"--firmware {name}: not a firmware deltacal knows ({names})")
        if named.is_probe_log(text):
            return named, True
        check_config_firmware(path, named)
        return named, named.is_console(text)
    for firmware in firmwares():
        if firmware.is_probe_log(text):
            return firmware, True
    content = next((firmware for firmware in firmwares() if firmware.is_config(path)), None)
    if content is not None:
        return content, False
    for firmware in firmwares():
        if firmware.is_console(text):
            return firmware, True
    named_like = next((firmware for firmware in firmwares() if firmware.is_config_name(path)), None)
    if named_like is not None:
        return named_like, False
    raise UsageError(f"{path}: neither a configuration nor a log that deltacal recognises by its content "
                     "(Klipper's printer.cfg, RepRapFirmware's config.g, Marlin's M503 capture, a console "
                     f"or log with probe results): give --firmware {names}")


def check_config_firmware(path: str | Path, firmware: Firmware[Any]) -> None:
    """Refuse ``path`` as ``firmware``'s configuration when it is another firmware's by its content.

    Raises:
        InputError: naming the firmware whose configuration the file is (so that a Klipper
            ``printer.cfg`` read as RepRapFirmware's is not said to have "no M665").
    """
    other = next((f for f in firmwares() if f is not firmware and f.is_config(path)), None)
    if other is not None:
        raise InputError(f"{other.title}'s configuration by its content ({other.config_file}), not "
                         f"{firmware.title}'s: name {other.name} as its firmware", str(path))


def config_files(path: str | Path, name: str | Firmware[Any] | None = None) -> tuple[Path, ...]:
    """Every file a firmware's configuration reads (:meth:`~.base.Firmware.config_files`), itself first.

    Args:
        path: The configuration (a command's ``--controller`` or ``--config``).
        name: The firmware (already told), or its name (``--firmware``), or None: told from the file.
            A file no firmware recognises, or that its firmware cannot read, is itself alone (its
            reader names the problem when the command reads it).
    """
    if isinstance(name, Firmware):
        firmware: Firmware[Any] | None = name
    else:
        firmware = firmware_named(name) if name is not None else config_firmware(path)
    if firmware is None:
        return (Path(path),)
    try:
        return firmware.config_files(path)
    except (DeltacalError, OSError):
        return (Path(path),)
