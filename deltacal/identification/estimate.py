"""Identification of a robot's geometry from measurements.

Weighted least squares on the base parameters (Savoure 2006, Eq. 23-26;
Bai 2015, Eq. 17 and 20), with two methods:

* ``linear``: one shot around the nominal geometry, as in the papers;
* ``iterated`` (default): Gauss-Newton relinearised around the current estimate
  with the exact kinematics, with step halving, until the step is below the
  noise (every base parameter's step under 1e-3 of its σ). It recovers encoder
  offsets of a degree and more in one call.

The base parameters are chosen once, from the column-scaled pivoted QR of the
weighted regressor at the start (:mod:`deltacal.identifiability`); parameters
outside the base stay at their starting value, their effect folded into the
base ones. Standard deviations come from the covariance ``(Wᵀ W)⁻¹`` of the
weighted base regressor (a priori σ of the measurements); the a posteriori
variance factor ``s0² = χ²/(m − r)`` says whether those σ were right.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import scipy.linalg

from ..errormodels import ErrorModel, get_model
from ..exceptions import AssemblyError, ConvergenceError, DeltacalError, GeometryError, IdentificationError
from ..geometry import DeltaGeometry
from ..identifiability import base_parameters
from ..kinematics import exact
from ..observations import (
    DISTANCE,
    SIGMA_ANGLE,
    SIGMA_POSITION,
    Measurements,
    Rows,
    build_rows,
    distance_residual_stats,
)
from ..resources import require_memory
from .diagnostics import check_plausible, check_rank
from .frames import (
    FRAME_RTOL,
    FRAME_UNITS,
    InstrumentFrame,
    absorbed_by_frames,
    frame_columns,
    frame_parameter_names,
    in_base_frame,
    initial_frames,
    to_axes_gauge,
)
from .outliers import data_snooping
from .points import point_columns, point_parameter_names, with_points_moved
from .quality import (
    PoorFitError,
    implausible_deviations,
    needs_review,
    poor_fit_message,
    readings,
    verdict,
)
from .result import IdentificationResult, ResidualStats


def _solve_wls(Ww: np.ndarray, rw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares by QR: solution, Q, and the inverse of R (covariance ``R⁻¹ R⁻ᵀ``)."""
    Q, R = np.linalg.qr(Ww)
    x = scipy.linalg.solve_triangular(R, Q.T @ rw, check_finite=False)
    Rinv = scipy.linalg.solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
    return x, Q, Rinv


#: Peak memory of a fit per element of the sensitivity S (M, 6, n): S, the rows, their
#: scaled and whitened copies, QR factors and trial rows, as measured on 20,000 positions.
_BYTES_PER_ELEMENT = 8 * 12


def _require_memory(measurements: Measurements, columns: int, distances: bool, pairs: str) -> None:
    """Refuse up front a fit whose rows would not fit the memory available (one line, no swap)."""
    needed = _BYTES_PER_ELEMENT * 6.0 * len(measurements) * max(columns, 1)
    advice = ("use fewer measurements" + (", --pairs reference or a Bai model (bai18: 18 columns)"
                                          if distances and pairs == "all" else ""))
    what = f"identification from {len(measurements):,} measurements with {columns} parameters"
    require_memory(needed, what, advice)


def _stats(geometry: DeltaGeometry, measurements: Measurements, rows: Rows, pairs: str) -> ResidualStats:
    """Residual statistics of a fit's rows; distances measured pair by pair (in bounded memory)."""
    if not np.any(rows.kind == DISTANCE):
        return ResidualStats.from_rows(rows)
    pose = exact.forward(geometry, measurements.q)
    rms, worst = distance_residual_stats(geometry, measurements, pose, pairs)
    return ResidualStats(distance_rms=rms, distance_max=worst)


