"""Identification of a linear Delta printer from probe heights and printed distances.

A printer measures itself: its probe triggers on the bed, and an object it printed is measured
with calipers (conventions, "Linear Delta printers"). Both are made at readings the firmware
commanded (the caller turns commanded positions into readings through the firmware's inverse
model); here they are equations of the printer's full geometry:

* a probe height: the probe point (the nozzle, or the nozzle plus ``probe_offset`` in the
  effector frame) is at its trigger height above the bed, ``z(q) = h`` (h = 0 unless given per
  row: a probe's ``z_offset``), σ ``height_sigma``;
* a distance between two printed features: ``|p(q1) − p(q2)| = d``, σ ``distance_sigma``, with
  p the nozzle;
* a nozzle position an instrument measured in its own frame (a tracker's, a CMM's), σ
  ``position_sigma`` per coordinate: the instrument's frame is free, so each step fits it in closed
  form (Kabsch) and its six motions are projected out of the rows (variable projection).

The gauge: {O} is the true bed, z = 0 (the bed's height and tilt relative to the nominal towers,
the free plane of a probing, are carried by the towers' endstops and leans: a printer is judged
against the bed it prints on). What no probe height and no distance sees (the printer moved along
the bed and turned about its normal: 3 rigid motions, and what the data leave out) is held at its
start value by the base parameters (Savoure 2006, Eq. 23-26): the pivoted QR keeps one parameter
per identifiable combination, preferring endstops, step scales, leans and rods
(:class:`~deltacal.printer.identification.errormodels.PrinterModel`). Gauss-Newton then iterates the kept
parameters to convergence, linearised at the exact kinematics of each estimate. Vectorised over
measurements. Units: mm and rad.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, replace
from typing import Literal, TypedDict, Unpack, get_args

import numpy as np
from scipy.linalg import solve_triangular

from ...errormodels import ErrorModel, get_model
from ...exceptions import AssemblyError, ConvergenceError, PoorFitError
from ...geometry import DeltaGeometry, Tolerances, Workspace
from ...holds import DETERMINED
from ...identifiability import BaseParameters, base_parameters
from ...identification.columns import build_columns
from ...identification.options import Method
from ...identification.result import IdentificationResult, ResidualStats
from ...identification.solver import solve_wls
from ...kinematics import exact
from ...observations import rigid_alignment
from ...options import with_overrides
from ...rotations import skew
from .errormodels import calibrated_values, kit_tolerances
from .evidence import SCALE_RANGE, evidence_scales
from .outliers import Outliers, find_outliers
from .where import firmware_determination, point_rows, where_it_holds

#: Probe trigger repeatability [mm] (a typical inductive or switch probe).
HEIGHT_SIGMA = 0.01
#: Caliper reading [mm].
DISTANCE_SIGMA = 0.02
#: A measured coordinate of the nozzle [mm].
POSITION_SIGMA = 0.01
#: Rank tolerance of the scaled pivoted QR.
RANK_RTOL = 1e-6
#: Gauss-Newton stops when no kept parameter moved by more than this [mm or rad].
STEP_TOLERANCE = 1e-9
MAX_ITERATIONS = 20
#: Halvings of a Gauss-Newton step that would leave a reading unassembled, at most.
HALVINGS = 30


@dataclass(frozen=True)
class PrinterMeasurements:
    """What a printer measured, at the readings the firmware commanded.

    Attributes:
        probe: Readings at which the probe triggered on the bed [mm], (N, 3).
        pairs: Readings at which the two features of each measured distance were printed
            [mm], (M, 2, 3).
        distance: The distances measured between them [mm], (M,).
        probe_offset: The probe's trigger point relative to the nozzle, in the effector frame [mm].
        height_sigma: σ of a probe height [mm].
        distance_sigma: σ of a distance [mm].
        positions: Readings at which an instrument measured the nozzle [mm], (K, 3).
        measured: The nozzle positions it measured, in its own frame [mm], (K, 3).
        position_sigma: σ of each measured coordinate [mm].
        trigger_height: The probe point's height above the bed at each probe's trigger [mm], (N,)
            (empty: 0 on every row).
    """

    probe: np.ndarray
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    distance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    probe_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    height_sigma: float = HEIGHT_SIGMA
    distance_sigma: float = DISTANCE_SIGMA
    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    measured: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    position_sigma: float = POSITION_SIGMA
    trigger_height: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        probe = np.asarray(self.probe, dtype=float).reshape(-1, 3)
        trigger = np.asarray(self.trigger_height, dtype=float).reshape(-1)
        if trigger.size == 0:
            trigger = np.zeros(probe.shape[0])
        if trigger.shape[0] != probe.shape[0] or not np.all(np.isfinite(trigger)):
            raise ValueError(f"{trigger.shape[0]} trigger heights for {probe.shape[0]} probe heights")
        object.__setattr__(self, "trigger_height", trigger)
        pairs = np.asarray(self.pairs, dtype=float).reshape(-1, 2, 3)
        distance = np.asarray(self.distance, dtype=float).reshape(-1)
        if distance.shape[0] != pairs.shape[0]:
            raise ValueError(f"{distance.shape[0]} distances for {pairs.shape[0]} pairs")
        positions = np.asarray(self.positions, dtype=float).reshape(-1, 3)
        measured = np.asarray(self.measured, dtype=float).reshape(-1, 3)
        if positions.shape != measured.shape or 0 < positions.shape[0] < 3:
            raise ValueError(f"{measured.shape[0]} measured positions for {positions.shape[0]} readings "
                             "(an instrument's frame needs 3 positions at least)")
        if not (self.height_sigma > 0.0 and self.distance_sigma > 0.0 and self.position_sigma > 0.0):
            raise ValueError("the σ of probe heights, distances and positions must be positive")
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "measured", measured)
        object.__setattr__(self, "probe", probe)
        object.__setattr__(self, "pairs", pairs)
        object.__setattr__(self, "distance", distance)
        object.__setattr__(self, "probe_offset", np.asarray(self.probe_offset, dtype=float).reshape(3))

    @property
    def rows(self) -> int:
        """Number of equations."""
        return self.probe.shape[0] + self.distance.shape[0] + 3 * self.positions.shape[0]

    @property
    def sigma(self) -> tuple[float, float, float]:
        """σ of a row of each kind (probe height, distance, position coordinate) [mm]."""
        return self.height_sigma, self.distance_sigma, self.position_sigma


def residuals_and_regressor(
    geometry: DeltaGeometry, model: ErrorModel, data: PrinterMeasurements
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whitened residuals (measured − model) and regressor at ``geometry``, and the kind of each row.

    Returns:
        r (m,), W (m, n) (both divided by each row's σ) and kind (m,): 0 probe height, 1 distance,
        2 a coordinate of a measured position.
    """
    tool = geometry.tool
    z, Jz = point_rows(geometry, model, data.probe, tool + data.probe_offset)
    rows = [((data.trigger_height - z[:, 2]) / data.height_sigma, Jz[:, 2] / data.height_sigma)]
    if data.distance.size:
        M = data.distance.shape[0]
        p, J = point_rows(geometry, model, data.pairs.reshape(-1, 3), tool)
        p, J = p.reshape(M, 2, 3), J.reshape(M, 2, 3, -1)
        d = p[:, 0] - p[:, 1]
        norm = np.linalg.norm(d, axis=1)
        u = d / norm[:, None]
        Jd = np.einsum("mk,mkp->mp", u, J[:, 0] - J[:, 1])
        rows.append(((data.distance - norm) / data.distance_sigma, Jd / data.distance_sigma))
    if data.positions.size:
        p, J = point_rows(geometry, model, data.positions, tool)
        frame = np.zeros((p.shape[0], 3, 6))  # the instrument frame's small motions: shift, turn
        frame[:, :, :3] = np.eye(3)
        frame[:, :, 3:] = -skew(p)
        F, Jp = frame.reshape(-1, 6), J.reshape(-1, J.shape[-1])
        Jp = Jp - F @ np.linalg.lstsq(F, Jp, rcond=None)[0]
        r = (rigid_alignment(data.measured, p) - p).reshape(-1)
        rows.append((r / data.position_sigma, Jp / data.position_sigma))
    kind = np.repeat([0, 1, 2], [data.probe.shape[0], data.distance.shape[0], 3 * data.positions.shape[0]])
    return np.concatenate([r for r, _ in rows]), np.concatenate([w for _, w in rows]), kind


