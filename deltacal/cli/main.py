"""The ``deltacal`` command: parser, dispatch, exit codes and one-line errors.

Commands (files in mm and deg; see docs/conventions.md for formats):

* ``deltacal demo``: the whole job on a simulated robot (plan, measure, identify,
  compensate, validate).
* ``deltacal import printer.cfg -o DIR`` (or ``klippy.log -o probe.csv``)
* ``deltacal identify NOMINAL MEASUREMENTS --model M -o CAL``
* ``deltacal compensate CAL TARGETS -o JOINTS``
* ``deltacal export CAL --mjcf ROBOT.xml``
* ``deltacal plan NOMINAL --model M [--n N | --epsilon E] -o POSES``
* ``deltacal simulate NOMINAL POSES (--perturb SEED | --truth TRUE) -o MEAS``
* ``deltacal view NOMINAL [...] [--html OUT]``
* ``deltacal report CAL -o REPORT.html [--measurements MEAS] [--truth TRUE] [--tool X,Y,Z]``
* ``deltacal compare OLD.toml NEW.toml [NEWER.toml ...] [-o COMPARE.html]``

Errors in the user's input print one line on stderr naming the file, line,
column or key and value, and exit with status 1 (bad data) or 2 (bad usage:
arguments, missing input file, missing output folder, output overwriting an
input); ``--debug`` shows the traceback. An unexpected failure (a bug) exits
with status 3. Outputs are written atomically: a failing command leaves any
earlier output file as it was.

Outputs are saved before anything is reported on stdout: a closed pipe
(``deltacal identify ... | head -1``) ends the command quietly with status 0,
other failures of stdout (a full disk) with status 1, the outputs written either
way. SIGTERM, like Ctrl-C, removes the temporary file of a write under way.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from typing import Any, TextIO

from .._version import __version__
from ..exceptions import DeltacalError, UsageError

#: The subcommands' modules, in the order ``--help`` lists them. They (and numpy, and the
#: library under them) are imported when the parser is built, not with this module, so that
#: ``deltacal --version`` answers at once; :mod:`.common` likewise, where it is used.
SUBCOMMANDS = ("demo", "import_", "identify", "compensate", "report", "compare", "export", "plan", "simulate",
               "view")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``deltacal`` command."""
    from .common import Parser

    parser = Parser(prog="deltacal", description="Geometric calibration of Delta parallel robots.")
    parser.add_argument("--version", action="version", version=f"deltacal {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name in SUBCOMMANDS:
        importlib.import_module(f".{name}", __package__).add_parser(sub)
    return parser


def _asks_version(argv: Sequence[str]) -> bool:
    """Whether ``--version`` comes among the options before the subcommand (argparse's reading)."""
    for arg in argv:
        if not arg.startswith("-"):
            return False
        if arg == "--version":
            return True
    return False


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings from the library on one line each, without the source location."""
    from .common import one_line
    from .progress import clear

    clear()  # never glued to a progress line
    print(one_line(f"warning: {message}"), file=sys.stderr)


#: Exit status after SIGTERM or SIGINT (128 + the signal's number, as a shell reports it).
EXIT_SIGNAL = {signal.SIGTERM: 128 + signal.SIGTERM, signal.SIGINT: 128 + signal.SIGINT}


class Terminated(BaseException):
    """SIGTERM arrived: unwinds like Ctrl-C, so that an atomic write removes its temporary file."""


class StdoutError(OSError):
    """Writing the report on standard output failed (a closed pipe, a full disk)."""


class _GuardedStdout:
    """Standard output whose failures are told apart from those of the files deltacal writes."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from exc

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from exc

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


def _terminate(signum: int, frame: object) -> None:
    raise Terminated(signum)


def _silence(stream: TextIO) -> None:
    """Point a closed stdout at /dev/null, so that the interpreter's last flush does not fail too."""
    try:
        fd = stream.fileno()
    except (OSError, ValueError, AttributeError):
        return
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, fd)
    os.close(null)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0, 1 bad data, 2 bad usage, 3 a bug)."""
    if _asks_version(sys.argv[1:] if argv is None else argv):
        print(f"deltacal {__version__}")
        return 0
    from threadpoolctl import threadpool_limits

    handled = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if handled else None
    stdout = sys.stdout
    sys.stdout = _GuardedStdout(stdout)  # type: ignore[assignment]
    try:
        # small matrices: BLAS threads only contend (see the package docstring)
        with threadpool_limits(limits=1):
            return _main(argv)
    finally:
        sys.stdout = stdout
        if handled:
            signal.signal(signal.SIGTERM, previous)


def _main(argv: Sequence[str] | None) -> int:
    from .common import EXIT_BUG, EXIT_DATA, EXIT_USAGE, one_line

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
            code = int(args.func(args) or 0)
            sys.stdout.flush()
            return code
        except StdoutError as exc:
            if args.debug:
                raise
            if exc.errno == errno.EPIPE:  # the reader has what it wanted: not an error of the work
                _silence(sys.stdout)
                return 0
            print(one_line(f"deltacal {args.command}: error: standard output: {exc.strerror} "
                           "(the output files were written)"), file=sys.stderr)
            return EXIT_DATA
        except KeyboardInterrupt:
            print("deltacal: interrupted", file=sys.stderr)
            return EXIT_SIGNAL[signal.SIGINT]
        except Terminated:
            print("deltacal: terminated", file=sys.stderr)
            return EXIT_SIGNAL[signal.SIGTERM]
        except (DeltacalError, ValueError, OSError) as exc:
            if args.debug:
                raise
            message = str(exc)
            if isinstance(exc, OSError) and not isinstance(exc, DeltacalError):
                message = f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": ")
            print(one_line(f"deltacal {args.command}: error: {message}"), file=sys.stderr)
            return EXIT_USAGE if isinstance(exc, UsageError) else EXIT_DATA
        except MemoryError:
            if args.debug:
                raise
            print(f"deltacal {args.command}: error: out of memory: the problem is too large for this machine "
                  "(fewer rows; see docs/errors.md)", file=sys.stderr)
            return EXIT_DATA
        except Exception as exc:
            if args.debug:
                raise
            print(one_line(f"deltacal {args.command}: internal error: {type(exc).__name__}: {exc} "
                           "(a bug: please report it with the output of --debug)"), file=sys.stderr)
            return EXIT_BUG
