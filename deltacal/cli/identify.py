"""``deltacal identify``: the geometry from measurements (a rotary Delta's; a printer's, by its firmware)."""

from __future__ import annotations

import argparse

import numpy as np

from .. import wings
from ..errormodels import MODEL_NAMES, PRINTER_MODEL_NAMES
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ..wings.requests import IdentifyRequest
from .common import add_firmware_argument, positive_float, request, show, sigma, three_numbers

#: A probe's trigger point is on the effector: within this of the nozzle along each axis [mm].
PROBE_OFFSET_MM = 100.0


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal identify``; returns the exit status."""
    return show(wings.identify(request(IdentifyRequest, args)))


def probe_offset(text: str) -> np.ndarray:
    """Argparse type of ``--probe-offset X,Y,Z`` [mm]: three numbers, each within :data:`PROBE_OFFSET_MM`."""
    values = np.asarray(three_numbers(text, "X,Y,Z in mm"))
    far = np.flatnonzero(np.abs(values) > PROBE_OFFSET_MM)
    if far.size:
        k = int(far[0])
        raise argparse.ArgumentTypeError(
            f"the probe's trigger point is on the effector, within {PROBE_OFFSET_MM:g} mm of the nozzle; "
            f"{'XYZ'[k]} = {values[k]:g} mm in {text!r} (metres? micrometres? deltacal reads millimetres)")
    return values


def add_parser(sub) -> None:
    """Register ``identify``."""
    p = sub.add_parser("identify", help="identify the geometry from measurements")
    p.add_argument("nominal", help="nominal robot file (TOML): a rotary Delta or a printer (kind = 'linear')")
    p.add_argument("measurements", nargs="+",
                   help="measurements (CSV); a printer: its probe heights, then distances files")
    p.add_argument("--model", choices=MODEL_NAMES + PRINTER_MODEL_NAMES, default=None,
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
    p.add_argument("--controller", metavar="SETTINGS",
                   help="a printer: the firmware's settings the measurements were made with (Klipper's "
                        "printer.cfg, Marlin's M503 capture, RepRapFirmware's config.g)")
    add_firmware_argument(p)
    p.add_argument("--live-correction-off", action="store_true",
                   help="a printer whose --controller printer.cfg includes deltacal's live correction "
                        "(export --live): the measurements were made with it off (DELTACAL_GEOMETRY "
                        "ENABLE=0 before probing and printing; without this, identify refuses them)")
    p.add_argument("--probe-offset", type=probe_offset,
                   default=np.zeros(3), metavar="X,Y,Z",
                   help="a printer: the probe's trigger point from the nozzle, in the effector frame [mm] "
                        "(default 0,0,0: the nozzle is the probe; a probe file's trigger_height_mm is that "
                        "point's height above the bed at the trigger)")
    p.add_argument("--sigma-height", type=sigma, default=0.01, metavar="MM",
                   help="a printer: σ of a probe height [mm] (default 0.01)")
    p.add_argument("--sigma-distance", type=sigma, default=0.02, metavar="MM",
                   help="a printer: σ of a caliper distance [mm] (default 0.02)")
    p.add_argument("--tolerance-scale", type=positive_float, default=None, metavar="S",
                   help="a printer: the factor of the kit's build tolerances the priors take (default: the "
                        "one the measurements make most probable)")
    p.set_defaults(func=run)
