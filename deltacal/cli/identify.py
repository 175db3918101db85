"""``deltacal identify``: the geometry from measurements."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from ..errormodels import MODEL_NAMES
from ..exceptions import AssemblyError, ConvergenceError, IdentificationError, InputError, UsageError
from ..geometry import DeltaGeometry
from ..identification import FitOptions, PoorFitError, identify
from ..identification.compliance import payload_span
from ..io import lines_text, read_measurement_file, save_calibration, unassembled_rows
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION, Measurements
from ..printer.robot import NominalLinearDelta
from ..robots import load_robot
from .common import check_input, check_output, sigma, warn
from .identify_printer import PRINTER_MODELS, add_arguments, run_printer


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal identify``; returns the exit status."""
    check_input(args.nominal)
    robot = load_robot(args.nominal)
    if isinstance(robot, NominalLinearDelta):
        return run_printer(args, robot)
    if len(args.measurements) != 1:
        raise UsageError(f"a rotary Delta's measurements are one CSV file, got {len(args.measurements)}")
    if args.controller is not None or args.firmware is not None:
        flag = "controller" if args.controller is not None else "firmware"
        raise UsageError(f"--{flag} applies to a printer's measurements (of commanded positions)")
    if args.tolerance_scale is not None:
        raise UsageError("--tolerance-scale applies to a printer's measurements")
    args.measurements = args.measurements[0]
    args.model = args.model or "complete"
    if args.model not in MODEL_NAMES:
        raise UsageError(f"--model {args.model}: a rotary Delta's models are {', '.join(MODEL_NAMES)}")
    if args.pairs is not None and not args.distances:
        raise UsageError("--pairs applies to --distances only")
    if args.rigid and args.compliance:
        raise UsageError("--rigid and --compliance: choose one (--rigid fits actuators that do not yield)")
    try:  # every option is checked once, by FitOptions
        options = FitOptions(
            method="linear" if args.linear else "iterated",
            sigma_position=args.sigma_position,
            sigma_angle=math.radians(args.sigma_angle),
            distances=args.distances,
            pairs=args.pairs or "all",
            frame=args.frame,
            accept_poor_fit=args.accept_poor_fit,
            free_points=tuple(args.free_points),
            compliance=args.compliance,
        )
    except ValueError as exc:
        raise UsageError(f"options that do not go together: {exc}") from exc
    for path in (args.nominal, args.measurements):
        check_input(path)
    check_output(args.output, (args.nominal, args.measurements))
    nominal = robot
    start = nominal.geometry()
    for name in args.free_points:
        if name not in start.point_names:
            raise InputError(f"unknown point {name!r}; the robot's points are {', '.join(start.point_names)}",
                             "--free-points")
    read = read_measurement_file(args.measurements, start.point_names)
    measurements, lines = read.measurements, read.lines
    warn(read.warnings)
    if args.distances and np.any(measurements.has_orientation):
        warn(["orientations are ignored when identifying from distances"])
    options = _with_compliance_default(args, options, start, read.measurements)
    try:
        result = identify(start, measurements, args.model, options=options)
    except AssemblyError as exc:
        # at the nominal geometry: the readings themselves are impossible
        if not exc.indices:
            raise
        raise unassembled_rows(exc, args.measurements, lines, measurements.q,
                               f"the robot {nominal.name!r}") from exc
    except PoorFitError as exc:
        raise IdentificationError(
            f"{args.measurements}: {exc}; nothing written (--accept-poor-fit keeps such a fit)"
        ) from exc
    except IdentificationError as exc:
        at = lines[exc.rows].tolist()
        where = f"line{'s' if len(at) > 1 else ''} {lines_text(at)}: " if at else ""
        raise IdentificationError(f"{args.measurements}: {where}{exc.detail}") from exc
    except ConvergenceError as exc:
        raise ConvergenceError(f"{args.measurements}: {exc}", exc.residual) from exc
    warn(result.warnings)
    save_calibration(result, args.output, lines)  # saved first: a failing stdout loses no result
    print(result.report(lines))
    if result.outliers:
        flagged = lines_text(lines[result.outliers].tolist())
        warn([f"{args.measurements}: line(s) {flagged} look like outliers (see the report): "
              "check them, or remove them and identify again"])
    print(f"\nwrote {args.output}")
    return 0


