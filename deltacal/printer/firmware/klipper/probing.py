"""Klipper's probe program: the bed probed at each point of a probe grid, its results on the console.

Klipper's ``PROBE`` (``klippy/extras/probe.py``) lowers the toolhead at its current x, y until the
probe triggers and answers on the console (and in ``klippy.log``), per sample, older releases
``probe at X,Y is z=Z`` (the toolhead's position at the trigger), current ones
``probe: at X,Y bed will contact at z=Z`` (the probe's offsets applied) and a closing
``Result: at X,Y estimate contact at z=Z``. Both print x, y with three decimals: the program
writes each point's x, y the same way, so that the log names the points of probe.csv (the newer
lines through the ``[probe]`` offsets, :mod:`.log`). It needs a probe section. Units: mm; feed
rates in mm/min.
"""

from __future__ import annotations

import numpy as np

from ..base import PROBE_CLEARANCE

#: Feed rate of the moves between points [mm/min] (Klipper's probing helpers' default 50 mm/s).
TRAVEL_FEED = 3000.0
#: Feed rate of the rise back to the clearance after each probe [mm/min].
LIFT_FEED = 600.0


def klipper_probe_program(points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``) and runs ``PROBE`` above each point in order.

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
             f"; {len(xy)} points, in the order of probe.csv; Klipper answers each PROBE on its console",
             "; (probe at X,Y is z=Z, or probe: at X,Y bed will contact at z=Z); save the console or",
             "; klippy.log and read it back: deltacal import klippy.log --config printer.cfg -o probe.csv",
             "G28 ; home", "G90 ; absolute positions", f"G1 Z{z} F{LIFT_FEED:.0f}"]
    for k, (x, y) in enumerate(xy, start=1):
        lines += [f"; point {k} of {len(xy)}", f"G1 X{x:.3f} Y{y:.3f} Z{z} F{TRAVEL_FEED:.0f}", "PROBE",
                  f"G1 Z{z} F{LIFT_FEED:.0f}"]
    lines.append("; done")
    return "\n".join(lines) + "\n"
