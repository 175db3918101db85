"""Predicted accuracy of a calibrated robot: the σ of its TCP position over the workspace.

The identified base parameters β have the covariance ``Σ_β = diag(σ) C diag(σ)``
(σ and the correlation C from the calibration file). At readings q, the TCP moves by
``δp = J(q) δβ`` for a change δβ of the base parameters, with

    J = S_x − [R t]_× S_α

the error model's sensitivity ``S = (S_x, S_α)`` (plate position and rotation per
parameter, :meth:`deltacal.errormodels.ErrorModel.sensitivity`, built on
:func:`~deltacal.errormodels.base.elementary_jacobian`) restricted to the kept
parameters' columns (a base parameter acts as its kept parameter: every regrouped one
has the same effect on the plate as the combination it is folded into), at the
identified geometry and the plate pose R of the readings that put the TCP ``t`` at the
point. Compensation commands the readings that put the *identified* robot's TCP at
the target; the real robot differs by the estimation error of β, so the TCP lands at

    p = target + J δβ,   Cov(p) = J Σ_β Jᵀ,

first order in δβ. :func:`predicted_tcp_sigma` returns the square roots of its diagonal.
Instrument frames' parameters are nuisance parameters: the marginal covariance of the
robot's parameters is used (their rows and columns of Σ dropped).

All vectorised over points (no Python loop over points). Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..exceptions import AssemblyError, UnreachableError
from ..geometry import DeltaGeometry, Workspace
from ..identification.columns import COMPLIANCE_NAMES
from ..identification.frames import gauge_sensitivity, to_axes_gauge
from ..kinematics import exact, statics
from ..printer.robot import in_plane_motion, less_bed_motion
from ..rotations import skew

#: Grid points along a side of a horizontal slice (and along x and z of the vertical one).
GRID = 41


def reachable_readings(geometry: DeltaGeometry, points: np.ndarray) -> np.ndarray:
    """Readings that put the geometry's TCP at each point, NaN rows for points out of reach, (N, 3)."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    q = np.full(points.shape, np.nan)
    todo = np.flatnonzero(np.all(np.isfinite(points), axis=1))
    while todo.size:
        try:
            q[todo] = exact.inverse(geometry, points[todo])
            break
        except UnreachableError as exc:
            if not exc.indices:
                raise
            todo = np.delete(todo, exc.indices)
    return q


