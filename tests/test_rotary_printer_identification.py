"""A rotary Delta printer's full geometry identified from probe heights and printed distances (library level):
simulated printers measured as Klipper measures them, identified with the rotary printer model from the
nominal start, corrected through Klipper's rotary kinematics; against Klipper's own extended calibration
on the same data.

The object: the linear printer's planned object (:mod:`deltacal.printer.printed`: its layout for a
printable cylinder of radius 80 mm and 100 mm high, its candidate pairs for a 150 mm caliper, the 40
distances its D-optimal selection picks with the rotary printer model's rows at the nominal printer,
through Klipper's nominal inverse). The probe: Klipper's round 9 x 9 mesh over r <= 64 mm (49 points).
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import pytest

from deltacal.calibration import Calibration
from deltacal.controller import corrected_targets
from deltacal.geometry import Tolerances, Workspace
from deltacal.holds import in_plane_motion
from deltacal.identification.result import IdentificationResult
from deltacal.printer.firmware.fitting import printable_grid
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import klipper_rotary_basic, klipper_rotary_extended
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.firmware.klipper.rotary_fit import fit_klipper_rotary
from deltacal.printer.identification.errormodels import RotaryPrinterModel
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer, residuals_and_regressor
from deltacal.printer.identification.where import correction_sensitivity
from deltacal.printer.printed.object import blocking, candidate_pairs, object_layout, probe_grid
from deltacal.printer.printed.plan import select_pairs
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.rotary_simulation import RotaryPrinter, nozzle_errors, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE

#: The effector deltacal's geometry gives Klipper's point effector (radius, rod spacing, nozzle drop).
EFFECTOR = (30.0, 50.0, 40.0)
#: The volume judged, as the rotary calibrate tests': r <= 50 mm, z 0.2 to 100 mm.
VOLUME = printable_grid(Workspace(radius=50.0, height=100.0, top_z=100.0))
#: The object's printable cylinder (the linear object's pads need more than 50 mm of radius).
OBJECT = Workspace(radius=80.0, height=100.0, top_z=100.0)
#: Rotary build tolerances (the rotary robot's defaults, :class:`Tolerances`, rods as a printer kit's and
#: gear ratios to 0.2 %), and a well-built printer's (balls, rods, shoulders 4-5 times better; the endstop
#: switches the same).
KIT = Tolerances(ball_centre=0.05, rod_length=0.1, axis_position=0.2, axis_direction=math.radians(0.1),
                 encoder_offset=math.radians(0.3), joint_scale=0.002)
WELL_BUILT = Tolerances(ball_centre=0.01, rod_length=0.02, axis_position=0.05,
                        axis_direction=math.radians(0.02), encoder_offset=math.radians(0.3),
                        joint_scale=0.0005)


def _nominal():
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    return k, k.geometry(*EFFECTOR).moved_rigidly(np.eye(3), np.array([0.0, 0.0, k.base_height(EFFECTOR[2])]))


def _plan(k, nominal, tolerances) -> tuple[np.ndarray, np.ndarray]:
    """The probe points (49, 2) and the planned object's 40 pairs, commanded (40, 6) [mm]."""
    model = RotaryPrinterModel()
    probe = probe_grid(0.8 * OBJECT.radius, 9)
    layout = object_layout(OBJECT, k.angle, 150.0)
    pairs = candidate_pairs(layout, 150.0)
    ends = layout.centres[pairs]
    data = PrinterMeasurements(k.readings(k.shoulder_angles(probe)),
                               k.readings(k.shoulder_angles(ends.reshape(-1, 3))).reshape(-1, 2, 3),
                               np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1))
    _, W, kind = residuals_and_regressor(nominal, model, data)
    W = W * model.prior_sigma(tolerances)
    information = np.eye(W.shape[1]) + W[kind == 0].T @ W[kind == 0]
    chosen = select_pairs(W[kind == 1], information, 40, layout, pairs, blocking(layout, pairs), at_least=1)
    return probe[:, :2], ends[chosen].reshape(-1, 6)


def test_the_planned_object_and_probe_points_are_within_klippers_reach():
    """The probe grid inside the object's printable radius, the 40 pairs' ends all commandable through
    Klipper's rotary limits (its check_move), no pair repeated."""
    k, _ = _nominal()
    xy, pairs = _planned(KIT)
    assert len(xy) == 49 and np.max(np.hypot(xy[:, 0], xy[:, 1])) <= OBJECT.radius
    ends = pairs.reshape(-1, 3)
    assert pairs.shape == (40, 6) and np.all(k.outside(ends) == 0)
    assert len({tuple(np.round(p, 6)) for p in pairs}) == 40


