"""What a value of a delta printer's firmware can be: the bounds of each kind of value, in one table.

A configuration's value beyond what any printer has (a rod of 1e308 mm, 1e-300 steps per mm, a
tower turned by 170°, an endstop adjusted by half a metre) is a slip or another machine's file: read
on, it overflows the model's arithmetic or gives a printer no one built. Each firmware's reader
names the kind of each key it reads in one table of its own (:data:`.klipper.config.BOUNDS`,
:data:`.rrf.config.BOUNDS`, :data:`.marlin.settings.BOUNDS`) and checks every value it reads against
it (:meth:`Bound.problem`), naming the key and the value. The bounds are wide: they tell what no
delta printer can be, not what a good one is. Units: mm, degrees, steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Bound:
    """The values a kind of setting can take on any delta printer.

    Attributes:
        low: The lowest value (excluded when ``open_low``).
        high: The highest value.
        words: What the value is, for messages (``"a length [mm]"``).
        open_low: Whether ``low`` itself is excluded (a length must be above 0).
    """

    low: float
    high: float
    words: str
    open_low: bool = False

    def problem(self, value: float) -> str | None:
        """Why ``value`` is not one of these (one clause), or None when it is."""
        if not math.isfinite(value):
            return "is not a finite number"
        below = value <= self.low if self.open_low else value < self.low
        if below or value > self.high:
            low = f"above {self.low:g}" if self.open_low else f"from {self.low:g}"
            return f"is beyond what a printer's {self.words} can be ({low} to {self.high:g})"
        return None


#: Rods, radii, print radii, rotation distances: from a micrometre to 10 m [mm].
LENGTH = Bound(0.001, 10_000.0, "length [mm]")
#: Heights and positions along an axis (homed height, endstop positions, Z limits) [mm].
POSITION = Bound(-10_000.0, 10_000.0, "position [mm]")
#: Endstop adjustments and rod trims: corrections of a few mm on a built printer [mm].
ADJUSTMENT = Bound(-100.0, 100.0, "adjustment [mm]")
#: A probe's offsets from the nozzle [mm].
PROBE_OFFSET = Bound(-1_000.0, 1_000.0, "probe offset [mm]")
#: A tower's angle correction from its nominal azimuth [deg].
TRIM_ANGLE = Bound(-45.0, 45.0, "tower angle correction [deg]")
#: A tower's azimuth [deg].
ANGLE = Bound(-360.0, 360.0, "tower angle [deg]")
#: Steps per mm of a carriage (or an extruder).
STEPS_PER_MM = Bound(0.01, 1_000_000.0, "steps per mm")
#: A carriage's travel per (micro)step [mm].
STEP_DISTANCE = Bound(1e-6, 100.0, "step distance [mm]")
#: A driver's microstepping (1 to 256: the finest drivers).
MICROSTEPS = Bound(1.0, 256.0, "microsteps")
#: A motor's full steps per rotation.
FULL_STEPS = Bound(1.0, 10_000.0, "full steps per rotation")
#: A bed tilt in percent (mm of Z per 100 mm of X or Y).
TILT_PERCENT = Bound(-100.0, 100.0, "bed tilt [%]")
#: Segments per second of a firmware that cuts moves into segments.
SEGMENTS_PER_SECOND = Bound(0.0, 100_000.0, "segments per second", open_low=True)
