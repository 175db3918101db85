"""What every subcommand shares: exit codes, argument types, the request of the arguments, what a job says."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from dataclasses import fields
from typing import TypeVar

import numpy as np

from ..io.names import name_problem
from ..printer.firmware.config_file import firmware_names
from ..wings.base import Done

Request = TypeVar("Request")

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


def request(cls: type[Request], args: argparse.Namespace) -> Request:
    """The job's request (:mod:`deltacal.wings.requests`) of the parsed arguments, field by option."""
    return cls(**{f.name: getattr(args, f.name) for f in fields(cls) if f.init})  # type: ignore[arg-type]


def show(done: Done) -> int:
    """Print what a job did (its lines on stdout); the exit status, 0."""
    for line in done.lines:
        print(line)
    return 0


def add_firmware_argument(p: argparse.ArgumentParser, subject: str = "--controller") -> None:
    """Register ``--firmware``: the firmware whose file ``subject`` (an option or argument) is."""
    names = firmware_names()
    p.add_argument("--firmware", choices=names, default=None,
                   help=f"a printer: the firmware whose settings {subject} is ({'|'.join(names)}; "
                        "default: told from the file's content)")


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