@functools.cache
def _planned(tolerances: Tolerances) -> tuple[np.ndarray, np.ndarray]:
    """The probe points and the object's pairs planned for a class of printers (one plan per class)."""
    k, nominal = _nominal()
    return _plan(k, nominal, tolerances)


class _Identified(NamedTuple):
    """A simulated printer, what was measured of it and what deltacal identified from it."""

    printer: RotaryPrinter
    probe: np.ndarray
    pairs: np.ndarray
    distances: np.ndarray
    result: IdentificationResult
    calibration: Calibration


@functools.cache
def _identified(tolerances: Tolerances, seed: int) -> _Identified:
    """The bed frame's truth (every error of the complete model, the arms' gear ratios), measured as
    Klipper measures (the probe's σ 0.01 mm, the caliper's 0.02 mm), identified from the nominal start."""
    k, nominal = _nominal()
    rng = np.random.default_rng(seed)
    truth = nominal.perturbed(tolerances, rng)
    printer = RotaryPrinter(replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3)), k)
    xy, pairs = _planned(tolerances)
    probe = probe_triggers(printer, k, xy)
    probe[:, 2] += rng.normal(0.0, 0.01, len(probe))  # the probe's repeatability
    distances = printed_distances(printer, k, pairs) + rng.normal(0.0, 0.02, len(pairs))  # the caliper's
    data = PrinterMeasurements(printer.readings(k, probe), np.stack(
        [printer.readings(k, pairs[:, :3]), printer.readings(k, pairs[:, 3:])], axis=1), distances)
    result = identify_printer(nominal, data, RotaryPrinterModel(), tolerances=tolerances)
    return _Identified(printer, probe, pairs, distances, result, Calibration.from_result(result))


@functools.cache
def _figures(tolerances: Tolerances, seed: int) -> dict[str, tuple[float, float]]:
    """3-D max over the volume, raw and less the motion along the bed no measurement sees [mm]: Klipper's
    nominal values, its basic and extended calibrations, ours (the calibration as ``compensate`` uses it:
    put in Klipper's frame along the bed, each correction weighted where it holds), ours with the whole
    correction everywhere (the identified printer's own error) and the values ours exports
    (``fit_klipper_rotary``)."""
    k, nominal = _nominal()
    printer, probe, pairs, distances, result, calibration = _identified(tolerances, seed)
    assert calibration.holds is not None  # where it holds, as a linear printer's
    controller = KlipperRotaryController(k)
    ours = printer.nozzle(k, corrected_targets(calibration, controller, VOLUME).commands) - VOLUME
    whole = printer.nozzle(k, corrected_targets(calibration, controller, VOLUME, bound=math.inf).commands)
    whole = whole - VOLUME
    lift = np.array([0.0, 0.0, -k.base_height(EFFECTOR[2])])  # the bed frame's printer into {O}
    exported = fit_klipper_rotary(result.geometry.moved_rigidly(np.eye(3), lift), k, OBJECT,
                                  nozzle_drop_of=nominal.moved_rigidly(np.eye(3), lift)).values
    errors = {"nominal": nozzle_errors(printer, k, VOLUME), "basic": nozzle_errors(
        printer, klipper_rotary_basic(k, probe), VOLUME), "extended": nozzle_errors(
        printer, klipper_rotary_extended(k, probe, pairs, distances), VOLUME), "ours": ours, "whole": whole,
        "exported": nozzle_errors(printer, exported, VOLUME)}
    return {name: (float(np.linalg.norm(e, axis=1).max()),
                   float(np.linalg.norm(less_bed_motion(VOLUME, e)[0], axis=1).max()))
            for name, e in errors.items()}


PRINTERS = [("kit", KIT, 200), ("kit", KIT, 201), ("kit", KIT, 202),
            ("well built", WELL_BUILT, 200), ("well built", WELL_BUILT, 201), ("well built", WELL_BUILT, 202)]
#: Where the issue's 1/3 is not reached (measured, less the motion along the bed).
NOT_A_THIRD = {("well built", 200): "ours 0.021 mm (the whole correction) against Klipper's extended 0.043 "
                                    "(0.48): below what the measurements determine (the posterior's "
                                    "expected max 0.019 mm, the bound 0.0145)"}


def _marked(p: tuple) -> object:
    if (p[0], p[2]) not in NOT_A_THIRD:
        return p
    return pytest.param(*p, marks=pytest.mark.xfail(strict=True, reason=f"issue 48, not reached: "
                                                                        f"{NOT_A_THIRD[p[0], p[2]]}"))


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize(("label", "tolerances", "seed"), [_marked(p) for p in PRINTERS],
                         ids=[f"{p[0]}-{p[2]}" for p in PRINTERS])
