"""``deltacal report``: one self-contained HTML page of a calibration."""

from __future__ import annotations

import argparse

import numpy as np

from ..exceptions import InputError, UsageError
from ..identification.quality import implausible_deviations
from ..io import load_calibration, load_geometry
from ..report import write_report
from ..robots import load_robot
from .common import check_input, check_output, non_negative_float, three_numbers, warn
from .firmware import add_firmware_argument, check_printer_values, controller_firmware


def tool_vector(text: str) -> np.ndarray:
    """Argparse type: ``X,Y,Z`` [mm], three finite numbers."""
    return np.array(three_numbers(text, "X,Y,Z in mm"))


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal report``; returns the exit status."""
    inputs = [args.calibration, *(args.measurements or ()), args.truth, args.robot, args.controller]
    for path in inputs:
        if path is not None:
            check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    controller = _controller(args, calibration)
    nominal = calibration.nominal
    truth = load_geometry(args.truth) if args.truth is not None else None
    robot = load_robot(args.robot) if args.robot is not None else None
    for path, geometry, what in ((args.truth, truth, "true robot"),
                                 (args.robot, robot.geometry() if robot else None, "robot file")):
        odd = implausible_deviations(nominal, geometry) if geometry is not None else []
        if odd:
            name = nominal.name or "robot"
            raise InputError(f"this {what} is not the calibration's robot ({'; '.join(odd)} from the "
                             f"calibration's nominal {name!r}): the file of another robot?", str(path))
    workspace = robot.workspace if robot is not None else None
    summary = write_report(
        calibration,
        args.output,
        measurements=args.measurements,
        truth=truth,
        truth_source=args.truth,
        tool=args.tool,
        payload=args.payload,
        workspace=workspace,
        view=not args.no_view,
        controller=controller,
    )
    warn(summary.warnings)
    w = summary.worst_point
    print(f"largest predicted σ of the TCP: {summary.worst_sigma * 1000.0:.4g} µm at "
          f"({w[0]:.1f}, {w[1]:.1f}, {w[2]:.1f}) mm")
    print(f"wrote {args.output}")
    return 0


def _controller(args: argparse.Namespace, calibration):
    """A printer's firmware values its measurements were commanded with (``--controller``), or None."""
    if not calibration.geometry.chain.firmware:
        if args.controller is not None:
            raise UsageError("--controller applies to a printer's calibration (its measurements' firmware)")
        return None
    if args.measurements and args.controller is None:
        raise UsageError(f"{args.calibration}: a printer's measurements are of commanded positions: give "
                         "--controller printer.cfg|config.g|M503.txt (the settings they were made with)")
    if args.controller is None:
        return None
    kind = controller_firmware(args.controller, args.firmware)
    model = kind.read_config(args.controller)
    check_printer_values(kind, calibration.geometry, model, args.calibration, args.controller)
    return model


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
    add_firmware_argument(p)
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
    p.set_defaults(func=run)
