"""Distances at a cost linear in the positions, against the dense generalised least squares (issue 20).

The reference below is written here, from Bai's Eq. 12-17: every pair's distance, its row of the
regressor, and the covariance of the correlated distances ``σ² D Dᵀ`` whitened by its SVD, then
Gauss-Newton on the same base parameters. It costs n⁴ and is only for small cases; the package's
rows (positions with each point's rigid motion projected out for all pairs, a low-rank whitening
for reference pairs) must give the same estimate and σ.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

from deltacal import Tolerances
from deltacal.errormodels import get_model
from deltacal.identification import fit, identify
from deltacal.kinematics import exact
from deltacal.observations import SIGMA_POSITION, Measurements, SharedReference, predicted_points
from deltacal.planning import bai_poses
from deltacal.rotations import skew


def dense_rows(geometry, meas, model, pairs):
    """Whitened residual and regressor of the distances, the dense way (SVD of the covariance)."""
    pose = exact.forward(geometry, meas.q)
    S = model.sensitivity(geometry, meas.q, pose)
    P = predicted_points(geometry, meas, pose)
    JP = S[:, :3] - skew(P - pose.position) @ S[:, 3:]
    names = np.array(meas.point)
    ab = []
    for name in dict.fromkeys(meas.point):
        idx = np.flatnonzero(names == name)
        if pairs == "all":
            ab += [(idx[i], idx[j]) for i in range(idx.size) for j in range(i + 1, idx.size)]
        else:
            ab += [(idx[0], idx[j]) for j in range(1, idx.size)]
    a, b = np.array(ab).T
    n = (P[b] - P[a]) / np.linalg.norm(P[b] - P[a], axis=1)[:, None]
    r = np.linalg.norm(meas.position[b] - meas.position[a], axis=1) - np.linalg.norm(P[b] - P[a], axis=1)
    A = np.einsum("kl,kln->kn", n, JP[b] - JP[a])
    D = np.zeros((len(a), len(meas), 3))  # d(distance)/d(positions)
    D[np.arange(len(a)), b] = n
    D[np.arange(len(a)), a] = -n
    U, sv, _ = np.linalg.svd(D.reshape(len(a), -1), full_matrices=False)
    keep = sv > sv[0] * 1e-10
    T = U[:, keep].T / sv[keep, None] / SIGMA_POSITION
    return T @ r, T @ A, len(a)


def dense_fit(start, meas, model, base, pairs, iterations=8):
    """Gauss-Newton of the dense whitened distances on the given base parameters."""
    geometry, total = start, np.zeros(base.rank)
    for _ in range(iterations):
        rw, Ww, _ = dense_rows(geometry, meas, model, pairs)
        step = np.linalg.lstsq(Ww[:, base.base], rw, rcond=None)[0]
        geometry, total = model.apply(geometry, base.expand(step)), total + step
    rw, Ww, K = dense_rows(geometry, meas, model, pairs)
    W = Ww[:, base.base]
    sigma = np.sqrt(np.diag(np.linalg.inv(W.T @ W)))
    chi2 = float(np.sum((rw - W @ np.linalg.lstsq(W, rw, rcond=None)[0]) ** 2))
    return total, sigma, chi2 / (Ww.shape[0] - base.rank), K


def _measurements(bai, seed, n=9, points=("smr_centre", "smr_offset"), frame=None):
    rng = np.random.default_rng(seed)
    g0 = bai.geometry()
    truth = g0.perturbed(Tolerances.bai2015(), rng)
    q = bai_poses(bai, n).q
    pose = exact.forward(truth, q)
    position = np.vstack([pose.point(truth.point(p)) for p in points])
    position += rng.normal(0.0, SIGMA_POSITION, position.shape)
    if frame is not None:  # a tracker's own frame: distances do not see it
        position = position @ frame[0].T + frame[1]
    return g0, Measurements(np.vstack([q] * len(points)), position, point=[p for p in points for _ in q])


@pytest.mark.parametrize("pairs", ["all", "reference"])
@pytest.mark.parametrize("model", ["bai42", "bai24", "complete", "classical", "bai32", "bai18"])
def test_distances_match_the_dense_generalised_least_squares(bai, model, pairs):
    """Same estimate (within 2 % of σ), same σ (1 %) and same s0² as the dense whitened pairs."""
    g0, meas = _measurements(bai, 16)
    result = fit(g0, meas, model, distances=True, pairs=pairs)
    values, sigma, s0, K = dense_fit(g0, meas, get_model(model), result.base, pairs)
    assert result.n_rows == K
    assert np.max(np.abs(result.values - values) / sigma) < 2e-2
    assert np.max(np.abs(result.sigma / sigma - 1.0)) < 1e-2
    assert result.variance_factor == pytest.approx(s0, rel=2e-2)


def test_all_pairs_do_not_depend_on_the_tracker_frame(bai):
    """Positions in a tracker's frame metres away and turned: the same fit (rigid alignment per point)."""
    turn = np.array([[0.0, -1.0, 0.0], [0.6, 0.0, -0.8], [0.8, 0.0, 0.6]])
    g0, meas = _measurements(bai, 3)
    _, moved = _measurements(bai, 3, frame=(turn, np.array([2500.0, -800.0, 300.0])))
    a = identify(g0, meas, "bai42", distances=True)
    b = identify(g0, moved, "bai42", distances=True)
    np.testing.assert_allclose(b.values, a.values, atol=1e-6 * float(np.min(a.sigma)))
    np.testing.assert_allclose(b.after.distance_rms, a.after.distance_rms, rtol=1e-9)


