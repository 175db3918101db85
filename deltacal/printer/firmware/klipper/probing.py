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
from ..probing import probe_program

#: How Klipper answers, after the count of points (the program's second line).
ANSWERS = "Klipper answers each PROBE on its console"
#: The rest of the program's header (comment lines).
NOTES = ("(probe at X,Y is z=Z, or probe: at X,Y bed will contact at z=Z); save the console or",
         "klippy.log and read it back: deltacal import klippy.log --config printer.cfg -o probe.csv")


def probe_lines(x: float, y: float) -> tuple[str, ...]:
    """Klipper's probe at a point: ``PROBE`` where the toolhead stands."""
    return ("PROBE",)


def klipper_probe_program(points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
    """The program that homes (``G28``) and runs ``PROBE`` above each point in order.

    :func:`~..probing.probe_program` with Klipper's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance)
