"""Plate points identified with the geometry: reflector positions on the plate (``--free-points``).

A measured point p of the plate sits at ``X + R p`` in {O} (X, R: the plate pose). When a
reflector's position on the plate is not known well enough, its three coordinates (plate
frame) can be identified with the geometry: the regressor of a measured position gains
``d(X + R p)/dp = R``. A common shift of every plate point together with the plate balls
moves nothing measured (the plate frame's origin is a convention), so where the geometry's
own parameters already account for a point's coordinates, they stay as given.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..geometry import DeltaGeometry
from ..observations import POSITION, Measurements, Rows

#: Coordinates of a point parameter, in the plate frame.
POINT_PARAMETERS = ("x", "y", "z")


def point_parameter_names(points: Sequence[str]) -> list[str]:
    """Names of the free points' parameters: ``P[name].x``, ``P[name].y``, ``P[name].z``."""
    return [f"P[{p}].{c}" for p in points for c in POINT_PARAMETERS]


def point_columns(
    rows: Rows, measurements: Measurements, points: Sequence[str], rotation: np.ndarray
) -> np.ndarray:
    """Regressor columns of the free points' coordinates, (m, 3 P).

    Args:
        rows: The rows built for the measurements (positions first, three rows each).
        measurements: The measurements (their ``point`` column).
        points: The free points, in parameter order.
        rotation: Plate orientation at each measurement, (M, 3, 3).
    """
    index = {name: k for k, name in enumerate(points)}
    which = np.array([index.get(name, -1) for name in measurements.point])
    F = np.zeros((rows.residual.size, 3 * len(points)))
    pos = np.flatnonzero(rows.kind == POSITION)
    m = rows.measurement[pos]
    on = which[m] >= 0
    pos, m = pos[on], m[on]
    k = pos % 3
    cols = 3 * which[m][:, None] + np.arange(3)
    F[pos[:, None], cols] = rotation[m, k, :]
    return F


def with_points_moved(geometry: DeltaGeometry, points: Sequence[str], moves: np.ndarray) -> DeltaGeometry:
    """The geometry with each named point moved on the plate by a row of ``moves`` [mm], (P, 3)."""
    named = dict(geometry.points)
    tool = geometry.tool
    for name, move in zip(points, np.asarray(moves, dtype=float), strict=True):
        if name == "tcp":
            tool = tool + move
        else:
            named[name] = named[name] + move
    return replace(geometry, points=named, tool=tool)
