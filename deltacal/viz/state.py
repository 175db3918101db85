"""The numbers of a scene: robot state at readings, TCP error field, workspace grid, colours."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..chains import REVOLUTE, Chain
from ..exceptions import UnreachableError
from ..geometry import (
    DeltaGeometry,
    Workspace,
    rotation_from_vector,
    vector_from_rotation,
)
from ..kinematics import exact
from ..kinematics.closed_form import VirtualDelta
from ..kinematics.workspace import default_workspace as default_workspace

#: Default factor on the plate's rotation vector: a 0.1 deg tilt is drawn as 10 deg.
DEFAULT_EXAGGERATION = 100.0


# A perceptually ordered colour map (viridis, 5 stops) for the error sizes.
_COLOUR_STOPS = np.array(
    [
        [0.267, 0.005, 0.329],
        [0.229, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ]
)


# ======================================================================== numbers of the scene
@dataclass(frozen=True)
class RobotState:
    """Everything needed to draw one robot at N readings (mm, rad).

    Attributes:
        q: Readings [rad], (N, 3).
        arm_rotation: Arm frames in {O}, (N, 3, 3, 3).
        arm_balls: Arm ball centres in {O} [mm], (N, 3, 2, 3).
        plate: True plate poses.
        shown_rotation: Plate rotation as drawn (tilt exaggerated), (N, 3, 3).
        plate_balls: Plate ball centres as drawn, in {O} [mm], (N, 3, 2, 3).
        tcp: True TCP in {O} [mm], (N, 3).
        axis_point: Actuator axis points in {O} [mm], (3, 3).
        arm_origin: Origins of the arm frames in {O} [mm], (N, 3, 3): the axis points of a
            rotary Delta's arms; a printer's carriages where they are on their towers.
        chain: The actuated chain (:mod:`deltacal.chains`): arms or carriages; :attr:`joint` is its word.
    """

    q: np.ndarray
    arm_rotation: np.ndarray
    arm_balls: np.ndarray
    plate: exact.PlatePose
    shown_rotation: np.ndarray
    plate_balls: np.ndarray
    tcp: np.ndarray
    axis_point: np.ndarray
    arm_origin: np.ndarray
    chain: Chain = REVOLUTE

    @property
    def joint(self) -> str:
        """The chain's word in files: ``"revolute"`` or ``"prismatic"``."""
        return self.chain.name

    @classmethod
    def compute(cls, geometry: DeltaGeometry, q: np.ndarray, exaggerate: float = 1.0) -> RobotState:
        """Poses of every element of ``geometry`` at readings q, plate tilt times ``exaggerate``."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        plate = exact.forward(geometry, q)
        shown = rotation_from_vector(exaggerate * vector_from_rotation(plate.rotation))
        balls = plate.position[:, None, None, :] + np.einsum("nkl,ijl->nijk", shown, geometry.plate_ball)
        # the arm frames' origins carried as points of the arms (Chain.carried_points)
        centre, along_f, along_g = geometry.chain.carried_points(
            geometry.axis_point, geometry.actuator_rotation(), np.zeros((3, 1, 3))
        )
        f, g = geometry.chain.path_terms(geometry.joint_coordinate(q)[:, :, None, None])
        origin = (centre + f * along_f + g * along_g)[:, :, 0]
        return cls(
            q=q,
            arm_rotation=geometry.arm_rotation(q),
            arm_balls=geometry.arm_balls_in_base(q),
            plate=plate,
            shown_rotation=shown,
            plate_balls=balls,
            tcp=plate.point(geometry.tool),
            axis_point=np.array(geometry.axis_point),
            arm_origin=origin,
            chain=geometry.chain,
        )


@dataclass(frozen=True)
class ErrorField:
    """TCP errors of the uncalibrated robot over a set of commanded points.

    Attributes:
        commanded: Commanded TCP positions in {O} [mm], (N, 3).
        reached: True TCP positions at the nominal inverse-kinematics readings [mm], (N, 3).
    """

    commanded: np.ndarray
    reached: np.ndarray

    @property
    def error(self) -> np.ndarray:
        """True minus commanded TCP [mm], (N, 3)."""
        return self.reached - self.commanded

    @property
    def magnitude(self) -> np.ndarray:
        """Error sizes [mm], (N,)."""
        return np.linalg.norm(self.error, axis=1)

    @classmethod
    def compute(
        cls, nominal_geometry: DeltaGeometry, true_geometry: DeltaGeometry, targets: np.ndarray
    ) -> ErrorField:
        """Errors at the targets reachable by both robots (others are dropped).

        Args:
            nominal_geometry: The model the uncalibrated controller uses.
            true_geometry: The real robot.
            targets: Commanded TCP positions [mm], (N, 3).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        q = reachable_readings(nominal_geometry, targets)
        keep = np.all(np.isfinite(q), axis=1)
        targets, q = targets[keep], q[keep]
        if targets.shape[0] == 0:
            return cls(np.zeros((0, 3)), np.zeros((0, 3)))
        reached = exact.forward(true_geometry, q).point(true_geometry.tool)
        return cls(targets, reached)


