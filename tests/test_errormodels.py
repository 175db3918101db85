"""Error models: sensitivities against finite differences, the classical model's parallel
plate, and Bai 2015's closed-form model 24/42 (Eq. 6-10) at the nominal geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import workspace_points
from numpy.testing import assert_allclose

from deltacal import DeltaGeometry, NominalDelta, Tolerances
from deltacal.errormodels import MODEL_NAMES, ClassicalModel, ErrorModel, SubModel, get_model
from deltacal.errormodels.base import N_ELEMENTARY, elementary_jacobian
from deltacal.geometry import vector_from_rotation
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta

#: Central-difference steps. The error of a central difference is about
#: h² |f'''| / 6 (truncation) + eps / h (the forward solver's residual, ~1e-13 mm, and
#: rounding of coordinates of ~1e3 mm). With h = 0.01 mm (1e-5 rad for angles, which
#: moves a point 375 mm away by 4e-3 mm) both terms are below 1e-9 of the sensitivities.
H_MM = 1e-2
H_RAD = 1e-5
#: Relative agreement required between S and its finite differences.
FD_RTOL = 1e-6
#: Below this a column of orientation rows [rad per unit] is "zero" (it is then held to an
#: absolute bound): 1e-4 is five orders above the finite-difference noise of ~1e-10.
ORIENTATION_FLOOR = 1e-4
#: Absolute agreement of orientation columns below the floor [rad per unit]: the noise of
#: the differences is ~3e-10 (1e-15 rad of rotation error over h = 1e-5).
ORIENTATION_ATOL = 1e-8


def _classical_geometry(nominal: NominalDelta, rng: np.random.Generator) -> DeltaGeometry:
    """A robot with perfect parallelograms: the nominal moved within the classical family.

    Encoder offsets and axis tilts are applied in two calls: applied together they are
    composed into one rotation vector, which tilts the axis about the wrong direction
    (see test_classical_apply_with_offset_and_tilt_keeps_parallelograms below).
    """
    model = ClassicalModel()
    per_limb = np.array([0.15, 0.15, 0.15, 1.7e-3, 1.7e-3, math.radians(1.0), 0.05, 0.1])
    dk = rng.normal(0.0, 1.0, 24) * np.tile(per_limb, 3)
    offsets = np.zeros(24)
    offsets[5::8] = dk[5::8]
    dk[5::8] = 0.0
    return model.apply(model.apply(nominal.geometry(), offsets), dk)


def _sensitivity_and_differences(model: ErrorModel, geometry: DeltaGeometry, q: np.ndarray):
    """S at q and its central differences through exact.forward of model.apply(g, ±h e_k)."""
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)
    F = np.zeros_like(S)
    for k, unit in enumerate(model.units):
        h = H_MM if unit == "mm" else H_RAD
        dk = np.zeros(model.size)
        dk[k] = h
        plus = exact.forward(model.apply(geometry, dk), q, start=pose)
        minus = exact.forward(model.apply(geometry, -dk), q, start=pose)
        F[:, :3, k] = (plus.position - minus.position) / (2.0 * h)
        # rotation from the minus pose to the plus pose, in the base frame
        F[:, 3:, k] = vector_from_rotation(plus.rotation @ np.swapaxes(minus.rotation, 1, 2)) / (2.0 * h)
    return S, F


def _column_norms(A: np.ndarray) -> np.ndarray:
    """Norm of each parameter's column over all poses and rows, A of shape (N, r, n)."""
    return np.linalg.norm(A.transpose(2, 0, 1).reshape(A.shape[2], -1), axis=1)


@pytest.mark.parametrize("name", ["classical", "bai42", "complete", "bai18", "bai32"])
def test_sensitivity_matches_finite_differences(bai, name):
    rng = np.random.default_rng(5)
    model = get_model(name)
    if name == "classical":
        geometry = _classical_geometry(bai, rng)
    else:
        geometry = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 6, rng))
    S, F = _sensitivity_and_differences(model, geometry, q)
    # every parameter moves the plate: position rows agree relative to each column
    pos_norm, pos_err = _column_norms(S[:, :3]), _column_norms(S[:, :3] - F[:, :3])
    assert np.all(pos_norm > 0.1)
    assert np.max(pos_err / pos_norm) < FD_RTOL
    # orientation rows: relative where they are not zero, absolute where they are
    ori_norm, ori_err = _column_norms(S[:, 3:]), _column_norms(S[:, 3:] - F[:, 3:])
    tilting = ori_norm > ORIENTATION_FLOOR
    if tilting.any():
        assert np.max(ori_err[tilting] / ori_norm[tilting]) < FD_RTOL
    assert np.all(ori_err[~tilting] < ORIENTATION_ATOL)
    if model.tilts_plate and name != "bai18":
        assert tilting.sum() >= 14  # the orientation group does tilt the plate
    if name in ("classical", "bai18"):
        assert not tilting.any()  # near perfect parallelograms these models cannot tilt it


