"""The classical model: perfect parallelograms, plate kept parallel (24 parameters).

Vischer and Clavel's 24 parameters, Bai 2015 model 24 (Eq. 10): per limb i the
actuator position ``p{i}x, p{i}y, p{i}z`` [mm] (base frame), the actuator axis
direction as two tilts ``tilt{i}r`` (about the arm's zero direction, ≈ r_i) and
``tilt{i}z`` (about the actuator frame's z, ≈ up) [rad], the encoder offset
``offset{i}`` [rad] (positive about the axis, like q), the arm length ``L{i}`` [mm]
and the (mean) rod length ``l{i}`` [mm].

Mapped back to a geometry, every parameter keeps each parallelogram perfect: an
axis tilt turns the plate-side ball pair with the arm-side one, a rod-length
change lengthens both rods. Around a geometry with perfect parallelograms the
plate therefore stays parallel (δα ≡ 0).
"""

from __future__ import annotations

import numpy as np

from ..geometry import DeltaGeometry
from .base import (
    N_ELEMENTARY,
    ErrorModel,
    actuator_rotation_index,
    arm_ball_index,
    axis_point_index,
    pair_rotation_moves,
    rod_index,
)


def position_pair_rotations(geometry: DeltaGeometry) -> np.ndarray:
    """Plate-pair rotations of the 8 position parameters of each limb, shape (18, 3, 8).

    An axis tilt turns the plate pair with the arm pair (plate frame taken parallel to
    the base), so the parallelogram stays perfect.
    """
    R0 = geometry.actuator_rotation()
    P = np.zeros((18, 3, 8))
    for i in range(3):
        P[3 * i : 3 * i + 3, i, 3] = R0[i][:, 0]
        P[3 * i : 3 * i + 3, i, 4] = R0[i][:, 2]
    return P


def position_moves(geometry: DeltaGeometry) -> np.ndarray:
    """Elementary moves of the 8 position parameters of each limb, shape (60, 3, 8).

    Per limb, columns: axis point x, y, z [mm]; tilt about x0 [rad]; tilt about z0 [rad];
    encoder offset [rad]; arm length [mm]; mean rod length [mm].
    """
    M = np.zeros((N_ELEMENTARY, 3, 8))
    P = position_pair_rotations(geometry)
    for i in range(3):
        for k in range(3):
            M[axis_point_index(i, k), i, k] = 1.0
        for col, axis_k in ((3, 0), (4, 2)):
            M[actuator_rotation_index(i, axis_k), i, col] = 1.0
            rot = P[:, i, col].reshape(2, 3, 3)
            M[:, i, col] += pair_rotation_moves(geometry, rot[0], rot[1])
        M[actuator_rotation_index(i, 1), i, 5] = 1.0
        for j in range(2):
            M[arm_ball_index(i, j, 0), i, 6] = 1.0
            M[rod_index(i, j), i, 7] = 1.0
    return M


class ClassicalModel(ErrorModel):
    """Perfect-parallelogram model, 24 parameters (Vischer and Clavel; Bai model 24)."""

    name = "classical"
    tilts_plate = False
    frame_held_first = tuple(f"p{i}{a}" for i in range(1, 4) for a in "xyz")

    _LIMB = ("p{i}x", "p{i}y", "p{i}z", "tilt{i}r", "tilt{i}z", "offset{i}", "L{i}", "l{i}")
    _UNITS = ("mm", "mm", "mm", "rad", "rad", "rad", "mm", "mm")

    @property
    def names(self) -> list[str]:
        """The 24 parameter names, limb by limb."""
        return [n.format(i=i) for i in range(1, 4) for n in self._LIMB]

    @property
    def units(self) -> list[str]:
        """Units of the parameters."""
        return [u for _ in range(3) for u in self._UNITS]

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """Moves of the 24 parameters."""
        return position_moves(geometry).reshape(N_ELEMENTARY, 24)

    def pair_rotations(self, geometry: DeltaGeometry) -> np.ndarray:
        """Axis tilts turn the plate pairs exactly."""
        return position_pair_rotations(geometry).reshape(18, 24)
