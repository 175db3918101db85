"""Tests of Savoure's planar parallelogram mechanism (deltacal.planar)."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.exceptions import AssemblyError, GeometryError, IdentificationError, UnreachableError
from deltacal.identifiability import base_parameters
from deltacal.planar import (
    LOOP_TOLERANCE,
    PAPER_BASE_ORDER,
    PARAMETER_NAMES,
    PlanarGeometry,
    PlanarMultibody,
    SimplifiedModel,
    calibration_jacobians,
    command_classical,
    command_improved,
    configuration,
    forward_position,
    identify_complete,
    identify_simplified,
    sensitivity,
    table2_errors,
)

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "reproduce_savoure2006.py"
Q_MEASURED = np.deg2rad(np.arange(-45.0, 45.0 + 1e-9, 5.0))
Q_FINE = np.deg2rad(np.arange(-60.0, 60.0 + 1e-9, 1.0))
NOMINAL = PlanarGeometry()
TRUE = NOMINAL.perturbed(table2_errors())
PAPER_REGROUPINGS = ["δa2x − δb2x", "δa2y − δb2y", "δb1x − δa1x"]  # Eq. 70-72


def random_errors(rng: np.random.Generator, size: float = 1.0) -> np.ndarray:
    """Errors of the size of Table 2's: 0.01° on q0, about 1 mm elsewhere."""
    return size * rng.normal(size=9) * np.array([np.deg2rad(0.01)] + [1.0] * 8)


