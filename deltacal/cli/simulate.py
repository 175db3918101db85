"""``deltacal simulate``: a true robot's tracker (and probe) measurements at planned poses, or a printer's."""

from __future__ import annotations

import argparse

import numpy as np

from .. import wings
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ..printer.simulation import TOLERANCE_CLASSES
from ..wings.printer.simulate import SIGMA_DISTANCE, SIGMA_HEIGHT
from ..wings.requests import SimulateRequest
from .common import (
    add_firmware_argument,
    non_negative_float,
    non_negative_list,
    positive_int,
    request,
    seed,
    show,
    station_frame,
    three_numbers,
)


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal simulate``: write the measurements (and the true geometry), return 0."""
    return show(wings.simulate(request(SimulateRequest, args)))


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
    p.add_argument("--controller", metavar="SETTINGS",
                   help="a printer: the firmware's settings (Klipper's printer.cfg, Marlin's M503 "
                        "capture, RepRapFirmware's config.g) the probing and the print are commanded with")
    add_firmware_argument(p)
    p.add_argument("--distances-output", metavar="OUT_DISTANCES.csv",
                   help="a printer: the filled distances file (with a DISTANCES.csv template)")
    p.add_argument("--sigma-height", type=non_negative_float, metavar="MM",
                   help=f"a printer: σ of a probe height [mm] (default {SIGMA_HEIGHT:g})")
    p.add_argument("--sigma-distance", type=non_negative_float, metavar="MM",
                   help=f"a printer: σ of a caliper distance [mm] (default {SIGMA_DISTANCE:g})")
    p.add_argument("--probe-offset", type=lambda t: np.asarray(three_numbers(t, "X,Y,Z in mm")),
                   metavar="X,Y,Z",
                   help="a printer: the probe's trigger point from the nozzle, in the effector frame [mm] "
                        "(default 0,0,0: the nozzle is the probe)")
    p.add_argument("--tolerances", choices=tuple(TOLERANCE_CLASSES),
                   help="a printer with --perturb: its build tolerances (default printer-kit: "
                        "Tolerances.printer_kit(); typical-kit and well-built: the anchor's classes)")
    p.set_defaults(func=run)
    return p
