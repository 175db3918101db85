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
"""

from __future__ import annotations

import numpy as np

from ..base import PROBE_CLEARANCE
from ..live_correction import LiveCorrection
from ..probing import ProbeTravel, probe_program, probe_travel
from .config import DEFAULT_TRIGGER_HEIGHT, RRFSettings

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

    Raises:
        InputError: an ``M558 H`` that is not a number, naming its line.
    """
    trigger = settings.get("G31 Z", DEFAULT_TRIGGER_HEIGHT)
    where = settings.where.get("G31 Z")
    trigger_key = (f"G31 Z, line {where.line} of {where.source}" if where is not None else
                   f"RepRapFirmware's default: no G31 Z in {settings.source}")
    dives = settings.values.get("M558 H", [DEFAULT_DIVE_HEIGHT])
    if not all(np.isfinite(dives)):
        raise settings.error("M558 H", "the dive height is not a number deltacal reads (an expression RRF "
                                       "computes?): the probe program's travel height is not known; write "
                                       "the number")
    dive = max(dives)
    line = settings.where.get("M558 H")
    key = (f"G31 Z + M558 H{dive:g} (line {line.line} of {line.source})" if line is not None else
           f"G31 Z + RepRapFirmware's default dive height (no M558 H) {dive:g}")
    return probe_travel(trigger, trigger_key, [(trigger + dive, key, "")])


def rrf_probe_program(points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
    """The program that homes (``G28``), then echoes each point and runs ``G30 S-1`` above it, in order.

    :func:`~..probing.probe_program` with RepRapFirmware's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance, live)