def _stats(r: np.ndarray, kind: np.ndarray, data: PrinterMeasurements) -> ResidualStats:
    """RMS and max of the probe heights' and the distances' residuals [mm]."""
    out = {}
    for k, key in enumerate(("height", "distance", "position")):
        if np.any(kind == k):
            v = r[kind == k] * data.sigma[k]
            v = np.linalg.norm(v.reshape(-1, 3), axis=1) if key == "position" else v
            out[f"{key}_rms"], out[f"{key}_max"] = float(np.sqrt(np.mean(v**2))), float(np.max(np.abs(v)))
    return ResidualStats(**out)


def measured_combinations(start: DeltaGeometry, data: PrinterMeasurements,
                          model: str | ErrorModel = "printer",
                          tolerances: Tolerances | None = None) -> BaseParameters:
    """What the measurements identify: the combinations they determine better than the tolerances do.

    With each parameter in units of its tolerance (``model.prior_sigma``), a combination whose
    singular value in the whitened regressor exceeds 1 is known to better than its tolerance
    from the measurements; their number is the rank, and the base parameters (Savoure 2006,
    Eq. 23-26) keep endstops, scales, leans and rods first. The ``unidentifiable`` are what only
    the build tolerances bound.
    """
    error_model = get_model(model) if isinstance(model, str) else model
    _, W, _ = residuals_and_regressor(start, error_model, data)
    factor = error_model.prior_factor(tolerances or kit_tolerances(error_model), start)
    determined = int(np.sum(np.linalg.svd(W @ factor, compute_uv=False) > 1.0))
    return base_parameters(W, error_model.names, rtol=RANK_RTOL, prefer=error_model.preferred,
                           rank=determined)


