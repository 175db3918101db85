"""Values held per tower of a linear Delta (towers A, B, C): a number, or one per tower.

A real printer's towers differ (Klipper's ``[stepper_a..c]`` hold each tower's ``arm_length``,
``position_endstop`` and ``rotation_distance``): such a value is held as (3,), in the towers'
order; a file writes it as one number when the three are equal and as ``[a, b, c]`` otherwise
(conventions, "Printers as they are found").
"""

from __future__ import annotations

import numpy as np

from .exceptions import GeometryError

#: The towers, in the order of a per-tower value ``[a, b, c]``.
TOWERS = ("A", "B", "C")


def per_tower(name: str, value: np.ndarray | float) -> np.ndarray:
    """A number or one positive finite value per tower, as a read-only (3,) array.

    Raises:
        GeometryError: neither one number nor three, or a value not positive and finite.
    """
    values = np.array(value, dtype=float).reshape(-1)
    values = np.repeat(values, len(TOWERS)) if values.size == 1 else values
    if values.shape != (len(TOWERS),) or not np.all(np.isfinite(values) & (values > 0.0)):
        raise GeometryError(f"{name} must be a positive length, or one per tower, got {value!r}")
    values.setflags(write=False)
    return values


def written_per_tower(values: np.ndarray) -> float | list[float]:
    """A per-tower value as a file writes it: a number when the three are equal, else ``[a, b, c]``."""
    values = np.asarray(values, dtype=float)
    return float(values[0]) if np.all(values == values[0]) else values.tolist()
