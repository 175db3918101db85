"""Marlin's probe results read from a console (a host's terminal saved, OctoPrint's ``serial.log``).

Marlin answers ``G30`` (``gcode/probe/G30.cpp``) with ``Bed X: <x> Y: <y> Z: <z>``, and ``G29``
with the same line for each point from ``V3`` on (``module/probe.cpp``, ``probe_at_point``):

* X, Y: the probe's position (the nozzle's + ``M851 X Y``);
* Z: ``run_z_probe() + M851 Z``: the nozzle's z when the probe triggered plus the probe's
  offset, the bed's height under the probe as Marlin sees it. The commanded nozzle position is
  therefore ``(X - M851 X, Y - M851 Y, Z - M851 Z)`` and the nozzle's height above the bed at
  the trigger ``-M851 Z``.

Numbers have ``SERIAL_FLOAT_PRECISION`` decimals (2 by default: 10 µm; ``probe_at_point``'s own
lines 3). ``G33`` prints averages over several probes at named points (``. c:+0.05 x:... yz:...``,
2 decimals) without their positions: not read. A line may carry a host's ``Recv:`` and Marlin's
``echo:``. Every result is a row, in the console's order. Units: mm.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ....exceptions import InputError
from ..probe_log import ProbeLog, log_text, probe_log

_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
#: Marlin's answer to a probe (G30, G29 V3): the probe's position and the bed's height under it.
BED_RESULT = re.compile(rf"\bBed X:\s*{_NUMBER}\s+Y:\s*{_NUMBER}\s+Z:\s*{_NUMBER}")
#: G33's probe results: the heights at its named points, without their positions.
G33_RESULT = re.compile(r"^\s*(?:(?:Recv|Send):\s*)?(?:echo:\s*)?\.\s+c:[-+]?\d", re.MULTILINE)


def is_marlin_probe_log(text: str) -> bool:
    """Whether a file's text holds Marlin's probe results (``Bed X: ...``, or G33's)."""
    return BED_RESULT.search(text) is not None or G33_RESULT.search(text) is not None


def read_marlin_probe_log(path: str | Path, text: str | None = None,
                          probe_offset: np.ndarray | None = None) -> ProbeLog:
    """The probe results of a Marlin console, as commanded nozzle positions, in its order.

    Args:
        path: The console's text file.
        text: Its text, if already read.
        probe_offset: ``M851 X Y Z`` [mm], (3,): needed (Marlin prints the probe's position); every
            row then carries the trigger height ``-M851 Z``.

    Raises:
        InputError: the file cannot be read, holds no ``Bed X:`` result (G33's alone are named), or
            no probe offset was given.
    """
    source, text = log_text(path, text)
    rows: list[list[float]] = []
    lines: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        match = BED_RESULT.search(line)
        if match:
            rows.append([float(v) for v in match.groups()])
            lines.append(number)
    if not rows:
        g33 = G33_RESULT.search(text)
        if g33 is not None:
            at = text.count("\n", 0, g33.start()) + 1
            raise InputError("G33's results ('. c:... x:...') are averages at points it does not print: "
                             "not read; probe with G30 (plan --object's probe.gcode) or G29 V3", source,
                             f"line {at}")
        raise InputError("no probe result in this log (Marlin's 'Bed X: x Y: y Z: z' lines of G30, or of "
                         "G29 V3): probe with plan --object's probe.gcode, and save the console", source)
    if probe_offset is None:
        raise InputError("Marlin's 'Bed X: x Y: y Z: z' is the probe's position and the bed's height under "
                         "it (M851 applied): give the printer's M503 capture with --config M503.txt", source,
                         f"line {lines[0]}")
    offset = np.asarray(probe_offset, dtype=float).reshape(3)
    return probe_log(np.array(rows) - offset, lines, -offset[2])
