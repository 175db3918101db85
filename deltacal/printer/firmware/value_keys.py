"""Where a firmware's model holds a value its configuration sets, and the unit the firmware writes it in.

Each firmware's :attr:`~.base.Firmware.value_keys` maps its own keys (``"stepper_a.position_endstop"``,
``"M665.L"``) to a :class:`ValueKey`: what a calibration records of the configuration it was identified
with (:class:`~deltacal.controller_record.ControllerRecord`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ValueKey:
    """Where a firmware's model holds a value its configuration sets, and the unit the firmware writes.

    Attributes:
        field: The model's attribute (``"position_endstop"``).
        index: The tower (0, 1, 2) or tilt axis of an array attribute, or None (a number).
        unit: How the firmware writes the model's value: ``""`` as held, ``"deg"`` (held in rad),
            ``"inverse"`` (steps per mm of a step distance held in mm), ``"percent"`` (a ratio held as one).
    """

    field: str
    index: int | None = None
    unit: str = ""

    def read(self, model: object) -> float | None:
        """The value in the firmware's unit, or None (the model holds none)."""
        value = getattr(model, self.field)
        if value is None:
            return None
        v = float(value if self.index is None else np.asarray(value)[self.index])
        return (math.degrees(v) if self.unit == "deg" else 1.0 / v if self.unit == "inverse"
                else 100.0 * v if self.unit == "percent" else v)

    def held(self, value: float) -> float:
        """A value in the firmware's unit as the model holds it (:meth:`read` undone)."""
        return (math.radians(value) if self.unit == "deg" else 1.0 / value if self.unit == "inverse"
                else value / 100.0 if self.unit == "percent" else value)
