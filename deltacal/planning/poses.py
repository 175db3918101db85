"""Pose sets: readings with their nominal targets; Bai's circles (Section 5) and the rough step's."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import PlanningError
from ..geometry import NominalDelta, Workspace
from ..kinematics.closed_form import VirtualDelta


# --------------------------------------------------------------------------- pose sets
@dataclass(frozen=True)
class PoseSet:
    """Poses to measure: readings to command and the nominal TCP targets they reach.

    Attributes:
        q: Joint readings [rad], shape (N, 3).
        targets: Nominal TCP positions in {O} [mm], shape (N, 3).
    """

    q: np.ndarray
    targets: np.ndarray

    def __post_init__(self) -> None:
        q = np.atleast_2d(np.asarray(self.q, dtype=float))
        t = np.atleast_2d(np.asarray(self.targets, dtype=float))
        if q.shape != t.shape or q.ndim != 2 or q.shape[1] != 3:
            raise ValueError(f"q and targets must both be (N, 3), got {q.shape} and {t.shape}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "targets", t)

    def __len__(self) -> int:
        return self.q.shape[0]

    def __getitem__(self, index) -> PoseSet:
        return PoseSet(self.q[index], self.targets[index])


def require_workspace(nominal: NominalDelta) -> Workspace:
    """The robot's workspace cylinder; PlanningError if the robot file has none."""
    if nominal.workspace is None:
        raise PlanningError(f"robot {nominal.name!r} has no [workspace] cylinder to plan in")
    return nominal.workspace


def circle(radius: float, z: float, n: int, phase: float = 0.0) -> np.ndarray:
    """N evenly spaced points of a horizontal circle about the z axis [mm], shape (n, 3).

    Args:
        radius: Circle radius [mm].
        z: Height of the circle [mm].
        n: Number of points.
        phase: Azimuth of the first point [rad] (Bai's swing angle ψ of the first pose).
    """
    angle = phase + 2.0 * np.pi * np.arange(n) / n
    return np.stack([radius * np.cos(angle), radius * np.sin(angle), np.full(n, float(z))], axis=1)


def poses_from_reference(
    nominal: NominalDelta, reference: np.ndarray, tool: np.ndarray | None = None
) -> PoseSet:
    """Poses putting the plate's reference point (the file's tool) at cylinder points.

    Args:
        nominal: The robot.
        reference: Positions of the file's tool [mm], shape (N, 3).
        tool: TCP in the plate frame [mm] whose targets to report (default: the file's tool).

    Returns:
        The readings (nominal inverse kinematics) and the TCP targets
        ``reference + tool - nominal.tool``.

    Raises:
        UnreachableError: naming the points the nominal robot cannot reach.
    """
    reference = np.atleast_2d(np.asarray(reference, dtype=float))
    shift = np.zeros(3) if tool is None else np.asarray(tool, dtype=float) - nominal.tool
    q = VirtualDelta.from_nominal(nominal).inverse(reference - nominal.tool)
    return PoseSet(q, reference + shift)


def bai_poses(
    nominal: NominalDelta, n: int, tool: np.ndarray | None = None, phase: float = 0.0
) -> PoseSet:
    """Bai's pose set of the fine calibration (Bai 2015, §3.3, Fig. 4): 2n + 1 poses.

    The centre of the cylinder (``P_0``) first, then n evenly spaced poses on the
    top circle and n on the bottom circle (radius R, same azimuths).

    Args:
        nominal: The robot, with a workspace.
        n: Poses per circle (>= 1).
        tool: TCP for the targets (see the module docstring).
        phase: Azimuth of the first pose of each circle [rad].
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    ws = require_workspace(nominal)
    ref = np.concatenate(
        [ws.centre[None], circle(ws.radius, ws.top_z, n, phase), circle(ws.radius, ws.bottom_z, n, phase)]
    )
    return poses_from_reference(nominal, ref, tool)


def rough_poses(
    nominal: NominalDelta,
    n: int,
    tool: np.ndarray | None = None,
    phase: float = 0.0,
    centre: bool = True,
) -> PoseSet:
    """Poses of the rough (encoder offset) step (Bai 2015, §5.1): the middle circle.

    Args:
        nominal: The robot, with a workspace.
        n: Poses on the middle circle of radius R (>= 1).
        tool: TCP for the targets (see the module docstring).
        phase: Azimuth of the first pose [rad].
        centre: Put the centre of the cylinder first (Bai: K = C(n+1, 2) distances).
    """
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    ws = require_workspace(nominal)
    parts = [ws.centre[None]] if centre else []
    parts.append(circle(ws.radius, ws.middle_z, n, phase))
    return poses_from_reference(nominal, np.concatenate(parts), tool)
