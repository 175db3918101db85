"""Klipper's rotary_delta values that fit a rotary Delta printer's calibration, as its keys (``export``).

The values the printer runs (its ``printer.cfg``, ``kinematics: rotary_delta``) start the fit
(:func:`~.rotary_fit.fit_klipper_rotary`); the calibration's geometry, in the robot's base frame {O},
is put in Klipper's frame (the bed's) as ``compensate`` puts it
(:meth:`~.rotary_controller.KlipperRotaryController.in_bed_frame`: the bed at shoulder height + the
nominal robot's nozzle drop below {O}). The printable volume is a robot file's ``[workspace]`` (in
{O}, moved up alike), else the configuration's own: ``[delta_calibrate] radius`` (else Klipper's
``max_xy``) from ``minimum_z_position`` up to Klipper's full-radius height ``limit_z``, as ``deltacal
import`` writes it. The file written is :func:`~.rotary_config.rotary_config_text`, what the values
leave as its comments. Units: mm.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ....exceptions import ConvergenceError, InputError, UnreachableError
from ....geometry import Workspace
from ..fitting import ErrorStats
from ..rotary_values import RotaryValues
from .config import KlipperConfig
from .rotary_config import rotary_config_text, rotary_from_config
from .rotary_controller import KlipperRotaryController
from .rotary_fit import fit_klipper_rotary
from .rotary_importer import printable_radius

if TYPE_CHECKING:
    from ....calibration import Calibration


def export_rotary(config: KlipperConfig, calibration: Calibration, source: str | Path,
                  volume: Workspace | None = None, where: str = "") -> RotaryValues:
    """Klipper's rotary values of ``config`` fitted to a rotary Delta's calibration (see the module).

    Args:
        config: The rotary printer's configuration, read (:func:`~.config.read_klipper_config`).
        calibration: The rotary Delta's calibration (or geometry file read as one), in {O}.
        source: Its file, for the messages.
        volume: The printable volume in {O} (a robot file's ``[workspace]``), or None: the configuration's.
        where: Where ``volume`` comes from (``" of printer.toml"``).

    Raises:
        InputError: the configuration's first problem, a target out of Klipper's reach, no convergence.
    """
    start = rotary_from_config(config)
    nominal = calibration.nominal
    lift = KlipperRotaryController(start).bed_height(nominal)
    if volume is None:
        radius, note = printable_radius(config, start)
        volume = Workspace(radius, start.limit_z - start.minimum_z_position, start.limit_z)
        where = f" of {config.source}: {note}, up to Klipper's limit_z"
    else:
        volume = Workspace(volume.radius, volume.height, volume.top_z + lift)
    shown = f"radius {volume.radius:g} mm, z from 0.2 to {volume.top_z:.3f} mm{where}"
    try:
        fit = fit_klipper_rotary(calibration.geometry, start, volume, nozzle_drop_of=nominal)
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"a target of the printable volume ({shown}) is out of Klipper's rotary_delta reach "
                         f"(row {k + 1} of the fit's grid): give --robot with a [workspace] it reaches",
                         str(source)) from None
    except ConvergenceError as exc:
        raise InputError(f"Klipper's rotary_delta values could not be fitted: {exc}", str(source)) from None
    lines = [f"Klipper's frame: its bed (z = 0) at z = {-lift:g} mm in {source}'s frame (shoulder height + "
             f"nozzle drop {-float(nominal.tool[2]):g} mm)",
             f"nozzle error over the printable volume ({shown}), of the printed part (less the shift along "
             "the bed and turn about its normal, which no measurement sees):",
             f"  these values: {_figures(fit.after)}",
             f"  the --config values: {_figures(fit.before)}",
             f"  held (not fitted): {', '.join(fit.held)}"]
    title = f"Klipper rotary_delta values fitted by deltacal to {source}"
    return RotaryValues(rotary_config_text(fit.values, title, lines), tuple(lines))


def _figures(stats: ErrorStats) -> str:
    """``3-D max 0.094 mm, RMS 0.040 mm; first layer (z 0.2 mm) max |dz| ..., peak to valley ...``."""
    return (f"3-D max {stats.max_3d:.3f} mm, RMS {stats.rms_3d:.3f} mm; first layer (z 0.2 mm) max |dz| "
            f"{stats.flatness:.3f} mm, peak to valley {stats.flatness_pv:.3f} mm")
