"""The identification matrix H of measurements at planned readings (pose, position, distance)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errormodels import MODEL_NAMES, ErrorModel, get_model
from ..geometry import DeltaGeometry, skew
from ..kinematics import exact, statics
from ..observations import SIGMA_ANGLE, SIGMA_POSITION, Measurements, build_rows, pair_rows

#: Measurement kinds a regressor can be built for.
MEASUREMENTS = ("pose", "position", "distance")


#: Name of the 3-parameter encoder-offset model of the rough step (Bai §5.1).
ROUGH = "rough"


#: Model names :func:`planning_model` accepts.
PLAN_MODELS = (*MODEL_NAMES, ROUGH)


#: Relative rank tolerance of the scaled regressors (as :func:`base_parameters`).
RANK_RTOL = 1e-8


# --------------------------------------------------------------------------- regressors
def planning_model(name: str) -> ErrorModel:
    """An error model by name; ``rough`` is the classical model's three encoder offsets."""
    if name == ROUGH:
        classical = get_model("classical")
        keep = {"offset1", "offset2", "offset3"}
        return classical.without([k for k in classical.names if k not in keep], ROUGH)
    return get_model(name)


def default_points(geometry: DeltaGeometry, model: ErrorModel, measurement: str) -> list[str]:
    """Reference points measured by default.

    Pose measurements see the plate's orientation: the TCP suffices. Positions and
    distances of a model that tilts the plate need several points (Bai §3.2: two
    reflectors for model 32): every named point of the robot, or the TCP if none.
    """
    if measurement == "pose" or not model.tilts_plate or not geometry.points:
        return ["tcp"]
    return list(geometry.points)


def check_measurement(measurement: str) -> None:
    """Refuse a measurement kind not in :data:`MEASUREMENTS` (ValueError naming the choices)."""
    if measurement not in MEASUREMENTS:
        raise ValueError(f"measurement must be one of {', '.join(MEASUREMENTS)}, got {measurement!r}")


def identification_matrix(
    geometry: DeltaGeometry,
    model: ErrorModel,
    q: np.ndarray,
    measurement: str = "pose",
    points: Sequence[str] = ("tcp",),
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
) -> np.ndarray:
    """The identification matrix H (weighted regressor) of measurements at readings q.

    Rows as in :func:`deltacal.observations.build_rows` (distances: :func:`~deltacal.observations.pair_rows`),
    divided by their σ:
    ``pose``: TCP position and plate orientation of each pose (6 rows), only the
    first point's position if several are named; ``position``: 3 rows per point and
    pose; ``distance``: one row per pair of positions of a same point, all pairs
    (Bai Eq. 12-16, K = C(N, 2) per point).

    Args:
        geometry: Geometry to linearise around (the nominal one).
        model: Error model.
        q: Readings [rad], shape (N, 3).
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured.
        sigma_position: σ of a position coordinate [mm].
        sigma_angle: σ of an orientation component [rad].

    Returns:
        H, shape (rows, model.size).
    """
    check_measurement(measurement)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    names = list(points)[:1] if measurement == "pose" else list(points)
    Q = np.concatenate([q] * len(names))
    pose = exact.forward(geometry, Q)
    rotvec = np.full(Q.shape, np.nan)
    if measurement == "pose":
        rotvec = pose.rotation_vector()
    meas = Measurements(
        q=Q,
        position=np.zeros_like(Q),
        point=[p for p in names for _ in range(q.shape[0])],
        rotation_vector=rotvec,
    )
    if measurement == "distance":
        rows = pair_rows(geometry, meas, model.sensitivity, sigma_position, "all", pose)
    else:
        rows = build_rows(geometry, meas, model.sensitivity, sigma_position, sigma_angle, pose=pose)
    return rows.scaled[1]  # Bai's H: rows divided by σ, not whitened


# --------------------------------------------------------------------------- D-optimal
def pose_blocks(
    geometry: DeltaGeometry,
    model: ErrorModel,
    q: np.ndarray,
    measurement: str = "pose",
    points: Sequence[str] = ("tcp",),
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
    payloads: Sequence[float] = (),
) -> np.ndarray:
    """Weighted regressor rows of each pose, stacked per pose, shape (N, b, n).

    ``pose``: 3 position rows of the first point and 3 orientation rows (b = 6);
    ``position``: 3 rows per point (b = 3 × points). Rows divided by σ as in
    :func:`deltacal.observations.build_rows`. With ``payloads`` [kg], each pose is measured at
    each payload and the actuators' compliances are fitted too: the rows of every payload, one
    after the other (b times the payloads), with three more columns ``c1..c3`` (the plate's
    sensitivity to θ_i times the gravity torque tau_i at that payload,
    :mod:`deltacal.identification.compliance`), shape (N, b P, n + 3).
    """
    if measurement not in ("pose", "position"):
        raise ValueError(f"per-pose blocks exist for pose or position measurements, not {measurement!r}")
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)  # (N, 6, n)
    loads = [S]
    if payloads:
        J = exact.forward_jacobian(geometry, q, pose)  # (N, 6, 3): the plate per θ_i
        loads = [np.concatenate([S, J * statics.gravity_torque(geometry, q, p, pose)[:, None]], axis=2)
                 for p in payloads]
    names = list(points)[:1] if measurement == "pose" else list(points)
    blocks = []
    for S in loads:
        for name in names:
            lever = pose.rotation @ geometry.point(name)  # (N, 3)
            blocks.append((S[:, :3] - skew(lever) @ S[:, 3:]) / sigma_position)  # dP = dx + dα × (R p)
        if measurement == "pose":
            blocks.append(S[:, 3:] / sigma_angle)
    return np.concatenate(blocks, axis=1)