def _with_compliance_default(args: argparse.Namespace, options: FitOptions, start: DeltaGeometry,
                             measurements: Measurements) -> FitOptions:
    """The options, with the compliances identified where the payloads vary (see conventions.md).

    Payloads that vary with the masses known: the compliances are identified (said on stdout);
    with no ``[masses]``, the choice is the user's (``--compliance`` or ``--rigid``), refused
    otherwise: a rigid fit would spread the deflections over the geometry.
    """
    span = payload_span(measurements)
    if span is None or args.rigid or args.compliance or args.distances:
        return options
    payloads = f"payload_kg varies from {span[0]:g} to {span[1]:g} kg"
    if start.masses.is_zero:
        raise InputError(
            f"{payloads} but {args.nominal} has no [masses]: a rigid fit would take the actuators' "
            "deflections for geometry; give --compliance (the compliances from the payloads' torques alone, "
            "the robot's own weight taken up by the geometry), the robot's [masses], or --rigid",
            args.measurements, "column payload_kg")
    print(f"{args.measurements}: {payloads} and {args.nominal} gives the masses: the actuators' compliances "
          "are identified too (--rigid fits a rigid robot)")
    return replace(options, compliance=True)


def add_parser(sub) -> None:
    """Register ``identify``."""
    p = sub.add_parser("identify", help="identify the geometry from measurements")
    p.add_argument("nominal", help="nominal robot file (TOML): a rotary Delta or a printer (kind = 'linear')")
    p.add_argument("measurements", nargs="+",
                   help="measurements (CSV); a printer: its probe heights, then distances files")
    p.add_argument("--model", choices=MODEL_NAMES + PRINTER_MODELS, default=None,
                   help="error model (default complete; a printer's: printer)")
    p.add_argument("-o", "--output", required=True, help="calibration file to write (TOML)")
    p.add_argument("--sigma-position", type=sigma, default=SIGMA_POSITION, metavar="MM",
                   help=f"σ of each measured coordinate [mm] (default {SIGMA_POSITION:g})")
    p.add_argument("--sigma-angle", type=sigma, default=SIGMA_ANGLE_DEG, metavar="DEG",
                   help=f"σ of each measured orientation component [deg] (default {SIGMA_ANGLE_DEG:g})")
    p.add_argument("--linear", action="store_true",
                   help="one-shot linear identification around the nominal geometry (the papers)")
    p.add_argument("--distances", action="store_true",
                   help="identify from distances between positions of a same point (no frame needed)")
    p.add_argument("--pairs", choices=("all", "reference"), default=None,
                   help="with --distances: all pairs, or each pose with the first (default all)")
    p.add_argument("--frame", choices=("base", "free"), default="base",
                   help="base: measurements in the robot base frame {O} (default); free: in an instrument's "
                        "own frame, one per station, identified with the geometry")
    p.add_argument("--accept-poor-fit", action="store_true",
                   help="keep a fit whose residuals are far beyond the σ given (warned, not refused)")
    p.add_argument("--free-points", nargs="+", metavar="NAME", default=[],
                   help="identify the position on the plate of these measured points (reflectors) too, "
                        "where the data can tell it from the plate geometry")
    p.add_argument("--compliance", action="store_true",
                   help="identify the actuators' compliances c1..c3 too [rad/N m] (the robot file's [masses] "
                        "and the measurements' payload_kg give the gravity torques; measure at 0 and a "
                        "heavy payload; the default where the payloads vary and the masses are known)")
    p.add_argument("--rigid", action="store_true",
                   help="fit rigid actuators even where the measurements' payloads vary")
    add_arguments(p)
    p.set_defaults(func=run)
