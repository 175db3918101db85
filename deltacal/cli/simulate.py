"""``deltacal simulate``: tracker (and probe) measurements of a true robot at planned poses.

A printer's robot file (``kind = "linear"``) goes to :mod:`.simulate_printer`: its probe heights
and printed distances, through its firmware.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from ..exceptions import AssemblyError, UsageError
from ..geometry import Tolerances
from ..identification.frames import in_instrument_frames
from ..io import (
    load_geometry,
    read_poses_file,
    save_geometry,
    unassembled_rows,
    write_measurements,
)
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ..printer.robot import NominalLinearDelta
from ..robots import load_robot
from ..simulation import Metrology, pose_stations, simulate_measurements, truth_path
from .common import (
    check_input,
    check_output,
    non_negative_float,
    non_negative_list,
    point_list,
    positive_int,
    seed,
    station_frame,
    warn,
)
from .simulate_printer import add_printer_arguments, refuse_printer_options, run_printer


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``simulate``."""
    p = subparsers.add_parser(
        "simulate",
        help="simulate tracker (and probe) measurements of a true robot at planned poses, or a "
             "printer's probe heights and printed distances",
        description=(
            "Simulate the measurements of a true robot (perturbed nominal or a geometry file) "
            "standing at the readings of a POSES file, through the Pinocchio closed-loop model, "
            "and write a measurements CSV. With --perturb, the true geometry is also written "
            "next to the output (MEAS.truth.toml). A printer (kind = 'linear'): PROBE.csv "
            "[DISTANCES.csv] are plan --object's templates, filled through the firmware of --controller "
            "(-o the probe heights, --distances-output the distances)."
        ),
    )
    p.add_argument("nominal", metavar="NOMINAL", help="robot file (TOML)")
    p.add_argument("poses", metavar="POSES", nargs="+",
                   help="POSES CSV written by 'deltacal plan'; a printer: PROBE.csv [DISTANCES.csv] written "
                        "by 'deltacal plan --object'")
    truth = p.add_mutually_exclusive_group(required=True)
    truth.add_argument("--perturb", type=seed, metavar="SEED",
                       help="true robot: the nominal perturbed with Bai's tolerances (a printer's: "
                            "--tolerances), seeded")
    truth.add_argument("--truth", metavar="TRUE.toml", help="true robot: a geometry file")
    p.add_argument("--points",
                   help="comma-separated reflector points (tcp or [points] names; default tcp)")
    p.add_argument("--sigma-position", type=non_negative_float, metavar="MM",
                   help=f"tracker noise per axis of one reading [mm] (default {SIGMA_POSITION:g})")
    p.add_argument("--sigma-angle", type=non_negative_float, metavar="DEG",
                   help=f"probe noise per component of one reading [deg] (default {SIGMA_ANGLE_DEG:g})")
    p.add_argument("--no-orientation", action="store_true", help="no orientation probe")
    p.add_argument("--repeats", type=positive_int,
                   help="readings averaged per measurement (default 1)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the measurement noise (default 0)")
    p.add_argument("--payload", type=non_negative_list, metavar="KG[,KG...]",
                   help="mass at the TCP [kg]; several: every pose measured at each, in that order "
                        "(default 0). Loads the true robot's compliant actuators (column payload_kg)")
    p.add_argument("--compliance", metavar="C[,C,C]",
                   help="the true actuators' compliance [rad/N m], one for all or one each (default: the "
                        "truth file's, else rigid); the robot's masses come from [masses]")
    p.add_argument("-o", "--output", required=True, metavar="MEAS.csv",
                   help="output file (a printer: the filled probe heights)")
    p.add_argument("--station", action="append", type=station_frame, metavar="NAME:RX,RY,RZ:X,Y,Z",
                   help="write the measurements in an instrument frame: rotation vector of {O} in it [deg] "
                        "and origin of {O} in it [mm]; repeat for several stations (consecutive "
                        "blocks of poses, one per station in order; all points of a pose in one station)")
    add_printer_arguments(p)
    p.set_defaults(func=run)
    return p


