"""``deltacal export CAL --controller klipper -o CALIBRATED.cfg``: the firmware values that fit best.

Klipper's model (vertical towers, one rod per tower, a point effector) cannot hold a real printer:
:func:`~deltacal.printer.firmware.klipper.fit.fit_klipper` finds its ``delta_radius``, tower ``angle``,
``arm_length``, ``position_endstop`` and ``rotation_distance`` that leave the least nozzle error
over the printable volume of the identified printer (its true bed as z = 0), judged in the printed
part's frame, with the first layer's height errors weighted
(:data:`~deltacal.printer.firmware.klipper.fit.EXPORT_FIRST_LAYER_WEIGHT`) so that its flatness is not
traded for the volume's. The file written holds only the keys Klipper knows, ready to replace those in
``printer.cfg``; what the values leave is printed (and kept as comments in the file), with what
each error source alone would leave (:func:`~deltacal.printer.firmware.budget.error_budget`, as for
every firmware): what ``compensate`` corrects through the firmware.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

import numpy as np

from ..exceptions import ConvergenceError, GeometryError, InputError, UnreachableError, UsageError
from ..geometry import DeltaGeometry, Workspace
from ..io import load_calibration
from ..printer.firmware.base import ErrorFigures, Firmware, FirmwareModel
from ..printer.firmware.budget import BED_TILT, error_budget
from ..printer.firmware.klipper.firmware import KLIPPER
from ..printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT
from ..robots import load_robot as load_robot_file
from ..viz import default_workspace
from .common import check_input, check_output
from .firmware import check_printer_values, refuse_deltacal_file


def run_klipper(args: argparse.Namespace) -> int:
    """Run ``export --controller klipper``; returns the exit status."""
    if args.output is None:
        raise UsageError("--controller klipper needs -o CALIBRATED.cfg, the Klipper values to write")
    if args.home is not None:
        raise UsageError("--home applies to --mjcf")
    inputs = [p for p in (args.calibration, args.robot, args.config) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    if not calibration.geometry.chain.firmware:
        raise UsageError(f"--controller klipper: {args.calibration} is a rotary Delta's calibration; "
                         "Klipper's values are a printer's (--controller offsets|limbs serve a rotary Delta)")
    if args.config is not None:
        refuse_deltacal_file(args.config, "--config")
    config = KLIPPER.read_config(args.config) if args.config is not None else None
    step = _step_distance(calibration.geometry.step_distance, config, args,
                          "geometry.step_distance_mm" if calibration.base else "step_distance_mm")
    if args.config is None and not args.keep_rotation_distance:
        raise UsageError("--controller klipper: rotation_distance is the step distance times each tower's "
                         "full_steps_per_rotation x microsteps, which the calibration does not hold: give "
                         "--config printer.cfg (the configuration the printer runs), or "
                         "--keep-rotation-distance to keep the printer's own rotation_distance")
    geometry, nominal = calibration.geometry, calibration.nominal
    if config is not None:
        check_printer_values(KLIPPER, replace(geometry, step_distance=step), config, args.calibration,
                             args.config)
    try:
        start = config if config is not None else KLIPPER.start(replace(nominal, step_distance=step))
    except GeometryError as exc:
        raise InputError(str(exc), str(args.calibration), "key nominal") from None
    workspace, where = _workspace(args, calibration.nominal)
    try:
        fit = KLIPPER.fit(geometry, start, step, workspace, hold_step_distance=args.keep_rotation_distance,
                          first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)
        budget = source_budget(KLIPPER, geometry, nominal, start, step, workspace,
                               args.keep_rotation_distance)
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"a target of the printable volume ({_text(workspace)}{where}) is out of Klipper's "
                         f"reach (row {k + 1} of the fit's grid): give --robot with a [workspace] it reaches",
                         str(args.robot or args.calibration), "key workspace") from None
    except ConvergenceError as exc:
        raise InputError(f"Klipper's values could not be fitted: {exc}", str(args.calibration)) from None
    lines = summary(KLIPPER, fit.before, fit.after, budget, workspace, where, fit.held,
                    args.config is not None)
    values = KLIPPER.admit_bed(fit.klipper, geometry, step, workspace.radius)
    if values is not fit.klipper:
        lines.append(f"minimum_z_position {values.minimum_z_position:g} mm: the true bed is below these "
                     f"values' z 0 over radius {workspace.radius:g} mm; a corrected first layer goes there "
                     "(compensate --controller)")
    KLIPPER.save_config(args.output, values, args.config,
                        title=f"Klipper delta values fitted by deltacal to {args.calibration}",
                        notes=lines)
    print(f"wrote the Klipper values that best fit {args.calibration} to {args.output}")
    print("\n".join(lines))
    return 0


def _step_distance(known: np.ndarray | None, config: FirmwareModel | None, args: argparse.Namespace,
                   key: str) -> np.ndarray:
    """The printer's nominal step distances (3,): the calibration's, else the configuration's (equal)."""
    if known is not None:
        return known
    if config is not None and np.all(config.step_distance == config.step_distance[0]):
        return np.array(config.step_distance)
    raise InputError("no step_distance_mm: the step distance the printer's readings count in is not known "
                     "(identify the printer again, or give --config printer.cfg with one rotation_distance "
                     "on its three towers)", str(args.calibration), f"key {key}")


