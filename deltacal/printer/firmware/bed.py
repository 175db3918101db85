"""Points on a printer's bed, where the first layer's correction is computed (``Firmware.admit_bed``)."""

from __future__ import annotations

import math

import numpy as np

#: Spacing of the bed's points :meth:`~.base.Firmware.admit_bed` corrects [mm].
BED_GRID_MM = 5.0


def bed_grid(radius: float, spacing: float = BED_GRID_MM) -> np.ndarray:
    """Points on the bed (z = 0) over a disk: the centre and rings every ``spacing``, the last at ``radius``.

    Args:
        radius: The disk's radius [mm].
        spacing: Between rings and between a ring's points, at most [mm].

    Returns:
        The points [mm], (N, 3).
    """
    rings = max(1, math.ceil(radius / spacing))
    points = [np.zeros((1, 3))]
    for r in np.linspace(radius / rings, radius, rings):
        n = max(6, math.ceil(2.0 * math.pi * r / spacing))
        t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
        points.append(np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(n)]))
    return np.concatenate(points)
