"""Base parameters: the QR rank and regroupings on constructed regressors, and the ranks of
Bai 2015's distance models (§3.2) and of the complete model with pose measurements."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import workspace_points
from numpy.testing import assert_allclose

from deltacal import NominalDelta
from deltacal.errormodels import get_model
from deltacal.errormodels.bai import MODEL32_REMOVED
from deltacal.geometry import vector_from_rotation
from deltacal.identifiability import base_parameters, pivoted_qr
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.observations import Measurements, build_rows, pair_rows

SIGMA_POSITION = 0.005  # [mm]
SIGMA_ANGLE = math.radians(0.003)  # [rad]


# ------------------------------------------------------------- constructed regressors
def test_full_rank_regressor():
    rng = np.random.default_rng(1)
    # columns in wildly different units: the scaling must not change the rank
    W = rng.normal(size=(40, 6)) * np.array([1e-3, 1.0, 1e3, 1.0, 1e6, 1e-6])
    names = [f"p{k}" for k in range(6)]
    base = base_parameters(W, names)
    assert base.rank == 6
    assert sorted(base.base) == list(range(6))
    assert base.unidentifiable == [] and base.absent == []
    assert_allclose(base.regrouping, np.eye(6)[base.base], atol=0)
    assert base.condition_number == pytest.approx(np.linalg.cond(W / np.linalg.norm(W, axis=0)), rel=1e-10)
    dk = rng.normal(size=6)
    assert_allclose(base.project(dk), dk[base.base], rtol=1e-15)
    assert_allclose(base.expand(base.project(dk)), dk, rtol=1e-15)
    assert sorted(base.labels()) == sorted(f"δ{n}" for n in names)


def _deficient_regressor(rng):
    """Columns p0..p5 with p2 = p0 - 2 p1, p4 = 0 and p5 = 1e-3 p3 (another unit)."""
    W = np.zeros((30, 6))
    W[:, 0], W[:, 1], W[:, 3] = rng.normal(size=30), rng.normal(size=30), 1e3 * rng.normal(size=30)
    W[:, 2] = W[:, 0] - 2.0 * W[:, 1]
    W[:, 5] = 1e-3 * W[:, 3]
    return W, [f"p{k}" for k in range(6)]


def test_rank_deficient_regressor_with_known_regroupings():
    rng = np.random.default_rng(2)
    W, names = _deficient_regressor(rng)
    base = base_parameters(W, names, prefer=["p0", "p1", "p3"])
    assert base.rank == 3
    assert base.base == [0, 1, 3]
    assert base.unidentifiable == [2, 4, 5]
    assert base.absent == [4]
    expected = np.array(
        [
            [1.0, 0.0, 1.0, 0.0, 0.0, 0.0],  # p0 + p2: p2 moves the measurements like p0 - 2 p1
            [0.0, 1.0, -2.0, 0.0, 0.0, 0.0],  # p1 - 2 p2
            [0.0, 0.0, 0.0, 1.0, 0.0, 1e-3],  # p3 + 0.001 p5
        ]
    )
    assert_allclose(base.regrouping, expected, atol=1e-12)
    assert base.labels() == ["δp0 + δp2", "δp1 − 2 δp2", "δp3 + 0.001 δp5"]
    # whichever columns pivoted QR keeps, the base parameters carry the whole effect
    for b in (base, base_parameters(W, names)):
        assert b.rank == 3
        dk = rng.normal(size=6)
        assert_allclose(W[:, b.base] @ b.project(dk), W @ dk, rtol=1e-10, atol=1e-10 * np.abs(W).max())
        assert_allclose(W @ b.expand(b.project(dk)), W @ dk, rtol=1e-10, atol=1e-10 * np.abs(W).max())


def test_rank_tolerance_is_relative_to_the_scaled_columns():
    rng = np.random.default_rng(3)
    W, names = _deficient_regressor(rng)
    noise = rng.normal(size=30)
    nearly = W.copy()
    nearly[:, 2] += 1e-12 * np.linalg.norm(W[:, 2]) * noise / np.linalg.norm(noise)
    assert base_parameters(nearly, names).rank == 3  # dependent to 1e-12: below rtol = 1e-8
    apart = W.copy()
    apart[:, 2] += 1e-6 * np.linalg.norm(W[:, 2]) * noise / np.linalg.norm(noise)
    assert base_parameters(apart, names).rank == 4  # 1e-6: a (poorly) identifiable column
    assert base_parameters(1e9 * W, names).rank == 3  # units of the measurements do not matter


# ---------------------------------------------------------------- Bai 2015, §3.2
def _bai_poses(nominal: NominalDelta, n: int) -> np.ndarray:
    """Bai's 2n + 1 poses (§3.3, Fig. 4): the workspace centre and n evenly spaced points on
    the boundary of the top and of the bottom layer; readings [rad]."""
    ws = nominal.workspace
    angle = 2.0 * np.pi * np.arange(n) / n
    rim = ws.radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    points = [ws.centre[None]]
    points += [np.column_stack([rim, np.full(n, z)]) for z in (ws.top_z, ws.bottom_z)]
    return VirtualDelta.from_nominal(nominal).inverse(np.vstack(points))


def _distance_regressor(nominal: NominalDelta, model_name: str, n: int, points: list[str]):
    """Weighted distance regressor (all pairs of each point) at the nominal geometry."""
    g = nominal.geometry()
    q = _bai_poses(nominal, n)
    pose = exact.forward(g, q)
    meas = Measurements(
        q=np.vstack([q] * len(points)),
        position=np.vstack([pose.point(g.point(p)) for p in points]),
        point=[p for p in points for _ in range(len(q))],
    )
    model = get_model(model_name)
    rows = pair_rows(g, meas, model.sensitivity, SIGMA_POSITION)
    assert rows.residual.size == len(points) * len(q) * (len(q) - 1) // 2  # Bai's K = C(2n+1, 2)
    return rows.scaled[1], model  # Bai's H: rows divided by σ (not whitened)


def test_bai18_distances_of_one_point_identify_all_18(bai):
    W, model = _distance_regressor(bai, "bai18", 7, ["smr_centre"])  # Bai §5.2: n = 7, K = 105
    base = base_parameters(W, model.names)
    assert base.rank == 18
    assert base.condition_number < 1e3


def test_bai24_distances_without_gauge_miss_the_six_rigid_motions(bai):
    W, model = _distance_regressor(bai, "bai24", 7, ["smr_centre"])
    assert base_parameters(W, model.names).rank == 18
    # the null space is the rigid motions of the base frame, written in Bai's parameters:
    # a translation v moves every Δe_i by v; a rotation w moves Δe_i by w × (b - a) r_i and
    # turns each actuator frame by w (LΔθ = L w.w0, LΔα0 = L w.u0, LΔβ0 = L w.v0)
    L, e = bai.arm_length, bai.base_radius - bai.plate_radius
    up = np.array([0.0, 0.0, 1.0])
    motions = []
    for v in np.eye(3):
        dk = np.zeros(24)
        for i in range(3):
            dk[8 * i + 1 : 8 * i + 4] = v
        motions.append(dk)
    for w in np.eye(3):
        dk = np.zeros(24)
        for i, r in enumerate(bai.radial):
            w0 = np.cross(r, up)
            dk[8 * i] = L * w @ w0
            dk[8 * i + 1 : 8 * i + 4] = np.cross(w, e * r)
            dk[8 * i + 5], dk[8 * i + 6] = L * w @ r, L * w @ up
        motions.append(dk)
    motions = np.array(motions).T
    assert np.linalg.matrix_rank(motions) == 6
    assert np.max(np.abs(W @ motions)) < 1e-12 * np.max(np.abs(W)) * np.max(np.abs(motions))


def test_bai36_distances_of_two_points_rank_32(bai):
    # Bai §5.2: model 32 from 2n + 1 = 19 poses of the two reflectors, K = 2 C(19, 2) = 342
    W, model = _distance_regressor(bai, "bai36", 9, ["smr_centre", "smr_offset"])
    base = base_parameters(W, model.names)
    assert base.rank == 32
    # Bai's Eq. 19: the four dependencies tie the actuator tilts (LΔα0, LΔβ0) and encoder
    # offsets (LΔθ) to the pair orientation errors (Δα03, Δβ03, Δα2). The pivoted QR keeps the
    # orientation errors and drops actuator parameters; where columns tie (all have unit norm at
    # the first step, and the limbs are symmetric) the earlier parameter is kept ...
    assert base.unidentifiable_names == ["Ldtheta2", "Ldalpha0_2", "Ldalpha0_3", "Ldbeta0_3"]
    # ... preferring the position group instead drops exactly Bai's four (model 32)
    prefer = [n for n in model.names if n not in MODEL32_REMOVED]
    assert base_parameters(W, model.names, prefer=prefer).unidentifiable_names == MODEL32_REMOVED
    W32, model32 = _distance_regressor(bai, "bai32", 9, ["smr_centre", "smr_offset"])
    assert base_parameters(W32, model32.names).rank == 32
    # without Eq. 11's gauge the six rigid motions are lost as well
    W42, model42 = _distance_regressor(bai, "bai42", 9, ["smr_centre", "smr_offset"])
    assert base_parameters(W42, model42.names).rank == 32


def test_complete_model_with_pose_measurements_rank_42(bai):
    rng = np.random.default_rng(4)
    g = bai.geometry().with_tool([0.0, 0.0, -180.0])
    q = VirtualDelta.from_geometry(g).inverse(workspace_points(bai, 60, rng) - bai.tool)
    pose = exact.forward(g, q)
    meas = Measurements(q, pose.point(g.tool), rotation_vector=vector_from_rotation(pose.rotation))
    model = get_model("complete")
    W = build_rows(g, meas, model.sensitivity, SIGMA_POSITION, SIGMA_ANGLE).weighted[1]
    base = base_parameters(W, model.names)
    # 51 - 9: per limb, physically,
    # * 2 x "a rod slid along its actuator axis": moving both ball centres of rod (i, j) by
    #   the same vector along the axis t_i (a_ijy in the arm frame, b_ij along t_i in the
    #   plate frame) changes no rod equation, the axis being fixed in the base and the
    #   plate parallel to it at the nominal geometry (6 in all);
    # * 1 x "encoder offset = both arm balls lowered": turning arm i about its axis by δ
    #   moves both arm balls (at x = L in the arm frame) by -L δ along the arm's z (3).
    assert base.rank == 42
    L = bai.arm_length
    null = []
    for i in range(3):
        for j in range(2):
            dk = np.zeros(51)
            dk[model.names.index(f"a{i + 1}{j + 1}y")] = 1.0
            for k, a in enumerate("xyz"):
                dk[model.names.index(f"b{i + 1}{j + 1}{a}")] = bai.tangent[i, k]
            null.append(dk)
        dk = np.zeros(51)
        dk[model.names.index(f"beta{i + 1}t")] = 1.0
        dk[model.names.index(f"a{i + 1}1z")] = dk[model.names.index(f"a{i + 1}2z")] = L
        null.append(dk)
    null = np.array(null).T
    assert np.linalg.matrix_rank(null) == 9
    assert np.max(np.abs(W @ null)) < 1e-12 * np.max(np.abs(W)) * np.max(np.abs(null))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_named_base_parameters_do_not_depend_on_rounding(bai, seed):
    """Ties are broken by the model's order, not by the last bits of BLAS (which vary by CPU)."""
    W, model = _distance_regressor(bai, "bai36", 9, ["smr_centre", "smr_offset"])
    base = base_parameters(W, model.names)
    rng = np.random.default_rng(seed)
    noisy = W * (1.0 + 1e-12 * rng.standard_normal(W.shape))
    again = base_parameters(noisy, model.names)
    assert again.rank == base.rank
    assert again.base_names == base.base_names
    assert again.unidentifiable_names == base.unidentifiable_names


def test_pivoted_qr_breaks_exact_ties_by_column_order():
    # three identical columns and a fourth independent: the first of the three is kept
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = np.array([0.0, 1.0, 0.0, -1.0])
    W = np.column_stack([a, a, a, b])
    for names in (["p0", "p1", "p2", "p3"], ["x", "y", "z", "w"]):
        base = base_parameters(W, names)
        assert base.rank == 2
        assert base.base_names[0] == names[0] and set(base.base_names) == {names[0], names[3]}
    diag, perm = pivoted_qr(W / np.linalg.norm(W, axis=0))
    assert perm[0] == 0 and diag[0] == pytest.approx(1.0) and diag[2] < 1e-12