def posterior_sigma(start: DeltaGeometry, data: PrinterMeasurements, model: str | ErrorModel = "printer",
                    tolerances: Tolerances | None = None) -> tuple[np.ndarray, np.ndarray]:
    """How well the measurements would know each parameter: its σ before and after them (n,), (n,).

    The prior σ is the build tolerance (``model.prior_sigma``); after, the marginal σ of the
    linearised fit at ``start`` (the measurements' σ and the priors together). A parameter whose
    σ after is close to before is one the measurements do not see.
    """
    error_model = get_model(model) if isinstance(model, str) else model
    _, W, _ = residuals_and_regressor(start, error_model, data)
    factor = error_model.prior_factor(tolerances or kit_tolerances(error_model), start)
    n = factor.shape[0]
    _, _, Rinv = solve_wls(np.vstack([W @ factor, np.eye(n)]), np.zeros(W.shape[0] + n))
    return np.sqrt(np.sum(factor**2, axis=1)), np.sqrt(np.sum((factor @ Rinv) ** 2, axis=1))


@dataclass(frozen=True)
class PrinterFitOptions:
    """How to fit a printer (:func:`identify_printer`): one value, checked once.

    Attributes:
        method: ``"linear"`` (one step at the start) or ``"iterated"`` (to convergence).
        tolerances: The build tolerances (None: :meth:`Tolerances.printer_kit`).
        tolerance_scale: ``"evidence"`` (the measurements choose it) or a factor applied to every
            tolerance (1: as given).
        workspace: The printable volume where the calibration's σ is given
            (:class:`~deltacal.holds.WhereItHolds`; None: the measurements' radius, 200 mm high).
        accept_poor_fit: Return a poor fit (:func:`poor_fit`) with a warning instead of raising
            :class:`~deltacal.exceptions.PoorFitError`.
        calibrated_start: The start is the firmware's values calibrated from these very
            measurements (a saved ``DELTA_CALIBRATE``): the directions of the values its own
            calibration fits take wide priors (:meth:`~.errormodels.PrinterModel.prior_factor`).
        reach: The controller's radius where it reaches beyond the workspace's [mm], or None: where
            the calibration's σ is given out to it (:func:`~.where.where_it_holds`).

    Raises:
        ValueError: a method or scale out of its range (the message names the field and value).
        TypeError: tolerances that are not a :class:`~deltacal.geometry.Tolerances`.
    """

    method: Method = "iterated"
    tolerances: Tolerances | None = None
    tolerance_scale: float | Literal["evidence"] = "evidence"
    workspace: Workspace | None = None
    accept_poor_fit: bool = False
    calibrated_start: bool = False
    reach: float | None = None

    def __post_init__(self) -> None:
        if self.method not in get_args(Method):
            raise ValueError(f"method must be 'linear' or 'iterated', got {self.method!r}")
        if self.tolerances is not None and not isinstance(self.tolerances, Tolerances):
            raise TypeError(f"tolerances must be a Tolerances, got {self.tolerances!r}")
        if self.workspace is not None and not isinstance(self.workspace, Workspace):
            raise TypeError(f"workspace must be a Workspace, got {self.workspace!r}")
        scale = self.tolerance_scale
        if scale != "evidence" and (isinstance(scale, str) or not isinstance(scale, (int, float))
                                    or not scale > 0.0):
            raise ValueError(f"tolerance_scale must be 'evidence' or a positive factor, got {scale!r}")


