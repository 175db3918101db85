"""The exported values leave the least largest error the firmware's values allow (issue 38, item 6).

``Firmware.fit(..., minimax=True)`` (what ``export`` writes) moves the least-squares values to the
least largest nozzle error over the volume, the first layer no less flat
(:func:`~deltacal.printer.firmware.fitting.least_largest`). "The firmware's best at equal first-layer
flatness" is measured here by other code: SciPy's SLSQP on the exact errors (the squared norms'
epigraph, the first layer's height errors as constraints) from several starts, the best kept.
Fresh printers: seeds 38820, 38821 (well built) and 38920, 38921 (typical kits), used by no other
test and by none of the runs the method's settings were chosen on (seeds 38600-38702 of the true
printers alone).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import minimize

from deltacal.printer.comparison import CLASSES, WORKSPACE, run_printer
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import (
    Cuts,
    error_stats,
    first_layer,
    largest_step,
    part_errors,
    printable_grid,
)
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT, KLIPPER_VALUES
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.values import to_klipper
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.firmware.rrf.fit import RRF_VALUES
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.simulation import random_true_printer

KOSSEL = load_printer(Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml")
STEP = KOSSEL.step_distance
GRID, LAYER = printable_grid(WORKSPACE), first_layer(WORKSPACE)
#: The fresh printers: seed -> tolerance class.
SEEDS = {38820: "well built", 38821: "well built", 38920: "typical kit", 38921: "typical kit"}


def _klipper_model(firmware, values):
    """The values as the model and value vector the independent check varies (Marlin's is Klipper's)."""
    if firmware is RRF_FIRMWARE:
        return RRF_VALUES, [c for c in range(16) if c != 3], values  # M665 Z held, as the fit holds it
    model = to_klipper(values) if firmware is MARLIN else values
    return KLIPPER_VALUES, [c for c in range(13) if c != 3], model  # angle_c held: the part's turn


def _slsqp_best(printer, vector, columns, flatness, spread, starts):
    """The least largest error (part's frame), the first layer's |dz| <= flatness and peak to valley <=
    spread: SLSQP on (values, t, highest, lowest) from each start.

    Returns the largest error [mm] of the best feasible point found (the starts included).
    """
    found = []
    k = len(columns)
    for start in starts:
        base = vector.values_of(start)
        _, B0, _, _ = part_errors(printer, start, vector, STEP, GRID, LAYER, columns)
        scale = np.sqrt(np.mean(np.sum(B0**2, axis=1), axis=0))

        last: dict[bytes, tuple] = {}  # SLSQP asks the constraints and their Jacobian at one x: once

        def at(x, base=base, start=start, scale=scale, last=last):
            key = np.asarray(x, dtype=float).tobytes()
            if key not in last:
                values = base.copy()
                values[columns] += x[:k] / scale
                model = vector.with_values(start, values)
                a, B, c, D = part_errors(printer, model, vector, STEP, GRID, LAYER, columns)
                last.clear()
                last[key] = (a, B / scale, c, D / scale)
            return last[key]

        def constraints(x):  # >= 0 where met [mm², mm]
            a, _, c, _ = at(x)
            t, high, low = x[k:]
            return np.concatenate([1e3 * (t**2 - np.sum(a * a, axis=1)), 1e3 * (flatness**2 - c * c),
                                   high - c, c - low, [spread - high + low]])

        def jacobian(x):
            a, B, c, D = at(x)
            n, m = len(a), len(c)
            rows = [np.column_stack([-2e3 * np.einsum("nj,njk->nk", a, B), np.full(n, 2e3 * x[k]),
                                     np.zeros((n, 2))]),
                    np.column_stack([-2e3 * c[:, None] * D, np.zeros((m, 3))]),
                    np.column_stack([-D, np.zeros(m), np.ones(m), np.zeros(m)]),
                    np.column_stack([D, np.zeros(m), np.zeros(m), -np.ones(m)]),
                    np.concatenate([np.zeros(k + 1), [-1.0, 1.0]])[None]]
            return np.vstack(rows)

        a0, _, c0, _ = at(np.zeros(k + 3))
        x0 = np.append(np.zeros(k), [np.max(np.linalg.norm(a0, axis=1)), np.max(c0), np.min(c0)])
        solved = minimize(lambda x: x[k], x0, jac=lambda x: np.eye(len(x))[k], method="SLSQP",
                          constraints=[{"type": "ineq", "fun": constraints, "jac": jacobian}],
                          options={"maxiter": 200, "ftol": 1e-12})
        for x in (solved.x, x0):
            a, _, c, _ = at(x)
            if np.max(np.abs(c)) <= flatness + 1e-6 and np.ptp(c) <= spread + 1e-6:
                found.append(float(np.max(np.linalg.norm(a, axis=1))))
    return min(found)


def test_part_errors_jacobian_is_their_slope():
    """The Jacobians least_largest steps on match central differences of the errors themselves."""
    truth = random_true_printer(KOSSEL, np.random.default_rng(38950), CLASSES["typical kit"][0]).geometry
    start = KLIPPER.nominal(KOSSEL)
    columns = [0, 1, 4, 7, 11]
    a, B, c, D = part_errors(truth, start, KLIPPER_VALUES, STEP, GRID, LAYER, columns)
    for k, column in enumerate(columns):
        h = 1e-3 * (start.step_distance[0] if column >= 10 else 1.0)
        moved = []
        for sign in (1.0, -1.0):
            values = KLIPPER_VALUES.values_of(start)
            values[column] += sign * h
            moved.append(part_errors(truth, KLIPPER_VALUES.with_values(start, values), KLIPPER_VALUES, STEP,
                                     GRID, LAYER, columns))
        size = np.max(np.abs(B[:, :, k]))
        assert_allclose((moved[0][0] - moved[1][0]) / (2 * h), B[:, :, k], atol=1e-5 * size, rtol=0)
        assert_allclose((moved[0][2] - moved[1][2]) / (2 * h), D[:, k], atol=1e-5 * size, rtol=0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_largest_step_solves_the_linear_minimax(seed):
    """On random linear errors, the cutting planes reach SLSQP's least largest error (with the bound)."""
    rng = np.random.default_rng(38960 + seed)
    a, B = rng.normal(0.0, 0.05, (200, 3)), rng.normal(0.0, 0.02, (200, 3, 5))
    c, D = rng.normal(0.0, 0.01, 80), rng.normal(0.0, 0.01, (80, 5))
    flatness = float(np.max(np.abs(c)))
    spread = float(np.ptp(c))
    step, largest, _ = largest_step(a, B, c, D, flatness, spread, 10.0, Cuts.largest(a, c))
    assert_allclose(largest, np.max(np.linalg.norm(a + B @ step, axis=1)), rtol=1e-12, atol=0)
    assert np.max(np.abs(c + D @ step)) <= flatness + 1e-6 and np.ptp(c + D @ step) <= spread + 1e-6
    assert np.max(np.abs(step)) < 10.0  # the trust region did not bind

    def constraints(x):  # x: the step, t, the highest and lowest z
        v, z = a + B @ x[:5], c + D @ x[:5]
        return np.concatenate([x[5] ** 2 - np.sum(v * v, axis=1), flatness**2 - z * z, x[6] - z, z - x[7],
                               [spread - x[6] + x[7]]])

    x0 = np.append(np.zeros(5), [np.max(np.linalg.norm(a, axis=1)), flatness, -flatness])
    solved = minimize(lambda x: x[5], x0, method="SLSQP", constraints=[{"type": "ineq", "fun": constraints}],
                      options={"maxiter": 500, "ftol": 1e-12})
    assert solved.success
    assert largest <= solved.x[5] + 1e-6 < largest + 2e-6 < np.max(np.linalg.norm(a, axis=1))


@pytest.fixture(scope="module", params=[KLIPPER, MARLIN, RRF_FIRMWARE], ids=lambda f: f.name)
def fresh(request):
    """Each fresh printer run through the firmware (:func:`run_printer`: measured, identified) and the
    values fitted to the identified printer both ways: ``{minimax: fit}``."""
    firmware = request.param
    plan = plan_object(KOSSEL, firmware.nominal(KOSSEL))
    out = []
    for seed, label in SEEDS.items():
        tolerances, tilt = CLASSES[label]
        run = run_printer(KOSSEL, plan, seed, tolerances, tilt, (), firmware_type=firmware)
        identified, truth = run.result.geometry, run.truth.geometry
        fits = {minimax: firmware.fit(identified, run.firmware, STEP, WORKSPACE,
                                      first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, minimax=minimax)
                for minimax in (False, True)}
        out.append((firmware, label, truth, identified, fits))
    return out


def _on(printer, firmware, values):
    """What the values leave on a printer (the part's frame) [mm]."""
    return error_stats(printer, _klipper_model(firmware, values)[2], STEP, WORKSPACE, GRID, part_frame=True)


@pytest.mark.slow
def test_exported_values_no_worse_than_the_least_squares(fresh):
    """On the printer they are fitted to: a lower largest error, the first layer no worse (its largest
    |dz| and its peak to valley); on the true printers, a lower largest error on the mean."""
    judged = []
    for firmware, _, truth, _, fits in fresh:
        squares, least = fits[False].after, fits[True].after
        assert least.max_3d <= squares.max_3d
        assert least.flatness <= squares.flatness + 1e-6 and least.flatness_pv <= squares.flatness_pv + 1e-6
        judged.append([_on(truth, firmware, fits[m].values).max_3d for m in (False, True)])
    squares_mean, least_mean = np.mean(judged, axis=0)
    print(f"{fresh[0][0].name} on the truth: least squares / exported {np.round(judged, 4).tolist()} mm")
    assert least_mean <= squares_mean


@pytest.mark.long
def test_exported_values_are_the_firmwares_best_on_the_identified_printer(fresh):
    """The independent optimiser (SLSQP from the exported values and the least squares, the same first
    layer's bounds) finds nothing more than 1 % (+ 0.1 µm) below the exported values."""
    for firmware, _, _, identified, fits in fresh:
        least = fits[True].after
        vector, columns, model = _klipper_model(firmware, fits[True].values)
        starts = [model, _klipper_model(firmware, fits[False].values)[2]]
        best = _slsqp_best(identified, vector, columns, least.flatness, least.flatness_pv, starts)
        print(f"{firmware.name}: identified printer: least squares {fits[False].after.max_3d:.4f}, exported "
              f"{least.max_3d:.4f}, SLSQP's best {best:.4f} mm")
        assert least.max_3d <= 1.01 * best + 1e-4


@pytest.mark.long
def test_kits_exported_values_within_a_quarter_of_the_firmwares_best_on_the_true_printer(fresh):
    """Issue 38's criterion on the typical kits (mean over the fresh kits): the exported values, judged on
    the true printer, <= 1.25 x the firmware's best there at the same first-layer flatness + 0.01 mm
    (the best: SLSQP from the exported values and the least squares and least largest fitted to the
    truth). On well-built printers the exported values carry the identification's own error at the
    volume's top (0.02-0.03 mm, about the best values' error itself): docs/results.md says how far."""
    firmware = fresh[0][0]
    if firmware is KLIPPER:
        pytest.skip("the criterion is Marlin's and RRF's (Klipper's figures: the tests above)")
    exported, best = [], []
    for _, label, truth, _, fits in fresh:
        if label != "typical kit":
            continue
        vector, columns, model = _klipper_model(firmware, fits[True].values)
        judged = error_stats(truth, model, STEP, WORKSPACE, GRID, part_frame=True)
        flat = judged.flatness
        own = [firmware.fit(truth, firmware.nominal(KOSSEL), STEP, WORKSPACE, minimax=minimax,
                            first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, flatness=flat if minimax else None)
               for minimax in (False, True)]
        starts = [model, *(_klipper_model(firmware, fit.values)[2] for fit in own)]
        exported.append(judged.max_3d)
        best.append(_slsqp_best(truth, vector, columns, flat, 2.0 * flat, starts))
    print(f"{firmware.name} kits on the truth: exported {np.round(exported, 4)}, best {np.round(best, 4)} mm")
    assert np.mean(exported) <= 1.25 * np.mean(best) + 0.01
