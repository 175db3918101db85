"""``deltacal export``: the identified robot as an MJCF model (MuJoCo, Pinocchio), or a controller's values.

``--controller offsets|limbs`` fits a rotary Delta's controller's joint offsets, or its per-limb values;
``--controller klipper|marlin|rrf`` a printer's firmware's values (one route for every firmware:
:mod:`deltacal.printer.firmware.export`). The calibration's wing does it (:func:`deltacal.wings.export`).
"""

from __future__ import annotations

import argparse

from .. import wings
from ..controller import FIT_KINDS
from ..holds import DEFAULT_BOUND
from ..io import control_character
from ..printer.firmware.config_file import firmware_names
from ..wings.requests import ExportRequest
from .common import positive_float, request, show, three_numbers


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal export``; returns the exit status."""
    return show(wings.export(request(ExportRequest, args)))


def _home_readings(text: str) -> str:
    """Argparse type of ``--home``: ``Q1,Q2,Q3``, three numbers (in the robot's unit, checked by the job)."""
    three_numbers(text, "Q1,Q2,Q3 (deg; a printer's in mm)")
    return text


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
    p.add_argument("--live", action="store_true",
                   help="with --controller klipper --config printer.cfg: -o OUTDIR gets "
                        "deltacal_geometry.py, a Klipper module that corrects every move itself, and "
                        "deltacal_geometry.cfg, its section (docs: printers, live correction)")
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