class PrinterFitOverrides(TypedDict, total=False):
    """The fields of :class:`PrinterFitOptions` as keyword arguments (see there), each optional."""

    method: Method
    tolerances: Tolerances | None
    tolerance_scale: float | Literal["evidence"]
    workspace: Workspace | None
    accept_poor_fit: bool
    calibrated_start: bool
    reach: float | None


def identify_printer(
    start: DeltaGeometry, data: PrinterMeasurements, model: str | ErrorModel = "printer", *,
    options: PrinterFitOptions | None = None, **overrides: Unpack[PrinterFitOverrides],
) -> IdentificationResult:
    """Identify a printer's geometry from probe heights and printed distances.

    A printer's measurements (at most 49 heights and 40 distances) identify about half of the
    complete model's combinations (:func:`measured_combinations`); the build tolerances bound the
    rest: each parameter has a prior, zero ± its tolerance (``model.prior_sigma``), and the fit is
    the most probable geometry (weighted least squares on the measurements and the priors
    together, Gauss-Newton at the exact kinematics). A combination the measurements determine
    is theirs, one they do not see stays within its tolerance, and the gauge along the bed (a
    shift and a turn no probe and no caliper sees) is the one of the smallest deviations.

    How wide the tolerances are is rarely known (a well-built printer's errors are a tenth of a
    kit's): by default they are scaled by the factor the measurements make most probable
    (:func:`~deltacal.printer.identification.evidence.evidence_scale`, at the fit with the tolerances as
    given), then the fit is made again with them. On the 10 well-built printers of
    ``scripts/printer_compare.py`` (the object then planned, 150 mm caliper) it took the G-code
    route's 3-D max error from 0.033 to 0.026 mm; on its 10 kits from 0.031 to 0.035 mm (a single
    factor shrinks a kit's balls and rods with its towers; 30 more kits: 0.030 to 0.032 mm).

    Args:
        start: The nominal printer (a prismatic DeltaGeometry, {O} on the nominal bed).
        data: The measurements, at the readings the firmware commanded.
        model: ``"printer"`` (the complete model) or ``"klipper"`` (the firmware's values).
        options: How to fit (:class:`PrinterFitOptions`: the method, the build tolerances and
            their scale; default: its defaults).
        **overrides: Fields of :class:`PrinterFitOptions` by name (``method="linear"``,
            ``tolerance_scale=0.5``, ...); they win over the same fields of ``options``.

    Returns:
        The result: the identified geometry on the true bed (z = 0), every parameter with its
        posterior σ; its hints say the scale of the tolerances, the noise factors and what only the
        tolerances bound; its ``outliers`` the measurements that do not fit the others
        (:func:`printer_outliers`: probe heights, then distances, then positions, from 0), kept in
        the fit (the caller decides); its ``holds`` where it holds (:func:`~.where.where_it_holds`).

    Raises:
        PoorFitError: a poor fit (:func:`poor_fit`), unless ``accept_poor_fit``.
    """
    options = with_overrides(PrinterFitOptions, options, overrides)
    method = options.method
    error_model = get_model(model) if isinstance(model, str) else model
    error_model.check_fits(start)
    given = options.tolerances or kit_tolerances(error_model)
    scale, noise, how = _tolerance_scale(start, data, error_model, given, options)
    used = scaled_tolerances(given, scale)
    calibrated = calibrated_values(options.calibrated_start, data.distance.size, error_model)
    factor = error_model.prior_factor(used, start, calibrated)  # the prior's Σ: factor factorᵀ
    taken = with_noise(data, noise)  # the measurements' σ: the given times each kind's s0
    measured = measured_combinations(start, taken, error_model, used)
    r0, _, kind = residuals_and_regressor(start, error_model, data)
    total, geometry, r, W, iterations = _map_fit(start, taken, error_model, factor, method)
    n = factor.shape[0]
    _, _, Rinv = solve_wls(np.vstack([W @ factor, np.eye(n)]), np.zeros(W.shape[0] + n))
    cov = factor @ (Rinv @ Rinv.T) @ factor.T
    sigma = np.sqrt(np.diag(cov))
    r = r * np.sqrt(noise[kind])  # whitened by the σ given, as s0² judges them
    chi2 = float(r @ r + np.sum(solve_triangular(factor, total, lower=True) ** 2))
    variance_factor = chi2 / max(r.size - (6 if data.positions.size else 0), 1)  # the frame's 6
    flagged = printer_outliers(start, data, error_model, options)
    inlier_factor = variance_factor
    if flagged.indices.size:  # the rows of the others, about the fit without the outliers
        rows = flagged.kept[measurement_of_rows(data)]
        inlier_factor = float(flagged.residual[rows] @ flagged.residual[rows]) / max(int(rows.sum()), 1)
    held = measured.unidentifiable_names
    hints = [f"the build tolerances scaled by {scale:.3g} ({how})", *_noise_hints(data, noise)]
    warnings: list[str] = []
    at_limit = options.tolerance_scale == "evidence" and scale >= SCALE_RANGE[1] / AT_LIMIT
    if held:
        hints.append(f"the measurements identify {measured.rank} of the {error_model.size} parameters' "
                     f"combinations; the build tolerances bound the other {len(held)} ({', '.join(held)})")
    volume = options.workspace or default_volume(geometry, data)
    result = IdentificationResult(
        model=error_model.name, method=method, geometry=geometry, start=start,
        # with the priors every parameter is kept, in the model's order
        base=base_parameters(np.vstack([W, np.linalg.inv(factor)]), error_model.names, rtol=RANK_RTOL,
                             prefer=error_model.names),
        values=total, sigma=sigma,
        correlation=cov / np.outer(sigma, sigma), before=_stats(r0, kind, data), after=_stats(r, kind, data),
        outliers=[int(k) for k in flagged.indices], iterations=iterations,
        variance_factor=variance_factor, inlier_variance_factor=inlier_factor,
        units=list(error_model.units), n_rows=r.size,
        residual_after=r * np.asarray(data.sigma)[kind],
        independent_rows=r.size, columns=build_columns(error_model).columns,
        hints=tuple(hints), warnings=tuple(warnings),
        holds=replace(where_it_holds(geometry, error_model, cov, volume, measured_top(geometry, data),
                                     options.reach),
                      values=firmware_determination(geometry, error_model,
                                                    stated_covariance(W, error_model.prior_factor(
                                                        given, start, calibrated)),
                                                    build_sigma(error_model, given), volume),
                      along_bed=error_model.apply(start, determined_values(total, W, factor))
                      if options.calibrated_start else None),
        tolerance_scale=float(scale),
    )
    poor = "" if flagged.indices.size else poor_fit(variance_factor, at_limit)  # outliers: said as such
    if poor and not options.accept_poor_fit:
        raise PoorFitError(poor, result, [], (PoorFitError.LARGE_RESIDUALS,))
    return replace(result, warnings=(*warnings, f"{poor} (kept: poor fit accepted)")) if poor else result


