"""A printer's calibration re-anchored to another controller: what the measurements determine is kept.

A printer's fit (:func:`~.fit.identify_printer`) is the most probable geometry under a prior centred
on the printer its controller described (the start: the firmware's values it was identified with):
along the combinations of parameters the measurements determine the estimate is theirs, along the
others it stays near the prior's centre, and ``[holds.along_bed]`` is the start moved along the
determined ones only. When the controller's values change (its owner ran the firmware's own
calibration again, or edited a value), the centre moves: by Δm in the model's parameters, the move
from the printer the recorded controller describes to the one the controller now given describes
(:func:`controller_shift`, each the parameter set whose nozzle lands where that controller's
forward model puts it, near the prior's centre). The calibration is then the same measurements
(:class:`~deltacal.measured_record.MeasuredRecord`, the file's ``[measured]``) identified again with
the start moved by Δm, the fit's own choices kept (the tolerances' scale, the method, the prior's
width; :func:`reanchored`): exact, where a linear update ``Σ Σ₀⁻¹ Δm`` left 0.08 mm of a 1.5 mm rod
change on a Kossel (a tenth: the fit is not linear over millimetres).
Units: mm and rad.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ...calibration import Calibration
from ...exceptions import AssemblyError
from ...geometry import DeltaGeometry, Workspace
from ...holds import bed_points
from ...measured_record import MeasuredRecord
from .errormodels import PrinterModel, RotaryPrinterModel, calibrated_values, kit_tolerances
from .fit import PrinterFitOptions, PrinterMeasurements, identify_printer, scaled_tolerances
from .where import point_rows, readings_at

#: Gauss-Newton steps of :func:`controller_parameters` at most, and the step [prior units] that ends them.
SHIFT_ITERATIONS = 12
SHIFT_TOLERANCE = 1e-9
#: The σ a controller's nozzle is matched with in :func:`controller_parameters` [mm].
SHIFT_SIGMA = 1e-4
#: Halvings of a step that leaves a reading unassembled, at most.
SHIFT_HALVINGS = 30
#: Heights of the layers the controllers are compared on, as fractions of the measured volume's.
SHIFT_LAYERS = (0.0, 0.5, 1.0)


def measured_record(data: PrinterMeasurements, options: PrinterFitOptions, tolerance_scale: float
                    ) -> MeasuredRecord | None:
    """What a calibration keeps of its measurements and fit (None: an instrument's positions, not kept)."""
    if data.positions.size:
        return None
    ws = options.workspace
    return MeasuredRecord(data.probe, data.trigger_height, data.pairs, data.distance, data.probe_offset,
                          data.height_sigma, data.distance_sigma, tolerance_scale, options.calibrated_start,
                          options.method, None if ws is None else (ws.radius, ws.height, ws.top_z))


def measurements_of(record: MeasuredRecord) -> PrinterMeasurements:
    """The measurements a record keeps, as the fit takes them."""
    return PrinterMeasurements(record.probe, record.pairs, record.distance, probe_offset=record.probe_offset,
                               height_sigma=record.height_sigma, distance_sigma=record.distance_sigma,
                               trigger_height=record.trigger_height)


def comparison_points(calibration: Calibration) -> np.ndarray:
    """Where two controllers of a calibration are compared: the first layer's points at three heights [mm]."""
    holds = calibration.where_held()
    assert holds is not None  # where_held refuses a printer's calibration without [holds]
    radius, top = holds.printable_radius, float(max(holds.measured_top, holds.height[1]))
    layer = bed_points(radius)
    return np.concatenate([layer + [0.0, 0.0, f * top] for f in SHIFT_LAYERS])


def controller_parameters(calibration: Calibration, forward: Callable[[np.ndarray], np.ndarray],
                          points: np.ndarray) -> np.ndarray:
    """The model's parameters whose nozzle lands where the controller's forward puts it (prior's centre else).

    At the readings that put the nominal printer's nozzle on ``points``, the parameters m (from the
    calibration's nominal, the model's order) minimise ``|nozzle(m, q) − forward(q)|² / σ² + |L⁻¹ m|²``
    with σ = :data:`SHIFT_SIGMA` (a tenth of a micrometre) and ``L Lᵀ`` the fit's prior: the nozzle
    matched, and what no nozzle sees left at the prior's centre (a least-norm step alone took
    combinations the nozzle barely sees by metres on a Duet Kossel, and diverged). Gauss-Newton,
    a step that leaves a reading unassembled halved.

    Args:
        calibration: A printer's calibration that recorded its measurements (``measured``).
        forward: The controller's forward model: readings [mm] (N, 3) -> nozzle positions (N, 3).
        points: Where to compare (:func:`comparison_points`) [mm], (N, 3).
    """
    model, nominal = calibration.model, calibration.nominal
    q = readings_at(nominal, points)
    q = q[np.all(np.isfinite(q), axis=1)]
    target = forward(q)
    L = prior_factor_of(calibration)
    n = model.size
    m = np.zeros(n)
    point, S = point_rows(nominal, model, q, nominal.tool)
    for _ in range(SHIFT_ITERATIONS):
        A = np.vstack([S.reshape(-1, n) @ L / SHIFT_SIGMA, np.eye(n)])
        b = np.concatenate([(target - point).reshape(-1) / SHIFT_SIGMA, -np.linalg.solve(L, m)])
        step = L @ np.linalg.lstsq(A, b, rcond=None)[0]
        for _ in range(SHIFT_HALVINGS):
            try:
                geometry = model.apply(nominal, m + step)
                point, S = point_rows(geometry, model, q, geometry.tool)
                break
            except AssemblyError:
                step = 0.5 * step
        else:
            raise ValueError("the controller's printer could not be matched (a step left the readings "
                             "unassembled)")
        m = m + step
        if np.max(np.abs(np.linalg.solve(L, step))) < SHIFT_TOLERANCE:
            break
    return m


#: Two controllers whose nozzles agree this closely at every compared reading command the same [mm].
SAME_NOZZLE = 1e-9


def same_commands(calibration: Calibration, recorded: Callable[[np.ndarray], np.ndarray],
                  now: Callable[[np.ndarray], np.ndarray]) -> bool:
    """Whether two controllers' forward models put the nozzle alike (values changed: limits only)."""
    q = readings_at(calibration.nominal, comparison_points(calibration))
    q = q[np.all(np.isfinite(q), axis=1)]
    return bool(np.max(np.abs(now(q) - recorded(q)), initial=0.0) <= SAME_NOZZLE)


def controller_shift(calibration: Calibration, recorded: Callable[[np.ndarray], np.ndarray],
                     now: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Δm: the move, in the model's parameters, from the recorded controller's printer to the one now given.

    Args:
        calibration: A printer's calibration that recorded its measurements.
        recorded: The forward model of the controller it was identified with (readings -> nozzle).
        now: The forward model of the controller now given.
    """
    points = comparison_points(calibration)
    return controller_parameters(calibration, now, points) - controller_parameters(calibration, recorded,
                                                                                     points)


def reanchored(calibration: Calibration, start: DeltaGeometry | np.ndarray,
               measured: MeasuredRecord | None = None, reach: float | None = None) -> Calibration:
    """The calibration's measurements identified again from another start: the prior's centre moved.

    Args:
        calibration: A printer's calibration that recorded its measurements (``measured``).
        start: The new start: a nominal printer (another robot file's, of the same step distance), or
            Δm, the move of the calibration's nominal in the model's parameters (:func:`controller_shift`).
        measured: The measurements to identify (by default the calibration's): a rotary printer's
            readings counted again by the controller now given (its arms' angles count from its
            endstop angles), the fit's choices the record's.
        reach: The radius out to which where it holds is given (a rotary printer's firmware's reach:
            :class:`~.fit.PrinterFitOptions`); None: the measured volume's.

    The fit's choices are the record's (the tolerances' scale as taken, the method, a start the
    firmware calibrated from the same data): only the prior's centre moves, never its width, so a
    small change of the values moves the calibration a little. (Tried and not kept: taking the
    build tolerances' prior about values not fitted to these measurements. On three simulated kits
    re-calibrated by Klipper it helped at z 25-100 mm, 0.008 mm, but the real V400 A's runs,
    each re-anchored to the first run's printer.cfg while the first kept its wide prior, then
    disagreed by 0.20 mm at z 10 against 0.07: the width jumped with any change of the values.)
    A poor fit is kept (it was judged when identified). The result keeps the calibration's records
    and source.

    Raises:
        ValueError: a calibration without its measurements (written before they were recorded), or a
            start of another step distance.
    """
    record = calibration.measured if measured is None else measured
    if record is None:
        raise ValueError("the calibration records no measurements: it cannot be re-anchored")
    ws = record.workspace
    if not isinstance(start, DeltaGeometry):
        start = calibration.model.apply(calibration.nominal, np.asarray(start, dtype=float))
    elif not np.array_equal(np.asarray(start.step_distance), np.asarray(calibration.nominal.step_distance)):
        raise ValueError("a start of another step distance than the calibration's readings count in")
    options = PrinterFitOptions(method="linear" if record.method == "linear" else "iterated",
                                tolerances=kit_tolerances(calibration.model),
                                tolerance_scale=record.tolerance_scale,
                                workspace=None if ws is None else Workspace(*ws), accept_poor_fit=True,
                                calibrated_start=record.calibrated_start, reach=reach)
    result = identify_printer(start, measurements_of(record), calibration.model, options=options)
    return replace(Calibration.from_result(result), controller=calibration.controller, measured=record,
                   source=calibration.source)


def prior_factor_of(calibration: Calibration) -> np.ndarray:
    """L with ``Σ₀ = L Lᵀ``: the fit's prior at the calibration's nominal (its record's scale, start)."""
    record = calibration.measured
    model = calibration.model
    if record is None or not isinstance(model, PrinterModel | RotaryPrinterModel):
        raise ValueError("re-anchoring needs a printer's calibration that recorded its measurements")
    used = scaled_tolerances(model.kit_tolerances(), record.tolerance_scale)
    return model.prior_factor(used, calibration.nominal, calibrated_values(record.calibrated_start,
                                                                           record.distance.size, model))
