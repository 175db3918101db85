"""``deltacal export``: the identified robot as an MJCF model (MuJoCo, Pinocchio), or a controller's values.

``--controller offsets|limbs`` fits the controller's joint offsets, or its per-limb values, to the
calibration over a grid of the workspace (the report's accuracy-map grid of the robot file's
``[workspace]``, else of the report's default cylinder) and writes a controller file whose ``[fit]``
holds the TCP error these values leave (:func:`deltacal.controller.fit_controller`).
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping

import numpy as np

from ..chains import Chain
from ..controller import FIT_KINDS, Controller, fit_controller
from ..exceptions import AssemblyError, GeometryError, InputError, UnreachableError, UsageError
from ..export import write_mjcf
from ..geometry import DeltaGeometry, Workspace
from ..holds import DEFAULT_BOUND
from ..io import control_character, load_calibration, load_nominal, read_toml, save_controller
from ..printer.firmware import firmware_named
from ..printer.firmware.klipper.firmware import KLIPPER
from ..report.accuracy import GRID, workspace_slices
from ..robots import load_robot as load_robot_file
from ..viz import default_workspace
from .common import check_input, check_output, positive_float, three_numbers
from .export_firmware import run_firmware
from .export_klipper import run_klipper
from .firmware import firmware_names


def load_robot(path: str) -> tuple[DeltaGeometry, list[str]]:
    """The geometry of a calibration, geometry or robot file (either kind), and the calibration's stations.

    Raises:
        InputError: naming the file, key and value of the first problem found.
    """
    data = read_toml(path)
    geometry = data.get("geometry")
    if "format" not in data and (data.get("kind") is not None or (
            isinstance(geometry, Mapping) and "base_radius_mm" in geometry)):
        return load_robot_file(path).geometry(), []  # a nominal robot file (it has no format key)
    calibration = load_calibration(path)  # a calibration or geometry file, checked as every command does
    return calibration.geometry, list(calibration.frames)


def _home_readings(text: str) -> str:
    """Argparse type of ``--home``: ``Q1,Q2,Q3``, three numbers (their unit is the robot's: :func:`_home`)."""
    three_numbers(text, "Q1,Q2,Q3 (deg; a printer's in mm)")
    return text


def _home(text: str | None, chain: Chain) -> np.ndarray | None:
    """``--home`` as readings, checked for the robot's kind.

    Arm angles in degrees within ±180 (one turn) -> [rad]; carriage travels below the endstops [mm],
    not negative (a carriage does not rise above its endstop).
    """
    if text is None:
        return None
    values = np.array(three_numbers(text, "Q1,Q2,Q3"))
    low, high = chain.option_range
    if np.any((values < low) | (values > high)):
        raise UsageError(f"argument --home: {chain.words.reading_rule}, got {text!r}")
    return chain.reading_from_file(values)


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal export``; returns the exit status."""
    firmware = firmware_named(args.controller)
    if firmware is KLIPPER:  # its route also prints each error source's share
        return run_klipper(args)
    if firmware is not None:
        return run_firmware(args, firmware)
    if args.controller is not None:
        return run_controller(args)
    if args.config is not None or args.keep_rotation_distance:
        raise UsageError("--config and --keep-rotation-distance apply to --controller "
                         f"{'|'.join(firmware_names())}")
    if args.output is not None or args.robot is not None:
        raise UsageError(f"{'-o' if args.output is not None else '--robot'} applies to --controller; "
                         "--mjcf names its own output")
    check_input(args.calibration)
    check_output(args.mjcf, (args.calibration,))
    geometry, stations = load_robot(args.calibration)
    write_mjcf(args.mjcf, geometry, name=args.name, home=_home(args.home, geometry.chain), stations=stations,
               source=str(args.calibration))
    frame = " (robot base frame {O}; the instrument frames are not exported)" if stations else ""
    print(f"wrote the MJCF model of {args.name or geometry.name or 'delta'} to {args.mjcf}{frame}")
    return 0


def run_controller(args: argparse.Namespace) -> int:
    """``export --controller offsets|limbs``: the controller values that best fit the calibration."""
    if args.output is None:
        raise UsageError("--controller needs -o CONTROLLER.toml, the controller file to write")
    if args.home is not None:
        raise UsageError("--home applies to --mjcf")
    if args.config is not None or args.keep_rotation_distance:
        raise UsageError("--config and --keep-rotation-distance apply to --controller "
                         f"{'|'.join(firmware_names())}")
    inputs = [p for p in (args.calibration, args.robot) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    if calibration.geometry.chain.firmware:
        raise UsageError(f"--controller {args.controller}: {args.calibration} is a printer's calibration; "
                         "its firmware's values: --controller klipper")
    start, workspace, shift, sized = _start(calibration, args)
    points = np.concatenate([s.points.reshape(-1, 3) for s in workspace_slices(workspace, GRID)]) + shift
    points = points[np.all(np.isfinite(points), axis=1)]
    try:
        fit = fit_controller(calibration, start, points, args.controller)
    except (UnreachableError, AssemblyError) as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"the workspace point {np.round(points[k], 3).tolist()} mm is out of reach of the "
                         f"{'controller model' if isinstance(exc, UnreachableError) else 'identified robot'}"
                         f" (workspace: {_text(workspace)}{sized}): give --robot with a [workspace] it "
                         "reaches",
                         str(args.robot or args.calibration), "key workspace") from None
    notes = {"calibration": str(args.calibration), "workspace": _text(workspace) + sized}
    name = args.name or start.name or calibration.robot
    save_controller(args.output, fit.controller.replace(name=name), fit, notes)
    what = {"offsets": "joint offsets", "limbs": "per-limb values"}[args.controller]
    print(f"wrote the {what} that best fit {args.calibration} to {args.output}")
    print(f"TCP error left over the workspace ({fit.points} points; {_text(workspace)}{sized}): "
          f"max {fit.max_error:.4f} mm, RMS {fit.rms_error:.4f} mm (the nominal controller leaves max "
          f"{fit.max_error_before:.4f} mm, RMS {fit.rms_error_before:.4f} mm)")
    if fit.held:
        print(f"held at nominal (not identifiable from the TCP error; b_i and a_i enter only as b_i - a_i): "
              f"{', '.join(fit.held)}")
    return 0


def _start(calibration, args: argparse.Namespace) -> tuple[Controller, Workspace, np.ndarray, str]:
    """The nominal controller, the workspace, its shift [mm] and a note on where it came from.

    The controller's tool is the calibration's (the TCP identified); a robot file's workspace is
    for its own tool, so it is shifted by the difference (the convention of the robot file).
    """
    tool = calibration.nominal.tool
    if args.robot is not None:
        nominal = load_nominal(args.robot)
        start = Controller.from_geometry(nominal).replace(tool=tool)
        if nominal.workspace is not None:
            return start, nominal.workspace, tool - nominal.tool, ""
        return start, default_workspace(nominal.geometry().with_tool(tool)), np.zeros(3), " (the default)"
    try:
        start = Controller.from_geometry(calibration.nominal)
    except GeometryError:
        raise InputError("the calibration's nominal geometry is not a classical Delta (a geometry file?): "
                         "give the robot file with --robot", str(args.calibration), "key nominal") from None
    return (start, default_workspace(calibration.nominal), np.zeros(3),
            " (the default; --robot gives the robot's own)")


def _text(workspace: Workspace) -> str:
    return (f"radius {workspace.radius:g} mm, z from {workspace.bottom_z:g} to {workspace.top_z:g} mm")


def add_parser(sub) -> None:
    """Register ``export``."""
    p = sub.add_parser(
        "export",
        help="write the robot as an MJCF model (MuJoCo, Pinocchio), or a controller's fitted values",
        description=(
            "Write the identified robot (a calibration file from identify, a geometry file or a nominal "
            "robot file) as an MJCF model in SI units: hinge joints arm1..arm3 whose values are the "
            "encoder readings [rad] (a printer's: slides carriage1..carriage3, their servos' controls the "
            "readings [mm]), ball-jointed rods closed on the plate by <connect> constraints, "
            "sites tcp and the named points, and a keyframe 'home' holding an assembly. With --controller "
            "offsets|limbs: the controller file (deltacal-controller-1) of the joint offsets alone, or of "
            "the per-limb values, that leave the least TCP error over the workspace; its [fit] and the "
            "printed line give the error they leave."
        ),
    )
    p.add_argument("calibration", metavar="CALIBRATION",
                   help="calibration file written by identify, or a geometry or robot file (TOML)")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--mjcf", metavar="ROBOT.xml", help="MJCF file to write")
    what.add_argument("--controller", choices=(*FIT_KINDS, *firmware_names()),
                      help="write a controller file (-o) with the joint offsets alone, or the per-limb "
                           "values, that best fit the calibration over the workspace; klipper: a printer's "
                           "[printer] and [stepper_a..c] values (-o CALIBRATED.cfg); marlin: M665, M666 "
                           "and M92 lines (-o CALIBRATED.gcode); rrf: RepRapFirmware's M665, M666 and M92 "
                           "lines for config-override.g (-o CALIBRATED.g)")
    p.add_argument("-o", "--output", metavar="CONTROLLER.toml|CALIBRATED.cfg",
                   help="with --controller: the controller file (klipper: the Klipper values)")
    p.add_argument("--config", metavar="PRINTER.cfg|M503.txt|config.g",
                   help="with --controller klipper|marlin|rrf: the configuration the printer runs (Marlin: "
                        "its M503 capture, its M851 and soft endstops kept; its values "
                        "start the fit; its microsteps and gears turn step distances into rotation_distance; "
                        "default: the nominal printer's values, 200 full steps x 16 microsteps); rrf: its "
                        "config.g or config-override.g (its values start the fit, its M350 microstepping "
                        "goes with M92; default: the nominal printer's values, x16)")
    p.add_argument("--sigma-bound", type=positive_float, default=DEFAULT_BOUND, metavar="MM",
                   help=f"a printer's values: fitted where the calibration's correction has a σ of at most "
                        f"MM (default {DEFAULT_BOUND:g})")
    p.add_argument("--keep-rotation-distance", action="store_true",
                   help="with --controller klipper|marlin|rrf: hold each tower's rotation_distance (Marlin, "
                        "RRF: M92) (the --config's, else the nominal step distance's)")
    p.add_argument("--robot", metavar="ROBOT.toml",
                   help="with --controller: the robot file (its nominal values start the fit and hold "
                        "what the fit cannot identify; its [workspace] is the fit's; default: the "
                        "calibration's nominal and the report's default workspace; klipper: the printer's "
                        "robot file, for its [workspace])")
    p.add_argument("--name", type=_model_name, help="model (or controller) name (default: the robot's name)")
    p.add_argument("--home", type=_home_readings, metavar="Q1,Q2,Q3",
                   help="readings of the 'home' keyframe [deg]; a printer's: carriage travels below the "
                        "endstops [mm] (default 0,0,0)")
    p.set_defaults(func=run)


def _model_name(text: str) -> str:
    """Argparse type of ``--name``: text without control characters (no XML file holds them)."""
    problem = control_character(text)
    if problem is not None:
        raise argparse.ArgumentTypeError(f"model name {text!r} {problem}")
    return text

