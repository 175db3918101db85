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
from dataclasses import dataclass, field
from typing import Literal, TypedDict, Unpack, get_args

import numpy as np

from ...errormodels import ErrorModel, get_model
from ...exceptions import AssemblyError, ConvergenceError
from ...geometry import DeltaGeometry, Tolerances
from ...identifiability import BaseParameters, base_parameters
from ...identification.columns import build_columns
from ...identification.options import Method
from ...identification.result import IdentificationResult, ResidualStats
from ...identification.solver import solve_wls
from ...kinematics import exact
from ...observations import rigid_alignment
from ...options import with_overrides
from ...rotations import skew
from .evidence import SCALE_RANGE, evidence_scale
from .outliers import Outliers, find_outliers

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


def _point_rows(geometry: DeltaGeometry, model: ErrorModel, q: np.ndarray, local: np.ndarray):
    """A plate point in {O} at readings q and its sensitivity to the model's parameters, (N, 3, n)."""
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)
    arm = pose.rotation @ local  # (N, 3)
    point = pose.position + arm
    return point, S[:, :3] - np.einsum("nkl,nlp->nkp", skew(arm), S[:, 3:])


def residuals_and_regressor(
    geometry: DeltaGeometry, model: ErrorModel, data: PrinterMeasurements
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whitened residuals (measured − model) and regressor at ``geometry``, and the kind of each row.

    Returns:
        r (m,), W (m, n) (both divided by each row's σ) and kind (m,): 0 probe height, 1 distance,
        2 a coordinate of a measured position.
    """
    tool = geometry.tool
    z, Jz = _point_rows(geometry, model, data.probe, tool + data.probe_offset)
    rows = [((data.trigger_height - z[:, 2]) / data.height_sigma, Jz[:, 2] / data.height_sigma)]
    if data.distance.size:
        M = data.distance.shape[0]
        p, J = _point_rows(geometry, model, data.pairs.reshape(-1, 3), tool)
        p, J = p.reshape(M, 2, 3), J.reshape(M, 2, 3, -1)
        d = p[:, 0] - p[:, 1]
        norm = np.linalg.norm(d, axis=1)
        u = d / norm[:, None]
        Jd = np.einsum("mk,mkp->mp", u, J[:, 0] - J[:, 1])
        rows.append(((data.distance - norm) / data.distance_sigma, Jd / data.distance_sigma))
    if data.positions.size:
        p, J = _point_rows(geometry, model, data.positions, tool)
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
    prior = error_model.prior_sigma(tolerances or Tolerances.printer_kit())
    determined = int(np.sum(np.linalg.svd(W * prior, compute_uv=False) > 1.0))
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
    prior = error_model.prior_sigma(tolerances or Tolerances.printer_kit())
    _, _, Rinv = solve_wls(np.vstack([W * prior, np.eye(prior.size)]), np.zeros(W.shape[0] + prior.size))
    return prior, np.sqrt(np.sum(Rinv**2, axis=1)) * prior


@dataclass(frozen=True)
class PrinterFitOptions:
    """How to fit a printer (:func:`identify_printer`): one value, checked once.

    Attributes:
        method: ``"linear"`` (one step at the start) or ``"iterated"`` (to convergence).
        tolerances: The build tolerances (None: :meth:`Tolerances.printer_kit`).
        tolerance_scale: ``"evidence"`` (the measurements choose it) or a factor applied to every
            tolerance (1: as given).

    Raises:
        ValueError: a method or scale out of its range (the message names the field and value).
        TypeError: tolerances that are not a :class:`~deltacal.geometry.Tolerances`.
    """

    method: Method = "iterated"
    tolerances: Tolerances | None = None
    tolerance_scale: float | Literal["evidence"] = "evidence"

    def __post_init__(self) -> None:
        if self.method not in get_args(Method):
            raise ValueError(f"method must be 'linear' or 'iterated', got {self.method!r}")
        if self.tolerances is not None and not isinstance(self.tolerances, Tolerances):
            raise TypeError(f"tolerances must be a Tolerances, got {self.tolerances!r}")
        scale = self.tolerance_scale
        if scale != "evidence" and (isinstance(scale, str) or not isinstance(scale, (int, float))
                                    or not scale > 0.0):
            raise ValueError(f"tolerance_scale must be 'evidence' or a positive factor, got {scale!r}")


class PrinterFitOverrides(TypedDict, total=False):
    """The fields of :class:`PrinterFitOptions` as keyword arguments (see there), each optional."""

    method: Method
    tolerances: Tolerances | None
    tolerance_scale: float | Literal["evidence"]


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
        posterior σ; its hints say the scale of the tolerances and what only they bound; its
        ``outliers`` the measurements that do not fit the others (:func:`printer_outliers`: probe
        heights, then distances, then positions, from 0), kept in the fit (the caller decides).
    """
    options = with_overrides(PrinterFitOptions, options, overrides)
    method = options.method
    error_model = get_model(model) if isinstance(model, str) else model
    error_model.check_fits(start)
    given = options.tolerances or Tolerances.printer_kit()
    scale, how = _tolerance_scale(start, data, error_model, given, options)
    used = scaled_tolerances(given, scale)
    prior = error_model.prior_sigma(used)
    measured = measured_combinations(start, data, error_model, used)
    r0, _, kind = residuals_and_regressor(start, error_model, data)
    total, geometry, r, W, iterations = _map_fit(start, data, error_model, prior, method)
    augmented = np.vstack([W, np.diag(1.0 / prior)])
    _, _, Rinv = solve_wls(augmented * prior, np.zeros(augmented.shape[0]))
    cov = (Rinv @ Rinv.T) * np.outer(prior, prior)
    sigma = np.sqrt(np.diag(cov))
    chi2 = float(r @ r + np.sum((total / prior) ** 2))
    variance_factor = chi2 / max(r.size - (6 if data.positions.size else 0), 1)  # the frame's 6
    flagged = printer_outliers(start, data, error_model, options)
    inlier_factor = variance_factor
    if flagged.indices.size:  # the rows of the others, about the fit without the outliers
        rows = flagged.kept[measurement_of_rows(data)]
        inlier_factor = float(flagged.residual[rows] @ flagged.residual[rows]) / max(int(rows.sum()), 1)
    held = measured.unidentifiable_names
    hints = [f"the build tolerances scaled by {scale:.3g} ({how})"]
    warnings = []
    if options.tolerance_scale == "evidence" and scale >= SCALE_RANGE[1] * (1.0 - 1e-6):
        warnings.append(f"the build tolerances scaled by {scale:.3g}, the largest searched: the measurements "
                        "fit no printer within it (a gross error in a file? the files of another printer?)")
    if held:
        hints.append(f"the measurements identify {measured.rank} of the {error_model.size} parameters' "
                     f"combinations; the build tolerances bound the other {len(held)} ({', '.join(held)})")
    return IdentificationResult(
        model=error_model.name, method=method, geometry=geometry, start=start,
        # with the priors every parameter is kept, in the model's order
        base=base_parameters(augmented, error_model.names, rtol=RANK_RTOL, prefer=error_model.names),
        values=total, sigma=sigma,
        correlation=cov / np.outer(sigma, sigma), before=_stats(r0, kind, data), after=_stats(r, kind, data),
        outliers=[int(k) for k in flagged.indices], iterations=iterations,
        variance_factor=variance_factor, inlier_variance_factor=inlier_factor,
        units=list(error_model.units), n_rows=r.size,
        residual_after=r * np.asarray(data.sigma)[kind],
        independent_rows=r.size, columns=build_columns(error_model).columns,
        hints=tuple(hints), warnings=tuple(warnings),
    )


def scaled_tolerances(tolerances: Tolerances, scale: float) -> Tolerances:
    """Every σ of ``tolerances`` times ``scale``."""
    return dataclasses.replace(tolerances, **{f.name: getattr(tolerances, f.name) * scale
                                              for f in dataclasses.fields(tolerances)})


def _map_fit(start: DeltaGeometry, data: PrinterMeasurements, error_model: ErrorModel, prior: np.ndarray,
             method: Method) -> tuple[np.ndarray, DeltaGeometry, np.ndarray, np.ndarray, int]:
    """The most probable parameters with these priors: (values, geometry, whitened r and W there, steps)."""
    total = np.zeros(error_model.size)
    geometry = start
    r, W, _ = residuals_and_regressor(start, error_model, data)
    iterations = 0
    while iterations < (1 if method == "linear" else MAX_ITERATIONS):
        iterations += 1
        whitened = np.vstack([W * prior, np.eye(prior.size)])  # in units of each tolerance
        step, _, _ = solve_wls(whitened, np.concatenate([r, -total / prior]))
        step = step * prior
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
                     given: Tolerances, options: PrinterFitOptions) -> tuple[float, str]:
    """The factor of the tolerances the fit takes, and how it was chosen (in words)."""
    if options.tolerance_scale != "evidence":
        return float(options.tolerance_scale), "as asked"
    total, _, r, W, _ = _map_fit(start, data, error_model, error_model.prior_sigma(given), options.method)
    y = r + W @ total  # the measurements about the estimate, in its linearisation
    scale = evidence_scale(y, W, lambda s: error_model.prior_sigma(scaled_tolerances(given, s)))
    return scale, "the scale the measurements make most probable"


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
    given = options.tolerances or Tolerances.printer_kit()

    def fit(kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        subset = measurements_kept(data, kept)
        scale, _ = _tolerance_scale(start, subset, error_model, given, options)
        prior = error_model.prior_sigma(scaled_tolerances(given, scale))
        geometry = _map_fit(start, subset, error_model, prior, options.method)[1]
        r, W, _ = residuals_and_regressor(geometry, error_model, data)
        return r, W * prior

    _, _, kind = residuals_and_regressor(start, error_model, data)
    return find_outliers(fit, measurement_of_rows(data), kind)
