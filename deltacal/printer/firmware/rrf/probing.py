"""RepRapFirmware's probe program: the bed probed at each point of a probe grid, its results on the console.

``G30 S-1`` (``src/GCodes/GCodes4.cpp``) probes at the current x, y and answers ``Stopped at height
Z mm``: the machine's Z when the probe triggered, less nothing (no ``H``), without changing the
coordinates (a plain ``G30`` would reset Z). That answer carries no x, y: the program echoes each
point first (``echo``, RRF 3's meta command), to the micrometre, so that the console names the
points of probe.csv. It needs a Z probe (``M558``; a nozzle that is the probe: ``G31 X0 Y0 Z0``).
Units: mm; feed rates in mm/min.
"""

from __future__ import annotations

import numpy as np

from ..base import PROBE_CLEARANCE
from ..probing import probe_program

#: How RepRapFirmware answers, after the count of points (the program's second line).
ANSWERS = "RepRapFirmware answers each G30 S-1 on its console"
#: The rest of the program's header (comment lines).
NOTES = ("(Stopped at height Z mm) after the echoed point (probe at X,Y)",)


def probe_lines(x: float, y: float) -> tuple[str, ...]:
    """RRF's probe at a point: the point echoed (to the micrometre), then ``G30 S-1``."""
    return (f'echo "probe at {x:.3f},{y:.3f}"', "G30 S-1")


def rrf_probe_program(points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``), then echoes each point and runs ``G30 S-1`` above it, in order.

    :func:`~..probing.probe_program` with RepRapFirmware's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance)