def _workspace(args: argparse.Namespace, nominal) -> tuple[Workspace, str]:
    """The printable volume: the robot file's ``[workspace]``, else the default for the nominal printer."""
    if args.robot is not None:
        robot = load_robot_file(args.robot)
        if robot.geometry().chain != nominal.chain:
            raise UsageError(f"--robot {args.robot}: a rotary Delta's robot file; give the printer's")
        if robot.workspace is not None:
            return robot.workspace, f" of {args.robot}"
    return default_workspace(nominal), " (the default; --robot gives the printer's own)"


def _text(workspace: Workspace) -> str:
    return f"radius {workspace.radius:g} mm, z from 0.2 to {workspace.top_z:g} mm"


def source_budget(firmware: Firmware[Any], geometry: DeltaGeometry, nominal: DeltaGeometry,
                  start: FirmwareModel, step: np.ndarray, workspace: Workspace,
                  hold_step_distance: bool) -> dict[str, ErrorFigures]:
    """What the firmware's values leave of each error source of the identified printer alone [mm].

    The printer's errors are its deviation from its nominal geometry, on its bed (no bed motion:
    the bed's tilt is in the towers' lean and positions):
    :func:`~deltacal.printer.firmware.budget.error_budget`.
    """
    return error_budget(firmware, nominal, geometry.deviation_from(nominal), np.eye(3), np.zeros(3), start,
                        step, workspace, hold_step_distance)


def summary(firmware: Firmware[Any], before: ErrorFigures, after: ErrorFigures,
            budget: dict[str, ErrorFigures], workspace: Workspace, where: str, held: list[str],
            from_config: bool) -> list[str]:
    """What the firmware's values leave, line by line [mm]: the whole, and each error source alone."""
    start = "the --config values" if from_config else "the nominal values"
    lines = [f"nozzle error over the printable volume ({_text(workspace)}{where}), of the printed part "
             "(less the shift along the bed and turn about its normal, which no measurement sees):",
             f"  these values: 3-D max {after.max_3d:.3f} mm, RMS {after.rms_3d:.3f} mm; first layer "
             f"(z 0.2 mm) max |dz| {after.flatness:.3f} mm, peak to valley {after.flatness_pv:.3f} mm",
             f"  {start}: 3-D max {before.max_3d:.3f} mm, RMS {before.rms_3d:.3f} mm; first layer "
             f"max |dz| {before.flatness:.3f} mm, peak to valley {before.flatness_pv:.3f} mm"]
    if held:
        lines.append(f"  held (not fitted): {', '.join(held)}")
    lines.append(f"what {firmware.title}'s values cannot hold of each error source alone (3-D max / first "
                 "layer max |dz|; deltacal compensate corrects them):")
    width = max(len(label) for label in budget)
    lines += [f"  {label:{width}s}  {stats.max_3d:.3f} / {stats.flatness:.3f} mm"
              for label, stats in budget.items() if label != BED_TILT]
    lines.append("  (the bed's tilt is in the towers' lean and positions: the printer is expressed on its "
                 "bed)")
    return lines
