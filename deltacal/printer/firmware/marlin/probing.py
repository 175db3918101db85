"""Marlin's probe program: the bed probed at each point of a probe grid, its results on the console.

Marlin's ``G30`` (``Marlin/src/gcode/probe/G30.cpp``) without X or Y probes where the probe stands
(its X, Y default to the current position plus the ``M851`` offsets, which is the probe's own
place), and reports ``Bed X: <x> Y: <y> Z: <z>`` with the probe's position. The program moves the
nozzle above each point of probe.csv, then runs ``G30`` there: the commanded nozzle position of
each row is the point itself, whatever the probe's offsets. Units: mm; feed rates in mm/min.
"""

from __future__ import annotations

import numpy as np

from ..base import PROBE_CLEARANCE

#: Feed rate of the moves between points [mm/min].
TRAVEL_FEED = 3000.0
#: Feed rate of the rise back to the clearance after each probe [mm/min].
LIFT_FEED = 600.0


def marlin_probe_program(points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``) and runs ``G30`` with the nozzle above each point in order.

    Args:
        points: Commanded nozzle positions [mm], (N, 2) or (N, 3) (z ignored).
        title: A first comment line.
        clearance: The nozzle's height while it moves between points [mm], above 0.

    Returns:
        The program's text (one command a line, ``;`` comments).
    """
    xy = np.atleast_2d(np.asarray(points, dtype=float))[:, :2]
    if not clearance > 0.0:
        raise ValueError(f"the probe program's clearance must be above 0 mm, got {clearance!r}")
    if not np.all(np.isfinite(xy)):
        raise ValueError("the points to probe must be finite")
    z = f"{clearance:.3f}"
    lines = [f"; {title}" if title else "; deltacal: probe the bed",
             f"; {len(xy)} points, in the order of probe.csv; Marlin answers each G30 on its console",
             "; (Bed X: x Y: y Z: z, the probe's position: the nozzle's plus M851 X, Y)",
             "G28 ; home", "G90 ; absolute positions", f"G1 Z{z} F{LIFT_FEED:.0f}"]
    for k, (x, y) in enumerate(xy, start=1):
        lines += [f"; point {k} of {len(xy)}", f"G1 X{x:.3f} Y{y:.3f} Z{z} F{TRAVEL_FEED:.0f}", "G30",
                  f"G1 Z{z} F{LIFT_FEED:.0f}"]
    lines.append("; done")
    return "\n".join(lines) + "\n"