def identify(
    start: DeltaGeometry,
    measurements: Measurements,
    model: str | ErrorModel = "complete",
    method: str = "iterated",
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
    distances: bool = False,
    pairs: str = "all",
    rtol: float = 1e-8,
    max_iter: int = 30,
    frame: str = "base",
    accept_poor_fit: bool = False,
    free_points: Sequence[str] = (),
) -> IdentificationResult:
    """Identify the geometry of a robot from measurements, and refuse a fit that cannot be right.

    The fit is :func:`fit`; then its residuals are tested against the σ given and its
    deviations for plausibility (:mod:`deltacal.identification.quality`). When they fail,
    the same data are fitted under other readings (orientations in radians, another point,
    swapped labels, an instrument frame) to name the likely causes.

    Args:
        start: Nominal geometry (the linearisation point of the first step).
        measurements: Readings and measured positions (and orientations).
        model: Error model or its name.
        method: ``"iterated"`` or ``"linear"``.
        sigma_position: σ of each measured coordinate [mm].
        sigma_angle: σ of each measured orientation component [rad].
        distances: Identify from distances between positions of a same point.
        pairs: Distance pairs, ``"all"`` or ``"reference"``.
        rtol: Rank tolerance.
        max_iter: Iterations at most.
        frame: ``"base"`` or ``"free"`` (see :func:`fit`).
        accept_poor_fit: Return a poor fit instead of raising (its ``warnings`` say why).
        free_points: Plate points whose position on the plate is identified too (see :func:`fit`).

    Returns:
        The result, holding the identified geometry.

    Raises:
        PoorFitError: the fit is far from the σ given or implausible (unless ``accept_poor_fit``).
        IdentificationError, AssemblyError, ConvergenceError: see :func:`fit`.
    """
    if free_points and distances:
        raise IdentificationError("free points are identified from positions and poses, not from distances")
    options = dict(method=method, sigma_position=sigma_position, sigma_angle=sigma_angle, distances=distances,
                   pairs=pairs, rtol=rtol, max_iter=max_iter, free_points=tuple(free_points))
    result = fit(start, measurements, model, frame=frame, **options)  # type: ignore[arg-type]
    if not needs_review(result, start):
        return result
    alternatives = []
    for cause, other, other_frame, points in readings(measurements, start.point_names, frame, distances,
                                                      free_points):
        try:
            alt_options = {**options, "free_points": points}
            alt = fit(start, other, model, frame=other_frame, **alt_options)  # type: ignore[arg-type]
        except DeltacalError:
            continue
        alternatives.append((cause, alt.variance_factor, implausible_deviations(start, alt.geometry)))
    poor, causes = verdict(result, start, alternatives)
    note = poor_fit_message(result, start, causes)
    if poor and not accept_poor_fit:
        raise PoorFitError(note, result, causes)
    if poor:
        return replace(result, warnings=(*result.warnings, note + " (kept: poor fit accepted)"))
    s0 = result.inlier_variance_factor
    excess = (f"variance factor s0² = {s0:.3g}: the residuals exceed the σ given "
              "(unmodelled effects, or σ too small): the σ of the parameters are too small by "
              f"a factor up to {math.sqrt(s0):.3g}")
    return replace(result, warnings=(*result.warnings, excess))