def determined_values(values: np.ndarray, W: np.ndarray, factor: np.ndarray,
                      ratio: float = DETERMINED) -> np.ndarray:
    """The parameters' values along the combinations the measurements determine, zero along the others.

    In units of the prior (``u = P⁻¹ θ``, ``Σ₀ = P Pᵀ``), the whitened regressor ``A = W P`` has
    singular values ``s_i`` and right vectors ``v_i``; along ``v_i`` the σ after the measurements is
    ``1 / √(1 + s_i²)`` of the prior's. The estimate's components along the ``v_i`` where that ratio
    is at most ``ratio`` (``s_i ≥ √(1/ratio² − 1)``: √8 for a third) are kept; along the others the
    start's values stay (zero).

    Args:
        values: The estimate (the start's deviations, the model's order), (n,).
        W: The measurements' whitened regressor there, (m, n).
        factor: The prior's factor P, (n, n), lower triangular.
        ratio: The largest σ after the measurements, over the prior's, of a determined combination.
    """
    _, s, Vt = np.linalg.svd(W @ factor, full_matrices=False)
    kept = Vt[s >= math.sqrt(1.0 / ratio**2 - 1.0)]
    u = solve_triangular(factor, values, lower=True)
    return factor @ (kept.T @ (kept @ u))


