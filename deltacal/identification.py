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
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.stats

from .errormodels import ErrorModel, get_model
from .exceptions import AssemblyError, ConvergenceError, GeometryError, IdentificationError
from .geometry import DeltaGeometry
from .identifiability import BaseParameters, base_parameters
from .kinematics import exact
from .observations import (
    DISTANCE,
    ORIENTATION,
    POSITION,
    SIGMA_ANGLE,
    SIGMA_POSITION,
    Measurements,
    Rows,
    build_rows,
)

#: Standardised residual [σ] above which a measurement is flagged as an outlier.
OUTLIER_THRESHOLD = 4.0


@dataclass(frozen=True)
class ResidualStats:
    """RMS and max of residuals by kind: positions and distances [mm], orientations [rad]."""

    position_rms: float = float("nan")
    position_max: float = float("nan")
    orientation_rms: float = float("nan")
    orientation_max: float = float("nan")
    distance_rms: float = float("nan")
    distance_max: float = float("nan")

    @classmethod
    def from_rows(cls, rows: Rows) -> ResidualStats:
        """Statistics of a set of rows; a position's error is its 3-D norm."""
        out = {}
        for kind, key in ((POSITION, "position"), (ORIENTATION, "orientation"), (DISTANCE, "distance")):
            mask = rows.kind == kind
            if not np.any(mask):
                continue
            r = rows.residual[mask]
            if kind != DISTANCE:
                r = np.linalg.norm(r.reshape(-1, 3), axis=1)
            out[f"{key}_rms"] = float(np.sqrt(np.mean(r**2)))
            out[f"{key}_max"] = float(np.max(np.abs(r)))
        return cls(**out)

    def as_dict(self) -> dict[str, float]:
        """The statistics that exist, orientations in degrees."""
        out = {}
        for k, v in self.__dict__.items():
            if math.isfinite(v):
                out[k.replace("orientation", "orientation_deg") if "orientation" in k else k + "_mm"] = (
                    math.degrees(v) if "orientation" in k else v
                )
        return out


