"""The summarise phase of a fit: covariance, statistics, outliers, the frames' covariance, gauge.

The covariance of the base parameters is ``(Wᵀ W)⁻¹`` of the weighted base regressor (a priori
σ of the measurements; Savoure 2006, Eq. 27), computed as ``R⁻¹ R⁻ᵀ`` from its QR; the a
posteriori variance factor is ``s0² = χ² / (m − r)``. Outliers are tested row group by row
group (:func:`.outliers.data_snooping`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .choice import Choice
from .frames import InstrumentFrame, to_axes_gauge
from .outliers import data_snooping
from .problem import Problem
from .result import IdentificationResult, ResidualStats
from .solver import Solution, solve_wls


def base_covariance(solution: Solution, kept: list[int]) -> np.ndarray:
    """Covariance of the base parameters, ``(Wᵀ W)⁻¹`` of the weighted base regressor.

    Args:
        solution: The fit's solution (its ``covariance_rows`` give ``W``).
        kept: The base parameters' columns.

    Returns:
        The covariance, shape (r, r), in the units of each kept parameter.
    """
    rw, Ww = solution.covariance_rows.weighted
    Rinv = solve_wls(Ww[:, kept], rw)[2]
    return Rinv @ Rinv.T


def frames_covariance(
    problem: Problem, frames: dict[str, InstrumentFrame], kept: list[int], cov: np.ndarray
) -> dict[str, InstrumentFrame]:
    """Each frame with its covariance: its kept parameters' block (a dropped one stays at zero)."""
    n, n_model = len(problem.columns), problem.columns.n_model
    full_cov = np.zeros((n, n))
    full_cov[np.ix_(kept, kept)] = cov
    return {
        s: replace(f, covariance=full_cov[n_model + 6 * k : n_model + 6 * k + 6,
                                          n_model + 6 * k : n_model + 6 * k + 6])
        for k, (s, f) in enumerate(frames.items())
    }


def _equations(rows) -> int:
    """The number of equations the rows stand for (distances of all pairs: the pairs)."""
    return rows.residual.size if rows.distances is None else rows.distances


def summarise(
    problem: Problem, choice: Choice, solution: Solution, before: ResidualStats
) -> IdentificationResult:
    """The result of a fit: values, σ, correlations, statistics, outliers, frames and gauge.

    Args:
        problem: The problem fitted.
        choice: Its base parameters.
        solution: Where the fit ended.
        before: Residual statistics at the start.

    Returns:
        The result.
    """
    base, kept, rows = choice.base, choice.base.base, solution.rows
    cov = base_covariance(solution, kept)
    sigma = np.sqrt(np.diag(cov))
    rw = rows.weighted[0]
    variance_factor = float(rw @ rw) / max(rows.independent - base.rank, 1)
    # outliers are tested row group by row group, on the rows before whitening
    rs, Ws = rows.scaled
    flagged = data_snooping(Ws[:, kept], rs, rows.measurement, rows.kind, rows.shared, rows.nuisance)
    # the fit's quality without the outliers (they are named on their own; distances mix rows)
    inlier_factor = variance_factor
    if flagged.size and rows.shared is None and rows.nuisance is None:
        inliers = ~np.isin(rows.measurement, flagged)
        inlier_factor = float(rs[inliers] @ rs[inliers]) / max(int(inliers.sum()) - base.rank, 1)
    geometry, frames, gauge = solution.geometry, solution.frames, (0.0, 0.0)
    if frames:
        frames = frames_covariance(problem, frames, kept, cov)
        if problem.options.axes_gauge:
            geometry, frames, shift, turn = to_axes_gauge(problem.start, geometry, frames)
            gauge = (shift, turn)
    columns = problem.columns.columns
    return IdentificationResult(
        model=problem.model.name, method=problem.options.method, geometry=geometry, start=problem.start,
        base=base, values=solution.values, sigma=sigma, correlation=cov / np.outer(sigma, sigma),
        before=before, after=problem.stats(solution.geometry, rows), outliers=[int(k) for k in flagged],
        iterations=solution.iterations, variance_factor=variance_factor,
        units=[columns[k].unit for k in kept], n_rows=_equations(solution.covariance_rows),
        independent_rows=rows.independent,
        residual_after=rows.residual, hints=choice.hints, frames=frames, gauge_motion=gauge,
        absorbed=choice.absorbed, inlier_variance_factor=inlier_factor, confounded=choice.confounded,
        columns=columns,
    )
