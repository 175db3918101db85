"""Marlin's probe program: the bed probed at each point of a probe grid, its results on the console.

Marlin's ``G30`` (``Marlin/src/gcode/probe/G30.cpp``) without X or Y probes where the probe stands
(its X, Y default to the current position plus the ``M851`` offsets, which is the probe's own
place), and reports ``Bed X: <x> Y: <y> Z: <z>`` with the probe's position. The program moves the
nozzle above each point of probe.csv, then runs ``G30`` there: the commanded nozzle position of
each row is the point itself, whatever the probe's offsets. Units: mm; feed rates in mm/min.

The program travels between points above the probe's trigger height, ``-M851 Z`` (the nozzle's
height above the bed when the probe triggers), by 5 mm (:func:`marlin_probe_travel`): Marlin's own
clearances between probes (``Z_CLEARANCE_BETWEEN_PROBES``) are compiled in, not in ``M503``.
"""

from __future__ import annotations

import numpy as np

from ....exceptions import InputError
from ..base import PROBE_CLEARANCE
from ..live_correction import LiveCorrection
from ..probing import MANUAL_TO_IDENTIFY, ProbeTravel, probe_program, probe_travel
from .settings import MarlinSettings

#: How Marlin answers, after the count of points (the program's second line).
ANSWERS = "Marlin answers each G30 on its console"
#: The rest of the program's header (comment lines).
NOTES = ("(Bed X: x Y: y Z: z, the probe's position: the nozzle's plus M851 X, Y)",)


def probe_lines(x: float, y: float) -> tuple[str, ...]:
    """Marlin's probe at a point: ``G30`` without X, Y (where the probe stands)."""
    return ("G30",)


def marlin_probe_travel(settings: MarlinSettings) -> ProbeTravel:
    """The height to travel at between probe points: ``-M851 Z`` + 5 mm.

    Raises:
        InputError: no ``M851 Z`` in the capture (the trigger height is not known).
    """
    if "Z" not in settings.values.get("M851", {}):
        raise InputError("no M851 Z (the probe's offset, in M503's report of a printer with a probe): the "
                         "probe program travels between points above the probe's trigger height, not known "
                         "without it; capture M503's whole report", settings.source, "M851 Z")
    line = settings.lines[("M851", "Z")]
    return probe_travel(-settings.get("M851", "Z"), f"-M851 Z, line {line} of {settings.source}")


def marlin_manual_heights(settings: MarlinSettings) -> str | None:
    """The paper test at each point by Marlin's own moves, or None: ``M503`` reports a probe (``M851``).

    A Marlin without a probe has no ``M851`` (``Marlin/src/gcode/config/M500-M504.cpp`` reports it
    with ``HAS_PROBE_XY_OFFSET``); its ``G30`` needs a probe, and its ``PROBE_MANUALLY`` ``G29``
    probes its own grid, not given points: the nozzle is moved above each point and lowered
    until a sheet of paper drags (the LCD's Move Z, or ``G1 Z`` steps from a host), and ``M114``
    reports its height.
    """
    if "M851" in settings.values:
        return None
    return (f"no M851 in {settings.source} (a printer without a probe; G30 needs one): no probe.gcode; "
            "measure the heights by hand (the paper test), at each point of probe.csv: G28 once, then "
            "G1 X<x_mm> Y<y_mm> Z5, lower the nozzle (the LCD's Move Z, or G1 Z in 0.05 mm steps) until a "
            f"sheet of paper drags, M114; Marlin answers X:.. Y:.. Z:Z: {MANUAL_TO_IDENTIFY}")


def marlin_probe_program(points: np.ndarray, title: str = "",
                         clearance: float | ProbeTravel = PROBE_CLEARANCE,
                         live: LiveCorrection | None = None) -> str:
    """The program that homes (``G28``) and runs ``G30`` with the nozzle above each point in order.

    :func:`~..probing.probe_program` with Marlin's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance, live)
