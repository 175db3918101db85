"""Accuracy of a (calibrated) robot over Bai's validation set.

Bai 2015, §5.2: measurements on the circles of radius R/2 and R of the top,
middle and bottom layers of the workspace, 96 poses beside the home pose (the
workspace centre): here 16 evenly spaced poses per circle, home first, 97 targets
(:func:`validation_targets`).

Metrics (:func:`validation_metrics`), for commanded readings q meant to put the
TCP on targets T, with P the actual TCP positions of the true robot (Pinocchio
model, :func:`deltacal.simulation.ground_truth_forward`), pose 0 the home pose:

* TCP position error ``|P_k − T_k|``: max and RMS;
* Bai's distance error ``Δρ_k = |P_k − P_0| − |T_k − T_0|`` (frame-free: what a
  tracker sees without registration);
* Bai's volumetric error ``Δv_k = |(P_k − P_0) − (T_k − T_0)|``.

Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .arguments import geometry_of, points_array
from .geometry import DeltaGeometry, NominalDelta
from .planning import PoseSet, circle, poses_from_reference, require_workspace
from .simulation import ForwardKinematics, compliant_forward

#: Layers and radii (fractions of R) of Bai's validation circles, in order.
LAYERS = ("top", "middle", "bottom")
RADII = (0.5, 1.0)


def validation_reference(nominal: NominalDelta, per_circle: int = 16, phase: float = 0.0) -> np.ndarray:
    """Positions of the file's tool of Bai's validation set [mm], shape (1 + 6 per_circle, 3).

    Home (the workspace centre) first, then per layer (top, middle, bottom) the
    circle of radius R/2 and the circle of radius R, ``per_circle`` poses each.
    """
    ws = require_workspace(nominal)
    parts = [ws.centre[None]]
    for z in (ws.top_z, ws.middle_z, ws.bottom_z):
        for fraction in RADII:
            parts.append(circle(fraction * ws.radius, z, per_circle, phase))
    return np.concatenate(parts)


def validation_poses(
    nominal: NominalDelta, per_circle: int = 16, tool: np.ndarray | None = None, phase: float = 0.0
) -> PoseSet:
    """Bai's validation set: TCP targets and the nominal readings that reach them.

    The targets follow the project convention (cylinder for the file's tool,
    shifted by ``tool − file tool``); the readings are the uncompensated commands.
    """
    return poses_from_reference(nominal, validation_reference(nominal, per_circle, phase), tool)


def validation_targets(
    nominal: NominalDelta, per_circle: int = 16, tool: np.ndarray | None = None, phase: float = 0.0
) -> np.ndarray:
    """TCP targets of Bai's validation set [mm], shape (97, 3) by default, home first."""
    return validation_poses(nominal, per_circle, tool, phase).targets


@dataclass(frozen=True)
class ValidationMetrics:
    """Accuracy over a validation set, home pose first (Bai 2015, §5.2, Table 5).

    Attributes:
        max_mm: Largest TCP position error ``|P_k − T_k|`` [mm].
        rms_mm: RMS TCP position error [mm].
        max_delta_rho_mm: Largest ``|Δρ_k|`` [mm].
        max_delta_v_mm: Largest ``Δv_k`` [mm].
        error_mm: ``|P_k − T_k|`` per pose [mm], shape (N,).
        delta_rho_mm: ``Δρ_k`` per pose [mm] (signed, 0 at home), shape (N,).
        delta_v_mm: ``Δv_k`` per pose [mm] (0 at home), shape (N,).
        actual: Actual TCP positions P [mm], shape (N, 3).
        targets: Targets T [mm], shape (N, 3).
    """

    max_mm: float
    rms_mm: float
    max_delta_rho_mm: float
    max_delta_v_mm: float
    error_mm: np.ndarray
    delta_rho_mm: np.ndarray
    delta_v_mm: np.ndarray
    actual: np.ndarray
    targets: np.ndarray

    def as_dict(self) -> dict[str, float | list[float]]:
        """Scalars and per-pose lists, for reports and TOML/JSON files."""
        return {
            "max_mm": self.max_mm,
            "rms_mm": self.rms_mm,
            "max_delta_rho_mm": self.max_delta_rho_mm,
            "max_delta_v_mm": self.max_delta_v_mm,
            "poses": int(self.error_mm.size),
            "error_mm": self.error_mm.tolist(),
            "delta_rho_mm": self.delta_rho_mm.tolist(),
            "delta_v_mm": self.delta_v_mm.tolist(),
        }

    def summary(self) -> str:
        """One line: max and RMS error, max |Δρ| and max Δv."""
        return (
            f"{self.error_mm.size} poses: max error {self.max_mm:.4f} mm, RMS {self.rms_mm:.4f} mm, "
            f"max |Δρ| {self.max_delta_rho_mm:.4f} mm, max Δv {self.max_delta_v_mm:.4f} mm"
        )


