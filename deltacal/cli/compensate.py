"""``deltacal compensate``: joint readings (or a controller's corrected targets) that put the TCP on targets.

The job (:mod:`deltacal.wings.compensate_job`) streams the targets file (or a G-code program) chunk by chunk,
a large file on every core; a progress line shows on a terminal.
"""

from __future__ import annotations

import argparse

from .. import wings
from ..compensation import METHODS
from ..gcode import DEFAULT_SEGMENT_MM
from ..holds import DEFAULT_BOUND
from ..wings.requests import CompensateRequest
from .common import add_firmware_argument, non_negative_float, positive_float, request, show, three_numbers
from .progress import Progress


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal compensate``; returns the exit status."""
    job = request(CompensateRequest, args)
    with Progress("compensate") as progress:
        done = wings.compensate(job, progress.update)
    return show(done)


def add_parser(sub) -> None:
    """Register ``compensate``."""
    p = sub.add_parser("compensate", help="joint readings that put the TCP at target positions")
    p.add_argument("calibration", help="calibration file written by identify (TOML)")
    p.add_argument("targets", help="targets (CSV: x_mm,y_mm,z_mm)")
    p.add_argument("-o", "--output", required=True, help="joints (or, with --controller, corrected targets) "
                                                          "file to write (CSV)")
    p.add_argument("--method", choices=METHODS, default="exact",
                   help="exact (default), or a linear compensator: savoure (Eq. 29-33), bai (Eq. 22-25)")
    p.add_argument("--frame", choices=("base", "instrument"), default="base",
                   help="targets in the robot base frame {O} (default), or in the instrument frame {T} of a "
                        "calibration identified with --frame free")
    p.add_argument("--station", help="with --frame instrument: the station whose frame the targets are in")
    p.add_argument("--controller", metavar="CONTROLLER",
                   help="write corrected targets (x_cmd_mm,y_cmd_mm,z_cmd_mm, in the base frame {O}) to "
                        "send a controller running this model (a controller file, a robot file: its "
                        "nominal controller, or a printer's firmware settings: Klipper's printer.cfg, "
                        "Marlin's M503 capture, RepRapFirmware's config.g) instead of joint readings")
    add_firmware_argument(p)
    p.add_argument("--payload", type=non_negative_float, default=0.0, metavar="KG",
                   help="mass carried at the TCP [kg] (default 0): with a calibration that identified the "
                        "actuators' compliances, the readings (or a controller's corrected targets) put "
                        "the loaded TCP on the targets (exact method)")
    p.add_argument("--sigma-bound", type=positive_float, default=DEFAULT_BOUND, metavar="MM",
                   help=f"a printer: the σ of a correction accepted [mm] (default {DEFAULT_BOUND:g}): where "
                        "the calibration's correction has a larger σ (the measurements do not determine it) "
                        "the controller's own command is sent, blended in from half of it")
    p.add_argument("--refuse-unheld", action="store_true",
                   help="a printer: refuse a target where the correction is not wholly applied (its σ above "
                        "half --sigma-bound) instead of sending the controller's own command there")
    p.add_argument("--segment-mm", type=positive_float, metavar="S",
                   help=f"G-code: longest move sent [mm] (default {DEFAULT_SEGMENT_MM:g}); longer moves are "
                        "split so the real path follows the intended straight line")
    p.add_argument("--start", type=lambda t: three_numbers(t, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="G-code: the TCP position at the program's start [mm], if its first move does "
                        "not give X, Y and Z")
    p.set_defaults(func=run)
