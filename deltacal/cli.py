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
column or key and value, and exit with status 1 (bad data) or 2 (bad usage:
arguments, missing input file, missing output folder, output overwriting an
input); ``--debug`` shows the traceback. An unexpected failure (a bug) exits
with status 3. Outputs are written atomically: a failing command leaves any
earlier output file as it was.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from . import __version__
from .exceptions import (
    AssemblyError,
    ConvergenceError,
    DeltacalError,
    IdentificationError,
    InputError,
    UnreachableError,
)

EXIT_DATA = 1
EXIT_USAGE = 2
EXIT_BUG = 3


class UsageError(DeltacalError):
    """The command line is wrong (a path that does not exist, an output over an input): status 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _one_line(text: str) -> str:
    """Text made one printable line: newlines become spaces, other control characters escapes."""
    text = text.replace("\r\n", " ").replace("\n", " ")
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def _warn(lines: Sequence[str]) -> None:
    for line in lines:
        print(_one_line(f"warning: {line}"), file=sys.stderr)


def positive_float(text: str) -> float:
    """Argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def non_negative_float(text: str) -> float:
    """Argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f"must be a finite non-negative number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """Argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def check_input(path: str | Path) -> None:
    """A usage error (exit 2) unless ``path`` is an existing file."""
    p = Path(path)
    if not p.exists():
        raise UsageError(f"{path}: file not found")
    if not p.is_file():
        raise UsageError(f"{path}: not a file")


def check_output(path: str | Path, inputs: Sequence[str | Path | None] = ()) -> None:
    """A usage error (exit 2) if the output's folder is missing, it is a folder, or an input."""
    out = Path(path)
    if not out.resolve().parent.is_dir():
        raise UsageError(f"{path}: the output folder does not exist")
    if out.is_dir():
        raise UsageError(f"{path}: is a folder; give the output file's name")
    for source in inputs:
        if source is not None and Path(source).exists() and out.resolve() == Path(source).resolve():
            raise UsageError(f"{path}: the output would overwrite an input file")


def _lines_text(lines: Sequence[int], limit: int = 10) -> str:
    shown = ", ".join(str(int(n)) for n in lines[:limit])
    return shown + (f" and {len(lines) - limit} more" if len(lines) > limit else "")


# --------------------------------------------------------------------------- identify
def _identify(args: argparse.Namespace) -> int:
    from .geometry import NominalDelta
    from .identification import identify
    from .io import data_row, read_measurements

    for path in (args.nominal, args.measurements):
        check_input(path)
    check_output(args.output, (args.nominal, args.measurements))
    nominal = NominalDelta.from_toml(args.nominal)
    start = nominal.geometry()
    measurements, notes = read_measurements(args.measurements, start.point_names)
    _warn(notes)
    if args.distances and np.any(measurements.has_orientation):
        _warn(["orientations are ignored when identifying from distances"])
    try:
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
    except AssemblyError as exc:
        # at the nominal geometry: the readings themselves are impossible
        lines = np.asarray(measurements.lines)[exc.indices].tolist() if exc.indices else []
        if not lines:
            raise
        k = exc.indices[0]
        q = np.round(np.degrees(measurements.q[k]), 6).tolist()
        more = f"; {len(lines)} rows in all, lines {_lines_text(lines)}" if len(lines) > 1 else ""
        raise InputError(
            f"the robot {nominal.name!r} cannot be assembled at the readings q = {q} deg{more}",
            args.measurements, f"{data_row(lines[0], k + 1)}, columns q1_deg..q3_deg",
        ) from exc
    except IdentificationError as exc:
        raise IdentificationError(f"{args.measurements}: {exc}") from exc
    except ConvergenceError as exc:
        raise ConvergenceError(f"{args.measurements}: {exc}", exc.residual) from exc
    print(result.report())
    if result.outlier_lines:
        _warn([f"{args.measurements}: line(s) {_lines_text(result.outlier_lines)} look like outliers "
               "(see the report): check them, or remove them and identify again"])
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
    p.add_argument("--sigma-position", type=positive_float, default=0.005, metavar="MM",
                   help="σ of each measured coordinate [mm] (default 0.005)")
    p.add_argument("--sigma-angle", type=positive_float, default=0.003, metavar="DEG",
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
    from .io import data_row, read_target_table, write_joints

    for path in (args.calibration, args.targets):
        check_input(path)
    check_output(args.output, (args.calibration, args.targets))
    geometry = DeltaGeometry.load(args.calibration)
    table = read_target_table(args.targets)
    _warn(table.warnings)
    targets = np.column_stack([table.numbers[c] for c in ("x_mm", "y_mm", "z_mm")])
    linear = None
    if args.method != "exact":
        from .io import load_linear_calibration

        linear = load_linear_calibration(args.calibration)
    try:
        q = compensate(geometry, targets, args.method, linear)
    except UnreachableError as exc:
        if not exc.indices:
            raise
        lines = table.lines[exc.indices].tolist()
        k = exc.indices[0]
        reason = "too close to a singularity" if "singularity" in str(exc) else "out of reach of the robot"
        more = f"; {len(lines)} targets in all, lines {_lines_text(lines)}" if len(lines) > 1 else ""
        raise InputError(
            f"target {np.round(targets[k], 6).tolist()} mm is {reason}{more}",
            args.targets, f"{data_row(lines[0], k + 1)}, columns x_mm..z_mm",
        ) from exc
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


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings from the library on one line each, without the source location."""
    print(_one_line(f"warning: {message}"), file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0, 1 bad data, 2 bad usage, 3 a bug)."""
    from threadpoolctl import threadpool_limits

    # small matrices: BLAS threads only contend (see the package docstring)
    with threadpool_limits(limits=1):
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage error (status 2), --help or --version (status 0)
        if exc.code is None or isinstance(exc.code, int):
            return int(exc.code or 0)
        return EXIT_USAGE
    with warnings.catch_warnings():
        if not args.debug:
            warnings.showwarning = _show_warning
        try:
            return int(args.func(args) or 0)
        except KeyboardInterrupt:
            print("deltacal: interrupted", file=sys.stderr)
            return 130
        except (DeltacalError, ValueError, OSError) as exc:
            if args.debug:
                raise
            message = str(exc)
            if isinstance(exc, OSError) and not isinstance(exc, DeltacalError):
                message = f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": ")
            print(_one_line(f"deltacal {args.command}: error: {message}"), file=sys.stderr)
            return EXIT_USAGE if isinstance(exc, UsageError) else EXIT_DATA
        except Exception as exc:
            if args.debug:
                raise
            print(_one_line(f"deltacal {args.command}: internal error: {type(exc).__name__}: {exc} "
                            "(a bug: please report it with the output of --debug)"), file=sys.stderr)
            return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
