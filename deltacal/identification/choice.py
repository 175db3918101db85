"""The choose phase of a fit: which parameters the measurements identify.

The base parameters come from the column-scaled pivoted QR of the weighted regressor
(:func:`deltacal.identifiability.base_parameters`; Savoure 2006, Eq. 23-26). With free
instrument frames their parameters are kept first, and the geometry's parameters that the
frames absorb are held (:func:`.frames.absorbed_by_frames`); free points enter only where the
geometry and the frames leave them something to say (the others are "confounded").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import IdentificationError
from ..identifiability import BaseParameters, base_parameters
from ..observations import Rows
from .columns import COMPLIANCE, FRAME, POINT
from .diagnostics import check_plausible, check_rank
from .frames import FRAME_RTOL, absorbed_by_frames
from .problem import Problem


@dataclass(frozen=True)
class Choice:
    """The parameters a fit identifies.

    Attributes:
        base: The base parameters over every column (the regroupings of the others).
        absorbed: Parameters of the geometry that the frames (nearly) absorb, held at their start.
        held: Parameters kept out of the base (the absorbed ones and, with frames, those outside
            the geometry's own base).
        confounded: Free points' coordinates the geometry already accounts for, and compliances
            the measurements cannot tell from the geometry (held).
        hints: What richer measurements would identify.
    """

    base: BaseParameters
    absorbed: tuple[str, ...] = ()
    held: tuple[str, ...] = ()
    confounded: tuple[str, ...] = ()
    hints: tuple[str, ...] = ()


def fixed_base(problem: Problem, W: np.ndarray) -> tuple[BaseParameters, list[str], list[str]]:
    """The base parameters among the model's and the frames' columns of a weighted regressor.

    Args:
        problem: The problem (its columns, model and rank tolerance).
        W: Weighted regressor, one column per column of ``problem.columns``.

    Returns:
        ``(base, absorbed, held)``: the base over the model's and frames' columns, the
        parameters the frames absorb, and every parameter held out of the base.
    """
    columns, model, rtol = problem.columns, problem.model, problem.options.rtol
    names, kinds = columns.names, [c.kind for c in columns.columns]
    # the columns are in order: the model's, the frames', the points' (slices, as the QR saw them)
    n_model, n_fixed = columns.n_model, columns.n_fixed
    fixed, model_cols = range(n_fixed), range(n_model)
    prefer = model.preferred
    absorbed: list[str] = []
    held: list[str] = []
    if columns.stations:
        # the geometry's own base first, as with measurements in {O}; then what the frames absorb
        own = base_parameters(W[:, :n_model], names[:n_model], rtol=rtol, prefer=prefer)
        # a model without rigid motions of its own (Bai's distance models, fitted as positions
        # with a frame per point) mimics none: only what is exactly the frames' is theirs
        absorbed = absorbed_by_frames(W[:, :n_fixed], names[:n_fixed], n_model, own.base,
                                      rtol if model.rigid_motion_free else FRAME_RTOL, model.frame_held_first)
        prefer = [names[k] for k in fixed if kinds[k] == FRAME] + [names[k] for k in own.base]
        # a parameter outside the geometry's own base only repeats base columns, except along
        # what the frames absorb: it would bring that back (b21x for an absorbed b22x, say)
        held = absorbed + [names[k] for k in model_cols if k not in own.base]
    base = base_parameters(W[:, :n_fixed], names[:n_fixed], rtol=rtol, prefer=prefer, exclude=held)
    return base, absorbed, held


def with_points(
    problem: Problem, W: np.ndarray, base: BaseParameters, held: list[str]
) -> tuple[BaseParameters, tuple[str, ...]]:
    """The base extended to the free points' columns where the geometry leaves them something to say.

    Returns:
        ``(base, confounded)``: the base over every column, and the points' coordinates left out.
    """
    names = problem.columns.names
    points = [k for k, c in enumerate(problem.columns.columns) if c.kind in (POINT, COMPLIANCE)]
    prefer = [base.names[k] for k in base.base] + [names[k] for k in points]
    full = base_parameters(W, names, rtol=problem.options.rtol, prefer=prefer, exclude=held)
    return full, tuple(names[k] for k in points if k not in full.base)


def choose(problem: Problem, rows: Rows) -> Choice:
    """The base parameters of the problem at its start rows, after the checks that refuse it.

    Args:
        problem: The problem.
        rows: Its rows at the start.

    Returns:
        The choice.

    Raises:
        IdentificationError: no distance to fit, no parameter identified, measurements far from
            any plausible robot, or poses too alike (the message says what would help).
    """
    opt, columns = problem.options, problem.columns
    if opt.distances and (rows.residual.size if rows.distances is None else rows.distances) == 0:
        raise IdentificationError(
            "no distance to fit: every measurement of a point is at the same readings as the others "
            "(distances need positions of a point at different poses)"
        )
    W = rows.weighted[1]
    base, absorbed, held = fixed_base(problem, W)
    if base.rank == 0:
        raise IdentificationError("the measurements identify no parameter of the model")
    stations = list(columns.stations)
    check_plausible(problem.start, problem.measurements, rows, frame_free=bool(stations))
    hints = check_rank(problem.start, problem.measurements, problem.model, base, W[:, : columns.n_fixed],
                       opt, stations)
    confounded: tuple[str, ...] = ()
    if columns.points or columns.compliance:
        base, confounded = with_points(problem, W, base, held)
    return Choice(base, tuple(absorbed), tuple(held), confounded, tuple(hints))