def test_shared_reference_whitening_is_the_inverse_square_root(bai):
    """√2 (I + G M Gᵀ) whitens ½ (I + G Gᵀ): T C Tᵀ = I, group by group."""
    rng = np.random.default_rng(2)
    n = rng.normal(size=(12, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    first = np.repeat([4, 9], 6)
    shared = SharedReference.of(first, np.arange(12) + 20, n)
    T = shared.whiten(np.eye(12))
    C = np.zeros((12, 12))
    for g in (first == 4, first == 9):
        C[np.ix_(g, g)] = 0.5 * (np.eye(6) + n[g] @ n[g].T)
    np.testing.assert_allclose(T @ C @ T.T, np.eye(12), atol=1e-12)


def test_a_blunder_in_distances_is_flagged(bai):
    """A 0.5 mm blunder in one position: flagged alone, with all pairs and with reference pairs."""
    g0, meas = _measurements(bai, 7, n=12)
    position = np.array(meas.position)
    position[5] += [0.3, -0.2, 0.35]
    bad = Measurements(meas.q, position, point=meas.point)
    assert fit(g0, bad, "bai42", distances=True).outliers == [5]
    assert fit(g0, bad, "bai42", distances=True, pairs="reference").outliers == [5]
    clean = fit(g0, meas, "bai42", distances=True, pairs="reference")
    assert clean.outliers == []


def test_distance_statistics_in_blocks_equal_every_pair_at_once(bai):
    """The blocked RMS and max over C(n, 2) pairs equal the direct ones (repeated readings skipped)."""
    from deltacal.observations import distance_residual_stats

    g0, meas = _measurements(bai, 11, n=40)
    meas = Measurements(np.vstack([meas.q, meas.q[:3]]), np.vstack([meas.position, meas.position[:3] + 0.01]),
                        point=[*meas.point, *meas.point[:3]])
    pose = exact.forward(g0, meas.q)
    P = predicted_points(g0, meas, pose)
    r = []
    for name in ("smr_centre", "smr_offset"):
        idx = [k for k, p in enumerate(meas.point) if p == name]
        for i, a in enumerate(idx):
            for b in idx[i + 1:]:
                if np.any(meas.q[a] != meas.q[b]):
                    measured = np.linalg.norm(meas.position[b] - meas.position[a])
                    r.append(measured - np.linalg.norm(P[b] - P[a]))
    rms, worst = distance_residual_stats(g0, meas, pose)
    assert rms == pytest.approx(float(np.sqrt(np.mean(np.square(r)))), rel=1e-9)
    assert worst == pytest.approx(float(np.max(np.abs(r))), rel=1e-9)


@pytest.mark.long
def test_a_problem_too_large_is_refused_in_one_line(bai, tmp_path):
    """100,000 positions under a 3 GB address-space limit: refused up front, exit 1, one line, no file."""
    import resource
    import subprocess
    import sys

    from deltacal.io import write_measurements
    from deltacal.kinematics.closed_form import VirtualDelta

    rng = np.random.default_rng(4)
    n = 100_000
    r, a = 400.0 * np.sqrt(rng.uniform(0, 1, n)), rng.uniform(0, 2 * np.pi, n)
    points = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(-950.0, -760.0, n)])
    q = VirtualDelta.from_nominal(bai).inverse(points - bai.tool)
    g = bai.geometry()
    write_measurements(tmp_path / "m.csv", Measurements(q, exact.forward(g, q).point(g.tool)))

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))

    out = subprocess.run(
        [sys.executable, "-c", "import sys; from deltacal.cli import main; sys.exit(main())", "identify",
         str(MODELS / "bai2015.toml"), str(tmp_path / "m.csv"), "--model", "bai42", "--distances",
         "-o", str(tmp_path / "cal.toml")],
        capture_output=True, text=True, preexec_fn=limit,
        env={**__import__("os").environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"},
    )
    assert out.returncode == 1, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "100,000 measurements" in lines[0] and "--pairs reference" in lines[0], lines
    assert "GB" in lines[0]
    assert not (tmp_path / "cal.toml").exists()


def test_the_poor_fit_bound_counts_independent_rows(bai):
    """All pairs of n positions of a point: 3n - 6 independent rows, not C(n, 2) (issue 20's leftover).

    The review's bound on s0² took C(n, 2) - r degrees of freedom: too tight, so fits were reviewed
    (and refitted several times) more often than noise allows.
    """
    from deltacal.identification.quality import excess_bound, poor_fit_message

    g0, meas = _measurements(bai, 16, n=20)
    n = len(meas) // 2  # positions of each of the two points
    result = fit(g0, meas, "bai42", distances=True)
    assert result.n_rows == 2 * n * (n - 1) // 2 and result.independent_rows == 2 * (3 * n - 6)
    bound = excess_bound(result.independent_rows - result.rank)
    assert bound > excess_bound(result.n_rows - result.rank)
    assert f"noise alone gives at most {bound:.3g}" in poor_fit_message(result, g0, [])
