"""A firmware's probe program, whatever the firmware: home, then probe the bed above each point in order.

Every firmware's program (:meth:`~.base.Firmware.probe_program`) is the same moves: ``G28``,
absolute positions, the rise to the clearance, then per point a move above it at the clearance,
the firmware's probing command(s) and the rise back. What differs is given by the firmware: its
probe line(s) per point and the comment lines that say how it answers. Each point's x, y are
written to the micrometre, as the firmwares echo them, so that a log names the points of
probe.csv. Units: mm; feed rates in mm/min.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .base import PROBE_CLEARANCE

#: Feed rate of the moves between points [mm/min] (Klipper's probing helpers' default, 50 mm/s).
TRAVEL_FEED = 3000.0
#: Feed rate of the rise back to the clearance after each probe [mm/min].
LIFT_FEED = 600.0


def probe_program(points: np.ndarray, answers: str, notes: Sequence[str],
                  probe: Callable[[float, float], Sequence[str]], title: str = "",
                  clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``) and runs the firmware's probe line(s) above each point in order.

    Args:
        points: Commanded nozzle positions [mm], (N, 2) or (N, 3) (z ignored).
        answers: How the firmware answers each probe (``"Klipper answers each PROBE on its console"``),
            after the count of points on the second comment line.
        notes: More comment lines of the header (without their ``;``).
        probe: The firmware's lines at a point, given its x, y [mm] (after the move above it).
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
    lines = [f"; {title}" if title else "; deltacal: probe the bed",
             f"; {len(xy)} points, in the order of probe.csv; {answers}",
             *(f"; {note}" for note in notes),
             "G28 ; home", "G90 ; absolute positions", f"G1 Z{z} F{LIFT_FEED:.0f}"]
    for k, (x, y) in enumerate(xy, start=1):
        lines += [f"; point {k} of {len(xy)}", f"G1 X{x:.3f} Y{y:.3f} Z{z} F{TRAVEL_FEED:.0f}",
                  *probe(float(x), float(y)), f"G1 Z{z} F{LIFT_FEED:.0f}"]
    lines.append("; done")
    return "\n".join(lines) + "\n"
