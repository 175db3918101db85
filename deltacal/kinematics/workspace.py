"""A workspace sized from the robot itself, for geometries without a robot file.

Units: mm.
"""

from __future__ import annotations

import numpy as np

from ..geometry import DeltaGeometry, Workspace
from .closed_form import VirtualDelta


def default_workspace(geometry: DeltaGeometry) -> Workspace:
    """A workspace cylinder sized from the robot, for geometries without a robot file.

    Centred on z under the plate at zero readings: radius 0.8 (b - a + L), height
    L / 2, middle 0.17 L below the zero-reading plate (close to Bai's Table 1
    cylinder for his robot). A printer's (a prismatic chain) stands on the bed, z = 0: radius
    0.7 ρ (ρ = tower radius − effector radius, Klipper's delta radius; 94 mm on a Kossel, whose
    printable radius is 92-115 mm), up to ρ below the nozzle at the endstops.
    """
    if geometry.chain.on_bed:
        reach = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)
                              - np.linalg.norm(geometry.plate_ball.mean(axis=1)[:, :2], axis=1)))
        nozzle = VirtualDelta.from_geometry(geometry).forward(np.zeros(3))[0, 2] + geometry.tool[2]
        top = float(nozzle) - reach
        return Workspace(radius=0.7 * reach, height=top, top_z=top)
    b = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
    a = float(np.mean(np.linalg.norm(geometry.plate_ball.mean(axis=1)[:, :2], axis=1)))
    L = float(np.mean(np.linalg.norm(geometry.arm_ball.mean(axis=1), axis=1)))
    z0 = float(VirtualDelta.from_geometry(geometry).forward(np.zeros(3))[0, 2] + geometry.tool[2])
    height = 0.5 * L
    middle = z0 - 0.17 * L
    return Workspace(radius=0.8 * (b - a + L), height=height, top_z=middle + 0.5 * height)
