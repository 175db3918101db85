"""Actuated chains: how an actuator moves the balls it carries.

A rotary Delta and a linear one (a 3D printer's towers) differ only here. Each limb's actuator
carries its arm-side balls rigidly, and the actuator's frame at zero motion is the same for both:
origin ``P_i`` (``axis_point``), rotation ``R0_i = [x0 w z0]`` with y along the joint's axis ``w_i``
(the rotation axis of a revolute joint, the line of travel of a prismatic one), x the radial
direction made orthogonal to it. A point ``a`` carried by the actuator is, at the joint coordinate
``θ_i = scale_i q_i + offset_i`` (reading q; the true angle [rad] or the true travel [mm]),

    A = C + f(θ) U + g(θ) V

* ``revolute``: f = cos, g = sin: a circle about the axis (:func:`arm_frame_circle`,
  ``C = P + a_y w``, ``U = a_x x0 + a_z z0``, ``V = a_z x0 − a_x z0``); q > 0 lowers the arm tip.
* ``prismatic``: f = θ, g = 0: a line down the tower, ``C = P + R0 a``, ``U = −w``, ``V = 0``; θ is
  the carriage's travel below its endstop (q: steps times the nominal step distance, scale: the
  true step distance over the nominal one).

Everything that moves an arm ball (the geometry, the exact solver, the virtual model) goes
through :func:`carried_points`, :func:`path_terms` and :func:`path_slopes`. Units: mm and rad.
"""

from __future__ import annotations

import numpy as np

#: The kinds of actuated joint.
JOINTS = ("revolute", "prismatic")

#: The largest joint step of one inverse-kinematics iteration, per joint kind [rad, mm]: small
#: enough that a far start cannot jump to the other branch (knee in; effector above the carriage).
MAX_STEP = {"revolute": 0.2, "prismatic": 50.0}

#: A warm start is used when the readings moved by less than this in each joint [rad, mm].
WARM_RADIUS = {"revolute": float(np.radians(5.0)), "prismatic": 20.0}


def check_joint(joint: str) -> str:
    """The joint kind, or ValueError naming the kinds known."""
    if joint not in JOINTS:
        raise ValueError(f"joint must be one of {', '.join(JOINTS)}, got {joint!r}")
    return joint


def arm_frame_circle(
    axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points fixed in the arm frames, on their circles about the actuator axes.

    A point ``a`` of arm i is at ``P_i + R0_i R_y(θ_i) a = C + cos θ_i U + sin θ_i V`` in {O}
    (θ the true angle; conventions), with ``C = P_i + a_y w_i``, ``U = a_x x0_i + a_z z0_i``
    and ``V = a_z x0_i − a_x z0_i`` in the actuator frame's axes ``R0_i = [x0 w z0]``.

    Args:
        axis_point: P_i [mm], shape (3, 3).
        actuator_rotation: R0_i, shape (3, 3, 3).
        local: Points in the arm frames [mm], shape (3, K, 3) (K points of each arm).

    Returns:
        C, U, V, each of shape (3, K, 3).
    """
    x0, w, z0 = (actuator_rotation[:, None, :, k] for k in range(3))  # (3, 1, 3) each
    ax, ay, az = local[..., 0:1], local[..., 1:2], local[..., 2:3]
    return axis_point[:, None, :] + ay * w, ax * x0 + az * z0, az * x0 - ax * z0


def carried_points(
    joint: str, axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paths of points carried by the actuators, ``A = C + f(θ) U + g(θ) V``: C, U, V.

    Args:
        joint: ``"revolute"`` or ``"prismatic"``.
        axis_point: P_i [mm], shape (3, 3).
        actuator_rotation: R0_i, shape (3, 3, 3).
        local: Points in the arm (or carriage) frames [mm], shape (3, K, 3).

    Returns:
        C, U, V, each of shape (3, K, 3).
    """
    if check_joint(joint) == "revolute":
        return arm_frame_circle(axis_point, actuator_rotation, local)
    centre = axis_point[:, None, :] + np.einsum("ikl,ijl->ijk", actuator_rotation, local)
    along = np.broadcast_to(-actuator_rotation[:, None, :, 1], centre.shape).copy()
    return centre, along, np.zeros_like(centre)


def path_terms(joint: str, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The coefficients ``f(θ), g(θ)`` of U and V in a carried point's position (any shape)."""
    if check_joint(joint) == "revolute":
        return np.cos(theta), np.sin(theta)
    return theta, np.zeros_like(theta)


def path_slopes(joint: str, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Their derivatives ``f'(θ), g'(θ)`` (any shape): ``dA/dθ = f' U + g' V``."""
    if check_joint(joint) == "revolute":
        return -np.sin(theta), np.cos(theta)
    return np.ones_like(theta), np.zeros_like(theta)
