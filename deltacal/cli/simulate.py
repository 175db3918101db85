"""``deltacal simulate``: tracker (and probe) measurements of a true robot at planned poses."""

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
    load_nominal,
    read_poses_file,
    save_geometry,
    unassembled_rows,
    write_measurements,
)
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ..simulation import Metrology, pose_stations, simulate_measurements, truth_path
from .common import (
    check_input,
    check_output,
    non_negative_float,
    point_list,
    positive_int,
    seed,
    station_frame,
    warn,
)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``simulate``."""
    p = subparsers.add_parser(
        "simulate",
        help="simulate tracker (and probe) measurements of a true robot at planned poses",
        description=(
            "Simulate the measurements of a true robot (perturbed nominal or a geometry file) "
            "standing at the readings of a POSES file, through the Pinocchio closed-loop model, "
            "and write a measurements CSV. With --perturb, the true geometry is also written "
            "next to the output (MEAS.truth.toml)."
        ),
    )
    p.add_argument("nominal", metavar="NOMINAL", help="robot file (TOML)")
    p.add_argument("poses", metavar="POSES", help="POSES CSV written by 'deltacal plan'")
    truth = p.add_mutually_exclusive_group(required=True)
    truth.add_argument("--perturb", type=seed, metavar="SEED",
                       help="true robot: the nominal perturbed with Bai's tolerances, seeded")
    truth.add_argument("--truth", metavar="TRUE.toml", help="true robot: a geometry file")
    p.add_argument("--points", default="tcp",
                   help="comma-separated reflector points (tcp or [points] names; default tcp)")
    p.add_argument("--sigma-position", type=non_negative_float, default=SIGMA_POSITION, metavar="MM",
                   help=f"tracker noise per axis of one reading [mm] (default {SIGMA_POSITION:g})")
    p.add_argument("--sigma-angle", type=non_negative_float, default=SIGMA_ANGLE_DEG, metavar="DEG",
                   help=f"probe noise per component of one reading [deg] (default {SIGMA_ANGLE_DEG:g})")
    p.add_argument("--no-orientation", action="store_true", help="no orientation probe")
    p.add_argument("--repeats", type=positive_int, default=1,
                   help="readings averaged per measurement (default 1)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the measurement noise (default 0)")
    p.add_argument("-o", "--output", required=True, metavar="MEAS.csv", help="output file")
    p.add_argument("--station", action="append", type=station_frame, metavar="NAME:RX,RY,RZ:X,Y,Z",
                   help="write the measurements in an instrument frame: rotation vector of {O} in it [deg] "
                        "and origin of {O} in it [mm]; repeat for several stations (consecutive "
                        "blocks of poses, one per station in order; all points of a pose in one station)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal simulate``: write the measurements (and the true geometry), return 0."""
    inputs = (args.nominal, args.poses, args.truth)
    for path in inputs:
        if path is not None:
            check_input(path)
    check_output(args.output, inputs)
    if args.truth is None:
        check_output(truth_path(args.output), inputs)
    nominal = load_nominal(args.nominal)
    read = read_poses_file(args.poses, nominal)
    poses = read.poses
    warn(read.warnings)
    if args.truth is not None:
        truth = load_geometry(args.truth)
    else:
        truth = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(args.perturb))
    points = tuple(point_list(args.points, truth.point_names))
    metrology = Metrology(
        points=points,
        sigma_position=args.sigma_position,
        sigma_angle=math.radians(args.sigma_angle),
        orientation=not args.no_orientation,
        repeats=args.repeats,
    )
    try:
        measurements = simulate_measurements(truth, poses.q, np.random.default_rng(args.seed), metrology)
    except AssemblyError as exc:  # poses of the nominal robot the true one cannot take
        if not exc.indices:
            raise
        robot = f"the true robot ({args.truth})" if args.truth is not None else "the perturbed robot"
        raise unassembled_rows(exc, args.poses, read.lines, poses.q, robot) from exc
    names = [name for name, _ in args.station or []]
    if len(set(names)) != len(names):
        raise UsageError(f"--station: each station once, got {', '.join(names)}")
    if args.station:
        frames = dict(args.station)
        station = pose_stations(list(frames), len(poses), len(points))
        measurements = in_instrument_frames(replace(measurements, station=station), frames)
    if args.perturb is not None:
        save_geometry(truth, truth_path(args.output))
    write_measurements(args.output, measurements)
    orientation = (
        f", orientation σ {math.degrees(metrology.angle_noise):.3g} deg" if metrology.orientation else ""
    )
    print(
        f"simulated {len(measurements)} measurements ({len(poses)} poses x {len(points)} point(s): "
        f"{', '.join(points)}; σ {metrology.position_noise:.3g} mm per axis{orientation}) -> {args.output}"
    )
    if args.perturb is not None:
        print(f"true geometry (seed {args.perturb}) -> {truth_path(args.output)}")
    return 0
