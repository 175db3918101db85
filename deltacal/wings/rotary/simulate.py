"""A rotary Delta's simulated measurements: a true robot at the planned poses, seen by a tracker, a probe."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...exceptions import AssemblyError, InputError
from ...geometry import NominalDelta, Tolerances
from ...identification.frames import in_instrument_frames
from ...io import load_geometry, read_poses_file, save_geometry, unassembled_rows, write_measurements
from ...observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ...simulation import Metrology, pose_stations, simulate_measurements, truth_path
from ..base import Done, check_files, warn
from ..requests import SimulateRequest


def point_list(text: str, known: list[str], option: str = "--points") -> list[str]:
    """Comma-separated point names, each checked against the robot's points.

    Raises:
        InputError: naming the option, for a name the robot does not have (or none at all).
    """
    points = [p.strip() for p in text.split(",") if p.strip()]
    if not points:
        raise InputError(f"no point named in {text!r}; the robot's points are {', '.join(known)}", option)
    for name in points:
        if name not in known:
            raise InputError(f"unknown point {name!r}; the robot's points are {', '.join(known)}", option)
    return points


def simulate_rotary(request: SimulateRequest, nominal: NominalDelta) -> Done:
    """``deltacal simulate`` of a rotary Delta: the measurements (and the true geometry) written."""
    request.check_rotary()
    poses_file = request.poses[0]
    inputs = (request.nominal, poses_file, request.truth)
    check_files(inputs, request.output)
    if request.truth is None:
        check_files(inputs, truth_path(Path(request.output)))
    read = read_poses_file(poses_file, nominal)
    poses = read.poses
    warn(read.warnings)
    if request.truth is not None:
        truth = load_geometry(request.truth)
    else:
        truth = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(request.perturb))
    if request.compliance is not None:
        truth = replace(truth, compliance=request.compliances())
    payloads = list(request.payload or [0.0])
    q = np.tile(poses.q, (len(payloads), 1))
    payload = np.repeat(payloads, len(poses))
    points = tuple(point_list(request.points or "tcp", truth.point_names))
    metrology = Metrology(
        points=points,
        sigma_position=SIGMA_POSITION if request.sigma_position is None else request.sigma_position,
        sigma_angle=math.radians(SIGMA_ANGLE_DEG if request.sigma_angle is None else request.sigma_angle),
        orientation=not request.no_orientation,
        repeats=request.repeats or 1,
    )
    try:
        measurements = simulate_measurements(truth, q, np.random.default_rng(request.seed), metrology,
                                             payload=payload)
    except AssemblyError as exc:  # poses of the nominal robot the true one cannot take
        if not exc.indices:
            raise
        robot = f"the true robot ({request.truth})" if request.truth is not None else "the perturbed robot"
        exc.indices = sorted({i % len(poses) for i in exc.indices})
        raise unassembled_rows(exc, poses_file, read.lines, poses.q, robot) from exc
    if request.station:
        frames = dict(request.station)
        station = pose_stations(list(frames), len(q), len(points))
        measurements = in_instrument_frames(replace(measurements, station=station), frames)
    if request.perturb is not None:
        save_geometry(truth, truth_path(Path(request.output)))
    write_measurements(request.output, measurements)
    orientation = (f", orientation σ {math.degrees(metrology.angle_noise):.3g} deg" if metrology.orientation
                   else "")
    loads = f" x {len(payloads)} payloads" if len(payloads) > 1 else ""
    lines = [f"simulated {len(measurements)} measurements ({len(poses)} poses{loads} x {len(points)} "
             f"point(s): {', '.join(points)}; σ {metrology.position_noise:.3g} mm per axis{orientation}) -> "
             f"{request.output}"]
    if request.perturb is not None:
        lines.append(f"true geometry (seed {request.perturb}) -> {truth_path(Path(request.output))}")
    return Done(tuple(lines))
