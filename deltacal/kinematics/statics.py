"""Statics of the closed loop under gravity: gravity torques and the compliant equilibrium.

Conventions ("Gravity and payload"): gravity acts along -z of {O} at :data:`GRAVITY`; the
gravitational energy U is that of the arms (centre of mass half-way from the actuator axis to
the elbow balls' midpoint), the six uniform rods (half-way between their balls), the plate (at
its origin) and a payload (a point mass at the TCP). The gravity torque about actuator i is
``tau_i = -dU/dθ_i`` [N m] of the closed loop (positive when gravity lowers the arm tip). An
actuator of compliance c_i [rad/N m] yields to it: true angle = reading + encoder offset +
c_i tau_i, with tau evaluated where the robot stands.

The rigid robot at the *effective readings* ``e = q + c tau(e)`` is the compliant robot at
readings q (the true angle is ``e + encoder_offset``). Two computations of tau share no code:

* :func:`gravity_torque`, virtual work through the numpy exact kinematics: every body's centre
  of mass moves with the plate's twist ``dX = J dq`` (:func:`~deltacal.kinematics.exact.
  forward_jacobian`, Savoure Eq. 17) or with its arm's rotation; vectorised over poses;
* :func:`multibody_gravity_torque`, the Pinocchio closed-loop model's generalised gravity
  carried to the actuators through the closures' constraint Jacobians
  (:meth:`~deltacal.kinematics.multibody.DeltaMultibody.gravity_torque`): the ground truth.

Units: mm and rad for geometry, kg, N m, rad/N m.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..exceptions import AssemblyError, GeometryError
from ..geometry import DeltaGeometry
from . import exact
from .exact import PlatePose

#: Gravity [m/s²] (conventions), along -z of {O}.
GRAVITY = 9.81
#: Convergence of the equilibrium: largest change of the effective readings [rad].
EQUILIBRIUM_TOLERANCE = 1e-12

#: Gravity torques of a rigid robot: (geometry, readings (N, 3) [rad], payload (N,) [kg]) -> (N, 3) [N m].
TorqueFunction = Callable[[DeltaGeometry, np.ndarray, np.ndarray], np.ndarray]


def payload_per_pose(payload: float | np.ndarray, n: int) -> np.ndarray:
    """The payload of each of n poses [kg], shape (n,): a scalar for all or one per pose.

    Raises:
        ValueError: a negative or non-finite mass, or a length other than n.
    """
    m = np.asarray(payload, dtype=float)
    m = np.full(n, float(m)) if m.ndim == 0 else np.array(m)
    if m.shape != (n,):
        raise ValueError(f"payload must be one mass or one per pose ({n}), got shape {m.shape}")
    bad = ~(np.isfinite(m) & (m >= 0.0))
    if np.any(bad):
        raise ValueError(f"payload must be finite non-negative masses [kg], got {m[bad][0]!r}")
    return m


def _check_revolute(geometry: DeltaGeometry) -> None:
    """Statics serve rotary Deltas (arms on revolute joints); a printer's carriages have none yet."""
    if not geometry.chain.gravity_statics:
        name = geometry.name or "this geometry"
        raise GeometryError(f"gravity statics serve rotary Delta robots; {name!r} is a {geometry.chain.name} "
                            "chain")


def _arm_lever(geometry: DeltaGeometry, q: np.ndarray) -> np.ndarray:
    """``(w_i × (E_i − P_i))_z`` [mm/rad], (N, 3): the elbow midpoint's height rate about each axis."""
    balls = geometry.arm_balls_in_base(q)  # (N, 3, 2, 3)
    elbow = balls.mean(axis=2) - geometry.axis_point[None]
    w = geometry.actuator_rotation()[:, :, 1]
    return np.cross(w[None], elbow)[..., 2]


def _height_rates(pose: PlatePose, J: np.ndarray, lever: np.ndarray) -> np.ndarray:
    """dz/dq [mm/rad], (N, 3), of plate points at levers ``R b`` (N, 3) from the plate's origin.

    A plate point moves by ``dp + dφ × (R b)`` (φ: rotation vector in {O}, as in the FK).
    """
    dp_z, dphi_x, dphi_y = J[:, 2, :], J[:, 3, :], J[:, 4, :]
    return dp_z + dphi_x * lever[:, 1:2] - dphi_y * lever[:, 0:1]


