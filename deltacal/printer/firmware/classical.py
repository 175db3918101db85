"""The classical delta model every firmware holds: vertical towers, one rod each, a point effector.

Klipper's, Marlin's and RepRapFirmware's models differ in their values' names and in what they add
(Marlin's homing moves, RRF's bed tilt), not in this maths: tower i stands at ``ρ (cos α_i, sin
α_i)``; its carriage point is at ``E_i = base_i + sqrt(ℓ_i² − ρ²)`` at the endstop (the nozzle's
height there, centred, plus the rod's rise); a nozzle target ``(x, y, z)`` puts the carriage at
``sqrt(ℓ_i² − (x − X_i)² − (y − Y_i)²) + z``; the forward kinematics are the trilateration of a
prismatic :class:`~deltacal.kinematics.closed_form.VirtualDelta` with a point effector whose
readings are steps. Each firmware's ``model`` module builds on these helpers. Units: mm, rad.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...chains import PRISMATIC
from ...exceptions import GeometryError, UnreachableError
from ...geometry import DeltaGeometry, radial_vectors
from ...kinematics.closed_form import VirtualDelta


def tower_positions(radius: float, angle: np.ndarray) -> np.ndarray:
    """Tower positions ``ρ (cos α_i, sin α_i)`` [mm], (3, 2), read-only."""
    towers = radius * radial_vectors(angle)[:, :2]
    towers.setflags(write=False)
    return towers


def carriage_tops(base: np.ndarray | float, rods: np.ndarray, radius: float,
                  more: np.ndarray | float | None = None) -> np.ndarray:
    """Carriage point heights at the endstops, ``base_i + sqrt(ℓ_i² − ρ²) (+ more_i)`` [mm], (3,), read-only.

    Args:
        base: The nozzle's height, centred, with the carriage at its endstop [mm] (per tower or one).
        rods: The rods ℓ_i [mm], (3,).
        radius: ρ [mm].
        more: What the firmware adds after (its endstop adjustments, its homing moves) [mm], or None.
    """
    top = base + np.sqrt(rods**2 - radius**2)
    if more is not None:
        top = top + more
    top.setflags(write=False)
    return top


def rod_rise(towers: np.ndarray, rods: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Each carriage point's height above the nozzle at targets, ``sqrt(ℓ_i² − dx² − dy²)`` [mm], (N, 3).

    NaN where a rod does not reach. Targets (N, 3) or (N, 2) [mm].
    """
    dx = targets[:, None, 0] - towers[None, :, 0]
    dy = targets[:, None, 1] - towers[None, :, 1]
    with np.errstate(invalid="ignore"):
        return np.sqrt(rods**2 - dx * dx - dy * dy)


def checked_steps(steps: np.ndarray, targets: np.ndarray, check: bool) -> np.ndarray:
    """The steps a firmware commands for targets, refused where a rod does not reach (``check``).

    Raises:
        UnreachableError: a target no rod reaches (``check``; else its row is NaN).
    """
    if check:
        bad = ~np.all(np.isfinite(steps), axis=1)
        if np.any(bad):
            raise UnreachableError.from_mask(bad, targets)
    return steps


def point_effector(angle: np.ndarray, towers: np.ndarray, carriage_top: np.ndarray, rods: np.ndarray,
                   step_distance: np.ndarray) -> VirtualDelta:
    """A firmware's model as a prismatic :class:`VirtualDelta` whose readings are steps.

    Carriage point ``(X_i, Y_i, E_i)`` at the endstop, sliding down z by ``d_i`` per step, a point
    effector (attachment and elbow at the origins), rods ℓ_i.

    Args:
        angle: The towers' azimuths α_i [rad], (3,).
        towers: Their positions [mm], (3, 2).
        carriage_top: The carriage points' heights at the endstops ``E_i`` [mm], (3,).
        rods: ℓ_i [mm], (3,).
        step_distance: d_i [mm], (3,).
    """
    r = radial_vectors(angle)
    z = np.tile([0.0, 0.0, 1.0], (3, 1))
    return VirtualDelta(
        axis_point=np.column_stack([towers, carriage_top]),
        actuator_rotation=np.stack([r, z, np.cross(r, z)], axis=-1),
        encoder_offset=np.zeros(3),
        elbow=np.zeros((3, 3)),
        plate_attachment=np.zeros((3, 3)),
        rod_length=np.array(rods),
        chain=PRISMATIC,
        joint_scale=np.array(step_distance),
    )


def home_position(positions: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The nozzle with every carriage at its endstop, by a model's ``positions`` [mm], (3,), read-only."""
    home = positions(np.zeros((1, 3)))[0]
    home.setflags(write=False)
    return home


def on_axis(tool: np.ndarray, title: str) -> None:
    """Refuse a nozzle off the effector's axis, which a firmware's point effector cannot have.

    Args:
        tool: The nozzle in the effector frame [mm], (3,).
        title: The firmware's name users read (``"Klipper"``).

    Raises:
        GeometryError: the nozzle has a horizontal offset.
    """
    if np.any(tool[:2] != 0.0):
        raise GeometryError(f"{title}'s model has no horizontal nozzle offset; the nozzle is at "
                            f"{tool.tolist()} mm in the effector frame")


def carriage_points(geometry: DeltaGeometry, title: str) -> tuple[np.ndarray, float]:
    """A printer geometry's carriage points as a point effector sees them, and their radius.

    Each tower's carriage point is its ball-pair midpoint less the effector's, plus the nozzle
    (in the bed's frame); the radius is the mean of their horizontal distances from the axis.

    Args:
        geometry: The printer (a prismatic chain with its step distance).
        title: The firmware's name users read, for the messages.

    Returns:
        The points [mm], (3, 3), and the radius [mm].

    Raises:
        GeometryError: not a printer (a prismatic chain), no step distance, or a nozzle off the
            effector's axis.
    """
    if not geometry.chain.firmware or geometry.step_distance is None:
        raise GeometryError(f"{title}'s values need a printer's geometry (a prismatic chain) with its "
                            "step distance")
    on_axis(geometry.tool, title)
    rotation = geometry.actuator_rotation()
    carriage = geometry.axis_point + np.einsum("ikl,il->ik", rotation, geometry.arm_ball.mean(axis=1))
    point = carriage - geometry.plate_ball.mean(axis=1) + geometry.tool
    return point, float(np.mean(np.linalg.norm(point[:, :2], axis=1)))
