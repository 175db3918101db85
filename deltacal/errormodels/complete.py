"""Savoure's complete model: every ball centre, every rod, every actuator frame (51).

Parameters (Savoure 2006, Eq. 12-20), per rod (i, j) in the order
(1,1), (1,2), (2,1), (2,2), (3,1), (3,2):

* ``b{i}{j}x, b{i}{j}y, b{i}{j}z`` [mm]: plate ball B_ij in the plate frame. As in
  Eq. 13 it stands for ``δb_ij − δp_i``: a move of the actuator point P_i is the
  same as the opposite move of the limb's plate balls, so P_i is not a parameter.
* ``a{i}{j}x, a{i}{j}y, a{i}{j}z`` [mm]: arm ball A_ij in the arm frame (x along the
  arm, y along the actuator axis).
* ``l{i}{j}`` [mm]: rod length.

then per actuator i the rotation δβ_i of its frame about P_i [rad] (Eq. 8),
components about the actuator frame's own axes: ``beta{i}r`` (about the arm's
zero direction, ≈ r_i), ``beta{i}t`` (about the actuator axis, ≈ t_i: the encoder
offset) and ``beta{i}z`` (≈ up). 7 × 6 + 3 × 3 = 51.
"""

from __future__ import annotations

import numpy as np

from ..geometry import DeltaGeometry
from .base import (
    N_ELEMENTARY,
    ErrorModel,
    ListedParameters,
    actuator_rotation_index,
    arm_ball_index,
    plate_ball_index,
    rod_index,
)


class CompleteModel(ListedParameters, ErrorModel):
    """Savoure's complete model (51 parameters), Eq. 12-22."""

    name = "complete"
    tilts_plate = True

    def __init__(self) -> None:
        names: list[str] = []
        units: list[str] = []
        for i in range(1, 4):
            for j in (1, 2):
                names += [f"b{i}{j}{a}" for a in "xyz"]
                names += [f"a{i}{j}{a}" for a in "xyz"]
                names.append(f"l{i}{j}")
                units += ["mm"] * 7
        for i in range(1, 4):
            names += [f"beta{i}{a}" for a in "rtz"]
            units += ["rad"] * 3
        self._names = names
        self._units = units
        M = np.zeros((N_ELEMENTARY, len(names)))
        col = 0
        for i in range(3):
            for j in range(2):
                for k in range(3):
                    M[plate_ball_index(i, j, k), col] = 1.0
                    col += 1
                for k in range(3):
                    M[arm_ball_index(i, j, k), col] = 1.0
                    col += 1
                M[rod_index(i, j), col] = 1.0
                col += 1
        for i in range(3):
            for k in range(3):
                M[actuator_rotation_index(i, k), col] = 1.0
                col += 1
        self._moves = M
        # keep physical meaning in the regroupings: actuator rotations (the encoder offset above
        # all), then rod lengths, plate balls and arm balls
        self.preferred = (
            [f"beta{i}{a}" for a in "trz" for i in range(1, 4)]
            + [f"l{i}{j}" for i in range(1, 4) for j in (1, 2)]
            + [f"b{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"]
            + [f"a{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"]
        )
        # the plate balls also carry the actuators' positions (Eq. 13)
        self.frame_held_first = tuple(f"b{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz")

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """Each parameter is one elementary move (constant matrix)."""
        return self._moves