def _compliance(text: str) -> np.ndarray:
    """``--compliance``: one value for the three actuators or three, finite, >= 0 [rad/N m]."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"--compliance: numbers [rad/N m] expected, got {text!r}") from None
    if len(values) not in (1, 3) or not all(math.isfinite(v) and v >= 0.0 for v in values):
        raise UsageError(f"--compliance: one or three finite non-negative numbers [rad/N m], got {text!r}")
    return np.broadcast_to(np.array(values), (3,)).copy()


def _rotary_options(args: argparse.Namespace) -> None:
    """A rotary Delta's simulation: one POSES file, no printer option; the defaults of its options."""
    refuse_printer_options(args)
    if len(args.poses) != 1:
        raise UsageError(f"a rotary Delta's simulation reads one POSES file, got {len(args.poses)}")
    args.poses = args.poses[0]
    defaults = {"points": "tcp", "sigma_position": SIGMA_POSITION, "sigma_angle": SIGMA_ANGLE_DEG,
                "repeats": 1, "payload": [0.0]}
    for name, value in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, value)


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal simulate``: write the measurements (and the true geometry), return 0."""
    check_input(args.nominal)
    nominal = load_robot(args.nominal)
    if isinstance(nominal, NominalLinearDelta):
        return run_printer(args, nominal)
    _rotary_options(args)
    inputs = (args.nominal, args.poses, args.truth)
    for path in inputs:
        if path is not None:
            check_input(path)
    check_output(args.output, inputs)
    if args.truth is None:
        check_output(truth_path(args.output), inputs)
    read = read_poses_file(args.poses, nominal)
    poses = read.poses
    warn(read.warnings)
    if args.truth is not None:
        truth = load_geometry(args.truth)
    else:
        truth = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(args.perturb))
    if args.compliance is not None:
        truth = replace(truth, compliance=_compliance(args.compliance))
    payloads = args.payload
    q = np.tile(poses.q, (len(payloads), 1))
    payload = np.repeat(payloads, len(poses))
    points = tuple(point_list(args.points, truth.point_names))
    metrology = Metrology(
        points=points,
        sigma_position=args.sigma_position,
        sigma_angle=math.radians(args.sigma_angle),
        orientation=not args.no_orientation,
        repeats=args.repeats,
    )
    try:
        measurements = simulate_measurements(truth, q, np.random.default_rng(args.seed), metrology,
                                             payload=payload)
    except AssemblyError as exc:  # poses of the nominal robot the true one cannot take
        if not exc.indices:
            raise
        robot = f"the true robot ({args.truth})" if args.truth is not None else "the perturbed robot"
        exc.indices = sorted({i % len(poses) for i in exc.indices})
        raise unassembled_rows(exc, args.poses, read.lines, poses.q, robot) from exc
    names = [name for name, _ in args.station or []]
    if len(set(names)) != len(names):
        raise UsageError(f"--station: each station once, got {', '.join(names)}")
    if args.station:
        frames = dict(args.station)
        station = pose_stations(list(frames), len(q), len(points))
        measurements = in_instrument_frames(replace(measurements, station=station), frames)
    if args.perturb is not None:
        save_geometry(truth, truth_path(args.output))
    write_measurements(args.output, measurements)
    orientation = (
        f", orientation σ {math.degrees(metrology.angle_noise):.3g} deg" if metrology.orientation else ""
    )
    loads = f" x {len(payloads)} payloads" if len(payloads) > 1 else ""
    print(
        f"simulated {len(measurements)} measurements ({len(poses)} poses{loads} x {len(points)} point(s): "
        f"{', '.join(points)}; σ {metrology.position_noise:.3g} mm per axis{orientation}) -> {args.output}"
    )
    if args.perturb is not None:
        print(f"true geometry (seed {args.perturb}) -> {truth_path(args.output)}")
    return 0
