"""How wide the priors of a fit should be: the tolerances' scale its measurements make most probable.

A fit with priors (each parameter zero ± its build tolerance) is only as good as those
tolerances: too wide, the combinations the measurements barely see take the measurements' noise;
too narrow, the fit cannot follow the robot. The user rarely knows which class their robot is
in. The measurements say it: for the linearised model ``y = W θ + e`` (whitened rows, ``e ~ N(0, I)``)
and the prior ``θ ~ N(0, diag(s σ)²)``, the probability of ``y`` given ``s`` (the evidence, or
type-II likelihood, MacKay 1992) is

``log p(y | s) = −½ yᵀ C⁻¹ y − ½ log det C + const``, with ``C = I + W diag(s σ)² Wᵀ``,

computed in the parameters' space (Woodbury: ``M = I + D WᵀW D``, ``D = diag(s σ)``,
``yᵀ C⁻¹ y = yᵀy − bᵀ M⁻¹ b`` with ``b = D Wᵀ y``, ``det C = det M``). :func:`evidence_scale`
maximises it over one common factor of the tolerances: a log grid, then a golden-section search
between the grid's neighbours of its best point (deterministic: no random start, and a tie on the
grid goes to the smaller scale).

The measurements' σ are the instruments' (a probe's repeatability, a caliper's), but a printer's
data also carry what no model holds (a probe that triggers differently across the bed, a bed that
is not flat, a print that shrank): a misfit larger than the σ given. With the noise fixed at the
σ given, the evidence can only explain it by wider tolerances, and the combinations the
measurements barely see then drift by millimetres to fit it. :func:`evidence_scales` estimates a
noise factor ``s0²`` per kind of measurement (probe heights, distances: different instruments)
with the tolerances' scale: ``e ~ N(0, S)``, ``S = diag(s0²)`` of each row's kind, so
``C = S + W diag(s σ)² Wᵀ``: a misfit the priors' shapes do not explain raises its kind's ``s0²``,
not ``s``. Each ``s0²`` is at least 1 (the data are never taken as better than the σ given).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

#: The scales searched, a factor of the given tolerances: from 1/200 to 4 times.
SCALE_RANGE = (0.005, 4.0)
#: Points of the log grid over :data:`SCALE_RANGE`.
GRID_POINTS = 31
#: Golden-section steps after the grid (the bracket shrinks by 0.618 each: to 1e-6 of a grid step).
REFINE_STEPS = 30
#: The noise's factors ``s0²`` searched: from the σ given (1) to residuals 300 times them.
NOISE_RANGE = (1.0, 1e5)
#: Expectation-maximisation steps of the noise factors at most, and the change of their log that ends them.
NOISE_ITERATIONS = 200
NOISE_TOLERANCE = 1e-6
#: The tolerances' scale before the measurements: log-normal, its median and its spread (a factor).
SCALE_PRIOR = (0.3, 3.0)
#: How many rows of evidence the σ given counts as, for each kind's noise factor.
NOISE_PRIOR_ROWS = 10.0


def log_evidence(y: np.ndarray, W: np.ndarray, prior: np.ndarray) -> float:
    """Log probability of whitened measurements ``y`` (m,) under ``y = W θ + e``, θ ~ N(0, diag(prior²)).

    Up to a constant that does not depend on ``prior``. W (m, n) and y whitened (each row divided by
    its σ); prior (n,) positive.
    """
    Wd = W * prior
    M = np.eye(prior.size) + Wd.T @ Wd
    L = np.linalg.cholesky(M)
    c = np.linalg.solve(L, Wd.T @ y)
    return float(-0.5 * (y @ y - c @ c) - np.sum(np.log(np.diag(L))))


def evidence_scale(y: np.ndarray, W: np.ndarray, prior_of: Callable[[float], np.ndarray],
                   bounds: tuple[float, float] = SCALE_RANGE) -> float:
    """The common factor ``s`` of the tolerances that makes the measurements most probable.

    Args:
        y: Whitened measurements about the linearisation point, (m,) (for a fit linearised at
            its estimate θ̂: the residuals plus ``W θ̂``).
        W: Whitened regressor, (m, n).
        prior_of: The priors' σ at a scale, (n,) (a factor that may leave some priors unscaled,
            such as a bed's free height).
        bounds: The scales searched (smallest, largest).

    Returns:
        The scale, within ``bounds``.
    """
    def value(log_s: float) -> float:
        return log_evidence(y, W, prior_of(math.exp(log_s)))

    return math.exp(_maximum(value, math.log(bounds[0]), math.log(bounds[1]))[0])


def _maximum(value: Callable[[float], float], lo: float, hi: float) -> tuple[float, float]:
    """The argument in [lo, hi] where ``value`` is largest, and its value: a grid then golden sections.

    Deterministic: a tie on the grid goes to the smaller argument.
    """
    grid = np.linspace(lo, hi, GRID_POINTS)
    values = np.array([value(g) for g in grid])
    best = int(np.argmax(values))
    a_lo, a_hi = grid[max(best - 1, 0)], grid[min(best + 1, GRID_POINTS - 1)]
    golden = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = a_hi - golden * (a_hi - a_lo), a_lo + golden * (a_hi - a_lo)
    fa, fb = value(a), value(b)
    for _ in range(REFINE_STEPS):
        if fa >= fb:
            a_hi, b, fb = b, a, fa
            a = a_hi - golden * (a_hi - a_lo)
            fa = value(a)
        else:
            a_lo, a, fa = a, b, fb
            b = a_lo + golden * (a_hi - a_lo)
            fb = value(b)
    found = 0.5 * (a_lo + a_hi)
    at = value(found)
    return (found, at) if at >= values[best] else (float(grid[best]), float(values[best]))


def noise_factors(y: np.ndarray, W: np.ndarray, prior: np.ndarray, kind: np.ndarray,
                  noise: tuple[float, float] = NOISE_RANGE) -> tuple[np.ndarray, float]:
    """The noise factor s0² of each kind of row that makes ``y`` most probable with this prior, and its log p.

    Expectation-maximisation of the evidence over the factors (variance components): with the
    rows' covariance ``S = diag(s0²_row)`` and ``Wd = W diag(prior)``, the posterior of the
    parameters in units of their prior is ``N(μ, M⁻¹)``, ``M = I + Wdᵀ S⁻¹ Wd``, and each kind's
    factor becomes ``(|y_k − Wd_k μ|² + tr(Wd_k M⁻¹ Wd_kᵀ)) / m_k``, held within ``noise``; each step
    raises the evidence, to a change of the factors below :data:`NOISE_TOLERANCE`.

    Args:
        y: Whitened measurements (m,).
        W: Whitened regressor (m, n).
        prior: The priors' σ (n,), or the prior covariance's factor ``P`` (``Σ = P Pᵀ``), (n, n).
        kind: Each row's kind (m,): the rows of a kind share their factor.
        noise: The factors' range (smallest, largest).

    Returns:
        ``(factor of each row (m,), log p(y))`` (log p up to a constant).
    """
    kinds, index = np.unique(kind, return_inverse=True)
    counts = np.bincount(index, minlength=kinds.size)
    Wd = W * prior if prior.ndim == 1 else W @ prior
    size = Wd.shape[1]
    factor = np.ones(kinds.size) * noise[0]
    for _ in range(NOISE_ITERATIONS):
        weight = 1.0 / factor[index]
        L = np.linalg.cholesky(np.eye(size) + Wd.T @ (Wd * weight[:, None]))
        b = Wd.T @ (weight * y)
        mu = np.linalg.solve(L.T, np.linalg.solve(L, b))
        spread = np.sum(np.linalg.solve(L, Wd.T) ** 2, axis=0)  # diag(Wd M⁻¹ Wdᵀ)
        residual = y - Wd @ mu
        expected = np.bincount(index, residual**2 + spread, minlength=kinds.size)
        found = np.clip((NOISE_PRIOR_ROWS + expected) / (NOISE_PRIOR_ROWS + counts + 2.0), *noise)
        if np.max(np.abs(np.log(found / factor))) < NOISE_TOLERANCE:
            factor = found
            break
        factor = found
    weight = 1.0 / factor[index]
    L = np.linalg.cholesky(np.eye(size) + Wd.T @ (Wd * weight[:, None]))
    c = np.linalg.solve(L, Wd.T @ (weight * y))
    value = -0.5 * (float(weight @ y**2) - float(c @ c)) - float(np.sum(np.log(np.diag(L)))) \
        - 0.5 * float(np.sum(np.log(factor[index])))
    # the σ given as NOISE_PRIOR_ROWS rows: an inverse-gamma density of each factor, its mode at 1
    value += float(np.sum(-(0.5 * NOISE_PRIOR_ROWS + 1.0) * np.log(factor) - 0.5 * NOISE_PRIOR_ROWS / factor))
    return factor[index], value


def evidence_scales(y: np.ndarray, W: np.ndarray, prior_of: Callable[[float], np.ndarray], kind: np.ndarray,
                    bounds: tuple[float, float] = SCALE_RANGE,
                    noise: tuple[float, float] = NOISE_RANGE) -> tuple[float, np.ndarray]:
    """The tolerances' scale ``s`` and each row's noise factor ``s0²`` that make the measurements likeliest.

    Args:
        y: Whitened measurements about the linearisation point, (m,) (see :func:`evidence_scale`).
        W: Whitened regressor (each row divided by the σ given), (m, n).
        prior_of: The priors' σ at a scale, (n,), or their covariance's factor (n, n).
        kind: Each row's kind (m,) (a printer's: probe height, distance, position coordinate): the
            rows of a kind share one factor (:func:`noise_factors`).
        bounds: The scales searched (smallest, largest); one value (``(s, s)``): the scale is given,
            the noise factors alone are found.
        noise: The noise factors searched (smallest, largest).

    Returns:
        ``(s, s0² of each row (m,))``: the most probable prior is ``prior_of(s)``, a row's σ the one
        given times its ``s0``.
    """
    if bounds[0] == bounds[1]:
        return float(bounds[0]), noise_factors(y, W, prior_of(bounds[0]), kind, noise)[0]

    def value(log_s: float) -> float:
        hyper = -0.5 * ((log_s - math.log(SCALE_PRIOR[0])) / math.log(SCALE_PRIOR[1])) ** 2
        return noise_factors(y, W, prior_of(math.exp(log_s)), kind, noise)[1] + hyper

    found, _ = _maximum(value, math.log(bounds[0]), math.log(bounds[1]))
    scale = math.exp(found)
    return scale, noise_factors(y, W, prior_of(scale), kind, noise)[0]
