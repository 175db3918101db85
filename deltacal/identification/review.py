"""The poor-fit review: a fit that fails the gate of :mod:`.quality`, fitted again and refused.

The same data are fitted again under other readings and with the complete model, and the fit
is refused with the causes found.

When a model that lacks parameters (``classical``, a Bai model) fails the gate and the complete
model fits the same data (s0² within :data:`.quality.FITS_WELL`, clearly better, a plausible
geometry), the cause is the model and the message says so (code
:attr:`~deltacal.exceptions.PoorFitError.RICHER_MODEL`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from ..errormodels import ErrorModel, get_model
from ..exceptions import DeltacalError, PoorFitError
from ..geometry import DeltaGeometry
from ..observations import Measurements
from .options import FitOptions
from .quality import (
    CLEARLY_BETTER,
    FITS_WELL,
    POOR_FIT,
    implausible_deviations,
    needs_review,
    poor_fit_message,
    quality_factor,
    readings,
    verdict,
)
from .result import IdentificationResult

#: The model tried when another fails the gate.
RICHER_MODEL = "complete"

Fit = Callable[..., IdentificationResult]


@dataclass(frozen=True)
class Data:
    """Measurements and the options of their fit."""

    measurements: Measurements
    options: FitOptions


def richer_model_note(result: IdentificationResult, start: DeltaGeometry, data: Data, fit: Fit) -> str:
    """``"the complete model fits these data, s0² = 1.2: use --model complete"``, or "" when it does not.

    Args:
        result: The fit that failed the gate.
        start: The geometry it started from.
        data: The measurements and options as the user gave them.
        fit: The fit function (:func:`.estimate.fit`).
    """
    if result.model == RICHER_MODEL:
        return ""
    try:
        alt = fit(start, data.measurements, get_model(RICHER_MODEL), options=data.options)
    except DeltacalError:
        return ""
    s0, alt_s0 = quality_factor(result), quality_factor(alt)
    fits = alt_s0 < FITS_WELL and alt_s0 < CLEARLY_BETTER * s0
    if fits and not implausible_deviations(start, alt.geometry):
        return f"the {RICHER_MODEL} model fits these data, s0² = {alt_s0:.2g}: use --model {RICHER_MODEL}"
    return ""


def review(
    result: IdentificationResult, start: DeltaGeometry, model: ErrorModel, data: Data, fit: Fit,
) -> IdentificationResult:
    """The fit, or :class:`PoorFitError` naming the likely causes; a moderate excess is warned.

    Args:
        result: The fit.
        start: The geometry it started from.
        model: Its error model.
        data: The measurements and options of the fit.
        fit: The fit function (:func:`.estimate.fit`).

    Returns:
        The result, with a warning when its fit is poor but accepted or its s0² moderately high.

    Raises:
        PoorFitError: the fit is poor and ``accept_poor_fit`` is not set.
    """
    if not needs_review(result, start):
        return result
    alternatives = []
    for cause, other, options in readings(data.measurements, start.point_names, data.options):
        try:
            alt = fit(start, other, model, options=options)
        except DeltacalError:
            continue
        alternatives.append((cause, alt.variance_factor, implausible_deviations(start, alt.geometry)))
    poor, causes = verdict(result, start, alternatives)
    richer = richer_model_note(result, start, data, fit) if poor else ""
    note = poor_fit_message(result, start, causes, richer)
    if poor and not data.options.accept_poor_fit:
        raise PoorFitError(note, result, causes, _codes(result, start, causes, richer),
                           RICHER_MODEL if richer else "")
    if poor:
        return replace(result, warnings=(*result.warnings, note + " (kept: poor fit accepted)"))
    s0 = result.inlier_variance_factor
    excess = (f"variance factor s0² = {s0:.3g}: the residuals exceed the σ given "
              "(unmodelled effects, or σ too small): the σ of the parameters are too small by "
              f"a factor up to {math.sqrt(s0):.3g}")
    return replace(result, warnings=(*result.warnings, excess))


def _codes(
    result: IdentificationResult, start: DeltaGeometry, causes: list[str], richer: str
) -> tuple[str, ...]:
    """The codes of a poor fit, most telling first."""
    codes = [PoorFitError.READINGS] if causes else []
    if richer:
        codes.append(PoorFitError.RICHER_MODEL)
    if implausible_deviations(start, result.geometry):
        codes.append(PoorFitError.IMPLAUSIBLE)
    if not codes or (quality_factor(result) > POOR_FIT and not causes and not richer):
        codes.append(PoorFitError.LARGE_RESIDUALS)
    return tuple(codes)
