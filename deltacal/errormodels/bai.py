"""Bai et al.'s linear error models: model 42 and its distance-based reductions.

Bai 2015, Eq. 1-10. The limb frame {0B_i} has ``u0`` along the arm's zero
direction (≈ r_i), ``v0`` up and ``w0 = u0 × v0`` (≈ −t_i) along the actuator
axis, so Bai's joint angle θ_i turns opposite to this project's q_i.

Position group Δp_r (per limb, Eq. 6): ``Ldtheta{i}`` = LΔθ_i [mm] (encoder
offset about w0), ``e{i}x, e{i}y, e{i}z`` = Δe_i = Δb_i − Δa_i [mm] (base frame),
``dL{i}`` = ΔL_i [mm], ``Ldalpha0_{i}``, ``Ldbeta0_{i}`` = LΔα_0,i, LΔβ_0,i [mm]
(actuator axis tilts about u0 and v0), ``dlbar{i}`` = mean rod-length error [mm].

Orientation group Δp_ε (per limb, Eq. 7): ``dltilde{i}_c`` = Δl̃_i / c,
``dctilde{i}_c`` = Δc̃_i / c, ``dalpha03_{i}``, ``dbeta03_{i}`` = Δα_03,i, Δβ_03,i
(plate ball pair turned relative to the actuator frame), ``dalpha2_{i}``,
``dbeta2_{i}`` = Δα_2,i, Δβ_2,i (arm ball pair turned in the arm) [rad].

Model 24 is the position group alone (Eq. 10, plate parallel); model 42 is both
(Eq. 8-9). For distance measurements Bai fixes the gauge with Eq. 11
(Δe_x,1 = Δe_y,2 = Δe_y,3 = Δe_z,i = 0): models 18 and 36. Model 32 drops the
four orientation parameters that distances cannot see (Bai §3.2, Eq. 19).

The sensitivity is computed from the rod equations at the exact pose
(:mod:`.base`); at a geometry with perfect parallelograms it equals Bai's
C_r and C_ε of Eq. 8-9 (tested).
"""

from __future__ import annotations

import numpy as np

from ..geometry import DeltaGeometry
from .base import (
    N_ELEMENTARY,
    ErrorModel,
    arm_ball_index,
    pair_frames,
    pair_rotation_moves,
    rod_index,
)
from .classical import position_moves, position_pair_rotations

POSITION_NAMES = ("Ldtheta{i}", "e{i}x", "e{i}y", "e{i}z", "dL{i}", "Ldalpha0_{i}", "Ldbeta0_{i}", "dlbar{i}")
ORIENTATION_NAMES = (
    "dltilde{i}_c",
    "dctilde{i}_c",
    "dalpha03_{i}",
    "dbeta03_{i}",
    "dalpha2_{i}",
    "dbeta2_{i}",
)
#: Bai Eq. 11: the gauge fixed for distance measurements.
DISTANCE_GAUGE = ["e1x", "e2y", "e3y", "e1z", "e2z", "e3z"]
#: Bai §3.2: the four orientation parameters removed from model 36 to get model 32.
MODEL32_REMOVED = ["dalpha03_2", "dalpha03_3", "dbeta03_3", "dalpha2_3"]