def gravitational_energy(
    geometry: DeltaGeometry, q: np.ndarray, payload: float | np.ndarray = 0.0, pose: PlatePose | None = None
) -> np.ndarray:
    """U of the rigid robot at readings q [J], shape (N,), from the bodies' positions alone.

    Args:
        geometry: The robot (its masses).
        q: Readings [rad], shape (N, 3).
        payload: Mass at the TCP [kg], one or one per pose.
        pose: The plate poses at q (default: the exact forward kinematics).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    m = geometry.masses
    payload = payload_per_pose(payload, q.shape[0])
    pose = exact.forward(geometry, q) if pose is None else pose
    A = geometry.arm_balls_in_base(q)  # (N, 3, 2, 3)
    arm_com = geometry.axis_point[None] + 0.5 * (A.mean(axis=2) - geometry.axis_point[None])
    B = pose.position[:, None, :] + np.einsum("nkl,jl->njk", pose.rotation, geometry.plate_ball.reshape(6, 3))
    rods = 0.5 * (A.reshape(-1, 6, 3) + B)
    height = (m.arm * arm_com[..., 2].sum(axis=1) + m.rod * rods[..., 2].sum(axis=1)
              + m.plate * pose.position[:, 2] + payload * pose.point(geometry.tool)[:, 2])
    return GRAVITY * 1e-3 * height


def gravity_torque(
    geometry: DeltaGeometry, q: np.ndarray, payload: float | np.ndarray = 0.0, pose: PlatePose | None = None
) -> np.ndarray:
    """Gravity torques ``tau_i = -dU/dθ_i`` of the rigid robot at readings q [N m], (N, 3).

    Virtual work through the exact kinematics (module docstring): the arm's centre of mass and
    the arm-side halves of its rods turn with θ_i alone; the plate, the plate-side halves of
    the rods and the payload move with the plate's twist ``J dq``.

    Args:
        geometry: The robot (its masses).
        q: Readings [rad], shape (N, 3) (the rigid robot's: for a compliant one, the
            effective readings, :func:`compliant_readings`).
        payload: Mass at the TCP [kg], one or one per pose.
        pose: The plate poses at q (default: the exact forward kinematics).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    m = geometry.masses
    payload = payload_per_pose(payload, q.shape[0])
    if m.is_zero and not np.any(payload):
        return np.zeros(q.shape)
    _check_revolute(geometry)
    pose = exact.forward(geometry, q) if pose is None else pose
    J = exact.forward_jacobian(geometry, q, pose)  # (N, 6, 3)
    plate_balls = np.einsum("nkl,jl->nk", pose.rotation, geometry.plate_ball.reshape(6, 3))  # Σ_j R B_j
    tool = pose.rotation @ geometry.tool
    rate = ((0.5 * m.arm + m.rod) * _arm_lever(geometry, q)  # arm side: own axis only
            + 0.5 * m.rod * (_height_rates(pose, J, plate_balls) + 5.0 * J[:, 2, :])  # Σ over 6 rods
            + m.plate * J[:, 2, :]
            + payload[:, None] * _height_rates(pose, J, tool))
    return -GRAVITY * 1e-3 * rate


def multibody_gravity_torque(
    geometry: DeltaGeometry, q: np.ndarray, payload: float | np.ndarray = 0.0
) -> np.ndarray:
    """Gravity torques of the rigid robot at readings q by the Pinocchio closed-loop model [N m], (N, 3).

    The ground truth of :func:`gravity_torque` (one closed-loop solve per pose).
    """
    from .multibody import DeltaMultibody

    q = np.atleast_2d(np.asarray(q, dtype=float))
    payload = payload_per_pose(payload, q.shape[0])
    out = np.empty(q.shape)
    for mass in np.unique(payload):
        model = DeltaMultibody(geometry, payload=float(mass))
        for n in np.flatnonzero(payload == mass):
            try:
                assembled = model.solve_forward(q[n])
            except AssemblyError as err:  # name the pose in the batch
                raise AssemblyError(f"{err} (index {int(n)})", [int(n)], q[n][None], err.residual) from None
            out[n] = model.gravity_torque(assembled.configuration)
    return out


def compliant_readings(
    geometry: DeltaGeometry,
    q: np.ndarray,
    payload: float | np.ndarray = 0.0,
    torque: TorqueFunction | None = None,
    tol: float = EQUILIBRIUM_TOLERANCE,
    max_iter: int = 50,
) -> np.ndarray:
    """Effective readings of the compliant robot in static equilibrium at readings q [rad], (N, 3).

    Solves ``e = q + c tau(e)`` (c: ``geometry.compliance``) by fixed-point iteration, all poses
    at once: the map contracts by about ``c |dtau/dθ|`` (1e-4 for reducers of 5e4 N m/rad), so
    a few iterations reach ``tol``. The rigid robot at e is the loaded robot at q: its true arm
    angles are ``e + encoder_offset``.

    Args:
        geometry: The robot (masses and compliances).
        q: Readings [rad], shape (N, 3).
        payload: Mass at the TCP [kg], one or one per pose.
        torque: Gravity torques of the rigid robot (default :func:`gravity_torque`;
            :func:`multibody_gravity_torque` for the ground truth).
        tol: Largest change of e at convergence [rad].
        max_iter: Iterations at most.

    Raises:
        AssemblyError: the robot cannot be assembled on the way, or no convergence.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    payload = payload_per_pose(payload, q.shape[0])
    c = np.asarray(geometry.compliance, dtype=float)
    if not np.any(c) or (geometry.masses.is_zero and not np.any(payload)):
        return q.copy()
    torque = gravity_torque if torque is None else torque
    e = q.copy()
    step = np.full(q.shape[0], np.inf)
    for _ in range(max_iter):
        e_new = q + c * torque(geometry, e, payload)
        step = np.max(np.abs(e_new - e), axis=1)
        e = e_new
        if np.all(step <= tol):
            return e
    bad = np.flatnonzero(step > tol)
    raise AssemblyError(
        f"no static equilibrium within {tol:g} rad after {max_iter} iterations at {bad.size} reading(s), "
        f"first: q = {np.round(np.degrees(q[bad[0]]), 6).tolist()} deg (index {int(bad[0])})",
        bad, q[bad], float(np.max(step)),
    )