def reachable_readings(geometry: DeltaGeometry, targets: np.ndarray) -> np.ndarray:
    """Readings putting the TCP at each target, NaN rows where it is out of reach."""
    first = VirtualDelta.from_geometry(geometry).inverse(targets - geometry.tool, check=False)
    out = np.full(targets.shape, np.nan)
    ok = np.flatnonzero(np.all(np.isfinite(first), axis=1))
    if ok.size:
        try:
            out[ok] = exact.inverse(geometry, targets[ok], start=first[ok])
        except UnreachableError as exc:
            good = np.setdiff1d(np.arange(ok.size), exc.indices)
            if good.size:
                out[ok[good]] = exact.inverse(geometry, targets[ok[good]], start=first[ok[good]])
    return out


def workspace_grid(workspace: Workspace, per_radius: int = 2) -> np.ndarray:
    """Points of a square grid inside the workspace cylinder, on its three layers.

    Args:
        workspace: The cylinder.
        per_radius: Grid steps per radius (2: spacing R/2, 13 points per layer).

    Returns:
        Points [mm], (N, 3), layer by layer from the top.
    """
    steps = np.arange(-per_radius, per_radius + 1) / per_radius * workspace.radius
    x, y = np.meshgrid(steps, steps, indexing="ij")
    inside = x**2 + y**2 <= workspace.radius**2 * (1.0 + 1e-9)
    xy = np.stack([x[inside], y[inside]], axis=1)
    layers = [workspace.top_z, workspace.middle_z, workspace.bottom_z]
    return np.concatenate([np.column_stack([xy, np.full(len(xy), z)]) for z in layers])


def demo_path(workspace: Workspace, frames: int = 100) -> np.ndarray:
    """A closed 3-D Lissajous path through the workspace centre (start and end there) [mm], (frames, 3)."""
    t = np.linspace(0.0, 2.0 * np.pi, frames)
    rho = 0.6 * workspace.radius
    return workspace.centre + np.column_stack(
        [rho * np.sin(t), 0.6 * rho * np.sin(2.0 * t), 0.35 * workspace.height * np.sin(3.0 * t)]
    )


def nice_number(x: float) -> float:
    """The largest of 1, 2, 5 times a power of ten not above x (x > 0)."""
    exponent = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**exponent <= x * (1 + 1e-12):
            return m * 10.0**exponent
    return 10.0**exponent  # pragma: no cover


def error_colours(fraction: np.ndarray) -> np.ndarray:
    """RGB in [0, 1] of the error colour map at fractions of the largest error, (N, 3)."""
    f = np.clip(np.asarray(fraction, dtype=float), 0.0, 1.0) * (len(_COLOUR_STOPS) - 1)
    i = np.minimum(np.floor(f).astype(int), len(_COLOUR_STOPS) - 2)
    w = (f - i)[:, None]
    return (1.0 - w) * _COLOUR_STOPS[i] + w * _COLOUR_STOPS[i + 1]
