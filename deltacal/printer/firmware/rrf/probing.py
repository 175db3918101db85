"""RepRapFirmware's probe program: the bed probed at each point of a probe grid, its results on the console.

``G30 S-1`` (``src/GCodes/GCodes4.cpp``) probes at the current x, y and answers ``Stopped at height
Z mm``: the machine's Z when the probe triggered, less nothing (no ``H``), without changing the
coordinates (a plain ``G30`` would reset Z). That answer carries no x, y: the program echoes each
point first (``echo``, RRF 3's meta command), to the micrometre, so that the console names the
points of probe.csv. It needs a Z probe (``M558``; a nozzle that is the probe: ``G31 X0 Y0 Z0``).
Units: mm; feed rates in mm/min.

``G30`` without ``P`` probes from where the nozzle stands: the program travels between points at
RRF's own height for probing, its dive height ``M558 H`` above the trigger height ``G31 Z``
(:func:`rrf_probe_travel`; RRF's defaults ``H5``, ``Z0.7``), or ``G31 Z`` + 5 mm when the dive
height is under 2 mm.

``M558 P0`` (no probe: :func:`~.config.rrf_manual_probe`) keeps the program: at each ``G30 S-1``
RRF asks the user to jog the nozzle down to the bed (Duet Web Control's or PanelDue's message box
"Adjust height until the nozzle just touches the bed, then press OK", with its Z jog buttons) and
answers ``Stopped at height Z mm``, the height the nozzle was left at, on its console as a probe's:
the points are given, the answers read back alike. The nozzle is lowered until a sheet of paper
drags: the trigger height is the paper's, :data:`~..probing.PAPER_MM` (not ``G31 Z``), and the
program travels that and the dive height above the bed (:func:`rrf_probe_travel`,
:func:`rrf_manual_heights`).
"""

from __future__ import annotations

import numpy as np

from ..base import PROBE_CLEARANCE
from ..live_correction import LiveCorrection
from ..probing import MANUAL_TO_IDENTIFY, PAPER_MM, ProbeTravel, probe_program, probe_travel
from .config import DEFAULT_TRIGGER_HEIGHT, RRFSettings, rrf_manual_probe

#: RepRapFirmware's dive height when no ``M558 H`` sets it (``DefaultZDive``) [mm].
DEFAULT_DIVE_HEIGHT = 5.0

#: How RepRapFirmware answers, after the count of points (the program's second line).
ANSWERS = "RepRapFirmware answers each G30 S-1 on its console"
#: The rest of the program's header (comment lines).
NOTES = ("(Stopped at height Z mm) after the echoed point (probe at X,Y)",)


def probe_lines(x: float, y: float) -> tuple[str, ...]:
    """RRF's probe at a point: the point echoed (to the micrometre), then ``G30 S-1``."""
    return (f'echo "probe at {x:.3f},{y:.3f}"', "G30 S-1")


def rrf_probe_travel(settings: RRFSettings) -> ProbeTravel:
    """The height to travel at between probe points: ``G31 Z`` + ``M558 H`` (module docstring).

    With ``M558 P0`` the trigger height is the paper's, :data:`~..probing.PAPER_MM`.

    Raises:
        InputError: an ``M558 H`` or ``P`` that is not a number, naming its line.
    """
    manual = rrf_manual_probe(settings)
    trigger = settings.get("G31 Z", DEFAULT_TRIGGER_HEIGHT) if manual is None else PAPER_MM
    where = settings.where.get("G31 Z")
    if manual is not None:
        trigger_key = (f"the paper's: M558 P0, line {manual.line} of {manual.source}: at each G30 S-1 RRF "
                       "asks to jog Z down until a sheet of paper drags, then OK")
    elif where is not None:
        trigger_key = f"G31 Z, line {where.line} of {where.source}"
    else:
        trigger_key = f"RepRapFirmware's default: no G31 Z in {settings.source}"
    dives = settings.values.get("M558 H", [DEFAULT_DIVE_HEIGHT])
    if not all(np.isfinite(dives)):
        raise settings.error("M558 H", "the dive height is not a number deltacal reads (an expression RRF "
                                       "computes?): the probe program's travel height is not known; write "
                                       "the number")
    dive = max(dives)
    line = settings.where.get("M558 H")
    base = "G31 Z" if manual is None else f"the paper's {PAPER_MM:g}"
    key = (f"{base} + M558 H{dive:g} (line {line.line} of {line.source})" if line is not None else
           f"{base} + RepRapFirmware's default dive height (no M558 H) {dive:g}")
    return probe_travel(trigger, trigger_key, [(trigger + dive, key, "")])


def rrf_manual_heights(settings: RRFSettings) -> str | None:
    """RRF's manual probing at each point by probe.gcode (module docstring), or None: no ``M558 P0``.

    Raises:
        InputError: an ``M558 P`` that is not a number, naming its line.
    """
    manual = rrf_manual_probe(settings)
    if manual is None:
        return None
    return (f"M558 P0 in {manual.source} (line {manual.line}: no probe, RRF's manual probing): probe.gcode "
            "still runs G30 S-1 at each point of probe.csv, and RRF asks each time 'Adjust height until the "
            "nozzle just touches the bed, then press OK': jog Z down (Duet Web Control or PanelDue) until a "
            "sheet of paper drags, OK; RRF answers 'Stopped at height Z mm': save the console, deltacal "
            f"import CONSOLE.txt --config {manual.source} -o probe.csv (trigger height {PAPER_MM:g} mm: the "
            "paper's, not G31 Z); or "
            f"{MANUAL_TO_IDENTIFY}")


def rrf_probe_program(points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
    """The program that homes (``G28``), then echoes each point and runs ``G30 S-1`` above it, in order.

    :func:`~..probing.probe_program` with RepRapFirmware's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance, live)