def test_model_contract(bai):
    for name in MODEL_NAMES:
        model = get_model(name)
        assert model.name == name
        assert len(model.names) == len(set(model.names)) == len(model.units) == model.size
        assert set(model.units) <= {"mm", "rad"}
        with pytest.raises(ValueError, match=f"expected {model.size} parameters"):
            model.apply(bai.geometry(), np.zeros(model.size + 1))
    assert [get_model(n).size for n in MODEL_NAMES] == [24, 42, 51, 24, 18, 36, 32]
    bai32 = get_model("bai32")
    assert isinstance(bai32, SubModel)
    assert set(bai32.names) < set(get_model("bai42").names)
    assert [get_model(n).rigid_motion_free for n in MODEL_NAMES] == [False] * 4 + [True] * 3  # Eq. 11
    assert get_model("bai42") is not get_model("bai42")  # made anew: a caller may change its own
    with pytest.raises(ValueError, match="unknown model 'bai99'; choose one of classical, bai42, .*klipper"):
        get_model("bai99")


def _parallelogram_mismatch(geometry: DeltaGeometry) -> float:
    """Largest difference between a limb's arm-pair and plate-pair vectors, or rod lengths [mm]."""
    R0 = geometry.actuator_rotation()
    arm_pair = np.einsum("ikl,il->ik", R0, geometry.arm_ball[:, 0] - geometry.arm_ball[:, 1])
    plate_pair = geometry.plate_ball[:, 0] - geometry.plate_ball[:, 1]
    rods = geometry.rod_length[:, 0] - geometry.rod_length[:, 1]
    return float(max(np.max(np.abs(arm_pair - plate_pair)), np.max(np.abs(rods))))


def test_classical_keeps_the_plate_parallel(bai):
    rng = np.random.default_rng(6)
    model = ClassicalModel()
    nominal = bai.geometry()
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 20, rng))
    # at a perfect geometry the classical parameters do not turn the plate at all
    S = model.sensitivity(nominal, q)
    assert np.max(np.abs(S[:, 3:])) < 1e-14
    assert np.max(np.abs(get_model("bai24").sensitivity(nominal, q)[:, 3:])) < 1e-14
    # positions, encoder offsets, arm and rod lengths keep the parallelograms exactly
    dk = rng.normal(0.0, 1.0, 24) * np.tile([0.15, 0.15, 0.15, 0, 0, 0.017, 0.05, 0.1], 3)
    moved = model.apply(nominal, dk)
    assert _parallelogram_mismatch(moved) < 1e-12
    assert moved.is_perfect(atol=1e-12)
    # axis tilts turn the arm pair with the exact rotation R(w) of the actuator frame and the
    # plate pair with the same finite rotation (ErrorModel.pair_rotations): still exact
    tilts = rng.normal(0.0, 1.7e-3, (3, 2))
    dk = np.zeros(24)
    dk[3::8], dk[4::8] = tilts[:, 0], tilts[:, 1]
    tilted = model.apply(nominal, dk)
    assert _parallelogram_mismatch(tilted) < 1e-12
    assert tilted.is_perfect(atol=1e-12)
    # so the plate stays parallel through the exact kinematics
    assert np.max(exact.forward(tilted, q).tilt()) < 1e-12


def test_is_perfect_honours_atol(bai):
    g = bai.geometry().with_errors({"limb1.rod1.length": 0.005})
    assert _parallelogram_mismatch(g) == pytest.approx(0.005)
    assert not g.is_perfect(atol=1e-9)


def test_classical_apply_with_offset_and_tilt_keeps_parallelograms(bai):
    model = ClassicalModel()
    dk = np.zeros(24)
    dk[3] = 1e-3  # tilt of limb 1 about x0 [rad]
    dk[5] = math.radians(1.0)  # encoder offset of limb 1 [rad]
    moved = model.apply(bai.geometry(), dk)
    # tilt and offset together keep the parallelogram exact too (once: 8.7e-4 mm = |tilt| |offset| c/2)
    assert _parallelogram_mismatch(moved) < 1e-12


