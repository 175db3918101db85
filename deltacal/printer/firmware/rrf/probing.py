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

#: Feed rate of the moves between points [mm/min].
TRAVEL_FEED = 3000.0
#: Feed rate of the rise back to the clearance after each probe [mm/min].
LIFT_FEED = 600.0


def rrf_probe_program(points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``), then echoes each point and runs ``G30 S-1`` above it, in order.

    Args:
        points: Commanded nozzle positions [mm], (N, 2) or (N, 3) (z ignored).
        title: A first comment line.
        clearance: The nozzle's height while it moves between points [mm], above 0.

    Returns:
        The program's text (one command a line, ``;`` comments).

    Raises:
        ValueError: a clearance not above 0, or points not finite.
    """
    xy = np.atleast_2d(np.asarray(points, dtype=float))[:, :2]
    if not clearance > 0.0:
        raise ValueError(f"the probe program's clearance must be above 0 mm, got {clearance!r}")
    if not np.all(np.isfinite(xy)):
        raise ValueError("the points to probe must be finite")
    z = f"{clearance:.3f}"
    lines = [
        f"; {title}" if title else "; deltacal: probe the bed",
        f"; {len(xy)} points, in the order of probe.csv; RepRapFirmware answers each G30 S-1 on its console",
        "; (Stopped at height Z mm) after the echoed point (probe at X,Y)",
        "G28 ; home",
        "G90 ; absolute positions",
        f"G1 Z{z} F{LIFT_FEED:.0f}",
    ]
    for k, (x, y) in enumerate(xy, start=1):
        lines += [
            f"; point {k} of {len(xy)}",
            f"G1 X{x:.3f} Y{y:.3f} Z{z} F{TRAVEL_FEED:.0f}",
            f'echo "probe at {x:.3f},{y:.3f}"',
            "G30 S-1",
            f"G1 Z{z} F{LIFT_FEED:.0f}",
        ]
    lines.append("; done")
    return "\n".join(lines) + "\n"
