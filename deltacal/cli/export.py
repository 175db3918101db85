"""``deltacal export``: the identified robot as an MJCF model (MuJoCo, Pinocchio)."""

from __future__ import annotations

import argparse
from collections.abc import Mapping

import numpy as np

from ..export import write_mjcf
from ..geometry import DeltaGeometry
from ..io import control_character, load_calibration, load_nominal, read_toml
from .common import check_input, check_output, three_numbers


def load_robot(path: str) -> tuple[DeltaGeometry, list[str]]:
    """The geometry of a calibration, geometry or nominal robot file, and the calibration's stations.

    Raises:
        InputError: naming the file, key and value of the first problem found.
    """
    data = read_toml(path)
    geometry = data.get("geometry")
    if "format" not in data and isinstance(geometry, Mapping) and "base_radius_mm" in geometry:
        return load_nominal(path).geometry(), []  # a nominal robot file (it has no format key)
    calibration = load_calibration(path)  # a calibration or geometry file, checked as every command does
    return calibration.geometry, list(calibration.frames)


def _readings_deg(text: str) -> np.ndarray:
    """Argparse type: ``Q1,Q2,Q3`` in degrees, each within ±180 (one turn of an arm) -> readings [rad]."""
    values = three_numbers(text, "Q1,Q2,Q3 (deg)")
    if np.any(np.abs(values) > 180.0):
        raise argparse.ArgumentTypeError(f"readings must lie within ±180 deg, got {text!r}")
    return np.radians(values)


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal export``; returns the exit status."""
    check_input(args.calibration)
    check_output(args.mjcf, (args.calibration,))
    geometry, stations = load_robot(args.calibration)
    write_mjcf(args.mjcf, geometry, name=args.name, home=args.home, stations=stations,
               source=str(args.calibration))
    frame = " (robot base frame {O}; the instrument frames are not exported)" if stations else ""
    print(f"wrote the MJCF model of {args.name or geometry.name or 'delta'} to {args.mjcf}{frame}")
    return 0


def add_parser(sub) -> None:
    """Register ``export``."""
    p = sub.add_parser(
        "export",
        help="write the robot as an MJCF model (MuJoCo, Pinocchio)",
        description=(
            "Write the identified robot (a calibration file from identify, a geometry file or a nominal "
            "robot file) as an MJCF model in SI units: hinge joints arm1..arm3 whose values are the "
            "encoder readings [rad], ball-jointed rods closed on the plate by <connect> constraints, "
            "sites tcp and the named points, and a keyframe 'home' holding an assembly."
        ),
    )
    p.add_argument("calibration", metavar="CALIBRATION",
                   help="calibration file written by identify, or a geometry or robot file (TOML)")
    p.add_argument("--mjcf", required=True, metavar="ROBOT.xml", help="MJCF file to write")
    p.add_argument("--name", type=_model_name, help="model name (default: the robot's name)")
    p.add_argument("--home", type=_readings_deg, metavar="Q1,Q2,Q3",
                   help="readings of the 'home' keyframe [deg] (default 0,0,0)")
    p.set_defaults(func=run)


def _model_name(text: str) -> str:
    """Argparse type of ``--name``: text without control characters (no XML file holds them)."""
    problem = control_character(text)
    if problem is not None:
        raise argparse.ArgumentTypeError(f"model name {text!r} {problem}")
    return text

