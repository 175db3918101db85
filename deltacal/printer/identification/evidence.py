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

    grid = np.linspace(math.log(bounds[0]), math.log(bounds[1]), GRID_POINTS)
    values = np.array([value(g) for g in grid])
    best = int(np.argmax(values))  # the first of equal values: the smaller scale
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, GRID_POINTS - 1)]
    golden = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)
    fa, fb = value(a), value(b)
    for _ in range(REFINE_STEPS):
        if fa >= fb:
            hi, b, fb = b, a, fa
            a = hi - golden * (hi - lo)
            fa = value(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + golden * (hi - lo)
            fb = value(b)
    found = 0.5 * (lo + hi)
    return float(math.exp(found if value(found) >= values[best] else grid[best]))
