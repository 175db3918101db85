"""The fit in parts (issue 20): build, choose, solve and summarise, each tested alone."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import deltacal
from deltacal import PoorFitError, Tolerances
from deltacal.errormodels import get_model
from deltacal.identification import FitOptions, fit, identify
from deltacal.identification.choice import choose, fixed_base
from deltacal.identification.columns import FRAME, GEOMETRY, POINT, build_columns
from deltacal.identification.options import FitOverrides, fit_options
from deltacal.identification.problem import build_problem
from deltacal.identification.result import ResidualStats
from deltacal.identification.solver import solve, solve_iterated, solve_linear, solve_wls
from deltacal.identification.summary import base_covariance, summarise
from deltacal.planning import d_optimal
from deltacal.simulation import Metrology, simulate_measurements


@pytest.fixture(scope="module")
def data(bai):
    rng = np.random.default_rng(20)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    q = d_optimal(bai, "complete", 40, rng=rng).poses.q
    exact = simulate_measurements(truth, q, rng, Metrology(sigma_position=0.0, sigma_angle=0.0))
    two = Metrology(points=("smr_centre", "smr_offset"), orientation=False)
    noisy = simulate_measurements(truth, q, rng, two)
    return bai.geometry(), truth, exact, noisy


def test_columns_of_a_free_frame_free_point_problem_have_their_kinds_and_units():
    model = get_model("classical")
    columns = build_columns(model, ["A", "B"], ["smr_offset"])
    kinds = [c.kind for c in columns.columns]
    n = len(model.names)
    assert kinds == [GEOMETRY] * n + [FRAME] * 12 + [POINT] * 3
    assert columns.n_model == n and columns.n_fixed == n + 12 and len(columns) == n + 15
    assert columns.names[n:n + 6] == ["T[A].rx", "T[A].ry", "T[A].rz", "T[A].tx", "T[A].ty", "T[A].tz"]
    assert columns.units[n:n + 6] == ["rad", "rad", "rad", "mm", "mm", "mm"]
    assert columns.names[-3:] == ["P[smr_offset].x", "P[smr_offset].y", "P[smr_offset].z"]
    assert columns.units[-3:] == ["mm"] * 3 and columns.units[:n] == list(model.units)


def test_choose_sees_a_rank_deficiency_built_into_the_regressor(data):
    start, _, exact, _ = data
    problem = build_problem(start, exact, get_model("complete"), FitOptions())
    W = problem.rows_at(start, {}).weighted[1].copy()
    base, _, _ = fixed_base(problem, W)
    i, j = base.base[3], base.base[7]
    W[:, j] = 2.0 * W[:, i]  # column j now repeats column i: one parameter less is identifiable
    deficient, _, _ = fixed_base(problem, W)
    assert deficient.rank == base.rank - 1
    assert not (i in deficient.base and j in deficient.base)


def test_choose_holds_what_the_frames_absorb_and_the_confounded_point(data):
    start, _, _, noisy = data
    options = FitOptions(frame="free", free_points=("smr_offset", "smr_centre"))
    problem = build_problem(start, noisy, get_model("complete"), options)
    choice = choose(problem, problem.rows_at(start, problem.frames))
    kinds = {c.name: c.kind for c in problem.columns.columns}
    assert choice.absorbed and all(kinds[name] == GEOMETRY for name in choice.absorbed)
    assert choice.confounded and all(kinds[name] == POINT for name in choice.confounded)
    kept = {choice.base.names[k] for k in choice.base.base}
    assert all(f"T[default].{p}" in kept for p in ("rx", "ry", "rz", "tx", "ty", "tz"))  # frames first
    assert not kept & set(choice.held)


def test_solve_converges_on_exact_data_and_the_linear_step_does_not(data):
    start, _, exact, _ = data
    problem = build_problem(start, exact, get_model("complete"), FitOptions())
    rows = problem.rows_at(start, {})
    base = choose(problem, rows).base
    iterated = solve_iterated(problem, base, rows)
    linear = solve_linear(problem, base, rows)
    assert iterated.iterations < problem.options.max_iter
    # noise-free data: from 22 mm at the start, the one linear step leaves 0.33 mm (the offsets
    # are large), Gauss-Newton 0.26 µm
    start_worst = np.max(np.abs(rows.residual))
    worst = np.max(np.abs(iterated.rows.residual))
    assert worst < 1e-4 * start_worst and worst < 1e-2 * np.max(np.abs(linear.rows.residual))
    assert linear.iterations == 1 and linear.covariance_rows is rows
    assert solve(problem, base, rows).iterations == iterated.iterations
    # the total step is what moves the start to the solution
    moved, _ = problem.moved(start, {}, base.expand(iterated.values))
    assert np.max(np.abs(deltacal.forward(moved, exact.q).position
                         - deltacal.forward(iterated.geometry, exact.q).position)) < 1e-3


def test_summarise_covariance_is_the_inverse_normal_matrix(data):
    start, _, _, noisy = data
    problem = build_problem(start, noisy, get_model("bai42"), FitOptions())
    rows = problem.rows_at(start, {})
    choice = choose(problem, rows)
    solution = solve(problem, choice.base, rows)
    result = summarise(problem, choice, solution, ResidualStats.from_rows(rows))
    Wk = solution.rows.weighted[1][:, choice.base.base]
    normal_inverse = np.linalg.inv(Wk.T @ Wk)
    cov = result.correlation * np.outer(result.sigma, result.sigma)
    assert np.allclose(cov, normal_inverse, rtol=1e-8, atol=0.0)
    assert np.allclose(base_covariance(solution, choice.base.base), normal_inverse, rtol=1e-8, atol=0.0)
    rw = solution.rows.weighted[0]
    assert result.variance_factor == pytest.approx(float(rw @ rw) / (rw.size - choice.base.rank))
    assert [c.kind for c in result.columns] == [GEOMETRY] * len(result.base.names)


def test_solve_wls_is_least_squares():
    rng = np.random.default_rng(7)
    A, b = rng.normal(size=(30, 5)), rng.normal(size=30)
    x, _, Rinv = solve_wls(A, b)
    assert np.allclose(x, np.linalg.lstsq(A, b, rcond=None)[0])
    assert np.allclose(Rinv @ Rinv.T, np.linalg.inv(A.T @ A))


def test_fit_with_options_equals_fit_with_keywords(data):
    start, _, _, noisy = data
    by_keywords = fit(start, noisy, "bai42", method="linear", sigma_position=0.004)
    by_options = fit(start, noisy, "bai42", options=FitOptions(method="linear", sigma_position=0.004))
    assert np.array_equal(by_keywords.values, by_options.values)
    assert np.array_equal(by_keywords.sigma, by_options.sigma)


@pytest.mark.parametrize(("options", "says"), [
    ({"method": "newton"}, "method must be one of ('linear', 'iterated'), got 'newton'"),
    ({"frame": "tracker"}, "frame must be one of ('base', 'free'), got 'tracker'"),
    ({"pairs": "some"}, "pairs must be one of ('all', 'reference'), got 'some'"),
    ({"sigma_position": -1.0}, "sigma_position must be a positive finite number, got -1.0"),
    ({"rtol": float("nan")}, "rtol must be a positive finite number"),
    ({"max_iter": 0}, "max_iter must be a positive integer, got 0"),
    ({"distances": True, "free_points": ("smr",)}, "free_points=('smr',) applies to positions and poses"),
    ({"distances": True, "frame": "free"}, "frame='free' applies to positions and poses"),
])
def test_options_are_checked_once_naming_the_field(options, says):
    with pytest.raises(ValueError, match=None) as caught:
        FitOptions(**options)
    assert says in str(caught.value)


def test_options_are_frozen_and_identify_checks_through_them(data):
    start, _, _, noisy = data
    options = FitOptions(free_points=("smr_offset", "smr_offset"))
    assert options.free_points == ("smr_offset",)
    with pytest.raises(AttributeError):
        options.method = "linear"  # type: ignore[misc]
    with pytest.raises(ValueError, match="method must be one of"):
        identify(start, noisy, "complete", method="newton")


def test_overrides_win_over_the_options_and_are_checked_once(data):
    start, _, _, noisy = data
    linear = FitOptions(method="linear", sigma_position=0.004)
    by_override = fit(start, noisy, "bai42", options=FitOptions(method="iterated", sigma_position=0.004),
                      method="linear")
    assert np.array_equal(by_override.values, fit(start, noisy, "bai42", options=linear).values)
    assert fit_options(linear, {}) is linear
    assert fit_options(None, {"free_points": ["a", "b", "a"]}).free_points == ("a", "b")
    with pytest.raises(TypeError, match=r"'methd' is not an option of FitOptions \(did you mean 'method'"):
        identify(start, noisy, "complete", methd="linear")  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="options must be a FitOptions, got str 'linear'"):
        fit_options("linear", {})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="distances must be True or False, got 'yes'"):
        FitOptions(distances="yes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="free_points must be a sequence of names, got 'smr'"):
        FitOptions(free_points="smr")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="max_iter must be a positive integer"):
        fit(start, noisy, "bai42", options=linear, max_iter=0)


def test_the_overrides_are_the_options_fields():
    assert tuple(FitOverrides.__annotations__) == FitOptions.names()


def test_poor_fit_error_is_exported_with_codes():
    from deltacal.identification.quality import PoorFitError as old_home

    assert old_home is PoorFitError is deltacal.identification.PoorFitError
    assert issubclass(PoorFitError, deltacal.IdentificationError)
    error = PoorFitError("m", None, [], (PoorFitError.RICHER_MODEL,), "complete")
    assert error.codes == ("richer_model",) and error.model == "complete"
    with pytest.raises(ValueError, match="unknown poor-fit code 'typo'"):
        PoorFitError("m", None, [], ("typo",))


def test_the_result_tells_kinds_by_its_columns_not_by_names(data):
    start, _, _, noisy = data
    result = identify(start, noisy, "complete", frame="free", free_points=["smr_offset"])
    kinds = [c.kind for c in result.columns]
    assert [c.name for c in result.columns] == result.base.names
    assert FRAME in kinds and POINT in kinds
    assert result.deviation.size == len(get_model("complete").names)
    with pytest.raises(ValueError, match="one record per parameter"):
        replace(result, columns=result.columns[:-1])
