"""``deltacal plan``: measurement poses (Bai's circles and κ(n) rule, or D-optimal), or a printer's object."""

from __future__ import annotations

import argparse
import sys

from .. import wings
from ..planning import MEASUREMENTS, PLAN_MODELS
from ..printer.printed.object import CALIPER_RANGE, MAX_DISTANCES
from ..wings.printer.plan import MAX_PROBE_GRID
from ..wings.requests import PlanRequest
from .common import (
    add_firmware_argument,
    int_at_most,
    non_negative_list,
    positive_float,
    positive_int,
    request,
    seed,
    show,
)

#: Largest --n-max: the κ(n) curve conditions one pose set per n (n = 200 takes minutes already).
N_MAX_LIMIT = 200


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal plan``: write the POSES file (or the object's folder), print what was chosen."""
    return show(wings.plan(request(PlanRequest, args), notify=lambda text: print(text, file=sys.stderr)))


def parse_epsilon(text: str) -> float:
    """ε0 from the command line: a fraction (``0.01``) or a percentage (``1%``)."""
    try:
        value = float(text[:-1]) / 100.0 if text.strip().endswith("%") else float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number or percentage: {text!r}") from None
    if not (0.0 < value < 1.0):
        raise argparse.ArgumentTypeError(f"epsilon must be in (0, 1) or (0 %, 100 %), got {text!r}")
    return value


def probe_grid_size(text: str) -> int:
    """Argparse type: an odd number of probe points across the bed, 3 to :data:`MAX_PROBE_GRID`."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 3 or value > MAX_PROBE_GRID or value % 2 == 0:
        raise argparse.ArgumentTypeError(f"must be odd, 3 to {MAX_PROBE_GRID} (Klipper's round_probe_count; "
                                         f"9 keeps 49 points within the radius), got {value}")
    return value


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``plan``."""
    p = subparsers.add_parser(
        "plan",
        help="plan measurement poses (Bai's circles and κ(n) rule, or D-optimal)",
        description=(
            "Plan measurement poses for a robot file and write a POSES CSV "
            "(q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm: readings, then the nominal TCP target). "
            "Strategy 'bai': the centre and n poses on each of the top and bottom circles of "
            "the workspace (the middle circle for --model rough), n given or chosen by Bai's "
            "κ(n) rule (Eq. 21). Strategy 'doptimal': COUNT poses of a random pool maximising "
            "log det of the scaled base regressor."
        ),
    )
    p.add_argument("nominal", metavar="NOMINAL", help="robot file (TOML) with a [workspace]")
    p.add_argument("--object", action="store_true",
                   help="a linear Delta printer: plan the probe grid and the object to print and measure "
                        "(-o DIR gets object.stl, probe.csv, probe.gcode, distances.csv and sheet.html)")
    p.add_argument("--controller", metavar="SETTINGS",
                   help="--object: the firmware's settings (Klipper's printer.cfg, Marlin's M503 "
                        "capture, RepRapFirmware's config.g) the probing and the print are commanded with")
    add_firmware_argument(p)
    p.add_argument("--distances", type=int_at_most(MAX_DISTANCES, "caliper distances of the object"),
                   metavar="N", help=f"--object: distances to measure (default and most: {MAX_DISTANCES})")
    p.add_argument("--probe-grid", type=probe_grid_size, metavar="N",
                   help="--object: probe points across the bed, odd (default 7: Klipper's round 7 x 7 mesh)")
    p.add_argument("--caliper", type=positive_float, metavar="MM",
                   help=f"--object: the caliper's longest outside reading (default {CALIPER_RANGE:g} mm)")
    p.add_argument("--model", choices=PLAN_MODELS,
                   help="error model (default: complete; 'rough': encoder offsets only)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--n", type=positive_int, help="poses per circle (strategy bai)")
    group.add_argument("--epsilon", type=parse_epsilon,
                       help="ε0 of the κ(n) rule, fraction or percentage (default: 1%%)")
    p.add_argument("--strategy", choices=("bai", "doptimal"),
                   help="Bai's circles (default) or D-optimal selection from a random pool")
    p.add_argument("--measure", choices=MEASUREMENTS,
                   help="measurement kind for κ and D-optimality (default: distance for Bai's "
                        "distance models bai18/bai36/bai32 and rough, pose otherwise)")
    p.add_argument("--points", help="comma-separated plate points measured (default: by model)")
    p.add_argument("--count", type=positive_int, help="poses to select (strategy doptimal; "
                   "default: twice the number of base parameters, divided by the rows per pose)")
    p.add_argument("--pool", type=positive_int, metavar="N",
                   help="candidate pool size (doptimal; default 1000). Memory and time grow linearly with "
                        "it: each candidate keeps its scaled regressor (about 2 KB for the complete model "
                        "and pose measurements) and each selection step scores every candidate; 200,000 "
                        "take about 0.6 GB and one to a few minutes. From 20,000 on, plan says the "
                        "estimate before it starts")
    p.add_argument("--seed", type=seed, help="seed of the candidate pool (doptimal; default 0)")
    p.add_argument("--payload", type=non_negative_list, metavar="KG[,KG...]",
                   help="doptimal: plan for the actuators' compliances too, every pose measured at each "
                        "payload [kg] (simulate --payload with the same list; the robot file's [masses])")
    p.add_argument("--n-max", type=int_at_most(N_MAX_LIMIT, "each n is a pose set to condition"),
                   help="largest n of the κ(n) curve (default 20)")
    p.add_argument("-o", "--output", required=True, metavar="POSES.csv",
                   help="output file (with --object: the folder of object.stl, probe.csv, distances.csv)")
    p.set_defaults(func=run)
    return p
