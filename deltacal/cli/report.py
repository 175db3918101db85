"""``deltacal report``: an HTML page of a calibration (a printer's in its firmware's words)."""

from __future__ import annotations

import argparse

import numpy as np

from .. import wings
from ..printer.firmware.config_file import firmware_names
from ..wings.requests import ReportRequest
from .common import non_negative_float, request, show, three_numbers


def tool_vector(text: str) -> np.ndarray:
    """Argparse type: ``X,Y,Z`` [mm], three finite numbers."""
    return np.array(three_numbers(text, "X,Y,Z in mm"))


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal report``; returns the exit status."""
    return show(wings.report(request(ReportRequest, args)))


def add_parser(sub) -> None:
    """Register ``report``."""
    p = sub.add_parser(
        "report",
        help="an HTML report of a calibration: parameters, residuals, predicted accuracy map",
        description=(
            "Write one self-contained HTML page (no network access, readable on a phone, printable) "
            "of a calibration file: the fit, the base parameters with σ and correlations, what is not "
            "identifiable and why, residuals per measurement, the predicted σ of the TCP over the "
            "workspace and a 3-D view of the identified robot."
        ),
    )
    p.add_argument("calibration", metavar="CALIBRATION.toml", help="calibration file written by identify")
    p.add_argument("-o", "--output", required=True, metavar="REPORT.html", help="HTML file to write")
    p.add_argument("--measurements", metavar="MEAS.csv", nargs="+",
                   help="the measurements the calibration was identified from (residual plots); a printer's "
                        "probe.csv and distances.csv, with --controller")
    p.add_argument("--controller", metavar="SETTINGS",
                   help="a printer: the firmware's settings its measurements were made with (printer.cfg, "
                        "config.g, an M503 capture)")
    p.add_argument("--history", metavar="OLDER.toml", nargs="+",
                   help="a printer: its earlier calibrations, oldest first (the calibration is the newest): "
                        "the page shows each owner's quantity in each and each step's change with its σ, all "
                        "under the calibration's prior, as compare does")
    p.add_argument("--truth", metavar="TRUE.toml",
                   help="true geometry of a simulation (simulate --perturb writes MEAS.truth.toml): actual "
                        "TCP errors beside the predicted σ")
    p.add_argument("--tool", type=tool_vector, metavar="X,Y,Z",
                   help="TCP in the plate frame for the accuracy map [mm] (default: the calibration's tool)")
    p.add_argument(
        "--robot", metavar="ROBOT.toml",
        help="robot file whose [workspace] the accuracy map covers (default: sized from the robot)",
    )
    p.add_argument("--payload", type=non_negative_float, default=0.0, metavar="KG",
                   help="a calibration with compliances: map the TCP deflection under this payload [kg] too")
    p.add_argument("--no-view", action="store_true", help="leave out the 3-D view (a smaller file)")
    p.add_argument("--firmware", choices=firmware_names(), default=None,
                   help="a printer's calibration: the firmware whose values the page fits and names, and "
                        f"whose settings --controller is ({'|'.join(firmware_names())}; default: "
                        "--controller's, told from its content, else the one the calibration was identified "
                        f"with, else {firmware_names()[0]}; another than the calibration's is refused)")
    p.set_defaults(func=run)