@dataclass(frozen=True)
class IdentificationResult:
    """The outcome of an identification.

    Attributes:
        model: Name of the error model.
        method: ``"linear"`` or ``"iterated"``.
        geometry: The identified full geometry.
        start: The geometry identification started from (nominal).
        base: Base parameters (rank, regroupings, condition number).
        values: Identified value of each base parameter (units of its kept parameter).
        sigma: Standard deviation of each base parameter.
        correlation: Correlation matrix of the base parameters.
        before: Residual statistics at the start.
        after: Residual statistics at the identified geometry.
        outliers: Indices of measurements flagged as outliers.
        outlier_lines: Their line numbers in the measurement file.
        iterations: Gauss-Newton iterations (1 for linear).
        variance_factor: s0² = χ² / (m − r) at the end.
        units: Unit of each base parameter.
        n_rows: Number of regressor rows.
        residual_after: Residual of every row at the end [mm or rad].
    """

    model: str
    method: str
    geometry: DeltaGeometry
    start: DeltaGeometry
    base: BaseParameters
    values: np.ndarray
    sigma: np.ndarray
    correlation: np.ndarray
    before: ResidualStats
    after: ResidualStats
    outliers: list[int]
    outlier_lines: list[int]
    iterations: int
    variance_factor: float
    units: list[str]
    n_rows: int
    residual_after: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    hints: tuple[str, ...] = ()

    @property
    def rank(self) -> int:
        """Numerical rank of the regressor."""
        return self.base.rank

    @property
    def condition_number(self) -> float:
        """Condition number of the column-scaled base regressor."""
        return self.base.condition_number

    @property
    def labels(self) -> list[str]:
        """Readable base parameters (regroupings)."""
        return self.base.labels()

    def strong_correlations(self, threshold: float = 0.9, limit: int = 5) -> list[tuple[int, int, float]]:
        """Pairs of base parameters (indices) with |correlation| above ``threshold``, strongest first."""
        C = np.triu(self.correlation, k=1)
        a, b = np.nonzero(np.abs(C) > threshold)
        order = np.argsort(-np.abs(C[a, b]))[:limit]
        return [(int(a[k]), int(b[k]), float(C[a[k], b[k]])) for k in order]

    def report(self) -> str:
        """A readable report: base parameters with σ, what is not identifiable, residuals, outliers."""
        lines = [
            f"model {self.model} ({len(self.base.names)} parameters), method {self.method}, "
            f"{self.iterations} iteration(s), {self.n_rows} equations",
            f"rank {self.rank} of {len(self.base.names)}, condition number {self.condition_number:.4g}",
            "",
            "identified base parameters (value ± σ):",
        ]
        width = max((len(s) for s in self.labels), default=10)
        for label, v, s, u in zip(self.labels, self.values, self.sigma, self.units, strict=True):
            if u == "rad":
                lines.append(f"  {label:<{width}}  {math.degrees(v):+12.6f} ± {math.degrees(s):.6f} deg")
            else:
                lines.append(f"  {label:<{width}}  {v:+12.6f} ± {s:.6f} mm")
        absent = self.base.absent
        folded = [k for k in self.base.unidentifiable if k not in absent]
        if folded:
            lines.append("")
            lines.append("not identifiable on their own (folded into the base parameters above):")
            lines.append("  " + ", ".join(self.base.names[k] for k in folded))
        if absent:
            lines.append("not seen by these measurements at all (left at their start value):")
            lines.append("  " + ", ".join(self.base.names[k] for k in absent))
        lines += [f"hint: {h}" for h in self.hints]
        lines.append("")
        lines.append("residuals             before        after")
        for key, unit, scale in (
            ("position", "mm", 1.0),
            ("distance", "mm", 1.0),
            ("orientation", "deg", math.degrees(1.0)),
        ):
            b_rms = getattr(self.before, f"{key}_rms")
            if not math.isfinite(b_rms):
                continue
            a_rms = getattr(self.after, f"{key}_rms")
            b_max = getattr(self.before, f"{key}_max")
            a_max = getattr(self.after, f"{key}_max")
            lines.append(f"  {key} RMS [{unit}]  {b_rms * scale:12.6f} {a_rms * scale:12.6f}")
            lines.append(f"  {key} max [{unit}]  {b_max * scale:12.6f} {a_max * scale:12.6f}")
        lines.append(f"variance factor s0² = {self.variance_factor:.3g} (1 if the σ given are right)")
        strong = self.strong_correlations()
        if strong:
            lines.append(
                "strongest correlations: "
                + "; ".join(f"{self.labels[a]} ~ {self.labels[b]} {c:+.3f}" for a, b, c in strong)
            )
        if self.outliers:
            lines.append(
                f"outliers (data snooping at {OUTLIER_THRESHOLD:g} σ): "
                + ", ".join(f"line {n}" for n in self.outlier_lines)
            )
        else:
            lines.append("outliers: none")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The calibration report as plain data (angles in degrees)."""
        params = []
        for label, name, v, s, u in zip(
            self.labels, self.base.base_names, self.values, self.sigma, self.units, strict=True
        ):
            if u == "rad":
                params.append({"name": name, "regrouping": label, "value_deg": math.degrees(v),
                               "sigma_deg": math.degrees(s)})
            else:
                params.append({"name": name, "regrouping": label, "value_mm": v, "sigma_mm": s})
        return {
            "model": self.model,
            "method": self.method,
            "rank": self.rank,
            "parameters": len(self.base.names),
            "condition_number": self.condition_number,
            "iterations": self.iterations,
            "variance_factor": self.variance_factor,
            "unidentifiable": self.base.unidentifiable_names,
            "residuals_before": self.before.as_dict(),
            "residuals_after": self.after.as_dict(),
            "outlier_lines": [int(n) for n in self.outlier_lines],
            "base_parameter": params,
            # correlation matrix of the base parameters, in the order of base_parameter
            "correlation": np.round(self.correlation, 6).tolist(),
        }


def _solve_wls(Ww: np.ndarray, rw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares by QR: solution, Q, and the inverse of R (covariance ``R⁻¹ R⁻ᵀ``)."""
    Q, R = np.linalg.qr(Ww)
    x = scipy.linalg.solve_triangular(R, Q.T @ rw, check_finite=False)
    Rinv = scipy.linalg.solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
    return x, Q, Rinv


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
) -> IdentificationResult:
    """Identify the geometry of a robot from measurements.

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

    def rows_at(geometry: DeltaGeometry) -> Rows:
        return build_rows(
            geometry, measurements, error_model.sensitivity, sigma_position, sigma_angle,
            distances=distances, pairs=pairs,
        )

    rows = rows_at(start)
    m = rows.residual.size
    rw, Ww = rows.weighted
    base = base_parameters(Ww, error_model.names, rtol=rtol, prefer=error_model.preferred)
    if base.rank == 0:
        raise IdentificationError("the measurements identify no parameter of the model")
    _check_plausible(start, measurements, rows)
    hints = _check_rank(start, measurements, error_model, base, Ww, sigma_position, sigma_angle,
                        distances, pairs, rtol)
    kept = base.base
    before = ResidualStats.from_rows(rows)
    geometry = start
    total = np.zeros(base.rank)
    cost = float(rw @ rw)
    iterations = 0
    for iterations in range(1, (1 if method == "linear" else max_iter) + 1):  # noqa: B007
        step, Q, Rinv = _solve_wls(Ww[:, kept], rw)
        if method == "linear":
            total = total + step
            geometry = error_model.apply(geometry, base.expand(step))
            rows = rows_at(geometry)
            break
        sigma_step = np.sqrt(np.sum(Rinv**2, axis=1))
        t = 1.0
        accepted = False
        assembled = 0
        for _ in range(12):
            try:
                trial = error_model.apply(geometry, base.expand(t * step))
                trial_rows = rows_at(trial)
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
        geometry, rows, total = trial, trial_rows, total + t * step
        previous, cost = cost, trial_cost
        rw, Ww = rows.weighted
        small_step = np.all(np.abs(t * step) <= 1e-3 * sigma_step)
        if small_step or previous - cost <= 1e-12 * max(previous, 1.0):
            break
    else:
        if method == "iterated":
            stats = ResidualStats.from_rows(rows)
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
    dof = max(rw.size - base.rank, 1)
    variance_factor = float(rw @ rw) / dof
    # outliers are tested row group by row group, on the rows before whitening
    rs, Ws = rows.scaled
    flagged = _outliers(Ws[:, kept], rs, rows.measurement, rows.kind)
    assert measurements.lines is not None
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
        after=ResidualStats.from_rows(rows),
        outliers=[int(k) for k in flagged],
        outlier_lines=[int(measurements.lines[k]) for k in flagged],
        iterations=iterations,
        variance_factor=variance_factor,
        units=[error_model.units[k] for k in kept],
        n_rows=m,
        residual_after=rows.residual,
        hints=tuple(hints),
    )


def _outliers(W: np.ndarray, rw: np.ndarray, measurement: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """Measurements that do not fit the others, by iterated data snooping (Baarda) on groups.

    Each measurement's rows g are tested by the drop of χ² its deletion would give,
    ``T_g = r_gᵀ (I − H_gg)⁻¹ r_g`` (H: hat matrix, so a high-leverage pose is tested
    by what the others predict for it), against the χ² quantile of
    :data:`OUTLIER_THRESHOLD` σ for its number of rows, each row's residual divided by
    ``max(1, s)``, s the robust (median) scale of the residuals of its kind (so σ given
    too small, or a model blind to the orientations, does not flag everything). The
    worst measurement is set aside and the fit redone, at most for a quarter of the
    measurements: one gross error no longer flags the rows it drags.
    """
    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    quantile: dict[int, float] = {}
    ids = np.unique(measurement)
    active = np.ones(rw.size, dtype=bool)
    flagged: list[int] = []
    for _ in range(max(1, ids.size // 4)):
        if np.count_nonzero(active) <= W.shape[1] + 1:
            break
        Q, _ = np.linalg.qr(W[active])
        r = rw[active] - Q @ (Q.T @ rw[active])
        leverage = np.clip(np.sum(Q**2, axis=1), 0.0, 1.0 - 1e-12)
        standardised = np.abs(r) / np.sqrt(1.0 - leverage)
        for k in np.unique(kind):
            of_kind = kind[active] == k
            r[of_kind] /= max(1.0, 1.4826 * float(np.median(standardised[of_kind])))
        meas = measurement[active]
        worst, worst_ratio = -1, 1.0
        ids_now, counts = np.unique(meas, return_counts=True)
        order = np.argsort(meas, kind="stable")  # rows grouped by measurement
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        for size in np.unique(counts):  # groups of one size at once (poses: 6 rows, points: 3...)
            groups = np.flatnonzero(counts == size)
            rows = order[starts[groups][:, None] + np.arange(size)[None, :]]  # (G, size)
            Qg = Q[rows]  # (G, size, rank)
            A = np.eye(size)[None] - Qg @ np.swapaxes(Qg, 1, 2)
            rg = r[rows]
            T = np.einsum("gi,gi->g", rg, (np.linalg.pinv(A, rcond=1e-12) @ rg[..., None])[..., 0])
            if size not in quantile:
                quantile[size] = float(scipy.stats.chi2.isf(p_value, size))
            ratio = T / quantile[size]
            k = int(np.argmax(ratio))
            if ratio[k] > worst_ratio:
                worst, worst_ratio = int(ids_now[groups[k]]), float(ratio[k])
        if worst < 0:
            break
        flagged.append(worst)
        active &= measurement != worst
    return np.array(sorted(flagged), dtype=int)


def _check_plausible(start: DeltaGeometry, measurements: Measurements, rows: Rows) -> None:
    """Refuse measurements no robot near ``start`` can have produced, before fitting them.

    Manufacturing errors move the measured points by similar amounts all over the
    workspace, so at the start geometry the position errors are alike. All of them
    large means wrong units or frame; a few far larger than the rest (three times the
    median, ten robust deviations and 5 % of the arm length) are gross errors that a
    least-squares fit would spread over every parameter (and hide: a lone far pose has
    a leverage near 1).
    """
    arm = float(np.mean(np.linalg.norm(start.arm_ball.mean(axis=1), axis=1)))
    position = rows.kind == POSITION
    if np.any(position):
        error = np.linalg.norm(rows.residual[position].reshape(-1, 3), axis=1)
        which = rows.measurement[position][::3]
    else:
        error = np.abs(rows.residual[rows.kind == DISTANCE])
        which = np.array([], dtype=int)
    if not error.size:
        return
    median = float(np.median(error))
    if median > 0.2 * arm:
        raise IdentificationError(
            f"the measured positions are a median {median:.4g} mm from where the nominal robot puts "
            f"them (arms of {arm:.4g} mm): check the units (readings in degrees, positions in mm), that "
            "positions are in the robot base frame, and the robot file"
        )
    spread = 1.4826 * float(np.median(np.abs(error - median)))
    gross = error > max(3.0 * median, median + 10.0 * spread, 0.05 * arm)
    if which.size and np.any(gross):
        assert measurements.lines is not None
        lines = [int(measurements.lines[k]) for k in which[gross]]
        k = int(np.argmax(np.where(gross, error, -np.inf)))
        raise IdentificationError(
            f"line{'s' if len(lines) > 1 else ''} {', '.join(map(str, lines[:10]))}: the measured "
            f"position is up to {error[k]:.4g} mm from where the nominal robot puts it at the row's "
            f"readings, the other rows a median {median:.4g} mm: a typing error in the readings or the "
            "position? Correct or remove the row"
        )


def _reference_regressor(
    start: DeltaGeometry, measurements: Measurements, model: ErrorModel, sigma_position: float,
    sigma_angle: float, distances: bool, pairs: str, orientation: bool = False, extra_point: bool = False,
) -> np.ndarray | None:
    """Weighted regressor of well-spread poses with the same kinds of measurement, or richer ones.

    Readings: 30 random poses within ±15 deg of the median measured readings; at each,
    every (point, with orientation) combination of the measurements. ``orientation``
    adds orientations, ``extra_point`` a second point off the first. None if fewer than
    10 of these poses assemble.
    """
    rng = np.random.default_rng(0)
    q = np.median(measurements.q, axis=0) + rng.uniform(-1.0, 1.0, (30, 3)) * math.radians(15.0)
    try:
        exact.forward(start, q)
    except AssemblyError as exc:
        q = np.delete(q, exc.indices, axis=0)
    kinds = sorted(set(zip(measurements.point, measurements.has_orientation.tolist(), strict=True)))
    if orientation:
        kinds = sorted({(name, True) for name, _ in kinds})
    geometry = start
    if extra_point:
        plate = float(np.mean(np.linalg.norm(start.plate_ball.mean(axis=1), axis=1)))
        offset = start.point(kinds[0][0]) + plate * np.array([1.0, 0.6, -0.5])
        geometry = replace(start, points={**start.points, "_extra": offset})
        kinds = kinds + [("_extra", kinds[0][1])]
    if len(q) < 10:
        return None
    point = [name for _ in q for name, _ in kinds]
    has = np.array([o for _ in q for _, o in kinds])
    ref = Measurements(q=np.repeat(q, len(kinds), axis=0), position=np.zeros((has.size, 3)), point=point,
                       rotation_vector=np.where(has[:, None], 0.0, np.full((has.size, 3), np.nan)))
    try:
        rows = build_rows(geometry, ref, model.sensitivity, sigma_position, sigma_angle,
                          distances=distances, pairs=pairs)
    except AssemblyError:
        return None
    return rows.weighted[1]


def _separated(
    base: BaseParameters, W: np.ndarray, richer: BaseParameters, W_richer: np.ndarray
) -> list[str]:
    """Parameters involved in the directions the richer regressor identifies and W does not."""

    def null(A: np.ndarray, rank: int) -> np.ndarray:
        return np.linalg.svd(A / richer.scale, full_matrices=True)[2][rank:].T

    N, N_richer = null(W, base.rank), null(W_richer, richer.rank)
    U, sv, _ = np.linalg.svd(N - N_richer @ (N_richer.T @ N), full_matrices=False)
    lost = U[:, sv > 0.5]
    return [base.names[k] for k in np.flatnonzero(np.max(np.abs(lost), axis=1, initial=0.0) > 0.2)]


def _check_rank(
    start: DeltaGeometry, measurements: Measurements, model: ErrorModel, base: BaseParameters,
    W: np.ndarray, sigma_position: float, sigma_angle: float, distances: bool, pairs: str, rtol: float,
) -> list[str]:
    """Compare the rank with what well-spread poses of the same kinds give.

    Raises IdentificationError if the poses are too few or too alike, naming the
    parameters lost and how many poses are needed; returns hints on what richer
    measurements (orientations, a second point) would identify.
    """
    args = (start, measurements, model, sigma_position, sigma_angle, distances, pairs)
    W_ref = _reference_regressor(*args)
    if W_ref is None:
        return []
    ref = base_parameters(W_ref, model.names, rtol=rtol)
    M = len(measurements)
    if base.rank < ref.rank:
        if distances:
            needed = ref.rank + 1 if pairs == "reference" else math.ceil(0.5 + math.sqrt(0.25 + 2 * ref.rank))
        else:
            needed = math.ceil(ref.rank * M / W.shape[0])
        spread = _spread_advice(start, measurements)
        if M < needed:
            raise IdentificationError(
                f"too few measurements: {M} give {W.shape[0]} equations, but model {model.name} has "
                f"{ref.rank} parameters identifiable from such measurements: measure at least {needed} "
                f"poses (two to three times as many for a useful estimate), {spread}"
            )
        lost = _separated(base, W, ref, W_ref)
        raise IdentificationError(
            f"the {M} measurements identify only {base.rank} of the {ref.rank} parameters model "
            f"{model.name} can identify from such measurements: the poses are too alike to separate "
            f"{_names_text(lost)}; {spread} would help"
        )
    hints = []
    one_point = len(set(measurements.point)) == 1
    has_orientation = bool(np.any(measurements.has_orientation))
    richer: list[tuple[str, bool, bool]] = []
    if not has_orientation and not distances:
        richer.append(("orientation measurements (rx_deg, ry_deg, rz_deg)", True, False))
    if not has_orientation and one_point:
        richer.append(("a second point measured on the plate, off the first", False, True))
    for label, orientation, extra_point in richer:
        W_rich = _reference_regressor(*args, orientation=orientation, extra_point=extra_point)
        if W_rich is None:
            continue
        rich = base_parameters(W_rich, model.names, rtol=rtol)
        if rich.rank > ref.rank:
            gained = _separated(ref, W_ref, rich, W_rich)
            hints.append(f"{label} would identify {rich.rank - ref.rank} more base parameter(s), "
                         f"separating {_names_text(gained)}")
    return hints


def _names_text(names: list[str], limit: int = 12) -> str:
    if not names:
        return "some of them"
    return ", ".join(names[:limit]) + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _spread_advice(start: DeltaGeometry, measurements: Measurements) -> str:
    """Which poses would help, from where the measured ones are."""
    size = float(np.mean(start.rod_length))
    z_span = float(np.ptp(measurements.position[:, 2]))
    radius = float(np.max(np.linalg.norm(measurements.position[:, :2], axis=1)))
    where = []
    if z_span < 0.05 * size:
        where.append(f"on the workspace's top and bottom layers (these span only {z_span:.3g} mm in z)")
    if radius < 0.05 * size:
        where.append(f"on the workspace's rim (these stay within {radius:.3g} mm of the axis)")
    if not where:
        return ("poses spread over the whole workspace (its top and bottom layers, centre and rim, each "
                "arm over a wide range of angles)")
    return "poses " + " and ".join(where)


def predict_measurements(geometry: DeltaGeometry, q: np.ndarray, point: str = "tcp") -> np.ndarray:
    """Exact positions of a plate point at readings q [mm], (N, 3) (a helper for checks)."""
    return exact.forward(geometry, q).point(geometry.point(point))