class BaiModel(ErrorModel):
    """Bai's model 24 (``orientation=False``) or model 42 (``orientation=True``)."""

    def __init__(self, orientation: bool = True) -> None:
        self.orientation = orientation
        self.tilts_plate = orientation
        self.name = "bai42" if orientation else "bai24"
        self.frame_held_first = tuple(f"e{i}{a}" for i in range(1, 4) for a in "xyz")
        # where parameters regroup, Bai's own choices are the ones dropped: the Eq. 11 gauge
        # (positions of the ball pairs, linear in the geometry) and the four of §3.2. Left to
        # the pivoted QR, distances dropped an encoder offset and axis tilts: held at zero while
        # the robot's are a degree, the rigid motions they stand for are wrong to second order
        # (tens of µm) and the fit stalls far from the minimum.
        last = [n for n in DISTANCE_GAUGE + MODEL32_REMOVED if n in self.names]
        self.preferred = [n for n in self.names if n not in last] + last

    @property
    def names(self) -> list[str]:
        """Δp_r then (model 42) Δp_ε, limb by limb within each group."""
        names = [n.format(i=i) for i in range(1, 4) for n in POSITION_NAMES]
        if self.orientation:
            names += [n.format(i=i) for i in range(1, 4) for n in ORIENTATION_NAMES]
        return names

    @property
    def units(self) -> list[str]:
        """Units: mm for Δp_r, rad (dimensionless) for Δp_ε."""
        return ["mm"] * 24 + (["rad"] * 18 if self.orientation else [])

    def _position_scaling(self, geometry: DeltaGeometry) -> np.ndarray:
        """T (3, 8, 8): Bai's position parameters in terms of :func:`position_moves` columns."""
        L = pair_frames(geometry)["arm_length"]
        T = np.zeros((3, 8, 8))
        for i in range(3):
            T[i, 5, 0] = -1.0 / L[i]  # LΔθ about w0 = -w
            T[i, 0, 1] = T[i, 1, 2] = T[i, 2, 3] = 1.0  # Δe
            T[i, 6, 4] = 1.0  # ΔL
            T[i, 3, 5] = 1.0 / L[i]  # LΔα0 about u0
            T[i, 4, 6] = 1.0 / L[i]  # LΔβ0 about v0
            T[i, 7, 7] = 1.0  # Δl̄
        return T

    def pair_rotations(self, geometry: DeltaGeometry) -> np.ndarray:
        """Ball pairs turned exactly by Bai's parameters.

        Axis tilts turn the plate pairs with the arm pairs; Δα03, Δβ03 turn the plate pairs
        (about −u0, −v0: the plate frame turned relative to the actuator frame) and Δα2, Δβ2
        the arm pairs (about the arm's x and z).
        """
        T = self._position_scaling(geometry)
        Pp = position_pair_rotations(geometry)  # (18, 3, 8)
        cols = [Pp[:, i] @ T[i] for i in range(3)]
        if self.orientation:
            R0 = geometry.actuator_rotation()
            for i in range(3):
                block = np.zeros((18, 6))
                block[3 * i : 3 * i + 3, 2] = -R0[i][:, 0]
                block[3 * i : 3 * i + 3, 3] = -R0[i][:, 2]
                block[9 + 3 * i, 4] = 1.0
                block[9 + 3 * i + 2, 5] = 1.0
                cols.append(block)
        return np.concatenate(cols, axis=1)

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """Elementary moves of Bai's parameters (Eq. 1-7 read as changes of the geometry)."""
        T = self._position_scaling(geometry)
        pos = position_moves(geometry)  # axis xyz, tilt x0, tilt z0, offset, arm length, rod
        cols = [pos[:, i] @ T[i] for i in range(3)]
        if self.orientation:
            f = pair_frames(geometry)
            P = self.pair_rotations(geometry)[:, 24:]
            for i in range(3):
                c = f["spacing"][i]
                block = np.zeros((N_ELEMENTARY, 6))
                # Bai's rod 1 sits at +c/2 w0 = -t_i: this project's rod 2 (rod 1 is on +t_i)
                block[rod_index(i, 1), 0] = 0.5 * c
                block[rod_index(i, 0), 0] = -0.5 * c
                unit = f["arm_half"][i] / np.linalg.norm(f["arm_half"][i])
                for k in range(3):
                    block[arm_ball_index(i, 0, k), 1] = 0.5 * c * unit[k]
                    block[arm_ball_index(i, 1, k), 1] = -0.5 * c * unit[k]
                for col in range(2, 6):
                    rot = P[:, 6 * i + col].reshape(2, 3, 3)
                    block[:, col] = pair_rotation_moves(geometry, rot[0], rot[1])
                cols.append(block)
        return np.concatenate(cols, axis=1)
