"""Nominal (design) parameters of a linear Delta printer (conventions, "Linear Delta printers").

Frame {O}: origin on the nominal bed at its centre, z up; the printer works above the bed. Tower i
is the vertical line through ``R r_i``; the carriage's ball-pair midpoint is at
``R r_i + (H_i − s_i) z`` with ``s_i >= 0`` its travel below the endstop (the reading: steps times
the tower's step distance d_i); carriage balls at that point ``± c/2 t_i``; effector balls at
``a r_i ± c/2 t_i`` in the effector frame {E} (origin: the ball plane's centre), which is the plate frame of
:class:`~deltacal.geometry.DeltaGeometry`; the nozzle is its TCP.

As a :class:`~deltacal.geometry.DeltaGeometry` the printer is a prismatic chain
(:mod:`deltacal.chains`): axis point ``R r_i + H_i z`` (the carriage frame's origin at the endstop),
axis direction ``z`` (up the tower), so the carriage frame is ``[r_i, z, −t_i]`` and its balls are
``(0, 0, ∓c/2)`` in it, on rods of length l_i. The rod length, the endstop height and the step
distance are per tower (a real printer's differ: Klipper's ``[stepper_a..c]`` hold each tower's
``arm_length``, ``position_endstop`` and ``rotation_distance``). Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..chains import PRISMATIC
from ..exceptions import GeometryError
from ..geometry import DeltaGeometry, Workspace, radial_vectors, tangent_vectors
from ..holds import in_plane_motion as in_plane_motion  # its home: a printer's gauge
from ..towers import TOWERS, per_tower

#: The values a printer holds per tower (conventions, "Printers as they are found").
PER_TOWER = ("rod_length", "endstop_height", "step_distance")


@dataclass(frozen=True)
class NominalLinearDelta:
    """Nominal parameters of a linear Delta printer, as in a robot file with ``kind = "linear"``.

    Attributes:
        name: Printer name.
        tower_radius: R, centre to each carriage's ball-pair midpoint, horizontal [mm].
        effector_radius: a, effector centre to each ball-pair midpoint [mm].
        rod_length: l_i of towers A, B, C [mm], (3,) (a number broadcasts).
        rod_spacing: c, distance between the two balls of a pair [mm].
        tower_azimuth: phi_i of towers A, B, C [rad], (3,).
        endstop_height: H_i, height of each carriage's ball-pair midpoint at its endstop [mm], (3,)
            (a number broadcasts).
        step_distance: d_i, each carriage's travel per step [mm], (3,) (a number broadcasts): what
            a tower's reading counts its steps in.
        tool: The nozzle in the effector frame [mm], (3,).
        points: Named reference points in the effector frame [mm].
        workspace: The printable cylinder (z from 0 up to its height), or None.
        description: Free text.
    """

    name: str
    tower_radius: float
    effector_radius: float
    rod_length: np.ndarray
    rod_spacing: float
    tower_azimuth: np.ndarray
    endstop_height: np.ndarray
    step_distance: np.ndarray
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    points: dict[str, np.ndarray] = field(default_factory=dict)
    workspace: Workspace | None = None
    description: str = ""

    #: The robot file's kind.
    kind = PRISMATIC.robot_kind

    def __post_init__(self) -> None:
        object.__setattr__(self, "tower_azimuth", np.asarray(self.tower_azimuth, dtype=float))
        object.__setattr__(self, "tool", np.asarray(self.tool, dtype=float))
        object.__setattr__(self, "points", {k: np.asarray(v, dtype=float) for k, v in self.points.items()})
        for key in ("tower_radius", "effector_radius", "rod_spacing"):
            value = getattr(self, key)
            if not math.isfinite(value) or value <= 0.0:
                raise GeometryError(f"{key} must be a positive finite length, got {value!r}")
        for key in PER_TOWER:
            object.__setattr__(self, key, per_tower(key, getattr(self, key)))
        if self.tower_azimuth.shape != (3,) or not np.all(np.isfinite(self.tower_azimuth)):
            raise GeometryError(f"tower_azimuth must be 3 finite angles, got {self.tower_azimuth}")
        if self.tool.shape != (3,) or not np.all(np.isfinite(self.tool)):
            raise GeometryError(f"tool must be 3 finite coordinates, got {self.tool}")
        reach = self.tower_radius - self.effector_radius
        for tower, rod in zip(TOWERS, self.rod_length, strict=True):
            if rod <= reach:
                raise GeometryError(f"rod_length {float(rod)} (tower {tower}) must exceed the horizontal "
                                    f"reach tower_radius - effector_radius = {reach}")

    @property
    def radial(self) -> np.ndarray:
        """Radial unit vectors r_i, shape (3, 3) (one row per tower)."""
        return radial_vectors(self.tower_azimuth)

    @property
    def tangent(self) -> np.ndarray:
        """Tangent unit vectors t_i, shape (3, 3)."""
        return tangent_vectors(self.tower_azimuth)

    def geometry(self) -> DeltaGeometry:
        """Full geometry of the perfect printer built to these nominal values (a prismatic chain)."""
        r, t = self.radial, self.tangent
        half = 0.5 * self.rod_spacing
        carriage_ball = np.zeros((3, 2, 3))
        carriage_ball[:, 0, 2] = -half  # +c/2 t_i: the carriage frame's z is -t_i
        carriage_ball[:, 1, 2] = half
        axis_point = self.tower_radius * r
        axis_point[:, 2] = self.endstop_height  # H_i
        a = self.effector_radius
        plate_ball = np.stack([a * r + half * t, a * r - half * t], axis=1)
        return DeltaGeometry(
            limb_azimuth=self.tower_azimuth.copy(),
            axis_point=axis_point,
            axis_direction=np.tile([0.0, 0.0, 1.0], (3, 1)),
            encoder_offset=np.zeros(3),
            arm_ball=carriage_ball,
            plate_ball=plate_ball,
            rod_length=np.repeat(self.rod_length[:, None], 2, axis=1),  # l_i, both rods of a tower
            tool=self.tool.copy(),
            points={k: v.copy() for k, v in self.points.items()},
            name=self.name,
            chain=PRISMATIC,
            step_distance=self.step_distance.copy(),
        )


def less_bed_motion(points: np.ndarray, errors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A printer's errors [mm], (N, 3), less the in-plane motion that fits them best, and that motion.

    Rows with a non-finite error are left out of the fit (and stay non-finite).
    """
    ok = np.all(np.isfinite(errors), axis=1)
    A = in_plane_motion(points)
    motion = np.linalg.lstsq(A[ok].reshape(-1, 3), errors[ok].reshape(-1), rcond=None)[0]
    return errors - A @ motion, motion
