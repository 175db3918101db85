"""The solve phase of a fit: weighted least squares on the base parameters.

``linear``: one step around the start (Savoure 2006, Eq. 26; Bai 2015, Eq. 20). ``iterated``:
Gauss-Newton relinearised around the current estimate with the exact kinematics, each step
halved until it lowers the cost (up to 12 times), until every base parameter's step is under
1e-3 of its σ or the cost stops falling.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..exceptions import AssemblyError, ConvergenceError, GeometryError
from ..geometry import DeltaGeometry
from ..identifiability import BaseParameters
from ..observations import Rows
from .frames import InstrumentFrame
from .problem import Problem

#: Halvings of a Gauss-Newton step at most.
HALVINGS = 12


def solve_wls(Ww: np.ndarray, rw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares by QR: solution, Q, and the inverse of R (covariance ``R⁻¹ R⁻ᵀ``)."""
    Q, R = np.linalg.qr(Ww)
    x = scipy.linalg.solve_triangular(R, Q.T @ rw, check_finite=False)
    Rinv = scipy.linalg.solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
    return x, Q, Rinv


@dataclass(frozen=True)
class Solution:
    """Where a fit ended.

    Attributes:
        geometry: The identified geometry.
        frames: The identified instrument frames (empty without free frames).
        rows: The rows at the identified geometry and frames.
        values: The base parameters' total step from the start (units of each kept parameter).
        iterations: Steps taken (1 for linear).
        covariance_rows: The rows whose regressor gives the covariance: the start's for
            ``linear`` (the one regressor used), the end's for ``iterated``.
    """

    geometry: DeltaGeometry
    frames: dict[str, InstrumentFrame]
    rows: Rows
    values: np.ndarray
    iterations: int
    covariance_rows: Rows = field(repr=False)


@dataclass(frozen=True)
class _State:
    geometry: DeltaGeometry
    frames: dict[str, InstrumentFrame]
    rows: Rows
    cost: float


def _halved_step(problem: Problem, base: BaseParameters, state: _State, total: np.ndarray,
                 step: np.ndarray) -> tuple[_State | None, float, int]:
    """The first of ``step``, ``step/2``, ... that lowers the cost: (new state or None, t, assembled).

    The geometry is the start moved by the total (``total + t step``), as the calibration file
    holds it (its base parameters moved from its nominal): composing the steps instead drifted
    from that sum by up to 4e-5 rad with encoder offsets of 20°. The frames compose their steps.
    """
    t = 1.0
    assembled = 0
    for _ in range(HALVINGS):
        try:
            trial, _ = problem.moved(problem.start, state.frames, base.expand(total + t * step))
            _, trial_frames = problem.moved(state.geometry, state.frames, base.expand(t * step))
            trial_rows = problem.rows_at(trial, trial_frames)
        except (AssemblyError, GeometryError):
            t *= 0.5
            continue
        assembled += 1
        trw = trial_rows.weighted[0]
        trial_cost = float(trw @ trw)
        if trial_cost <= state.cost * (1.0 + 1e-12):
            return _State(trial, trial_frames, trial_rows, trial_cost), t, assembled
        t *= 0.5
    return None, t, assembled


def solve_linear(problem: Problem, base: BaseParameters, rows: Rows) -> Solution:
    """One weighted least-squares step around the start (the papers' identification)."""
    rw, Ww = rows.weighted
    step = solve_wls(Ww[:, base.base], rw)[0]
    geometry, frames = problem.moved(problem.start, problem.frames, base.expand(step))
    return Solution(geometry, frames, problem.rows_at(geometry, frames), step, 1, rows)


def solve_iterated(problem: Problem, base: BaseParameters, rows: Rows) -> Solution:
    """Gauss-Newton with step halving from the start.

    Raises:
        ConvergenceError: not one trial geometry of the first step could be assembled, or no
            convergence in ``max_iter`` iterations (with the residual reached).
    """
    rw, Ww = rows.weighted
    state = _State(problem.start, problem.frames, rows, float(rw @ rw))
    total = np.zeros(base.rank)
    max_iter = problem.options.max_iter
    for iterations in range(1, max_iter + 1):
        step, _, Rinv = solve_wls(Ww[:, base.base], rw)
        sigma_step = np.sqrt(np.sum(Rinv**2, axis=1))
        new, t, assembled = _halved_step(problem, base, state, total, step)
        if new is None:
            # no step lowers the cost: the current geometry is the minimum (kept as it is),
            # unless no trial geometry could even be assembled
            if iterations == 1 and assembled == 0:
                raise ConvergenceError(
                    "identification could not take a single step: every trial geometry failed to "
                    f"assemble at the measured readings (weighted residual {math.sqrt(state.cost):.6g})",
                    math.sqrt(state.cost),
                )
            break
        previous, state, total = state.cost, new, total + t * step
        rw, Ww = state.rows.weighted
        small_step = np.all(np.abs(t * step) <= 1e-3 * sigma_step)
        if small_step or previous - state.cost <= 1e-12 * max(previous, 1.0):
            break
    else:
        stats = problem.stats(state.geometry, state.rows)
        rms = stats.distance_rms if problem.options.distances else stats.position_rms
        raise ConvergenceError(
            f"identification did not converge in {max_iter} Gauss-Newton iterations "
            f"(residual RMS {rms:.6g} mm, weighted residual {math.sqrt(state.cost):.6g}): "
            "check the measurements for gross errors",
            rms,
        )
    return Solution(state.geometry, state.frames, state.rows, total, iterations, state.rows)


def solve(problem: Problem, base: BaseParameters, rows: Rows) -> Solution:
    """The fit's solution by the problem's method, from the rows at the start."""
    if problem.options.method == "linear":
        return solve_linear(problem, base, rows)
    return solve_iterated(problem, base, rows)
