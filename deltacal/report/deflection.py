"""The deflection map of a calibration that identified the actuators' compliances.

How far the identified robot's TCP moves under gravity, over the workspace: its own weight
(compliant against rigid actuators) and a payload the user gives (loaded against unloaded), at
the readings that put the unloaded TCP on each point. A table by layer (top, middle, bottom of
the workspace cylinder) and ring (centre, half radius, rim): the largest deflection of each
cell [mm]. Through the exact kinematics' statics (:mod:`deltacal.kinematics.statics`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..exceptions import AssemblyError
from ..geometry import DeltaGeometry, Workspace
from ..kinematics import exact, statics
from .accuracy import reachable_readings

#: Points around each ring of the map.
RING_POINTS = 24


@dataclass(frozen=True)
class DeflectionMap:
    """Largest TCP deflections [mm] by layer (rows: top, middle, bottom) and ring (centre, R/2, R).

    Attributes:
        layers: z of each layer [mm], (3,).
        radii: Radius of each ring [mm], (3,).
        own_weight: Own weight's deflection (compliant minus rigid actuators), (3, 3).
        payload: The payload's (loaded minus unloaded), (3, 3); NaN cells out of reach.
        payload_kg: The payload [kg].
    """

    layers: np.ndarray
    radii: np.ndarray
    own_weight: np.ndarray
    payload: np.ndarray
    payload_kg: float


def _tcp(geometry: DeltaGeometry, q: np.ndarray, payload: float) -> np.ndarray:
    return exact.forward(geometry, statics.compliant_readings(geometry, q, payload)).point(geometry.tool)


def deflection_map(geometry: DeltaGeometry, workspace: Workspace, payload: float) -> DeflectionMap:
    """The deflection map of a geometry with compliances over a workspace cylinder (module docstring)."""
    layers = np.array([workspace.top_z, workspace.middle_z, workspace.bottom_z])
    radii = np.array([0.0, 0.5, 1.0]) * workspace.radius
    angle = np.linspace(0.0, 2.0 * np.pi, RING_POINTS, endpoint=False)
    own, loaded = np.full((3, 3), np.nan), np.full((3, 3), np.nan)
    rigid = replace(geometry, compliance=np.zeros(3))
    for i, z in enumerate(layers):
        for j, r in enumerate(radii):
            ring = np.stack([r * np.cos(angle), r * np.sin(angle), np.full_like(angle, z)], axis=1)
            q = reachable_readings(geometry, ring)
            q = q[np.all(np.isfinite(q), axis=1)]
            if not len(q):
                continue
            try:
                free = _tcp(geometry, q, 0.0)
                own[i, j] = np.linalg.norm(free - _tcp(rigid, q, 0.0), axis=1).max()
                loaded[i, j] = np.linalg.norm(_tcp(geometry, q, payload) - free, axis=1).max()
            except AssemblyError:
                continue
    return DeflectionMap(layers, radii, own, loaded, float(payload))