#: s0² beyond which a printer's fit is poor whatever its tolerances: residuals 5 times the σ given. A
#: printed object's scatter gives 3-4 (docs/printers.md, the real V400 runs); a probe height off by a
#: millimetre, another printer's data or a wrong trigger height give tens to thousands.
PRINTER_POOR_FIT = 25.0


#: A tolerances' scale within this factor of the largest searched is at the limit.
AT_LIMIT = 1.1


def poor_fit(variance_factor: float, at_limit: bool) -> str:
    """Why a printer's fit is poor, in one line ("" when it is not).

    Poor: s0² above :data:`PRINTER_POOR_FIT` (the misfit the noise factors did not take), or the
    tolerances' scale at the largest searched (:data:`AT_LIMIT`): the measurements fit no printer
    within four times a kit's tolerances, whatever s0² the geometry so bent leaves. A misfit that
    looks like noise goes to the noise factors (:func:`~.evidence.evidence_scales`) and is said
    there; one that looks like a printer far out of its tolerances is refused here.
    """
    if not (variance_factor > PRINTER_POOR_FIT or at_limit):
        return ""
    if at_limit:
        why = (f"the measurements fit no printer within {SCALE_RANGE[1]:g} times the build tolerances (s0² "
               f"{variance_factor:.3g})")
    else:
        why = (f"s0² = {variance_factor:.3g} (residuals {math.sqrt(variance_factor):.2g} times the σ given), "
               "far beyond what the measurements' noise gives")
    return (f"a poor fit: {why}: a probe biased across the bed, a bed that moved between the points, a wrong "
            "trigger height (z_offset), or another printer's data?")