def metrics_from_positions(actual: np.ndarray, targets: np.ndarray, home: int = 0) -> ValidationMetrics:
    """Validation metrics of actual TCP positions against targets (vectorised).

    Args:
        actual: Actual positions P [mm], shape (N, 3).
        targets: Desired positions T [mm], shape (N, 3).
        home: Index of the home pose P_0 (Bai: the workspace centre).
    """
    P = np.atleast_2d(np.asarray(actual, dtype=float))
    T = np.atleast_2d(np.asarray(targets, dtype=float))
    if P.shape != T.shape or P.shape[1:] != (3,) or P.shape[0] < 1:
        raise ValueError(f"actual and targets must both be (N, 3), got {P.shape} and {T.shape}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(T))):
        raise ValueError("actual and targets must be finite")
    error = np.linalg.norm(P - T, axis=1)
    dP = P - P[home]
    dT = T - T[home]
    delta_rho = np.linalg.norm(dP, axis=1) - np.linalg.norm(dT, axis=1)
    delta_v = np.linalg.norm(dP - dT, axis=1)
    return ValidationMetrics(
        max_mm=float(error.max()),
        rms_mm=float(math.sqrt(np.mean(error**2))),
        max_delta_rho_mm=float(np.abs(delta_rho).max()),
        max_delta_v_mm=float(delta_v.max()),
        error_mm=error,
        delta_rho_mm=delta_rho,
        delta_v_mm=delta_v,
        actual=P,
        targets=T,
    )


def validate(
    truth: DeltaGeometry,
    q: np.ndarray,
    targets: np.ndarray,
    forward: ForwardKinematics | None = None,
    home: int = 0,
    payload: float = 0.0,
) -> ValidationMetrics:
    """Accuracy of the true robot commanded with readings q towards targets.

    Args:
        truth: The true robot (its ``tool`` is the TCP; a calibration: its geometry).
        q: Commanded readings [rad], shape (N, 3) (e.g. from compensation).
        targets: Desired TCP positions [mm], shape (N, 3), home pose first.
        forward: Forward kinematics of the true robot (default: the Pinocchio model).
        home: Index of the home pose.
        payload: Mass at the TCP [kg]: a robot with compliant actuators stands where its static
            equilibrium puts it (:func:`~deltacal.simulation.compliant_forward`).

    Raises:
        AssemblyError: readings at which the true robot cannot be assembled.
        ValueError: readings or targets not of shape (N, 3) (or (3,): one), not as many of each, or
            a home index out of them.
        TypeError: a truth that is neither a geometry nor holds one (a calibration's).
    """
    truth = geometry_of(truth, "truth")
    q, targets = points_array(q, "q", "reading"), points_array(targets, "targets")
    if len(q) != len(targets):
        raise ValueError(f"q and targets must have a row per pose each: {len(q)} readings for {len(targets)} "
                         "targets")
    if not 0 <= home < len(targets):
        raise ValueError(f"home must be the index of a target (0 to {len(targets) - 1}), got {home}")
    pose = compliant_forward(truth, q, payload, forward)
    return metrics_from_positions(pose.point(truth.tool), targets, home)
