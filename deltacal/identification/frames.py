"""The instrument frame {T}: where a laser tracker measures, identified with the geometry.

A tracker measures in its own frame {T}, metres from the robot, yawed, not levelled.
Its pose is ``y_T = R y_O + t`` (``R``: rotation of {O} in {T}; ``t``: origin of {O} in
{T}), one per station. Identification with a free frame:

1. a closed-form first estimate per station (Horn/Kabsch: the rotation and translation
   that best map the nominal robot's predicted points onto the measured ones; from the
   orientations when the positions lie on a line), so any distance and yaw work;
2. 6 parameters per station in the iterated least squares: a small rotation ``δθ`` and a
   shift ``δu``, both about/along the axes of {O} (``R <- R exp(δθ)``, ``t <- t + R δu``);
   the measurements are carried into {O} by the current estimate and the frame's columns
   appended to the geometry's;
3. the base-parameter QR keeps the frame's parameters first: the combinations of the
   geometry that a rigid motion of the whole robot would absorb are dropped and named;
4. the gauge: the rigid motion that {T} and the robot's base share is fixed afterwards by
   moving the identified robot (and the frames with it, so that nothing measured changes)
   until its actuator axes have no net rigid motion from the nominal ones (the least-squares
   rigid motion between the segments ``[P_i, P_i + L w_i]`` of the nominal and identified
   axes is the identity). {O} is that frame: centred on the actuator axes, z along their
   mean normal, as the conventions define it for a real robot.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from ..exceptions import IdentificationError
from ..geometry import DeltaGeometry
from ..identifiability import pivoted_qr
from ..kinematics.exact import PlatePose
from ..observations import ORIENTATION, POSITION, Measurements, Rows, predicted_points
from ..rotations import rotation_from_vector, skew, vector_from_rotation

#: The six parameters of a frame, in the order of its columns.
FRAME_PARAMETERS = ("rx", "ry", "rz", "tx", "ty", "tz")
#: Their units.
FRAME_UNITS = ("rad", "rad", "rad", "mm", "mm", "mm")
#: A combination of the geometry's parameters whose effect on the measurements is within this
#: fraction of what the frames do (the sine of its principal angle with their span) is absorbed
#: by the frame (one parameter held at its start value per combination): told apart from the
#: frame only through that 1 %, it would be estimated with 100 times the noise, and the fit
#: would wander along it. Measured: the complete model's rigid motions of the robot come out at
#: sines 0 (translations) and 3e-4 to 2.3e-3 (rotations, mimicked by the ball centres except for
#: the lever of the measured points); every other combination at 1.
FRAME_RTOL = 1e-2


@dataclass(frozen=True)
class InstrumentFrame:
    """Pose of the robot base {O} in an instrument frame {T}: ``y_T = rotation @ y_O + translation``.

    Attributes:
        rotation: Rotation of {O} in {T}, (3, 3).
        translation: Origin of {O} in {T} [mm], (3,).
        covariance: Covariance of the 6 small corrections (δθ [rad], δu [mm]) about and along
            the axes of {O}, (6, 6); zeros when not identified.
        centre: Pivot of the rotation corrections, in {O} [mm]: the centroid of the measured
            points, so that a correction's rotation and shift are nearly independent (about
            {O}'s origin, a metre above the points, each would need the other).
    """

    rotation: np.ndarray
    translation: np.ndarray
    covariance: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def identity(cls) -> InstrumentFrame:
        """{T} = {O}."""
        return cls(np.eye(3), np.zeros(3))

    @classmethod
    def from_vectors(cls, rotation_vector: ArrayLike, translation: ArrayLike) -> InstrumentFrame:
        """From a rotation vector [rad] and a translation [mm]."""
        rotation = rotation_from_vector(np.asarray(rotation_vector, dtype=float))
        return cls(rotation, np.asarray(translation, dtype=float))

    @property
    def rotation_vector(self) -> np.ndarray:
        """Rotation vector of {O} in {T} [rad], (3,)."""
        return vector_from_rotation(self.rotation)

    @property
    def rotation_sigma(self) -> np.ndarray:
        """σ of a small rotation of {O} about the axes of {T} [rad], (3,)."""
        C = self.rotation @ self.covariance[:3, :3] @ self.rotation.T
        return np.sqrt(np.clip(np.diag(C), 0.0, None))

    @property
    def translation_sigma(self) -> np.ndarray:
        """σ of the origin of {O} along the axes of {T} [mm], (3,)."""
        A = self.rotation @ np.hstack([skew(self.centre), np.eye(3)])  # dt = R ([c]x dθ + du)
        C = A @ self.covariance @ A.T
        return np.sqrt(np.clip(np.diag(C), 0.0, None))

    def to_base(self, y: np.ndarray) -> np.ndarray:
        """Points given in {T} expressed in {O}, (..., 3)."""
        return (np.asarray(y, dtype=float) - self.translation) @ self.rotation

    def from_base(self, p: np.ndarray) -> np.ndarray:
        """Points given in {O} expressed in {T}, (..., 3)."""
        return np.asarray(p, dtype=float) @ self.rotation.T + self.translation

    def corrected(self, step: np.ndarray) -> InstrumentFrame:
        """The frame after a correction (δθ, δu) about and along the axes of {O}.

        Points seen in {O} move by ``y -> c + exp(-δθ) (y - c) - δu`` (c: :attr:`centre`).
        """
        step = np.asarray(step, dtype=float)
        R = self.rotation @ rotation_from_vector(step[:3])
        c = self.centre
        t = self.translation + self.rotation @ c - R @ (c - step[3:])
        return InstrumentFrame(R, t, self.covariance, c)

    def after_moving_base(self, rotation: np.ndarray, translation: np.ndarray) -> InstrumentFrame:
        """The frame seen from {O'} when the robot is moved rigidly by ``p' = rotation p + translation``.

        Nothing measured changes: ``y_T = R p + t = (R Gᵀ) p' + (t - R Gᵀ g)``.
        """
        G, g = np.asarray(rotation, float), np.asarray(translation, float)
        R = self.rotation @ G.T
        # the corrections are about the axes of {O}: turned with it
        J = np.zeros((6, 6))
        J[:3, :3] = G
        J[3:, 3:] = G
        return InstrumentFrame(R, self.translation - R @ g, J @ self.covariance @ J.T, G @ self.centre + g)


def frame_parameter_names(stations: list[str]) -> list[str]:
    """Names of the frame parameters of each station: ``T[station].rx`` ... ``T[station].tz``."""
    return [f"T[{s}].{p}" for s in stations for p in FRAME_PARAMETERS]


def absorbed_by_frames(
    W: np.ndarray, names: list[str], n_model: int, kept: list[int], frame_rtol: float = FRAME_RTOL,
    held_first: Collection[str] = (),
) -> list[str]:
    """Parameters of the geometry that the frames (nearly) absorb.

    The columns are scaled to unit norm. The principal angles between the span of the
    geometry's base columns ``kept`` and the span of the frames' columns say which
    combinations of the geometry move the measurements as the frames do: those whose angle
    has a sine below ``frame_rtol`` (a rigid motion of the whole robot: its translations
    exactly, its rotations to a few 0.1 % with the complete model). One parameter per such
    combination is held: a column-pivoted QR of the combinations picks the parameters that
    take the largest part in them (so what is left is well conditioned), those of
    ``held_first`` first (the model's :attr:`~deltacal.errormodels.ErrorModel.frame_held_first`:
    the complete model's plate balls), ties to the later parameter in the order ``kept``.
    Holding an axis tilt instead fixes the tilt at its nominal value and costs accuracy
    (14-17 % more TCP error in two of the six cases of the far-tracker test).

    A test column by column would miss a combination spread over many parameters (the
    complete model turns the robot about z with every ball centre and axis a little), whose
    near-null direction Gauss-Newton then overshoots along a curved valley.

    Args:
        W: Weighted regressor, geometry columns then frame columns, (m, n_model + 6 S).
        names: Parameter names of the columns.
        n_model: Number of geometry columns.
        kept: Indices of the geometry's base parameters (without the frames), in order.
        frame_rtol: See :data:`FRAME_RTOL`.
        held_first: Parameters held in preference.

    Returns:
        Names of the absorbed parameters, in the order ``kept``.
    """
    norms = np.linalg.norm(W, axis=0)
    Ws = W / np.where(norms > 0, norms, 1.0)
    G, F = Ws[:, kept], Ws[:, n_model:]
    if not kept or F.shape[1] == 0:
        return []
    Qg, Rg = np.linalg.qr(G)
    Uf, sf, _ = np.linalg.svd(F, full_matrices=False)
    Qf = Uf[:, sf > 1e-8 * max(float(sf[0]), 1e-300)]
    # sines of the principal angles: singular values of the part of span(G) outside span(F)
    _, sines, Vt = np.linalg.svd(Qg - Qf @ (Qf.T @ Qg), full_matrices=False)
    shared = Vt[sines < frame_rtol]
    if not shared.size:
        return []
    # the combinations in parameter space (scaled columns), one row each
    combinations = scipy.linalg.solve_triangular(Rg, shared.T, check_finite=False).T
    order = np.arange(len(kept))[::-1]  # ties to the later parameter
    # the preferred ones win unless the others take a thousand times their part
    weight = np.array([1.0 if names[kept[j]] in held_first else 1e-3 for j in order])
    _, perm = pivoted_qr(combinations[:, order] * weight)
    held = {kept[int(order[j])] for j in perm[: len(shared)]}
    return [names[k] for k in kept if k in held]


def rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation that best map points ``source`` onto ``target`` (Horn/Kabsch).

    Least squares over the points, proper rotation (determinant +1).

    Args:
        source: Points, (n, 3).
        target: Points, (n, 3).

    Returns:
        ``(R, t)`` with ``target ≈ source @ R.T + t``.
    """
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    R = _rotation_fit(source - cs, target - ct)
    return R, ct - R @ cs


def _rotation_fit(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The proper rotation that best turns vectors ``source`` onto ``target`` (n, 3), no centring."""
    U, _, Vt = np.linalg.svd(source.T @ target)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(Vt.T @ U.T))) or 1.0])
    return Vt.T @ D @ U.T


def _mean_rotation(rotations: np.ndarray) -> np.ndarray:
    """The rotation nearest (Frobenius) to the mean of rotations, (3, 3)."""
    U, _, Vt = np.linalg.svd(np.mean(rotations, axis=0))
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt))) or 1.0])
    return U @ D @ Vt


def initial_frames(
    geometry: DeltaGeometry, measurements: Measurements, pose: PlatePose
) -> dict[str, InstrumentFrame]:
    """Closed-form first estimate of each station's frame from the geometry's predictions.

    Positions: Horn/Kabsch on the predicted and measured points (at least three not on
    one line). Otherwise, orientations: the mean of ``R_measured R_predictedᵀ``, then the
    translation from the positions' centroids.

    Raises:
        IdentificationError: a station has neither three positions off a line nor an orientation.
    """
    predicted = predicted_points(geometry, measurements, pose)
    station = np.array(measurements.station)
    has = measurements.has_orientation
    frames = {}
    for name in measurements.stations:
        rows = station == name
        P, Y = predicted[rows], measurements.position[rows]
        spread = np.linalg.svd(P - P.mean(axis=0), compute_uv=False) if len(P) > 1 else np.zeros(3)
        line_like = len(P) < 3 or spread[1] < 1e-3 * max(spread[0], 1e-300)
        if not line_like:
            R, t = rigid_fit(P, Y)
        elif np.any(has[rows]):
            assert measurements.rotation_vector is not None
            sel = rows & has
            measured = rotation_from_vector(measurements.rotation_vector[sel])
            R = _mean_rotation(measured @ np.swapaxes(pose.rotation[sel], 1, 2))
            t = Y.mean(axis=0) - R @ P.mean(axis=0)
        else:
            raise IdentificationError(
                f"station {name!r}: {len(P)} position(s) on a line and no orientation: a free instrument "
                "frame needs at least three positions not on one line, or an orientation"
            )
        frames[name] = InstrumentFrame(R, t, centre=P.mean(axis=0))
    return frames


def in_base_frame(measurements: Measurements, frames: dict[str, InstrumentFrame]) -> Measurements:
    """The measurements carried from their stations' frames into {O}."""
    position = np.array(measurements.position)
    assert measurements.rotation_vector is not None
    rotation_vector = np.array(measurements.rotation_vector)
    station = np.array(measurements.station)
    has = measurements.has_orientation
    for name, frame in frames.items():
        rows = station == name
        position[rows] = frame.to_base(position[rows])
        sel = rows & has
        if np.any(sel):
            R = frame.rotation.T @ rotation_from_vector(rotation_vector[sel])
            rotation_vector[sel] = vector_from_rotation(R)
    return replace(measurements, position=position, rotation_vector=rotation_vector)


def in_instrument_frames(measurements: Measurements, frames: dict[str, InstrumentFrame]) -> Measurements:
    """Measurements given in {O} expressed in their stations' frames (what a tracker reads)."""
    position = np.array(measurements.position)
    assert measurements.rotation_vector is not None
    rotation_vector = np.array(measurements.rotation_vector)
    station = np.array(measurements.station)
    has = measurements.has_orientation
    for name, frame in frames.items():
        rows = station == name
        position[rows] = frame.from_base(position[rows])
        sel = rows & has
        if np.any(sel):
            turned = frame.rotation @ rotation_from_vector(rotation_vector[sel])
            rotation_vector[sel] = vector_from_rotation(turned)
    return replace(measurements, position=position, rotation_vector=rotation_vector)


def frame_columns(
    rows: Rows, in_base: Measurements, stations: list[str], centres: np.ndarray | None = None
) -> np.ndarray:
    """Regressor columns of the frames' corrections for rows built in {O}, (m, 6 S).

    With the measurements carried into {O} by the frame, a correction (δθ, δu) moves a
    measured position by ``-δθ × y - δu`` and a measured orientation by ``-δθ``; the
    regressor holds d(predicted)/d(parameter), so the columns are ``[-[y]×, I]`` for a
    position (``y`` taken from the frame's :attr:`~InstrumentFrame.centre`) and ``[I, 0]``
    for an orientation.
    """
    index = {name: k for k, name in enumerate(stations)}
    st = np.array([index[s] for s in in_base.station])
    F = np.zeros((rows.residual.size, 6 * len(stations)))
    which = rows.measurement
    pos = np.flatnonzero(rows.kind == POSITION)
    if pos.size:
        m = which[pos]
        k = pos % 3  # positions come first, three rows each
        y = in_base.position[m] - (0.0 if centres is None else np.asarray(centres)[st[m]])
        S = skew(y)  # (r, 3, 3)
        base = 6 * st[m]
        F[pos[:, None], base[:, None] + np.arange(3)] = -S[np.arange(pos.size), k]
        F[pos, base + 3 + k] = 1.0
    ori = np.flatnonzero(rows.kind == ORIENTATION)
    if ori.size:
        m = which[ori]
        k = (ori - 3 * len(in_base)) % 3
        F[ori, 6 * st[m] + k] = 1.0
    return F


def axes_motion(nominal: DeltaGeometry, geometry: DeltaGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Net rigid motion of the actuator axes from the nominal ones: ``(G, g)``, identified ≈ G nominal + g.

    Measured on what identification can see of the axes, their lines: ``G`` is the rotation that
    best turns the nominal directions ``w_i`` onto the identified ones (Horn, no centring); ``g``
    the shift that then best puts each turned nominal axis point on the identified axis line
    (least squares of the distances to the lines, closed form). Where a point sits along its
    axis is not seen by any measurement (the arm's balls take it up), so it must not move the
    gauge: with the segments ``[P_i, P_i + L w_i]`` it did, turning {O} about z by up to 0.08°
    (0.7 mm at the TCP of Bai's robot).
    """
    w0 = nominal.axis_direction / np.linalg.norm(nominal.axis_direction, axis=1, keepdims=True)
    w1 = geometry.axis_direction / np.linalg.norm(geometry.axis_direction, axis=1, keepdims=True)
    G = _rotation_fit(w0, w1)
    across = np.eye(3)[None] - w1[:, :, None] * w1[:, None, :]  # (3, 3, 3): projectors across the lines
    gap = geometry.axis_point - nominal.axis_point @ G.T
    g = np.linalg.solve(across.sum(axis=0), np.einsum("ikl,il->k", across, gap))
    return G, g


def to_axes_gauge(
    nominal: DeltaGeometry, geometry: DeltaGeometry, frames: dict[str, InstrumentFrame]
) -> tuple[DeltaGeometry, dict[str, InstrumentFrame], float, float]:
    """Move the identified robot and its frames so that its actuator axes have no net rigid motion.

    Returns:
        The moved geometry, the frames seen from the new {O} (nothing measured changes), and
        the size of the motion removed: translation [mm] and rotation [rad].
    """
    G, g = axes_motion(nominal, geometry)
    back, shift = G.T, -G.T @ g
    moved = geometry.moved_rigidly(back, shift)
    new_frames = {name: f.after_moving_base(back, shift) for name, f in frames.items()}
    return moved, new_frames, float(np.linalg.norm(g)), float(np.linalg.norm(vector_from_rotation(G)))


def gauge_sensitivity(model, geometry: DeltaGeometry, columns: list[int], step: float = 1e-6) -> np.ndarray:
    """How the gauge's rigid motion follows each parameter: ``(δθ, δg)`` per unit parameter, (6, r).

    The gauge moves the identified robot by the inverse of :func:`axes_motion`, so a change of a
    parameter that turns or shifts the actuator axes is undone at every TCP position p by
    ``-(δθ × p + δg)``: a covariance of the TCP in {O} must subtract it (the marginal covariance of
    the robot's parameters alone holds the frame's uncertainty, which the gauge does not pass to
    {O}). Central differences of :func:`axes_motion` through the model's exact ``apply``: the
    motion is a smooth function of the parameters, and a step of 1e-6 (mm or rad) leaves errors
    of order 1e-12 relative.

    Args:
        model: The error model (``apply`` and ``size``).
        geometry: Where to linearise (the identified geometry, in its gauge).
        columns: The model's columns of the parameters, (r,).
        step: Central-difference step [mm or rad].
    """
    out = np.zeros((6, len(columns)))
    for j, column in enumerate(columns):  # a few dozen parameters, each one geometry
        motion = []
        for sign in (1.0, -1.0):
            dk = np.zeros(model.size)
            dk[column] = sign * step
            G, g = axes_motion(geometry, model.apply(geometry, dk))
            motion.append(np.concatenate([vector_from_rotation(G), g]))
        out[:, j] = (motion[0] - motion[1]) / (2 * step)
    return out
