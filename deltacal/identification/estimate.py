"""Identification of a robot's geometry from measurements.

Weighted least squares on the base parameters (Savoure 2006, Eq. 23-26;
Bai 2015, Eq. 17 and 20), with two methods:

* ``linear``: one shot around the nominal geometry, as in the papers;
* ``iterated`` (default): Gauss-Newton relinearised around the current estimate
  with the exact kinematics, with step halving, until the step is below the
  noise (every base parameter's step under 1e-3 of its σ). It recovers encoder
  offsets of a degree and more in one call.

A fit is four phases, each a function of typed values: build (:func:`.problem.build_problem`:
the columns, one :class:`~.columns.Column` per parameter), choose (:func:`.choice.choose`: the
base parameters, from the column-scaled pivoted QR of the weighted regressor at the start, and
what the frames absorb; parameters outside the base stay at their starting value, their effect
folded into the base ones), solve (:func:`.solver.solve`) and summarise
(:func:`.summary.summarise`: covariance ``(Wᵀ W)⁻¹`` of the weighted base regressor, a priori σ
of the measurements; the variance factor ``s0² = χ²/(m − r)`` says whether those σ were right).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Unpack

import numpy as np

from ..errormodels import ErrorModel, get_model
from ..exceptions import AssemblyError
from ..geometry import DeltaGeometry
from ..kinematics import exact
from ..observations import POSITION, Measurements, Rows
from .choice import choose
from .frames import initial_frames
from .offsets import encoder_offsets
from .options import FitOptions, FitOverrides, fit_options
from .problem import Problem, build_problem
from .result import IdentificationResult
from .review import Data, review
from .solver import solve
from .summary import summarise


def identify(
    start: DeltaGeometry,
    measurements: Measurements,
    model: str | ErrorModel = "complete",
    *,
    options: FitOptions | None = None,
    **overrides: Unpack[FitOverrides],
) -> IdentificationResult:
    """Identify the geometry of a robot from measurements, and refuse a fit that cannot be right.

    The fit is :func:`fit`; then its residuals are tested against the σ given and its
    deviations for plausibility (:func:`.review.review`). When they fail, the same data are
    fitted under other readings (orientations in radians, another point, swapped labels, an
    instrument frame) and with the complete model, to name the likely causes.

    Args:
        start: Nominal geometry (the linearisation point of the first step).
        measurements: Readings and measured positions (and orientations).
        model: Error model or its name.
        options: How to fit (:class:`FitOptions`; default: its defaults).
        **overrides: Fields of :class:`FitOptions` by name (``method="linear"``,
            ``sigma_position=0.005`` [mm], ``accept_poor_fit=True``: return a poor fit instead of
            raising, its ``warnings`` saying why, ...); they win over the same fields of
            ``options``.

    Returns:
        The result, holding the identified geometry.

    Raises:
        TypeError: an override that names no option, or ``options`` not a :class:`FitOptions`.
        ValueError: an option out of range, or options that do not go together.
        PoorFitError: the fit is far from the σ given or implausible (unless ``accept_poor_fit``).
        IdentificationError, AssemblyError, ConvergenceError: see :func:`fit`.
    """
    options = fit_options(options, overrides)
    error_model = get_model(model) if isinstance(model, str) else model
    result = fit(start, measurements, error_model, options=options)
    return review(result, start, error_model, Data(measurements, options), fit)


#: Encoder offsets found first (:mod:`.offsets`) below these [rad] leave the start as it is: the
#: base parameters are chosen at the start (the papers' way, and every figure of docs/results.md).
#: With free frames what they absorb depends on the offsets from about 1°; in {O} the choice
#: does not, only the start's plausibility check (its residuals grow with the offsets: 87 mm at
#: 8° read as wrong units).
OFFSETS_FIRST = {"free": math.radians(1.0), "base": math.radians(5.0)}


def fit(
    start: DeltaGeometry,
    measurements: Measurements,
    model: str | ErrorModel = "complete",
    *,
    options: FitOptions | None = None,
    **overrides: Unpack[FitOverrides],
) -> IdentificationResult:
    """Fit the geometry of a robot to measurements (weighted least squares, base parameters).

    Build (:func:`.problem.build_problem`), choose (:func:`.choice.choose`), solve
    (:func:`.solver.solve`), summarise (:func:`.summary.summarise`).

    Args:
        start: Nominal geometry (the linearisation point of the first step).
        measurements: Readings and measured positions (and orientations).
        model: Error model or its name (see :data:`deltacal.errormodels.MODEL_NAMES`).
        options: How to fit (:class:`FitOptions`: the method, the σ of the measurements,
            distances, the rank tolerance, the frame, free points, compliances...; default:
            its defaults).
        **overrides: Fields of :class:`FitOptions` by name (``method="linear"``,
            ``frame="free"``, ``free_points=["smr"]``, ...); they win over the same fields of
            ``options``. With ``free_points``, the measured plate points (reflectors) whose
            position on the plate is identified with the geometry, three parameters
            ``P[name].x/y/z`` each (plate frame): what the geometry's own parameters already
            account for (a common shift of every plate point with the plate balls: the plate
            frame's origin is a convention) is not; those coordinates are held at their given
            values and listed in the result's ``confounded``. With ``frame="free"``, each
            station's instrument frame is identified with the geometry
            (:mod:`deltacal.identification.frames`).

    Returns:
        The result, holding the identified geometry.

    Raises:
        TypeError: an override that names no option, or ``options`` not a :class:`FitOptions`.
        ValueError: an option out of range, or options that do not go together.
        IdentificationError: too few measurements, poses too alike to identify what
            such measurements can identify (the message says which parameters and what
            would help), or measured positions far from any plausible robot (units, frame).
        AssemblyError: a measurement's readings cannot be assembled by the robot.
        ConvergenceError: Gauss-Newton did not converge (with the residual reached).
    """
    options = fit_options(options, overrides)
    error_model = get_model(model) if isinstance(model, str) else model
    problem = build_problem(start, measurements, error_model, options)
    rows = problem.rows_at(start, problem.frames)
    choice = choose(problem, _rows_to_choose_at(problem, rows))
    before = problem.stats(start, rows)
    solution = solve(problem, choice.base, rows)
    return summarise(problem, choice, solution, before)


def _rows_to_choose_at(problem: Problem, rows: Rows) -> Rows:
    """The rows where the base parameters are chosen: at the start with the encoder offsets found first.

    The choice (and with free frames, what they absorb) depends on where the robot is; of its
    errors only the encoder offsets can be degrees (:mod:`.offsets`). Offsets under
    :data:`OFFSETS_FIRST` leave the start as it is. The fit itself starts from the start.
    """
    opt = problem.options
    if opt.distances or opt.method != "iterated" or not np.any(rows.kind == POSITION):
        return rows
    free = bool(problem.columns.stations)
    try:
        found = encoder_offsets(problem.start, problem.measurements, free)
    except AssemblyError:  # an offset that does not assemble on the way: the start as it is
        return rows
    if np.max(np.abs(found)) < OFFSETS_FIRST["free" if free else "base"]:
        return rows
    at = replace(problem.start, encoder_offset=problem.start.encoder_offset + found)
    seen = problem.measurements
    frames = initial_frames(at, seen, exact.forward(at, seen.q)) if free else {}
    return problem.rows_at(at, frames)
