"""D-optimal selection from large candidate pools: bounded memory, the same selection (issue 21, item 7).

``plan --strategy doptimal --pool 200000`` built an N × r × r information array (2.6 GB) and
failed with MemoryError; 50,000 took 1.2 GB. The pool is now processed in chunks.
"""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest
from conftest import MODELS

from deltacal import resources
from deltacal.cli import main
from deltacal.identifiability import base_parameters
from deltacal.planning import candidate_pool, d_optimal, planning_model, pool_memory, pose_blocks
from deltacal.planning import doptimal as doptimal_module
from deltacal.planning.regressor import RANK_RTOL, default_points

ROBOT = str(MODELS / "bai2015.toml")


def _log_det(M):
    sign, value = np.linalg.slogdet(M)
    return float(value) if sign > 0 else -math.inf


def reference_selection(nominal, model, count, pool, measurement, max_passes=10):
    """The selection as written before the chunks: the whole regressor at once, an N × r × r
    information array and a dense solve per step (the formulation the chunks must reproduce)."""
    error_model = planning_model(model)
    geometry = nominal.geometry()
    pts = default_points(geometry, error_model, measurement)
    raw = pose_blocks(geometry, error_model, pool.q, measurement, pts)
    N, b, n = raw.shape
    base = base_parameters(raw.reshape(N * b, n), error_model.names, rtol=RANK_RTOL)
    scale = np.linalg.norm(raw.reshape(N * b, n), axis=0) / math.sqrt(N)
    blocks = raw[:, :, base.base] / np.where(scale > 0.0, scale, 1.0)[base.base]
    r = blocks.shape[2]
    info = np.einsum("kbi,kbj->kij", blocks, blocks)
    ridge = 1e-9 * float(np.trace(info.mean(axis=0))) / r

    def gains(M):
        X = np.linalg.solve(M, blocks.reshape(-1, r).T).T.reshape(N, b, r)
        sign, value = np.linalg.slogdet(np.eye(b) + np.einsum("kbi,kci->kbc", X, blocks))
        return np.where(sign > 0, value, -np.inf)

    M, chosen, taken = ridge * np.eye(r), [], np.zeros(N, dtype=bool)
    for _ in range(count):
        k = int(np.argmax(np.where(taken, -np.inf, gains(M))))
        chosen.append(k)
        taken[k] = True
        M = M + info[k]
    for _ in range(max_passes):
        improved = False
        for slot in range(count):
            k = chosen[slot]
            M_minus = M - info[k]
            g = np.where(taken, -np.inf, gains(M_minus))
            j = int(np.argmax(g))
            if g[j] > _log_det(M) - _log_det(M_minus) + 1e-9:
                chosen[slot], taken[k], taken[j] = j, False, True
                M = M_minus + info[j]
                improved = True
        if not improved:
            break
    return np.array(chosen), base.base_names


@pytest.mark.parametrize(("model", "measurement", "count", "seed"), [
    ("complete", "pose", 14, 0), ("classical", "pose", 8, 1), ("bai42", "position", 12, 2)])
def test_the_chunked_selection_is_the_dense_one(bai, monkeypatch, model, measurement, count, seed):
    pool = candidate_pool(bai, 500, np.random.default_rng(seed))
    want, names = reference_selection(bai, model, count, pool, measurement)
    # the gains of every candidate differ by far more than rounding here: no tie decides
    design = d_optimal(bai, model, count, pool=pool, measurement=measurement)
    assert design.selected.tolist() == want.tolist() and design.base_names == names
    monkeypatch.setattr(doptimal_module, "CHUNK", 37)  # many chunks, a short last one
    small = d_optimal(bai, model, count, pool=pool, measurement=measurement)
    assert small.selected.tolist() == want.tolist() and small.base_names == names
    np.testing.assert_allclose(small.blocks, design.blocks, rtol=1e-12, atol=1e-12)


@pytest.mark.slow
def test_the_memory_of_a_selection_stays_within_its_estimate(bai, monkeypatch):
    """What require_memory is told is an upper bound of what the selection allocates; the
    dense formulation took about N × r² more (the information of every candidate)."""
    monkeypatch.setattr(doptimal_module, "CHUNK", 256)
    pool = candidate_pool(bai, 4000, np.random.default_rng(3))
    estimate = pool_memory(len(pool), 6, planning_model("complete").size)
    tracemalloc.start()
    try:
        d_optimal(bai, "complete", 10, pool=pool, max_passes=1)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= estimate
    dense = 8.0 * len(pool) * 42 * 42  # the information array of the dense formulation alone
    assert dense > estimate


def test_a_pool_too_large_for_the_memory_is_refused_before_it_is_drawn(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(resources, "available_memory", lambda: 200e6)
    out = tmp_path / "poses.csv"
    assert main(["plan", ROBOT, "--strategy", "doptimal", "--pool", "200000", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a D-optimal selection from 200,000 candidates needs about" in err
    assert "plan --pool" in err and not out.exists()


def test_plan_says_what_a_large_pool_costs(tmp_path, capsys, monkeypatch):
    from deltacal.wings.rotary import plan

    monkeypatch.setattr(plan, "LARGE_POOL", 300)
    out = tmp_path / "poses.csv"
    args = ["plan", ROBOT, "--strategy", "doptimal", "--count", "8", "--seed", "4", "-o", str(out)]
    assert main([*args, "--pool", "300"]) == 0
    err = capsys.readouterr().err
    assert "plan: 300 candidates: the selection takes about" in err and "MB of memory" in err
    assert " s per step on one core (8 steps, then 8 per exchange pass, up to 88 in all" in err
    assert main([*args, "--pool", "299"]) == 0
    assert "candidates:" not in capsys.readouterr().err  # small pools: nothing to say