def test_identified_rotary_printers_a_third_of_klippers_extended_calibration(label, tolerances, seed):
    """Klipper's example values, the bed frame's truth with every error of the complete model and the arms'
    gear ratios (none of which but the endstops Klipper's model holds), measured as Klipper measures; 3-D
    max over r <= 50, z 0.2..100 mm less the shift along the bed and turn about its normal no probe or
    caliper sees (the printer's convention: the part is the same part). The issue's bound: ours at most a
    third of Klipper's extended calibration's on the same data. Measured, ours / Klipper's extended [mm]:
    kits 0.035 / 0.167, 0.036 / 0.310, 0.036 / 0.466; well built 0.021 / 0.043, 0.026 / 0.086, 0.033 / 0.105
    (docs/printers.md, "Rotary Delta printers"). Measured over the volume (the object's levels), the
    correction along the bed is applied whole where it holds (:attr:`~deltacal.holds.WhereItHolds.bed_level`):
    weighted by its significance too, as a calibration at one height is, they were 0.044, 0.042, 0.035 and
    0.032, 0.032, 0.025."""
    figures = _figures(tolerances, seed)
    assert figures["ours"][1] <= figures["extended"][1] / 3.0, figures


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize(("label", "tolerances", "seed"), PRINTERS, ids=[f"{p[0]}-{p[2]}" for p in PRINTERS])
def test_the_exported_rotary_values_never_worse_than_klippers(label, tolerances, seed):
    """The issue's bound: the values deltacal exports (its identified printer fitted with Klipper's rotary
    model) never worse than Klipper's extended calibration's, 3-D max less the motion along the bed."""
    figures = _figures(tolerances, seed)
    assert figures["exported"][1] <= figures["extended"][1], figures


def _posterior_maxima(identified: _Identified, draws: int = 2000) -> np.ndarray:
    """The whole correction's 3-D max over the volume (less the motion along the bed) on printers drawn from
    the calibration's posterior [mm], (draws,): parameter errors δθ ~ N(0, Σ) (the identification's
    covariance), the corrected nozzle moved by J' δθ (the nozzle's sensitivity in the controller's frame,
    :func:`~deltacal.printer.identification.where.correction_sensitivity`, to first order)."""
    result = identified.result
    assert identified.calibration.holds is not None
    covariance = result.correlation * np.outer(result.sigma, result.sigma)
    J, reached = correction_sensitivity(result.geometry, RotaryPrinterModel(), VOLUME,
                                        identified.calibration.holds.printable_radius)
    assert reached.all()
    value, vector = np.linalg.eigh(covariance)
    root = vector * np.sqrt(np.clip(value, 0.0, None))
    drawn = root @ np.random.default_rng(0).standard_normal((len(value), draws))
    errors = J.reshape(-1, J.shape[2]) @ drawn
    A = in_plane_motion(VOLUME).reshape(-1, 3)
    errors = errors - A @ np.linalg.lstsq(A, errors, rcond=None)[0]
    return np.linalg.norm(errors.reshape(len(VOLUME), 3, draws), axis=1).max(axis=0)


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize(("seed", "within_reach"), [(200, False), (201, True)], ids=["200", "201"])
def test_the_well_built_third_is_below_what_the_measurements_determine(seed, within_reach):
    """Issue 48's third on the two well-built printers nearest it, against the noise floor: the 3-D max
    (less the motion along the bed) the whole correction leaves on printers drawn from the calibration's
    posterior (49 probe heights σ 0.01 mm, 40 distances σ 0.02 mm). The posterior is honest: the identified
    printer's own error is a likely draw (between its 5th and 95th percentiles). Measured [mm]: well built
    200: the bound (Klipper's extended / 3) 0.0145, the posterior's expected max 0.0193 (median 0.0187,
    P(max <= bound) 0.20), the whole correction 0.021 (its 67th percentile): below what the measurements
    determine. Well built 201: bound 0.0287, expected max 0.0213 (P 0.88), ours (the whole correction where
    it holds: the object measured over the volume) 0.026 (81st percentile) meets it. More distances (the
    object's layout gives 54) leave 200's expected max at 0.019; a 15 x 15 probe
    mesh (149 points) lowers it to 0.0165 and Klipper's extended's third with it, to 0.0124."""
    figures = _figures(WELL_BUILT, seed)
    bound, whole = figures["extended"][1] / 3.0, figures["whole"][1]
    maxima = _posterior_maxima(_identified(WELL_BUILT, seed))
    assert 0.05 < np.mean(maxima <= whole) < 0.95, (whole, np.percentile(maxima, [5, 50, 95]))
    if within_reach:
        assert np.mean(maxima) <= bound and figures["ours"][1] <= bound, (figures, np.mean(maxima))
    else:
        assert np.mean(maxima) > bound and whole > bound, (figures, np.mean(maxima))
