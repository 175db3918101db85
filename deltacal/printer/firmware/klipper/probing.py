"""Klipper's probe program: the bed probed at each point of a probe grid, its results on the console.

Klipper's ``PROBE`` (``klippy/extras/probe.py``) lowers the toolhead at its current x, y until the
probe triggers and answers on the console (and in ``klippy.log``), per sample, older releases
``probe at X,Y is z=Z`` (the toolhead's position at the trigger), current ones
``probe: at X,Y bed will contact at z=Z`` (the probe's offsets applied) and a closing
``Result: at X,Y estimate contact at z=Z``. Both print x, y with three decimals: the program
writes each point's x, y the same way, so that the log names the points of probe.csv (the newer
lines through the ``[probe]`` offsets, :mod:`.log`). It needs a probe section. Units: mm; feed
rates in mm/min.

The program travels between points above the probe's ``z_offset`` (:func:`klipper_probe_travel`):
at Klipper's own ``horizontal_move_z`` of ``[delta_calibrate]``, else of ``[bed_mesh]`` (default 5),
when it is far enough above ``z_offset`` (Klipper's probing refuses one below:
``klippy/extras/probe.py``, "horizontal_move_z can't be less than probe's z_offset"), else
``z_offset`` + 5 mm.
"""

from __future__ import annotations

import numpy as np

from ....exceptions import InputError
from ..base import PROBE_CLEARANCE
from ..live_correction import LiveCorrection
from ..probing import MANUAL_TO_IDENTIFY, ProbeTravel, probe_program, probe_travel
from .config import KlipperConfig
from .log import PROBE_SECTIONS

#: How Klipper answers, after the count of points (the program's second line).
ANSWERS = "Klipper answers each PROBE on its console"
#: The rest of the program's header (comment lines).
NOTES = ("(probe at X,Y is z=Z, or probe: at X,Y bed will contact at z=Z); save the console or",
         "klippy.log and read it back: deltacal import klippy.log --config printer.cfg -o probe.csv")


def probe_lines(x: float, y: float) -> tuple[str, ...]:
    """Klipper's probe at a point: ``PROBE`` where the toolhead stands."""
    return ("PROBE",)


#: The sections whose ``horizontal_move_z`` is Klipper's own travel height between probe points, in order.
TRAVEL_SECTIONS = ("delta_calibrate", "bed_mesh")
#: Klipper's ``horizontal_move_z`` when a section does not set it [mm].
DEFAULT_HORIZONTAL_MOVE_Z = 5.0


def klipper_probe_travel(config: KlipperConfig) -> ProbeTravel:
    """The height to travel at between probe points: above the probe's ``z_offset`` (module docstring).

    Raises:
        InputError: no probe section (the trigger height is not known), or a value that is not a number.
    """
    section = next((name for name in PROBE_SECTIONS if name in config.sections), None)
    if section is None:
        raise InputError(f"no probe section ([{'], ['.join(PROBE_SECTIONS)}]): the probe program travels "
                         "between points above the probe's trigger height (its z_offset), not known without "
                         "it; add the probe's section", config.source)
    trigger = config.number(section, "z_offset")
    own = []
    for name in (name for name in TRAVEL_SECTIONS if name in config.sections):
        default = "" if config.has(name, "horizontal_move_z") else " (Klipper's default)"
        own.append((config.number(name, "horizontal_move_z", DEFAULT_HORIZONTAL_MOVE_Z),
                    f"[{name}] horizontal_move_z{default}", "Klipper refuses to probe with it"))
    origin = config.origin.get((section, "z_offset"), config.source)
    return probe_travel(trigger, f"[{section}] z_offset of {origin}", own)


def klipper_manual_heights(config: KlipperConfig) -> str | None:
    """Klipper's paper test at each point (``MANUAL_PROBE``, ``klippy/extras/manual_probe.py``), or None.

    None when ``printer.cfg`` has a probe section. ``MANUAL_PROBE`` starts Klipper's helper where
    the nozzle stands (``TESTZ`` moves it, ``ACCEPT`` answers ``Z position is Z``, the toolhead's
    commanded z): one point at a time on the console, not from a file (the helper does not hold
    the file's next lines back).
    """
    if any(name in config.sections for name in PROBE_SECTIONS):
        return None
    sections = "], [".join(PROBE_SECTIONS)
    return (f"no probe section in {config.source} ([{sections}]): no probe.gcode; measure the heights by "
            "hand (Klipper's paper test), at each point of probe.csv on the console: G28 once, then "
            "G1 X<x_mm> Y<y_mm> Z5, MANUAL_PROBE, TESTZ Z=-0.1 ... until a sheet of paper drags, "
            f"ACCEPT; Klipper answers 'Z position is Z': {MANUAL_TO_IDENTIFY}")


def klipper_probe_program(points: np.ndarray, title: str = "",
                          clearance: float | ProbeTravel = PROBE_CLEARANCE,
                          live: LiveCorrection | None = None) -> str:
    """The program that homes (``G28``) and runs ``PROBE`` above each point in order.

    :func:`~..probing.probe_program` with Klipper's words (its arguments, values and errors).
    """
    return probe_program(points, ANSWERS, NOTES, probe_lines, title, clearance, live)
