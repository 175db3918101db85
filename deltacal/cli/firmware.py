"""``--firmware NAME``: which firmware's settings a printer's ``--controller`` file is.

Without it the firmware is told from the file's content (:func:`~deltacal.printer.firmware.config_firmware`);
with it, the firmware of that name among :func:`~deltacal.printer.firmware.firmwares`. A printer's
calibration (or robot file) and its firmware's settings are checked to be of one printer
(:func:`check_config_printer`).
"""

from __future__ import annotations

import argparse
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..exceptions import GeometryError, InputError, UsageError
from ..geometry import DeltaGeometry
from ..printer.firmware import check_config_firmware, config_firmware, firmware_named, firmwares
from ..printer.firmware.base import Firmware, FirmwareModel


def firmware_names() -> tuple[str, ...]:
    """The names ``--firmware`` takes."""
    return tuple(firmware.name for firmware in firmwares())


def add_firmware_argument(p: argparse.ArgumentParser, subject: str = "--controller") -> None:
    """Register ``--firmware``: the firmware whose file ``subject`` (an option or argument) is."""
    names = firmware_names()
    p.add_argument("--firmware", choices=names, default=None,
                   help=f"a printer: the firmware whose settings {subject} is ({'|'.join(names)}; "
                        "default: told from the file's content)")


def controller_firmware(path: str | Path, name: str | None) -> Firmware[Any]:
    """The firmware of ``--controller PATH``: the one named, else the one whose settings the file is.

    Raises:
        UsageError: a file of deltacal's own (a robot file...), or no name and a file no firmware
            recognises.
    """
    refuse_deltacal_file(path)
    if name is not None:
        named = firmware_named(name)
        assert named is not None  # argparse's choices are the firmwares' names
        check_config_firmware(path, named)
        return named
    firmware = config_firmware(path)
    if firmware is None:
        raise UsageError(f"--controller {path}: not a firmware's settings that deltacal recognises (a "
                         "Klipper printer.cfg, a Marlin M503 capture...): give --firmware "
                         f"{'|'.join(firmware_names())}")
    return firmware


def refuse_deltacal_file(path: str | Path, option: str = "--controller") -> None:
    """A usage error if ``path``, given as a firmware's settings, is deltacal's own file (a robot file)."""
    own = _deltacal_file(path)
    if own is not None:
        raise UsageError(f"{option} {path}: {own}, not a firmware's configuration: give the printer's "
                         "settings (Klipper's printer.cfg, Marlin's M503 capture)")


def _deltacal_file(path: str | Path) -> str | None:
    """What file of deltacal's own ``path`` is (``"a deltacal robot file"``), or None (none of its)."""
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    kind = data.get("format")
    if isinstance(kind, str) and kind.startswith("deltacal-"):
        return f"a deltacal file (format = {kind!r})"
    return "a deltacal robot file" if isinstance(data.get("geometry"), dict) else None


def check_config_printer(config: str | Path, name: str | None, geometry: DeltaGeometry,
                         source: str | Path) -> None:
    """Refuse a firmware's settings (``--controller``) of another printer than the geometry's.

    Nothing is checked for a rotary Delta's geometry, or for a file that is not a firmware's settings
    (a controller or robot file).

    Args:
        config: The settings file.
        name: ``--firmware``, or None (told from the file).
        geometry: The calibration's identified geometry, or a robot file's nominal one.
        source: Where the geometry comes from, for the message.

    Raises:
        InputError: the settings' first problem, or the first value of another printer
            (:meth:`~deltacal.printer.firmware.base.Firmware.check_same_printer`).
    """
    if not geometry.chain.firmware:
        return
    firmware = controller_firmware(config, name) if name is not None else config_firmware(config)
    if firmware is not None:
        check_printer_values(firmware, geometry, firmware.read_config(config), source, config)


def check_printer_values(firmware: Firmware[Any], geometry: DeltaGeometry, model: FirmwareModel,
                         source: str | Path, config: str | Path) -> None:
    """Refuse a firmware's values ``model`` (read from ``config``) of another printer than ``geometry``.

    The geometry's values are the firmware's at its tolerances' centre
    (:meth:`~deltacal.printer.firmware.base.Firmware.start`), in the configuration's step distance when
    the geometry holds none (a calibration written before it was kept).

    Raises:
        InputError: naming both values (or the geometry the firmware's model cannot hold).
    """
    if geometry.step_distance is None:
        geometry = replace(geometry, step_distance=model.step_distance)
    try:
        ours = firmware.start(geometry)
    except GeometryError as exc:
        raise InputError(str(exc), str(source)) from None
    firmware.check_same_printer(ours, model, f"{source}'s geometry", str(config))