def fit(
    start: DeltaGeometry,
    measurements: Measurements,
    model: str | ErrorModel = "complete",
    method: str = "iterated",
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
    distances: bool = False,
    pairs: str = "all",
    rtol: float = 1e-8,
    max_iter: int = 30,
    frame: str = "base",
    axes_gauge: bool = True,
    free_points: Sequence[str] = (),
) -> IdentificationResult:
    """Fit the geometry of a robot to measurements (weighted least squares, base parameters).

    Args:
        start: Nominal geometry (the linearisation point of the first step).
        measurements: Readings and measured positions (and orientations).
        model: Error model or its name (see :data:`deltacal.errormodels.MODEL_NAMES`).
        method: ``"iterated"`` (Gauss-Newton with the exact kinematics) or ``"linear"``.
        sigma_position: σ of each measured coordinate [mm].
        sigma_angle: σ of each measured orientation component [rad].
        distances: Identify from distances between positions of a same point.
        pairs: ``"all"`` pairs or pairs with the ``"reference"`` (first) pose.
        rtol: Rank tolerance relative to the largest scaled pivot.
        max_iter: Iterations at most for ``"iterated"``.
        frame: ``"base"``: the measurements are in the robot base frame {O};
            ``"free"``: each station's instrument frame is identified with the geometry
            (see :mod:`deltacal.identification.frames`).
        axes_gauge: With free frames, move the identified robot (and the frames) to the gauge
            where its actuator axes have no net rigid motion; False keeps the model's own gauge
            (Bai's distance models fix it by their parameters, Eq. 11).
        free_points: Measured plate points (reflectors) whose position on the plate is
            identified with the geometry, three parameters ``P[name].x/y/z`` each (plate
            frame). What the geometry's own parameters already account for (a common shift
            of every plate point with the plate balls: the plate frame's origin is a
            convention) is not: those coordinates are held at their given values and listed
            in the result's ``confounded``.

    Returns:
        The result, holding the identified geometry.

    Raises:
        IdentificationError: too few measurements, poses too alike to identify what
            such measurements can identify (the message says which parameters and what
            would help), or measured positions far from any plausible robot (units, frame).
        AssemblyError: a measurement's readings cannot be assembled by the robot.
        ConvergenceError: Gauss-Newton did not converge (with the residual reached).
    """
    error_model = get_model(model) if isinstance(model, str) else model
    if method not in ("linear", "iterated"):
        raise ValueError(f"method must be 'linear' or 'iterated', got {method!r}")
    if frame not in ("base", "free"):
        raise ValueError(f"frame must be 'base' or 'free', got {frame!r}")
    if frame == "free" and distances:
        raise IdentificationError(
            "distances do not depend on the instrument frame: a free frame is for positions and poses"
        )
    stations = measurements.stations if frame == "free" else []
    free_points = list(dict.fromkeys(free_points))
    for name in free_points:
        if name not in measurements.point:
            measured = ", ".join(dict.fromkeys(measurements.point))
            raise IdentificationError(
                f"free point {name!r} is not measured; the measured points are {measured}"
            )
    n_model = len(error_model.names)
    _require_memory(measurements, n_model + 6 * len(stations) + 3 * len(free_points), distances, pairs)
    names = list(error_model.names) + frame_parameter_names(stations)
    n_fixed = len(names)  # columns before the free points
    names += point_parameter_names(free_points)
    frames: dict[str, InstrumentFrame] = {}
    if stations:
        frames = initial_frames(start, measurements, exact.forward(start, measurements.q))

    def rows_at(geometry: DeltaGeometry, frames: dict[str, InstrumentFrame]) -> Rows:
        seen = in_base_frame(measurements, frames) if frames else measurements
        pose = exact.forward(geometry, seen.q)
        rows = build_rows(
            geometry, seen, error_model.sensitivity, sigma_position, sigma_angle,
            distances=distances, pairs=pairs, pose=pose,
        )
        extra = []
        if frames:
            centres = np.array([frames[name].centre for name in stations])
            extra.append(frame_columns(rows, seen, stations, centres))
        if free_points:
            extra.append(point_columns(rows, seen, free_points, pose.rotation))
        return replace(rows, regressor=np.hstack([rows.regressor, *extra])) if extra else rows

    def moved(
        geometry: DeltaGeometry, frames: dict[str, InstrumentFrame], full: np.ndarray
    ) -> tuple[DeltaGeometry, dict[str, InstrumentFrame]]:
        corrections = full[n_model:n_fixed].reshape(-1, 6)
        moved_geometry = error_model.apply(geometry, full[:n_model])
        if free_points:
            moved_geometry = with_points_moved(moved_geometry, free_points, full[n_fixed:].reshape(-1, 3))
        return (
            moved_geometry,
            {s: frames[s].corrected(c) for s, c in zip(stations, corrections, strict=True)},
        )

    rows = rows_at(start, frames)
    m = rows.residual.size if rows.distances is None else rows.distances
    if distances and m == 0:
        raise IdentificationError(
            "no distance to fit: every measurement of a point is at the same readings as the others "
            "(distances need positions of a point at different poses)"
        )
    rw, Ww = rows.weighted
    # with a free frame its parameters are kept first: the base drops what they absorb
    prefer = error_model.preferred
    absorbed: list[str] = []
    held: list[str] = []
    if stations:
        # the geometry's own base first, as with measurements in {O}; then what the frames absorb
        own = base_parameters(Ww[:, :n_model], names[:n_model], rtol=rtol, prefer=prefer)
        # a model without rigid motions of its own (Bai's distance models, fitted as positions
        # with a frame per point) mimics none: only what is exactly the frames' is theirs
        absorbed = absorbed_by_frames(Ww[:, :n_fixed], names[:n_fixed], n_model, own.base,
                                      rtol if error_model.rigid_motion_free else FRAME_RTOL,
                                      error_model.frame_held_first)
        prefer = names[n_model:n_fixed] + [names[k] for k in own.base]
        # a parameter outside the geometry's own base only repeats base columns, except along
        # what the frames absorb: it would bring that back (b21x for an absorbed b22x, say)
        held = absorbed + [names[k] for k in range(n_model) if k not in own.base]
    base = base_parameters(Ww[:, :n_fixed], names[:n_fixed], rtol=rtol, prefer=prefer, exclude=held)
    if base.rank == 0:
        raise IdentificationError("the measurements identify no parameter of the model")
    check_plausible(start, measurements, rows, frame_free=bool(stations))
    hints = check_rank(start, measurements, error_model, base, Ww[:, :n_fixed], sigma_position, sigma_angle,
                       distances, pairs, rtol, stations)
    confounded: list[str] = []
    if free_points:
        # the points only where the geometry (and the frames) leave them something to say
        prefer = [names[k] for k in base.base] + names[n_fixed:]
        base = base_parameters(Ww, names, rtol=rtol, prefer=prefer, exclude=held)
        confounded = [names[k] for k in range(n_fixed, len(names)) if k not in base.base]
    kept = base.base
    before = _stats(start, measurements, rows, pairs)
    geometry = start
    total = np.zeros(base.rank)
    cost = float(rw @ rw)
    iterations = 0
    for iterations in range(1, (1 if method == "linear" else max_iter) + 1):  # noqa: B007
        step, Q, Rinv = _solve_wls(Ww[:, kept], rw)
        if method == "linear":
            total = total + step
            geometry, frames = moved(geometry, frames, base.expand(step))
            rows = rows_at(geometry, frames)
            break
        sigma_step = np.sqrt(np.sum(Rinv**2, axis=1))
        t = 1.0
        accepted = False
        assembled = 0
        for _ in range(12):
            try:
                trial, trial_frames = moved(geometry, frames, base.expand(t * step))
                trial_rows = rows_at(trial, trial_frames)
            except (AssemblyError, GeometryError):
                t *= 0.5
                continue
            assembled += 1
            trw = trial_rows.weighted[0]
            trial_cost = float(trw @ trw)
            if trial_cost <= cost * (1.0 + 1e-12):
                accepted = True
                break
            t *= 0.5
        if not accepted:
            # no step lowers the cost: the current geometry is the minimum (kept as it is),
            # unless no trial geometry could even be assembled
            if iterations == 1 and assembled == 0:
                raise ConvergenceError(
                    "identification could not take a single step: every trial geometry failed to "
                    f"assemble at the measured readings (weighted residual {math.sqrt(cost):.6g})",
                    math.sqrt(cost),
                )
            break
        geometry, frames, rows, total = trial, trial_frames, trial_rows, total + t * step
        previous, cost = cost, trial_cost
        rw, Ww = rows.weighted
        small_step = np.all(np.abs(t * step) <= 1e-3 * sigma_step)
        if small_step or previous - cost <= 1e-12 * max(previous, 1.0):
            break
    else:
        if method == "iterated":
            stats = _stats(geometry, measurements, rows, pairs)
            rms = stats.distance_rms if distances else stats.position_rms
            raise ConvergenceError(
                f"identification did not converge in {max_iter} Gauss-Newton iterations "
                f"(residual RMS {rms:.6g} mm, weighted residual {math.sqrt(cost):.6g}): "
                "check the measurements for gross errors",
                rms,
            )
    rw, Ww = rows.weighted
    if method == "iterated":
        _, Q, Rinv = _solve_wls(Ww[:, kept], rw)
    # linear: the covariance and leverages are those of the one regressor used
    cov = Rinv @ Rinv.T
    sigma = np.sqrt(np.diag(cov))
    correlation = cov / np.outer(sigma, sigma)
    dof = max(rows.independent - base.rank, 1)
    variance_factor = float(rw @ rw) / dof
    # outliers are tested row group by row group, on the rows before whitening
    rs, Ws = rows.scaled
    flagged = data_snooping(Ws[:, kept], rs, rows.measurement, rows.kind, rows.shared, rows.nuisance)
    # the fit's quality without the outliers (they are named on their own; distances mix rows)
    inlier_factor = variance_factor
    if flagged.size and rows.shared is None and rows.nuisance is None:
        inliers = ~np.isin(rows.measurement, flagged)
        inlier_factor = float(rs[inliers] @ rs[inliers]) / max(int(inliers.sum()) - base.rank, 1)
    gauge = (0.0, 0.0)
    if frames:
        # each frame's covariance: its kept parameters' block (a dropped one stays at zero)
        full_cov = np.zeros((len(names), len(names)))
        full_cov[np.ix_(kept, kept)] = cov
        frames = {
            s: replace(f, covariance=full_cov[n_model + 6 * k : n_model + 6 * k + 6,
                                              n_model + 6 * k : n_model + 6 * k + 6])
            for k, (s, f) in enumerate(frames.items())
        }
        if axes_gauge:
            geometry, frames, shift, turn = to_axes_gauge(start, geometry, frames)
            gauge = (shift, turn)
    return IdentificationResult(
        model=error_model.name,
        method=method,
        geometry=geometry,
        start=start,
        base=base,
        values=total,
        sigma=sigma,
        correlation=correlation,
        before=before,
        after=_stats(geometry, measurements, rows, pairs),
        outliers=[int(k) for k in flagged],
        iterations=iterations,
        variance_factor=variance_factor,
        units=[(list(error_model.units) + list(FRAME_UNITS) * len(stations)
                + ["mm"] * (len(names) - n_fixed))[k] for k in kept],
        n_rows=m,
        residual_after=rows.residual,
        hints=tuple(hints),
        frames=frames,
        gauge_motion=gauge,
        absorbed=tuple(absorbed),
        inlier_variance_factor=inlier_factor,
        confounded=tuple(confounded),
    )
