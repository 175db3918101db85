"""What every subcommand shares: exit codes, argument types, input and output checks, warnings."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..exceptions import InputError, UsageError
from ..io.atomic import check_output_path, output_problem
from ..io.inputs import input_problem
from ..io.names import name_problem

EXIT_DATA = 1
EXIT_USAGE = 2
EXIT_BUG = 3


#: A number as users type it, and comma-separated lists of them (``-85,-85,-85``, ``-50,0,0``,
#: ``-1e-3``): read as an option's value, never as an option (argparse knows ``-85`` only).
_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NUMBERS = re.compile(rf"^-{_NUMBER}(?:,\s*[+-]?{_NUMBER})*$")


class Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors and exit status 2.

    Negative numbers and lists of numbers (``--home -85,-85,-85``) are values, as users type them.
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NUMBERS

    def error(self, message: str) -> None:  # type: ignore[override]
        """Print the one-line usage error and exit with status 2."""
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def one_line(text: str) -> str:
    """Text made one printable line: newlines become spaces, other control characters escapes."""
    text = text.replace("\r\n", " ").replace("\n", " ")
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def warn(lines: Sequence[str]) -> None:
    """Print each line on stderr as ``warning: ...``, one line each (a progress line cleared first)."""
    from .progress import clear

    if lines:
        clear()
    for line in lines:
        print(one_line(f"warning: {line}"), file=sys.stderr)


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


def non_negative_list(text: str) -> list[float]:
    """Argparse type: comma-separated finite numbers >= 0 (at least one, each once)."""
    values = [non_negative_float(part.strip()) for part in text.split(",")]
    if len(set(values)) != len(values):
        raise argparse.ArgumentTypeError(f"each value once, got {text!r}")
    return values


def positive_int(text: str) -> int:
    """Argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


#: σ accepted on the command line [mm or deg]: below, the weights overflow; above, nothing is measured.
SIGMA_RANGE = (1e-9, 1e3)


def sigma(text: str) -> float:
    """Argparse type: a standard deviation in :data:`SIGMA_RANGE`."""
    value = positive_float(text)
    low, high = SIGMA_RANGE
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be between {low:g} and {high:g}, got {text!r}")
    return value


def seed(text: str) -> int:
    """Argparse type: a seed of numpy's generator, an integer >= 0 written in decimal digits."""
    if re.fullmatch(r"[0-9]+", text.strip()) is None:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0 (a seed), got {text!r}")
    return int(text)


def int_at_most(maximum: int, why: str):
    """Argparse type: an integer in [1, maximum] (``why`` says where the bound comes from)."""

    def parse(text: str) -> int:
        value = positive_int(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"must be at most {maximum} ({why}), got {value}")
        return value

    return parse


def check_input(path: str | Path) -> None:
    """A usage error (exit 2) unless ``path`` is a regular file (``io.inputs.input_problem``)."""
    problem = input_problem(path)
    if problem is not None:
        raise UsageError(f"{path}: {problem}")


def check_output(path: str | Path, inputs: Sequence[str | Path | None] = ()) -> None:
    """A usage error (exit 2) if ``path`` cannot be an output file, or is one of the inputs.

    Called before any work is done, so that a bad ``-o`` costs nothing (see
    :func:`deltacal.io.atomic.output_problem` for what is refused).
    """
    check_output_path(path)
    out = Path(path)
    for source in inputs:
        if source is not None and Path(source).exists() and out.resolve() == Path(source).resolve():
            raise UsageError(f"{path}: the output would overwrite an input file")


def check_output_folder(folder: str | Path, names: Sequence[str], inputs: Sequence[str | Path | None],
                        what: str) -> list[Path]:
    """The output files ``names`` in ``folder``, checked as :func:`check_output` checks one (status 2).

    A folder that does not exist yet is made by the command, once its work is done: it is checked as
    a new output in its parent (which must exist and be writable), as every other output is.

    Args:
        folder: The ``-o`` folder.
        names: The files written there.
        inputs: The command's inputs (none may be overwritten).
        what: What writes there, for the message (``"plan --object"``).

    Raises:
        UsageError: naming the folder (or a file in it) and what is wrong.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder}: {what} writes {len(names)} files in a folder; this is a file")
    outputs = [folder / name for name in names]
    if folder.exists():
        for path in outputs:
            check_output(path, inputs)
        return outputs
    problem = output_problem(folder)
    parent = folder.parent if str(folder.parent) else Path(".")
    if problem is not None and not parent.exists():
        problem = (f"the folder {str(parent)!r} does not exist ({what} makes its output folder, not the "
                   "folders above it)")
    if problem is not None:
        raise UsageError(f"{folder}: {problem}")
    return outputs


def point_list(text: str, known: Sequence[str], option: str = "--points") -> list[str]:
    """Comma-separated point names, each checked against the robot's points."""
    points = [p.strip() for p in text.split(",") if p.strip()]
    if not points:
        raise InputError(f"no point named in {text!r}; the robot's points are {', '.join(known)}", option)
    for name in points:
        if name not in known:
            raise InputError(f"unknown point {name!r}; the robot's points are {', '.join(known)}", option)
    return points


def three_numbers(text: str, what: str, context: str = "") -> list[float]:
    """Three finite comma-separated numbers, or an argparse error naming ``what`` they should be.

    Args:
        text: The option's value, or a part of it.
        what: What the three numbers are, for the message (``"X,Y,Z in mm"``).
        context: The whole option value when ``text`` is a part of it, for the message.
    """
    where = f" in {context!r}" if context else ""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected three numbers {what}, got {text!r}{where}") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected three finite numbers {what}, got {text!r}{where}")
    return values


def station_frame(text: str):
    """Argparse type: ``NAME:RX,RY,RZ:X,Y,Z`` -> (name, InstrumentFrame) (degrees, mm)."""
    from ..identification.frames import InstrumentFrame

    parts = text.split(":")
    if len(parts) != 3 or not parts[0].strip():
        raise argparse.ArgumentTypeError(f"expected NAME:RX,RY,RZ:X,Y,Z (deg, mm), got {text!r}")
    problem = name_problem(parts[0].strip())
    if problem is not None:
        raise argparse.ArgumentTypeError(f"station name {parts[0].strip()!r} {problem}, in {text!r}")
    rotation = three_numbers(parts[1], "RX,RY,RZ (deg)", text)
    translation = three_numbers(parts[2], "X,Y,Z (mm)", text)
    return parts[0].strip(), InstrumentFrame.from_vectors(np.radians(rotation), np.array(translation))