def load_script():
    spec = importlib.util.spec_from_file_location("reproduce_savoure2006", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


# --- geometry ------------------------------------------------------------------------------


def test_table2_values():
    assert NOMINAL.parameters().tolist() == [0.0, 125.0, 125.0, 0.0, 125.0, 125.0, 0.0, 950.0, 950.0]
    assert NOMINAL.h == 100.0
    assert_allclose(np.rad2deg(table2_errors()[0]), 0.01)
    assert table2_errors()[1:].tolist() == [1.0, 0.0, 3.0, 0.0, -2.0, 0.0, 1.0, -1.0]
    assert TRUE.a2y == 3.0 and TRUE.b2x == 123.0 and TRUE.l2 == 949.0


def test_bad_geometry_is_refused():
    with pytest.raises(GeometryError, match="l2"):
        PlanarGeometry(l2=0.0)
    with pytest.raises(GeometryError, match="not finite"):
        PlanarGeometry(h=float("nan"))
    with pytest.raises(ValueError, match="shape"):
        NOMINAL.perturbed(np.zeros(8))


# --- simplified model, Eq. 34-38 -----------------------------------------------------------


def test_simplified_round_trip_and_derivatives():
    model = SimplifiedModel(length=951.0, q0=np.deg2rad(0.3), h=100.0)
    q = Q_MEASURED
    assert_allclose(model.inverse(model.forward(q)), q, atol=1e-14)
    eps = 1e-6
    fd = (model.forward(q + eps) - model.forward(q - eps)) / (2 * eps)
    assert_allclose(model.jacobian(q), fd, rtol=1e-8)
    assert_allclose(model.inverse_jacobian(q) * model.jacobian(q), 1.0, rtol=1e-14)
    S = model.sensitivity(q)
    for j, delta in enumerate(([eps, 0.0], [0.0, 1e-3])):
        step = delta[j]
        d = np.array(delta)
        fd_pose = (model.corrected(d).forward_pose(q) - model.corrected(-d).forward_pose(q)) / (2 * step)
        assert_allclose(S[:, :, j], fd_pose, rtol=1e-7, atol=1e-9)


def test_simplified_inverse_out_of_reach():
    with pytest.raises(UnreachableError, match="beyond the bar length"):
        SimplifiedModel().inverse(np.array([0.0, 951.0]))


# --- complete forward model, Eq. 41-52, against the Pinocchio loop --------------------------


@pytest.mark.parametrize("h", [0.0, 100.0, 200.0])
def test_closed_form_matches_pinocchio(h):
    rng = np.random.default_rng(41)
    geometries = [NOMINAL, TRUE] + [NOMINAL.perturbed(random_errors(rng, 3.0)) for _ in range(3)]
    for g in geometries:
        g = g.with_tool(h)
        exact = PlanarMultibody(g).tcp_pose(Q_FINE)
        closed = forward_position(Q_FINE, g)
        assert_allclose(closed[:, :2], exact[:, :2], rtol=0, atol=1e-9)  # [mm]
        assert_allclose(closed[:, 2], exact[:, 2], rtol=0, atol=1e-12)  # [rad]


def test_closed_form_closes_the_loop():
    cfg = configuration(Q_FINE, TRUE)
    assert_allclose(np.linalg.norm(cfg.b1 - cfg.a1, axis=-1), TRUE.l1, rtol=1e-15)
    assert_allclose(np.linalg.norm(cfg.b2 - cfg.a2, axis=-1), TRUE.l2, rtol=1e-15)
    # B1B2 is rigid on the plate and C sits h below O_p.
    assert_allclose(np.linalg.norm(cfg.b2 - cfg.b1, axis=-1), np.hypot(248.0, 0.0), rtol=1e-14)
    assert_allclose(np.linalg.norm(cfg.c - cfg.b1, axis=-1), np.hypot(TRUE.b1x, TRUE.h), rtol=1e-14)


def test_nominal_is_the_simplified_model():
    pose = forward_position(Q_FINE, NOMINAL)
    assert_allclose(pose, SimplifiedModel.from_geometry(NOMINAL).forward_pose(Q_FINE), atol=1e-10)


def test_pinocchio_loop_residual():
    mb = PlanarMultibody(TRUE)
    config = mb.assemble(0.3)
    assert np.linalg.norm(mb.closure_residual(config)) < LOOP_TOLERANCE


def test_impossible_assembly():
    with pytest.raises(AssemblyError, match="does not close"):
        configuration(np.array([0.0, 0.1]), PlanarGeometry(l2=500.0))


# --- complete sensitivity, Eq. 56-69 --------------------------------------------------------


def finite_difference_sensitivity(q: np.ndarray, g: PlanarGeometry) -> np.ndarray:
    steps = np.array([1e-6] + [1e-3] * 8)  # [rad], [mm]
    columns = []
    for j, step in enumerate(steps):
        d = np.zeros(9)
        d[j] = step
        columns.append(
            (forward_position(q, g.perturbed(d)) - forward_position(q, g.perturbed(-d))) / (2 * step)
        )
    return np.stack(columns, axis=-1)


# Natural scale of each entry: rows x, y [mm] and alpha [rad] per mm of error (1 / 250 mm of
# base), columns per mm, q0 per rad (times l = 950 mm).
ENTRY_SCALE = np.outer([1.0, 1.0, 1.0 / 250.0], [950.0] + [1.0] * 8)


@pytest.mark.parametrize("h", [0.0, 100.0, 200.0])
def test_sensitivity_matches_finite_differences(h):
    rng = np.random.default_rng(56)
    for g in (NOMINAL, TRUE, NOMINAL.perturbed(random_errors(rng, 3.0))):
        g = g.with_tool(h)
        S = sensitivity(Q_FINE, g)
        S_fd = finite_difference_sensitivity(Q_FINE, g)
        assert np.all(np.abs(S - S_fd) <= 1e-6 * ENTRY_SCALE)


def test_nominal_jacobians_are_eq_64_65():
    q = Q_MEASURED
    length, h, b1x, b2x = 950.0, NOMINAL.h, NOMINAL.b1x, NOMINAL.b2x
    u, v = np.sin(q), -np.cos(q)
    zero, one = np.zeros_like(q), np.ones_like(q)
    J_X = np.stack(
        [
            np.stack([u, v, -u * h - v * b1x], -1),
            np.stack([u, v, -u * h + v * b2x], -1),
            np.stack([-v, u, v * h - u * b1x], -1),
        ],
        -2,
    )
    J_k = np.stack(
        [
            np.stack([zero, -u, zero, zero, u, zero, zero, one, zero], -1),
            np.stack([zero, zero, u, v, zero, -u, -v, zero, one], -1),
            # Eq. 65 prints [-l, 0, ..., -v, ...]; the differential of Eq. 55 gives +l and +v δa1x.
            np.stack([length * one, v, zero, zero, -v, zero, zero, zero, zero], -1),
        ],
        -2,
    )
    J_X_c, J_k_c = calibration_jacobians(q, NOMINAL)
    assert_allclose(J_X_c, J_X, atol=1e-12)
    assert_allclose(J_k_c, J_k, atol=1e-9)
    # The printed third row fails the finite-difference test: it is a misprint.
    J_k_paper = J_k.copy()
    J_k_paper[:, 2, 0] = -length
    J_k_paper[:, 2, 1] = 0.0
    S_paper = np.linalg.solve(J_X, J_k_paper)
    assert np.max(np.abs(S_paper - finite_difference_sensitivity(q, NOMINAL))) > 100.0


def test_q0_column_is_eq_38():
    S_C = sensitivity(Q_MEASURED, NOMINAL)
    S_S = SimplifiedModel.from_geometry(NOMINAL).sensitivity(Q_MEASURED)
    assert_allclose(S_C[:, :, 0], S_S[:, :, 0], atol=1e-9)


# --- observability, Eq. 70-73 ---------------------------------------------------------------


@pytest.mark.parametrize("h", [0.0, 100.0, 200.0])
def test_six_of_nine_with_paper_regroupings(h):
    S_G = sensitivity(Q_MEASURED, NOMINAL.with_tool(h)).reshape(-1, 9)
    base = base_parameters(S_G, list(PARAMETER_NAMES), prefer=PAPER_BASE_ORDER)
    assert base.rank == 6
    assert base.base_names == ["q0", "a2x", "a2y", "b1x", "l1", "l2"]
    assert base.labels() == ["δq0"] + PAPER_REGROUPINGS[:3] + ["δl1", "δl2"]
    expected = np.zeros((6, 9))
    for row, (kept, dropped, sign) in enumerate(
        [
            ("q0", None, 0),
            ("a2x", "b2x", -1),
            ("a2y", "b2y", -1),
            ("b1x", "a1x", -1),
            ("l1", None, 0),
            ("l2", None, 0),
        ]
    ):
        expected[row, PARAMETER_NAMES.index(kept)] = 1.0
        if dropped:
            expected[row, PARAMETER_NAMES.index(dropped)] = sign
    assert_allclose(base.regrouping, expected, atol=1e-9)
    # Without a preference the pivoted QR finds the same rank.
    assert base_parameters(S_G, list(PARAMETER_NAMES)).rank == 6


def test_base_columns_are_full_rank():
    S_G = sensitivity(Q_MEASURED, NOMINAL).reshape(-1, 9)
    kept = [PARAMETER_NAMES.index(n) for n in ("q0", "a2x", "a2y", "b1x", "l1", "l2")]
    base = base_parameters(S_G[:, kept], [PARAMETER_NAMES[k] for k in kept])
    assert base.rank == 6 and base.unidentifiable == []
    assert np.isfinite(base.condition_number)


# --- identification -------------------------------------------------------------------------


def test_noise_free_recovers_representable_errors():
    rng = np.random.default_rng(23)
    delta = random_errors(rng)
    delta[[1, 5, 6]] = 0.0  # a1x, b2x, b2y: not kept, so the true geometry is in the model
    measured = PlanarMultibody(NOMINAL.perturbed(delta)).tcp_pose(Q_MEASURED)
    result = identify_complete(Q_MEASURED, measured, NOMINAL)
    assert result.regroupings() == PAPER_REGROUPINGS
    assert_allclose(result.estimate[0], delta[0], atol=1e-12)  # [rad]
    assert_allclose(result.estimate[1:], result.base.project(delta)[1:], atol=1e-9)  # [mm]
    assert result.residual_rms < 1e-10


def test_noise_free_recovers_base_combination_to_second_order():
    # The regroupings of Eq. 70-72 hold to first order (they mix base and plate frames),
    # so the recovery error of the base combination must shrink as the square of the errors.
    misfit = []
    for size in (1.0, 0.1, 0.01):
        delta = size * table2_errors()
        measured = PlanarMultibody(NOMINAL.perturbed(delta)).tcp_pose(Q_MEASURED)
        result = identify_complete(Q_MEASURED, measured, NOMINAL)
        misfit.append(np.max(np.abs(result.estimate[1:] - result.base.project(delta)[1:])))
    assert misfit[0] < 0.1  # [mm] for Table 2's errors
    assert_allclose(misfit[0] / misfit[1], 100.0, rtol=0.1)
    assert_allclose(misfit[1] / misfit[2], 100.0, rtol=0.1)


def test_noisy_identification_agrees_with_its_standard_deviations():
    rng = np.random.default_rng(2006)
    sigma = np.array([0.003, 0.003, np.deg2rad(0.003)])
    exact = PlanarMultibody(TRUE).tcp_pose(Q_MEASURED)
    reference = identify_complete(Q_MEASURED, exact, NOMINAL, noise_std=sigma)
    z = []
    for _ in range(20):
        noisy = exact + rng.normal(size=exact.shape) * sigma
        result = identify_complete(Q_MEASURED, noisy, NOMINAL, noise_std=sigma)
        z.append((result.estimate - reference.estimate) / result.std)
    z = np.array(z)
    # 120 standard normal draws: none beyond 4.5 sigma, and a spread close to 1.
    assert np.max(np.abs(z)) < 4.5
    assert 0.8 < np.std(z) < 1.2


def test_simplified_identification_of_a_true_parallelogram():
    # With l1 = l2 and the joints at nominal the mechanism is exactly the virtual bar.
    delta = np.array([np.deg2rad(0.05), 0, 0, 0, 0, 0, 0, 1.5, 1.5])
    measured = PlanarMultibody(NOMINAL.perturbed(delta)).tcp_pose(Q_MEASURED)
    for coordinates in (("x",), ("x", "y")):
        result = identify_simplified(
            Q_MEASURED, measured, SimplifiedModel.from_geometry(NOMINAL), coordinates=coordinates
        )
        assert_allclose(result.delta, [delta[0], 1.5], atol=1e-10)


def test_identification_needs_enough_configurations():
    measured = forward_position(Q_MEASURED[:1], TRUE)
    with pytest.raises(IdentificationError, match="cannot identify"):
        identify_complete(Q_MEASURED[:1], measured, NOMINAL)
    with pytest.raises(IdentificationError, match=">= 2"):
        identify_simplified(Q_MEASURED[:1], measured, SimplifiedModel())
    with pytest.raises(ValueError, match="shape"):
        identify_complete(Q_MEASURED, measured, NOMINAL)


# --- compensation ---------------------------------------------------------------------------


def test_classical_compensation_is_exact_for_a_true_parallelogram():
    delta = np.array([np.deg2rad(0.05), 0, 0, 0, 0, 0, 0, 1.5, 1.5])
    true = PlanarMultibody(NOMINAL.perturbed(delta).with_tool(200.0))
    model = SimplifiedModel.from_geometry(NOMINAL).corrected([delta[0], 1.5])
    x = np.linspace(-600.0, 600.0, 13)
    assert_allclose(true.tcp_pose(command_classical(x, model))[:, 0], x, atol=1e-9)


def test_improved_compensation_error_is_second_order():
    # Eq. 29-33 are linear in the errors: what is left must scale as their square.
    x = SimplifiedModel.from_geometry(NOMINAL).forward(np.deg2rad(np.arange(-45.0, 46.0, 5.0)))
    nominal = NOMINAL.with_tool(200.0)
    left = []
    for size in (0.1, 0.01):
        true = NOMINAL.perturbed(size * table2_errors())
        result = identify_complete(Q_MEASURED, PlanarMultibody(true).tcp_pose(Q_MEASURED), NOMINAL)
        reached = PlanarMultibody(true.with_tool(200.0)).tcp_pose(command_improved(x, nominal, result))
        left.append(np.max(np.abs(reached[:, 0] - x)))
    assert_allclose(left[0] / left[1], 100.0, rtol=0.05)


@pytest.mark.slow
def test_reproduction_script(tmp_path):
    summary = load_script().run(tmp_path, seed=2006)
    on_disk = json.loads((tmp_path / "savoure2006.json").read_text())
    assert on_disk["identifiable"] == summary["identifiable"] == 6
    assert on_disk["parameters"] == 9
    assert on_disk["regroupings"] == PAPER_REGROUPINGS
    for h in ("h0", "h200"):
        errors = on_disk["max_error_mm"][h]
        assert set(errors) == {"none", "classical", "improved"}
        assert all(isinstance(v, float) for v in errors.values())
        assert errors["improved"] < errors["classical"] < errors["none"]
    h200 = on_disk["max_error_mm"]["h200"]
    assert h200["improved"] < 0.25 * h200["classical"]
    for n in (5, 6, 7):
        assert (tmp_path / f"savoure2006_fig{n}.png").stat().st_size > 10_000
