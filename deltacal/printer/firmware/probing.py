"""A firmware's probe program, whatever the firmware: home, then probe the bed above each point in order.

Every firmware's program (:meth:`~.base.Firmware.probe_program`) is the same moves: ``G28``,
absolute positions, the rise to the clearance, then per point a move above it at the clearance,
the firmware's probing command(s) and the rise back. What differs is given by the firmware: its
probe line(s) per point and the comment lines that say how it answers. Each point's x, y are
written to the micrometre, as the firmwares echo them, so that a log names the points of
probe.csv. Units: mm; feed rates in mm/min.

The clearance is a :class:`ProbeTravel` each firmware works out from its configuration
(:meth:`~.base.Firmware.probe_travel`): the probe hangs below the nozzle by its trigger height (a
Klipper ``z_offset``, ``-M851 Z``, RRF's ``G31 Z``: 16 to 24 mm on FLSUN's and Anycubic's
deltas), so the nozzle travels above that height, never at a fixed 5 mm (:func:`probe_travel`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .live_correction import LiveCorrection

#: Height of the nozzle above the bed while a probe program moves between points, the margin above the
#: probe's trigger height of :func:`probe_travel` [mm] (Klipper's ``horizontal_move_z`` default).
PROBE_CLEARANCE = 5.0
#: Feed rate of the moves between points [mm/min] (Klipper's probing helpers' default, 50 mm/s).
TRAVEL_FEED = 3000.0
#: Feed rate of the rise back to the clearance after each probe [mm/min].
LIFT_FEED = 600.0
#: Least height above the trigger height of a firmware's own travel height for it to be taken [mm].
MIN_TRAVEL_MARGIN = 2.0
#: A sheet of printer paper: the nozzle's height above the bed when the paper test's sheet drags under
#: it, the trigger height of heights measured by hand (``trigger_height_mm`` of plan's probe.csv) [mm].
PAPER_MM = 0.1
#: How heights measured by hand go to ``identify``, or are left out (the end of each firmware's line).
MANUAL_TO_IDENTIFY = (f"write it in probe.csv's z_mm (trigger_height_mm {PAPER_MM:g}: the paper's thickness; "
                      "set yours), then identify PRINTER.toml probe.csv distances.csv; or leave the heights "
                      "out: identify PRINTER.toml distances.csv fits the distances alone")


@dataclass(frozen=True)
class ProbeTravel:
    """The nozzle's height above the bed while a probe program moves between points.

    Attributes:
        height: The height [mm], above 0 and above the probe's trigger height.
        reason: Where it comes from, in the configuration's words (a comment line of the program).
    """

    height: float
    reason: str


def probe_travel(trigger: float, trigger_key: str, own: Sequence[tuple[float, str, str]] = ()) -> ProbeTravel:
    """The height to travel at between points: the firmware's own, or the trigger height and a margin.

    The first of the firmware's own travel heights that is at least :data:`MIN_TRAVEL_MARGIN`
    above the trigger height is taken; else the trigger height (0 if below) plus
    :data:`~.base.PROBE_CLEARANCE`. The reason names each height the configuration gives and why
    one was not taken.

    Args:
        trigger: The nozzle's height above the bed when the probe triggers [mm].
        trigger_key: Where the configuration sets it (``"[probe] z_offset of printer.cfg"``).
        own: The firmware's own travel heights, in order of preference: (height [mm], where it is
            set, what the firmware does with a height below the trigger height or "").

    Raises:
        ValueError: a height that is not finite.
    """
    if not all(np.isfinite([trigger, *(h for h, _, _ in own)])):
        raise ValueError("the probe's trigger and travel heights must be finite")
    # below the bed: a nozzle that presses the bed to trigger (Duet3D's Smart Effector, G31 Z-0.1)
    side = f"{trigger:g} mm above" if trigger >= 0.0 else f"{-trigger:g} mm below"
    trigger_words = f"the probe triggers with the nozzle {side} the bed ({trigger_key})"
    refused = []
    for height, key, below in own:
        if height >= trigger + MIN_TRAVEL_MARGIN:
            return ProbeTravel(float(height), f"{key} = {height:g} mm; {trigger_words}")
        if height < trigger:
            refused.append(f"{key} = {height:g} mm is below it{': ' + below if below else ''}")
        else:
            refused.append(f"{key} = {height:g} mm is less than {MIN_TRAVEL_MARGIN:g} mm above it")
    height = max(float(trigger), 0.0) + PROBE_CLEARANCE
    why = "".join(f"; {reason}" for reason in refused)
    return ProbeTravel(height, f"{trigger_words}, + {PROBE_CLEARANCE:g} mm{why}")


def probe_program(points: np.ndarray, answers: str, notes: Sequence[str],
                  probe: Callable[[float, float], Sequence[str]], title: str = "",
                  clearance: float | ProbeTravel = PROBE_CLEARANCE,
                  live: LiveCorrection | None = None) -> str:
    """The program that homes (``G28``) and runs the firmware's probe line(s) above each point in order.

    Args:
        points: Commanded nozzle positions [mm], (N, 2) or (N, 3) (z ignored).
        answers: How the firmware answers each probe (``"Klipper answers each PROBE on its console"``),
            after the count of points on the second comment line.
        notes: More comment lines of the header (without their ``;``).
        probe: The firmware's lines at a point, given its x, y [mm] (after the move above it).
        title: A first comment line.
        clearance: The nozzle's height while it moves between points [mm], above 0; a
            :class:`ProbeTravel` (the configuration's) says where it comes from in the header.
        live: The configuration's live correction, or None: its ``off`` command is the program's first
            (the probe measures the printer itself, not the corrected one), its ``on`` the last.

    Returns:
        The program's text (one command a line, ``;`` comments).

    Raises:
        ValueError: a clearance not above 0, or points not finite.
    """
    xy = np.atleast_2d(np.asarray(points, dtype=float))[:, :2]
    if isinstance(clearance, ProbeTravel):
        notes = [*notes, f"travels at Z{clearance.height:.3f} between points: {clearance.reason}"]
        clearance = clearance.height
    if not clearance > 0.0:
        raise ValueError(f"the probe program's clearance must be above 0 mm, got {clearance!r}")
    if not np.all(np.isfinite(xy)):
        raise ValueError("the points to probe must be finite")
    z = f"{clearance:.3f}"
    lines = [f"; {title}" if title else "; deltacal: probe the bed",
             f"; {len(xy)} points, in the order of probe.csv; {answers}",
             *(f"; {note}" for note in notes),
             *([] if live is None else [f"{live.off} ; deltacal's live correction off while probing"]),
             "G28 ; home", "G90 ; absolute positions", f"G1 Z{z} F{LIFT_FEED:.0f}"]
    for k, (x, y) in enumerate(xy, start=1):
        lines += [f"; point {k} of {len(xy)}", f"G1 X{x:.3f} Y{y:.3f} Z{z} F{TRAVEL_FEED:.0f}",
                  *probe(float(x), float(y)), f"G1 Z{z} F{LIFT_FEED:.0f}"]
    if live is not None:
        lines.append(f"{live.on} ; deltacal's live correction on again")
    lines.append("; done")
    return "\n".join(lines) + "\n"