def tcp_jacobian(
    geometry: DeltaGeometry, calibration: Calibration, q: np.ndarray, tool: np.ndarray | None = None
) -> np.ndarray:
    """J: TCP displacement per unit base parameter (robot's, in the file's order), (N, 3, r).

    Args:
        geometry: Geometry at which to linearise (the identified one).
        calibration: The calibration (model and base parameters).
        q: Readings [rad], (N, 3), all assembled.
        tool: TCP in the plate frame [mm] (default: the geometry's tool).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    tool = geometry.tool if tool is None else np.asarray(tool, dtype=float)
    pose = exact.forward(geometry, q)
    model = calibration.model
    names = calibration.robot_names
    compliance = [COMPLIANCE_NAMES.index(n) for n in names if n in COMPLIANCE_NAMES]  # last in the fit
    columns = [model.names.index(name) for name in names if name not in COMPLIANCE_NAMES]
    S = model.sensitivity(geometry, q, pose)[:, :, columns]  # (N, 6, r)
    if compliance:  # unloaded: c_i moves the plate as θ_i by tau_i (the robot's own weight)
        tau = statics.gravity_torque(geometry, q, 0.0, pose)
        own = exact.forward_jacobian(geometry, q, pose) * tau[:, None]
        S = np.concatenate([S, own[:, :, compliance]], axis=2)
    lever = pose.rotation @ tool  # R t, (N, 3)
    J = S[:, :3] - skew(lever) @ S[:, 3:]
    if calibration.frames:  # {O} is the axes gauge: the rigid motion it undoes is no error in {O}
        A = gauge_sensitivity(model, geometry, columns)
        A = np.concatenate([A, np.zeros((6, len(compliance)))], axis=1)
        J = J + skew(pose.point(tool)) @ A[:3] - A[3:]
    if geometry.chain.on_bed and not compliance:
        J = J - in_plane_motion(pose.point(tool)) @ _bed_gauge(geometry, calibration, tool)
    return J


def _bed_gauge(geometry: DeltaGeometry, calibration: Calibration, tool: np.ndarray) -> np.ndarray:
    """A printer's gauge along its bed: the bed motion each parameter moves the printed volume by, (3, r).

    No probe height and no distance sees the printer shifted along its bed or turned about its
    normal: such a change of the parameters moves every printed point rigidly and is no error of
    a part. It is the least-squares bed motion of the TCP displacements over reference points of
    the volume (two rings, on the bed and a tower's reach above it).
    """
    reach = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
    angle = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    ring = 0.4 * reach * np.column_stack([np.cos(angle), np.sin(angle), np.zeros(12)])
    reference = np.concatenate([ring, ring + [0.0, 0.0, 0.5 * reach]])
    q = reachable_readings(geometry.with_tool(tool), reference)
    ok = np.all(np.isfinite(q), axis=1)
    columns = [calibration.model.names.index(name) for name in calibration.robot_names]
    pose = exact.forward(geometry, q[ok])
    S = calibration.model.sensitivity(geometry, q[ok], pose)[:, :, columns]
    J = S[:, :3] - skew(pose.rotation @ tool) @ S[:, 3:]
    A = in_plane_motion(pose.point(tool))
    return np.linalg.lstsq(A.reshape(-1, 3), J.reshape(-1, J.shape[-1]), rcond=None)[0]


def predicted_tcp_covariance(
    calibration: Calibration, points: np.ndarray, tool: np.ndarray | None = None
) -> np.ndarray:
    """Covariance of the compensated TCP position at each point [mm²], (N, 3, 3); NaN out of reach."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    geometry = calibration.geometry if tool is None else calibration.geometry.with_tool(tool)
    q = reachable_readings(geometry, points)
    ok = np.flatnonzero(np.all(np.isfinite(q), axis=1))
    out = np.full((points.shape[0], 3, 3), np.nan)
    if ok.size:
        J = tcp_jacobian(geometry, calibration, q[ok])
        out[ok] = np.einsum("nir,rs,njs->nij", J, calibration.covariance(), J)
    return out


def predicted_tcp_sigma(
    calibration: Calibration, points: np.ndarray, tool: np.ndarray | None = None
) -> np.ndarray:
    """σ of each coordinate of the compensated TCP position at each point [mm], (N, 3).

    Args:
        calibration: The calibration (identified geometry, base parameters, σ, correlation).
        points: TCP targets in the base frame [mm], (N, 3).
        tool: TCP in the plate frame [mm] (default: the calibration's tool).

    Returns:
        σ_x, σ_y, σ_z per point; NaN rows for points out of reach.
    """
    cov = predicted_tcp_covariance(calibration, points, tool)
    return np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))


def sigma_3d(sigma: np.ndarray) -> np.ndarray:
    """RMS length of the 3-D TCP error from per-axis σ: ``√(σx² + σy² + σz²)``, (N,)."""
    return np.sqrt(np.sum(np.asarray(sigma) ** 2, axis=-1))


@dataclass(frozen=True)
class Slice:
    """A plane of points through the workspace and a value at each.

    Attributes:
        label: e.g. ``"z = -790 mm"`` or ``"y = 0 mm"``.
        horizontal: True for a plane z = const (axes x, y), False for y = 0 (axes x, z).
        u: First axis coordinates of the grid [mm], (nu,).
        v: Second axis coordinates [mm], (nv,).
        points: The points [mm], (nv, nu, 3); NaN outside the workspace.
    """

    label: str
    horizontal: bool
    u: np.ndarray
    v: np.ndarray
    points: np.ndarray


