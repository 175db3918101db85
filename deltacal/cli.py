"""The ``deltacal`` command.

Commands (files in mm and deg; see the README for formats):

* ``deltacal demo``: the whole job on a simulated robot (plan, measure, identify,
  compensate, validate).
* ``deltacal identify NOMINAL MEASUREMENTS --model M -o CAL``
* ``deltacal compensate CAL TARGETS -o JOINTS``
* ``deltacal plan NOMINAL --model M [--n N | --epsilon E] -o POSES``
* ``deltacal simulate NOMINAL POSES (--perturb SEED | --truth TRUE) -o MEAS``
* ``deltacal view NOMINAL [...] [--html OUT]``

Errors in the user's input print one line on stderr naming the file, line,
column or key and value, and exit with status 1 (bad data) or 2 (bad usage);
``--debug`` shows the traceback. Outputs are written atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from . import __version__
from .exceptions import DeltacalError, InputError

EXIT_DATA = 1
EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _warn(lines: Sequence[str]) -> None:
    for line in lines:
        print(f"warning: {line}", file=sys.stderr)


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _check_output(path: str) -> None:
    folder = Path(path).resolve().parent
    if not folder.is_dir():
        raise InputError("the output folder does not exist", str(path))


# --------------------------------------------------------------------------- identify
def _identify(args: argparse.Namespace) -> int:
    from .geometry import NominalDelta
    from .identification import identify
    from .io import read_measurements

    _check_output(args.output)
    nominal = NominalDelta.from_toml(args.nominal)
    start = nominal.geometry()
    measurements, warnings = read_measurements(args.measurements, start.point_names)
    _warn(warnings)
    if args.distances and np.any(measurements.has_orientation):
        _warn(["orientations are ignored when identifying from distances"])
    result = identify(
        start,
        measurements,
        args.model,
        method="linear" if args.linear else "iterated",
        sigma_position=args.sigma_position,
        sigma_angle=math.radians(args.sigma_angle),
        distances=args.distances,
        pairs=args.pairs,
    )
    print(result.report())
    result.save(args.output)
    print(f"\nwrote {args.output}")
    return 0


def _add_identify(sub) -> None:
    from .errormodels import MODEL_NAMES

    p = sub.add_parser("identify", help="identify the geometry from measurements")
    p.add_argument("nominal", help="nominal robot file (TOML)")
    p.add_argument("measurements", help="measurements (CSV)")
    p.add_argument("--model", choices=MODEL_NAMES, default="complete", help="error model (default complete)")
    p.add_argument("-o", "--output", required=True, help="calibration file to write (TOML)")
    p.add_argument("--sigma-position", type=_positive, default=0.005, metavar="MM",
                   help="σ of each measured coordinate [mm] (default 0.005)")
    p.add_argument("--sigma-angle", type=_positive, default=0.003, metavar="DEG",
                   help="σ of each measured orientation component [deg] (default 0.003)")
    p.add_argument("--linear", action="store_true",
                   help="one-shot linear identification around the nominal geometry (the papers)")
    p.add_argument("--distances", action="store_true",
                   help="identify from distances between positions of a same point (no frame needed)")
    p.add_argument("--pairs", choices=("all", "reference"), default="all",
                   help="distance pairs: all pairs, or each pose with the first (default all)")
    p.set_defaults(func=_identify)


# --------------------------------------------------------------------------- compensate
def _compensate(args: argparse.Namespace) -> int:
    from .compensation import compensate
    from .geometry import DeltaGeometry
    from .io import read_targets, write_joints

    _check_output(args.output)
    geometry = DeltaGeometry.load(args.calibration)
    targets, warnings = read_targets(args.targets)
    _warn(warnings)
    linear = None
    if args.method != "exact":
        from .io import load_linear_calibration

        linear = load_linear_calibration(args.calibration)
    q = compensate(geometry, targets, args.method, linear)
    write_joints(args.output, targets, q)
    print(f"wrote {len(targets)} joint readings to {args.output}")
    return 0


def _add_compensate(sub) -> None:
    p = sub.add_parser("compensate", help="joint readings that put the TCP at target positions")
    p.add_argument("calibration", help="calibration file written by identify (TOML)")
    p.add_argument("targets", help="targets (CSV: x_mm,y_mm,z_mm)")
    p.add_argument("-o", "--output", required=True, help="joints file to write (CSV)")
    p.add_argument("--method", choices=("exact", "savoure", "bai"), default="exact",
                   help="exact (default), or a linear compensator: savoure (Eq. 29-33), bai (Eq. 22-25)")
    p.set_defaults(func=_compensate)


# --------------------------------------------------------------------------- demo
def _demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    run_demo(out_dir=Path(args.out), seed=args.seed, quick=args.quick)
    return 0


def _add_demo(sub) -> None:
    p = sub.add_parser("demo", help="the whole job on a simulated robot (bai2015)")
    p.add_argument("--out", default="results", help="folder for demo.json and plots (default results)")
    p.add_argument("--seed", type=int, default=2015, help="seed of the simulated robot (default 2015)")
    p.add_argument("--quick", action="store_true", help="fewer poses, for a fast check")
    p.set_defaults(func=_demo)


def _optional_parsers() -> list[Callable]:
    """Commands that live next to their module (planning, simulation, viz)."""
    adders = []
    for module, name in (("planning", "add_plan_parser"), ("simulation", "add_simulate_parser"),
                         ("viz", "add_view_parser")):
        try:
            mod = __import__(f"deltacal.{module}", fromlist=[name])
        except ImportError:
            continue
        adder = getattr(mod, name, None)
        if adder is not None:
            adders.append(adder)
    return adders


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``deltacal`` command."""
    parser = _Parser(prog="deltacal", description="Geometric calibration of Delta parallel robots.")
    parser.add_argument("--version", action="version", version=f"deltacal {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _add_demo(sub)
    _add_identify(sub)
    _add_compensate(sub)
    for adder in _optional_parsers():
        adder(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("deltacal: interrupted", file=sys.stderr)
        return 130
    except (DeltacalError, ValueError, OSError) as exc:
        if args.debug:
            raise
        message = str(exc).replace("\n", " ")
        if isinstance(exc, OSError) and not isinstance(exc, DeltacalError):
            message = f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": ")
        print(f"deltacal {args.command}: error: {message}", file=sys.stderr)
        return EXIT_DATA


if __name__ == "__main__":
    sys.exit(main())
