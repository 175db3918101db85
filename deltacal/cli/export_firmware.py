"""``deltacal export CAL --controller FIRMWARE --config SETTINGS -o OUT``: a firmware's values that fit best.

For a firmware other than Klipper (Marlin, RepRapFirmware; Klipper's route, :mod:`.export_klipper`,
also prints each error source's share): through the firmware interface alone
(:class:`~deltacal.printer.firmware.base.Firmware`), its values that leave the least nozzle error
over the printable volume of the identified printer (its true bed as z = 0), judged in the printed
part's frame, with the first layer's height errors weighted as Klipper's export weighs them
(:data:`~deltacal.printer.firmware.klipper.fit.EXPORT_FIRST_LAYER_WEIGHT`). The fit starts from
``--config`` (the settings the printer runs, whose other values it keeps: RRF's print radius, its
microstepping), else from the calibration's nominal printer. What the values leave is printed and
kept as comments in the file.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..exceptions import ConvergenceError, GeometryError, InputError, UnreachableError, UsageError
from ..geometry import DeltaGeometry, Workspace
from ..io import load_calibration
from ..printer.firmware.base import ErrorFigures, Firmware, FirmwareModel, undetermined_values
from ..printer.firmware.budget import BED_TILT, error_budget
from ..printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT
from ..printer.identification.where import holds_in_words
from ..robots import load_robot as load_robot_file
from ..viz import default_workspace
from .common import check_input, check_output
from .firmware import check_printer_values, refuse_deltacal_file


def run_firmware(args: argparse.Namespace, firmware: Firmware[Any]) -> int:
    """Run ``export --controller NAME`` for a firmware; returns the exit status."""
    begun = export_start(args, firmware, "OUT, the firmware's values to write", "a firmware's values")
    with fit_refusals(args, begun, "the firmware's"):
        fit = firmware.fit(begun.geometry, begun.start, begun.step, begun.workspace,
                           hold_step_distance=args.keep_rotation_distance,
                           first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, hold=begun.kept)
        budget = source_budget(firmware, begun, args.keep_rotation_distance)
    lines = summary(firmware, fit.before, fit.after, budget, begun, fit.held, begun.config is not None)
    firmware.save_config(args.output, fit.values, args.config,
                         title=f"{firmware.title} values fitted by deltacal to {args.calibration}",
                         notes=lines)
    print(f"wrote the {firmware.title} values that best fit {args.calibration} to {args.output}")
    print("\n".join(lines))
    print(f"to apply: {firmware.apply_note}")
    return 0


@dataclass(frozen=True)
class ExportStart:
    """What a firmware's values are fitted from: the calibration, the settings, the start, the volume.

    Attributes:
        geometry: The identified printer (its true bed is z = 0).
        nominal: Its nominal geometry.
        config: The firmware's values of ``--config``, or None.
        step: The printer's nominal step distances [mm], (3,).
        start: The values the fit starts from (``--config``'s, else the nominal printer's).
        workspace: The printable volume.
        where: Where the volume comes from, for the messages.
        kept: The classical values the calibration's measurements do not determine: kept at the
            start's (:func:`~deltacal.printer.firmware.base.undetermined_values`).
    """

    geometry: DeltaGeometry
    nominal: DeltaGeometry
    config: Any
    step: np.ndarray
    start: Any
    workspace: Workspace
    where: str
    kept: tuple[str, ...] = ()


def export_start(args: argparse.Namespace, firmware: Firmware[Any], output: str, values: str,
                 needs_config: str = "") -> ExportStart:
    """Check the inputs of ``export --controller FIRMWARE`` and read what the fit starts from.

    Args:
        args: The command's arguments.
        firmware: The firmware.
        output: What ``-o`` is, for the message when it is missing (``"OUT, the firmware's values
            to write"``).
        values: Whose values are a printer's, for a rotary Delta's calibration (``"Klipper's values"``).
        needs_config: The message of the firmware that needs ``--config`` unless the step distances are
            kept ("" : none needed).

    Raises:
        UsageError: a missing or misplaced option, or a rotary Delta's calibration.
        InputError: a file's first problem (named by its line or key).
    """
    if args.output is None:
        raise UsageError(f"--controller {firmware.name} needs -o {output}")
    if args.home is not None:
        raise UsageError("--home applies to --mjcf")
    inputs = [p for p in (args.calibration, args.robot, args.config) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    if not calibration.geometry.chain.firmware:
        raise UsageError(f"--controller {firmware.name}: {args.calibration} is a rotary Delta's calibration; "
                         f"{values} are a printer's (--controller offsets|limbs serve a rotary Delta)")
    if args.config is not None:
        refuse_deltacal_file(args.config, "--config")
    config = firmware.read_config(args.config) if args.config is not None else None
    step = step_distance(calibration.geometry.step_distance, config, args,  # type: ignore[arg-type]
                         "geometry.step_distance_mm" if calibration.base else "step_distance_mm")
    if needs_config and args.config is None and not args.keep_rotation_distance:
        raise UsageError(needs_config)
    geometry, nominal = calibration.geometry, calibration.nominal
    if config is not None:
        check_printer_values(firmware, replace(geometry, step_distance=step), config, args.calibration,
                             args.config)
    try:
        start = config if config is not None else firmware.start(replace(nominal, step_distance=step))
    except GeometryError as exc:
        raise InputError(str(exc), str(args.calibration), "key nominal") from None
    workspace, where = printable_volume(args, nominal)
    if calibration.holds is not None:
        held = calibration.holds.held_volume(workspace, args.sigma_bound)
        if held is None:
            raise InputError(f"the calibration holds nowhere within σ {args.sigma_bound:g} mm "
                             f"(--sigma-bound): {holds_in_words(calibration.holds, args.sigma_bound)}; no "
                             "value to export",
                             str(args.calibration))
        workspace, where = held, f"{where}, where the calibration holds (σ within {args.sigma_bound:g} mm)"
    return ExportStart(geometry, nominal, config, step, start, workspace, where,
                       undetermined_values(calibration.holds))


@contextmanager
def fit_refusals(args: argparse.Namespace, begun: ExportStart, whose: str) -> Iterator[None]:
    """A fit's failures as one line naming the file: a target out of reach, no convergence.

    Args:
        args: The command's arguments.
        begun: What the fit starts from.
        whose: Whose the values are (``"Klipper's"``, ``"the firmware's"``).

    Raises:
        InputError: in place of the fit's UnreachableError or ConvergenceError.
    """
    try:
        yield
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        volume = f"{volume_text(begun.workspace)}{begun.where}"
        raise InputError(f"a target of the printable volume ({volume}) is out of {whose} reach (row {k + 1} "
                         "of the fit's grid): give --robot with a [workspace] it reaches",
                         str(args.robot or args.calibration), "key workspace") from None
    except ConvergenceError as exc:
        raise InputError(f"{whose} values could not be fitted: {exc}", str(args.calibration)) from None


def volume_line(begun: ExportStart) -> str:
    """The summary's first line: the volume the errors are judged over, in the printed part's frame."""
    return (f"nozzle error over the printable volume ({volume_text(begun.workspace)}{begun.where}), of the "
            "printed part (less the shift along the bed and turn about its normal, which no measurement "
            "sees):")


def step_distance(known: np.ndarray | None, config: FirmwareModel | None, args: argparse.Namespace,
                   key: str) -> np.ndarray:
    """The printer's nominal step distances (3,): the calibration's, else the configuration's (equal)."""
    if known is not None:
        return known
    if config is not None and np.all(config.step_distance == config.step_distance[0]):
        return np.array(config.step_distance)
    raise InputError("no step_distance_mm: the step distance the printer's readings count in is not known "
                     "(identify the printer again, or give --config printer.cfg with one rotation_distance "
                     "on its three towers)", str(args.calibration), f"key {key}")


def printable_volume(args: argparse.Namespace, nominal: DeltaGeometry) -> tuple[Workspace, str]:
    """The printable volume: the robot file's ``[workspace]``, else the default for the nominal printer."""
    if args.robot is not None:
        robot = load_robot_file(args.robot)
        if robot.geometry().chain != nominal.chain:
            raise UsageError(f"--robot {args.robot}: a rotary Delta's robot file; give the printer's")
        if robot.workspace is not None:
            return robot.workspace, f" of {args.robot}"
    return default_workspace(nominal), " (the default; --robot gives the printer's own)"


def volume_text(workspace: Workspace) -> str:
    """The printable volume in words, for the messages and the summary."""
    return f"radius {workspace.radius:g} mm, z from 0.2 to {workspace.top_z:g} mm"


def source_budget(firmware: Firmware[Any], begun: ExportStart,
                  hold_step_distance: bool) -> dict[str, ErrorFigures]:
    """What the firmware's values leave of each error source of the identified printer alone [mm].

    The printer's errors are its deviation from its nominal geometry, on its bed (no bed motion:
    the bed's tilt is in the towers' lean and positions):
    :func:`~deltacal.printer.firmware.budget.error_budget`.
    """
    geometry, nominal = begun.geometry, begun.nominal
    return error_budget(firmware, nominal, geometry.deviation_from(nominal), np.eye(3), np.zeros(3),
                        begun.start, begun.step, begun.workspace, hold_step_distance)


def summary(firmware: Firmware[Any], before: ErrorFigures, after: ErrorFigures,
            budget: dict[str, ErrorFigures], begun: ExportStart, held: list[str],
            from_config: bool) -> list[str]:
    """What the firmware's values leave, line by line [mm]: the whole, and each error source alone."""
    start = "the --config values" if from_config else "the nominal values"
    lines = [volume_line(begun),
             f"  these values: 3-D max {after.max_3d:.3f} mm, RMS {after.rms_3d:.3f} mm; first layer "
             f"(z 0.2 mm) max |dz| {after.flatness:.3f} mm, peak to valley {after.flatness_pv:.3f} mm",
             f"  {start}: 3-D max {before.max_3d:.3f} mm, RMS {before.rms_3d:.3f} mm; first layer "
             f"max |dz| {before.flatness:.3f} mm, peak to valley {before.flatness_pv:.3f} mm"]
    if held:
        lines.append(f"  held (not fitted): {', '.join(held)}")
    if begun.kept:
        lines.append(f"  kept at {start} (the measurements do not determine them better than the build "
                     f"tolerances): {', '.join(begun.kept)}")
    lines.append(f"what {firmware.title}'s values cannot hold of each error source alone (3-D max / first "
                 "layer max |dz|; deltacal compensate corrects them):")
    width = max(len(label) for label in budget)
    lines += [f"  {label:{width}s}  {stats.max_3d:.3f} / {stats.flatness:.3f} mm"
              for label, stats in budget.items() if label != BED_TILT]
    lines.append("  (the bed's tilt is in the towers' lean and positions: the printer is expressed on its "
                 "bed)")
    return lines