def workspace_slices(workspace: Workspace, n: int = GRID) -> list[Slice]:
    """Three horizontal slices (top, middle, bottom of the cylinder) and the vertical one at y = 0."""
    R = workspace.radius
    u = np.linspace(-R, R, n)
    X, Y = np.meshgrid(u, u)
    outside = X**2 + Y**2 > R**2 * (1.0 + 1e-9)
    out = []
    for z in (workspace.top_z, workspace.middle_z, workspace.bottom_z):
        pts = np.stack([X, Y, np.full_like(X, z)], axis=-1)
        pts[outside] = np.nan
        out.append(Slice(f"z = {z:.0f} mm", True, u, u, pts))
    zs = np.linspace(workspace.bottom_z, workspace.top_z, max(n // 2, 5))
    XZ, ZZ = np.meshgrid(u, zs)
    pts = np.stack([XZ, np.zeros_like(XZ), ZZ], axis=-1)
    out.append(Slice("y = 0 mm (vertical)", False, u, zs, pts))
    return out


@dataclass(frozen=True)
class AccuracyMap:
    """The predicted σ of the TCP (and, for simulations, the actual error) over workspace slices.

    Attributes:
        slices: The slices.
        sigma: 3-D σ on each slice [mm], each (nv, nu); NaN out of reach.
        error: Actual TCP error norm on each slice [mm] (with a true geometry), or None.
        tool: The tool used [mm].
        worst: Largest 3-D σ [mm].
        worst_point: Where it is [mm], (3,).
        worst_axes: σ_x, σ_y, σ_z there [mm].
        shift: With a true geometry and free instrument frames, the common shift removed from the
            actual errors [mm], (3,); else None (see :func:`accuracy_map`).
        bed_motion: With a true printer, the shift along the bed [mm] and turn about its normal
            [rad] removed from the actual errors, ``(x, y, angle)``; else None.
    """

    slices: list[Slice]
    sigma: list[np.ndarray]
    error: list[np.ndarray] | None
    tool: np.ndarray
    worst: float
    worst_point: np.ndarray
    worst_axes: np.ndarray
    shift: np.ndarray | None = None
    bed_motion: np.ndarray | None = None


def actual_tcp_error(
    geometry: DeltaGeometry, truth: DeltaGeometry, points: np.ndarray, tool: np.ndarray | None = None
) -> np.ndarray:
    """Where the true robot's TCP lands minus the target, commanding the identified robot's readings.

    Both through the exact forward/inverse kinematics, unloaded: with compliant actuators the
    readings compensate the identified robot's own weight (as ``compensate``) and the true robot
    stands at its equilibrium. NaN rows where either cannot reach, (N, 3).
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if tool is not None:
        geometry, truth = geometry.with_tool(tool), truth.with_tool(tool)
    q = reachable_readings(geometry, points)
    if np.any(geometry.compliance):
        ok = np.all(np.isfinite(q), axis=1)
        q[ok] -= geometry.compliance * statics.gravity_torque(geometry, q[ok])
    out = np.full(points.shape, np.nan)
    todo = np.flatnonzero(np.all(np.isfinite(q), axis=1))
    while todo.size:
        try:
            effective = statics.compliant_readings(truth, q[todo])
            out[todo] = exact.forward(truth, effective).point(truth.tool) - points[todo]
            break
        except AssemblyError as exc:
            if not exc.indices:
                raise
            todo = np.delete(todo, exc.indices)
    return out


def accuracy_map(
    calibration: Calibration,
    workspace: Workspace,
    tool: np.ndarray | None = None,
    truth: DeltaGeometry | None = None,
    n: int = GRID,
) -> AccuracyMap:
    """Predicted σ (and actual errors with ``truth``) on :func:`workspace_slices`, in one batch.

    With free instrument frames the calibration's {O} is its axes gauge, not the simulator's: the
    truth is moved to its own axes gauge first, and the errors' mean (the translation no
    measurement in a station's frame sees) is removed and returned as ``shift``.
    """
    tool = calibration.geometry.tool if tool is None else np.asarray(tool, dtype=float)
    slices = workspace_slices(workspace, n)
    flat = np.concatenate([s.points.reshape(-1, 3) for s in slices])
    axes = predicted_tcp_sigma(calibration, flat, tool)
    total = sigma_3d(axes)
    sizes = np.cumsum([0] + [s.points.shape[0] * s.points.shape[1] for s in slices])
    shapes = [s.points.shape[:2] for s in slices]
    sigma = [total[a:b].reshape(shape) for a, b, shape in zip(sizes[:-1], sizes[1:], shapes, strict=True)]
    error, shift, moved = None, None, None
    if truth is not None:
        if calibration.frames:
            # the truth is in the simulator's {O}; the calibration in its axes gauge: compare there
            truth = to_axes_gauge(calibration.nominal, truth, {})[0]
        vectors = actual_tcp_error(calibration.geometry, truth, flat, tool)
        if calibration.frames:
            # what a free frame cannot see: where the robot is along its own axes (the common shift
            # of its axes and plate balls); the gauge holds it at nominal, the truth has its own
            shift = np.nanmean(vectors, axis=0)
            vectors = vectors - shift
        if calibration.geometry.chain.on_bed:
            vectors, moved = less_bed_motion(flat, vectors)
        err = np.linalg.norm(vectors, axis=1)
        error = [err[a:b].reshape(shape) for a, b, shape in zip(sizes[:-1], sizes[1:], shapes, strict=True)]
    if not np.any(np.isfinite(total)):
        raise UnreachableError("no point of the workspace slices is within reach of the identified robot")
    k = int(np.nanargmax(total))
    return AccuracyMap(slices, sigma, error, tool, float(total[k]), flat[k], axes[k], shift, moved)