def stated_covariance(W: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """The parameters' covariance after the measurements under the prior ``factor factorᵀ`` (n, n).

    The measurements' whitened regressor ``W`` at the fit (its noise factors in it) with the prior of
    the build tolerances as stated, not scaled by the evidence: whether the measurements determine a
    firmware value (:func:`~.where.firmware_determination`) is judged against the tolerances the
    owner stated. Against the evidence-scaled ones a well-built printer's narrow prior (scale 0.15)
    left values the 40 distances fix "undetermined" (a delta radius at 0.38 of that narrow σ, kept
    at the start by ``export``: 0.036 -> 0.066 mm). The fit's own posterior against the stated σ
    would not do: at scale 0.15 every value's σ is at most 0.15 of its stated one, measured or not.
    """
    n = factor.shape[0]
    _, _, Rinv = solve_wls(np.vstack([W @ factor, np.eye(n)]), np.zeros(W.shape[0] + n))
    return factor @ (Rinv @ Rinv.T) @ factor.T


def build_sigma(model: ErrorModel, tolerances: Tolerances) -> np.ndarray:
    """Each parameter's σ from the build tolerances alone: the bed's free tilt and height left out (n,).

    The priors' σ of the bed's tilt and height (:data:`~.errormodels.BED_TILT`, ``BED_HEIGHT``) say
    where a bed may sit, not how well a printer is built: with them, any probe height would
    "determine" every endstop and lean.
    """
    bed = model.prior_sigma(scaled_tolerances(tolerances, 0.0))  # the bed's alone
    return np.sqrt(np.clip(model.prior_sigma(tolerances) ** 2 - bed**2, 0.0, None))


def measured_points(geometry: DeltaGeometry, data: PrinterMeasurements) -> np.ndarray:
    """Where the nozzle was at every measurement's readings [mm], (K, 3)."""
    readings = np.concatenate([data.probe, data.pairs.reshape(-1, 3), data.positions])
    return exact.forward(geometry, readings).point(geometry.tool)


def measured_top(geometry: DeltaGeometry, data: PrinterMeasurements) -> float:
    """The highest the nozzle was at a measurement [mm]."""
    return float(np.max(measured_points(geometry, data)[:, 2]))


#: The height of :func:`default_volume` [mm].
DEFAULT_HEIGHT = 200.0


def default_volume(geometry: DeltaGeometry, data: PrinterMeasurements) -> Workspace:
    """The printable volume when none is given: the measurements' radius, :data:`DEFAULT_HEIGHT` high."""
    radius = float(np.max(np.hypot(*measured_points(geometry, data)[:, :2].T)))
    return Workspace(radius=radius, height=DEFAULT_HEIGHT, top_z=DEFAULT_HEIGHT)


def scaled_tolerances(tolerances: Tolerances, scale: float) -> Tolerances:
    """Every σ of ``tolerances`` times ``scale``."""
    return dataclasses.replace(tolerances, **{f.name: getattr(tolerances, f.name) * scale
                                              for f in dataclasses.fields(tolerances)})


def _map_fit(start: DeltaGeometry, data: PrinterMeasurements, error_model: ErrorModel, factor: np.ndarray,
             method: Method) -> tuple[np.ndarray, DeltaGeometry, np.ndarray, np.ndarray, int]:
    """The most probable parameters with the prior ``N(0, factor factorᵀ)``.

    Returns:
        The values, the geometry, the whitened residuals and regressor there, the steps made.
    """
    total = np.zeros(error_model.size)
    geometry = start
    r, W, _ = residuals_and_regressor(start, error_model, data)
    iterations = 0
    while iterations < (1 if method == "linear" else MAX_ITERATIONS):
        iterations += 1
        whitened = np.vstack([W @ factor, np.eye(factor.shape[0])])  # in units of the prior
        step, _, _ = solve_wls(whitened, np.concatenate([r, -solve_triangular(factor, total, lower=True)]))
        step = factor @ step
        for _ in range(HALVINGS):  # a step that leaves a reading unassembled is halved
            try:
                geometry = error_model.apply(start, total + step)
                r, W, _ = residuals_and_regressor(geometry, error_model, data)
                break
            except AssemblyError:
                step = 0.5 * step
        else:
            raise ConvergenceError(f"the fit left the readings unassembled after {HALVINGS} halvings of "
                                   "its step (a measurement far from the others?)", float("nan"))
        total = total + step
        if np.max(np.abs(step)) < STEP_TOLERANCE:
            break
    return total, geometry, r, W, iterations


def _tolerance_scale(start: DeltaGeometry, data: PrinterMeasurements, error_model: ErrorModel,
                     given: Tolerances, options: PrinterFitOptions) -> tuple[float, np.ndarray, str]:
    """The tolerances' factor the fit takes, each kind's noise factor s0² (3,), and how the first was chosen.

    Both from the evidence (:func:`~.evidence.evidence_scales`), linearised at the fit with the
    tolerances as given (or as asked); a scale asked is taken as it is, the s0² found for it. The
    factors are by kind: probe heights, distances, positions (1 for a kind without rows).
    """
    asked = options.tolerance_scale != "evidence"
    start_scale = float(options.tolerance_scale) if asked else 1.0
    calibrated = calibrated_values(options.calibrated_start, data.distance.size, error_model)
    factor = error_model.prior_factor(scaled_tolerances(given, start_scale), start, calibrated)
    total, _, r, W, _ = _map_fit(start, data, error_model, factor, options.method)
    _, _, kind = residuals_and_regressor(start, error_model, data)
    y = r + W @ total  # the measurements about the estimate, in its linearisation
    def factor_of(s: float) -> np.ndarray:
        return error_model.prior_factor(scaled_tolerances(given, s), start, calibrated)

    scale, rows = evidence_scales(y, W, factor_of, kind, (start_scale, start_scale) if asked else SCALE_RANGE)
    noise = np.ones(3)
    noise[kind] = rows
    return scale, noise, "as asked" if asked else "the scale the measurements make most probable"


def with_noise(data: PrinterMeasurements, noise: np.ndarray) -> PrinterMeasurements:
    """The measurements with each kind's σ times the square root of its noise factor s0² (3,)."""
    factor = np.sqrt(np.asarray(noise, dtype=float))
    return dataclasses.replace(data, height_sigma=data.height_sigma * float(factor[0]),
                               distance_sigma=data.distance_sigma * float(factor[1]),
                               position_sigma=data.position_sigma * float(factor[2]))


def _noise_hints(data: PrinterMeasurements, noise: np.ndarray) -> list[str]:
    """The kinds of measurement whose misfit the evidence takes as more than their σ given, in words."""
    words = []
    for k, (what, rows) in enumerate((("probe heights", data.probe.shape[0]),
                                      ("distances", data.distance.shape[0]),
                                      ("positions", data.positions.shape[0]))):
        if rows and noise[k] > 1.0 + 1e-6:
            factor = math.sqrt(noise[k])
            words.append(f"the {what}' σ taken as {factor:.3g} times the σ given ({data.sigma[k]:g} mm -> "
                         f"{data.sigma[k] * factor:.3g} mm, with the tolerances' scale: their misfit is more "
                         "than the instruments' noise, what no model of the printer holds)")
    return words


def measurement_of_rows(data: PrinterMeasurements) -> np.ndarray:
    """The measurement of each row (probe heights, then distances, then positions: 3 rows each), (m,)."""
    N, M, K = data.probe.shape[0], data.distance.shape[0], data.positions.shape[0]
    return np.concatenate([np.arange(N + M), N + M + np.repeat(np.arange(K), 3)]).astype(int)


def measurements_kept(data: PrinterMeasurements, kept: np.ndarray) -> PrinterMeasurements:
    """The measurements of the mask ``kept`` (over :func:`measurement_of_rows`' measurements) alone.

    An instrument's positions are kept whole when fewer than 3 would be left (its frame needs 3).
    """
    N, M = data.probe.shape[0], data.distance.shape[0]
    positions = kept[N + M:]
    if 0 < int(positions.sum()) < 3:
        positions = np.ones_like(positions)
    return dataclasses.replace(data, probe=data.probe[kept[:N]], pairs=data.pairs[kept[N:N + M]],
                               distance=data.distance[kept[N:N + M]], positions=data.positions[positions],
                               measured=data.measured[positions],
                               trigger_height=data.trigger_height[kept[:N]])


def printer_outliers(start: DeltaGeometry, data: PrinterMeasurements, model: str | ErrorModel = "printer",
                     options: PrinterFitOptions | None = None) -> Outliers:
    """The measurements that do not fit the others (:func:`~.outliers.find_outliers`).

    Each trial fit is :func:`identify_printer`'s (the tolerances' scale chosen again without the
    suspects), and every row is tested about it.

    Args:
        start: The nominal printer.
        data: The measurements.
        model: The error model.
        options: How to fit (default: :class:`PrinterFitOptions`' defaults).

    Returns:
        The outliers (indices over :func:`measurement_of_rows`' measurements) and every row's whitened
        residual about the fit without them.
    """
    options = options or PrinterFitOptions()
    error_model = get_model(model) if isinstance(model, str) else model
    given = options.tolerances or kit_tolerances(error_model)

    def fit(kept: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        subset = measurements_kept(data, kept)
        scale, noise, _ = _tolerance_scale(start, subset, error_model, given, options)
        calibrated = calibrated_values(options.calibrated_start, data.distance.size, error_model)
        factor = error_model.prior_factor(scaled_tolerances(given, scale), start, calibrated)
        total, geometry = _map_fit(start, with_noise(subset, noise), error_model, factor, options.method)[:2]
        r, W, _ = residuals_and_regressor(geometry, error_model, data)
        return r, W @ factor, solve_triangular(factor, total, lower=True)

    _, _, kind = residuals_and_regressor(start, error_model, data)
    return find_outliers(fit, measurement_of_rows(data), kind)