# ----------------------------------------------------------------- Bai 2015, Eq. 6-10
def _bai_closed_form(nominal: NominalDelta, x: np.ndarray, q: np.ndarray):
    """Bai's C_rr, C_rε and C_ε (Eq. 8-9) at plate position x and readings q, written out.

    Bai's limb frame {0B_i}: u0 along the arm's zero direction (r_i), v0 up, w0 = u0 × v0
    (= -t_i) along the actuator axis; his joint angle θ_i turns about w0, so θ = -q.
    """
    L, b, a = nominal.arm_length, nominal.base_radius, nominal.plate_radius
    A_rr, A_re, A_ee = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    B_r, B_e = np.zeros((3, 24)), np.zeros((3, 18))
    for i in range(3):
        u0, v0 = nominal.radial[i], np.array([0.0, 0.0, 1.0])
        w0 = np.cross(u0, v0)
        theta = -q[i]
        u1 = math.cos(theta) * u0 + math.sin(theta) * v0  # arm direction, R0 R1 x
        v1 = np.cross(w0, u1)  # Eq. 2
        elbow = b * u0 + L * u1  # C_i
        plate_ball = x + a * u0  # A_i
        l_hat = (plate_ball - elbow) / np.linalg.norm(plate_ball - elbow)
        A_rr[i] = l_hat  # Eq. 6
        A_re[i] = np.cross(a * u0, l_hat)
        A_ee[i] = np.cross(w0, l_hat)  # Eq. 7
        s, c = math.sin(theta), math.cos(theta)
        B_r[i, 8 * i : 8 * i + 8] = [l_hat @ v1, *l_hat, l_hat @ u1, s * l_hat @ w0, -c * l_hat @ w0, 1.0]
        B_e[i, 6 * i : 6 * i + 6] = [1.0, l_hat @ w0, -l_hat @ v0, l_hat @ u0, -l_hat @ v1, l_hat @ u1]
    C_rr = np.linalg.solve(A_rr, B_r)  # Eq. 10
    C_e = np.linalg.solve(A_ee, B_e)  # Eq. 9
    C_re = -np.linalg.solve(A_rr, A_re @ C_e)  # Eq. 8
    return C_rr, C_re, C_e


def _bai_poses(bai, n: int = 8):
    rng = np.random.default_rng(7)
    x = workspace_points(bai, n, rng)
    return x, VirtualDelta.from_nominal(bai).inverse(x)


def test_bai24_position_rows_are_bai_eq_10(bai):
    x, q = _bai_poses(bai)
    S = get_model("bai24").sensitivity(bai.geometry(), q)
    for k in range(len(q)):
        C_rr = _bai_closed_form(bai, x[k], q[k])[0]
        assert_allclose(S[k, :3], C_rr, rtol=0, atol=1e-12 * np.max(np.abs(C_rr)))
    assert np.max(np.abs(S[:, 3:])) < 1e-14  # model 24: plate parallel


def test_bai42_rows_are_bai_eq_8_9_except_dltilde(bai):
    x, q = _bai_poses(bai)
    model = get_model("bai42")
    S = model.sensitivity(bai.geometry(), q)
    keep = [k for k, n in enumerate(model.names[24:]) if not n.startswith("dltilde")]
    for k in range(len(q)):
        C_rr, C_re, C_e = _bai_closed_form(bai, x[k], q[k])
        assert_allclose(S[k, :3, :24], C_rr, rtol=0, atol=1e-12 * np.max(np.abs(C_rr)))
        assert_allclose(S[k, :3, 24:][:, keep], C_re[:, keep], rtol=0, atol=1e-12 * np.max(np.abs(C_re)))
        assert_allclose(S[k, 3:, 24:][:, keep], C_e[:, keep], rtol=0, atol=1e-12 * np.max(np.abs(C_e)))


def test_bai42_dltilde_is_bai_eq_9(bai):
    x, q = _bai_poses(bai)
    model = get_model("bai42")
    S = model.sensitivity(bai.geometry(), q)
    cols = [k for k, n in enumerate(model.names[24:]) if n.startswith("dltilde")]
    for k in range(len(q)):
        C_e = _bai_closed_form(bai, x[k], q[k])[2]
        assert_allclose(S[k, 3:, 24:][:, cols], C_e[:, cols], rtol=0, atol=1e-12 * np.max(np.abs(C_e)))


def test_elementary_jacobian_times_moves_is_the_product(bai):
    """J_k e without forming J_k (compensation's path) equals J_k @ e, at any pose."""
    rng = np.random.default_rng(5)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    q = np.radians(rng.uniform(-10.0, 40.0, (20, 3)))
    pose = exact.forward(g, q)
    e = rng.standard_normal(N_ELEMENTARY)
    full = np.einsum("nke,e->nk", elementary_jacobian(g, q, pose), e)
    assert np.max(np.abs(elementary_jacobian(g, q, pose, moves=e) - full)) < 1e-12 * np.max(np.abs(full))
