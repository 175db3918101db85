"""Actuator compliances identified with the geometry (``identify --compliance``).

An actuator of compliance c_i yields to the gravity torque it holds: the true arm angle is
``reading + offset + c_i tau_i`` (:mod:`deltacal.kinematics.statics`). The robot measured at
readings q with a payload stands as the rigid robot at the effective readings
``e = q + c tau(e)``; the rows of a fit are built there. To first order, a change δc_i moves
the plate as a change ``tau_i δc_i`` of θ_i does: the column of c_i is the plate's sensitivity
to θ_i (``forward_jacobian``, Savoure Eq. 17) times tau_i. Where the torques barely vary over
the measurements (one payload, similar poses), those columns are near multiples of the encoder
offsets' and the base-parameter QR leaves the compliances out.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..geometry import DeltaGeometry
from ..kinematics import exact, statics
from ..kinematics.exact import PlatePose
from ..observations import Measurements


def loaded_readings(geometry: DeltaGeometry, measurements: Measurements) -> Measurements:
    """The measurements with their readings replaced by the effective ones of ``geometry``."""
    effective = statics.compliant_readings(geometry, measurements.q, measurements.payload_kg)
    return replace(measurements, q=effective)


def with_compliance(sensitivity, payload: np.ndarray):
    """The model's sensitivity ``(geometry, q, pose) -> S`` (M, 6, n) with the compliances' columns last.

    Args:
        sensitivity: The error model's sensitivity.
        payload: The payload of each measurement [kg], (M,) (q is the effective readings).
    """

    def extended(geometry: DeltaGeometry, q: np.ndarray, pose: PlatePose) -> np.ndarray:
        tau = statics.gravity_torque(geometry, q, payload, pose)  # (M, 3) [N m]
        J = exact.forward_jacobian(geometry, q, pose)  # (M, 6, 3): dX/dθ
        return np.concatenate([sensitivity(geometry, q, pose), J * tau[:, None, :]], axis=2)

    return extended


def with_compliance_moved(geometry: DeltaGeometry, step: np.ndarray) -> DeltaGeometry:
    """The geometry with its compliances moved by ``step`` [rad/N m], (3,)."""
    return replace(geometry, compliance=geometry.compliance + np.asarray(step, dtype=float))


def payload_span(measurements: Measurements) -> tuple[float, float] | None:
    """The least and greatest payload of the measurements [kg], or None when every row carries the same.

    Measurements at payloads that differ see the actuators deflect by different amounts at one
    reading: a rigid fit spreads those deflections over the geometry (conventions, "Gravity and
    payload"), so a command identifies the compliances by default there.
    """
    payload = measurements.payload_kg
    low, high = float(payload.min()), float(payload.max())
    return None if low == high else (low, high)
