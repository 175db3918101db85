"""A rotary Delta's measurement poses: Bai's circles and κ(n) rule (Eq. 21), or a D-optimal selection."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ...exceptions import PlanningError
from ...geometry import NominalDelta
from ...identifiability import base_parameters
from ...io import write_poses
from ...planning import (
    ROUGH,
    PoseSet,
    bai_poses,
    candidate_pool,
    condition_curve,
    d_optimal,
    default_points,
    identification_matrix,
    planning_model,
    pool_cost,
    require_pool_memory,
    require_workspace,
    rough_poses,
)
from ...planning.regressor import RANK_RTOL
from ..base import Done, check_files
from ..requests import PlanRequest
from .simulate import point_list

#: Pools from this size on are told what they cost before the selection starts.
LARGE_POOL = 20_000


def plan_poses(request: PlanRequest, nominal: NominalDelta,
               notify: Callable[[str], None] | None = None) -> Done:
    """``deltacal plan`` of a rotary Delta: the POSES file written, what was chosen said."""
    check_files((request.nominal,), request.output)
    model = planning_model(request.model or "complete")
    measurement = request.measurement
    geometry = nominal.geometry()
    if request.points:
        points = point_list(request.points, geometry.point_names)
    else:
        points = default_points(geometry, model, measurement)
    if (request.strategy or "bai") == "bai":
        poses, report = _plan_bai(request, nominal, model, measurement, points)
    else:
        poses, report = _plan_doptimal(request, nominal, model, measurement, points, notify)
    write_poses(request.output, poses)
    return Done((report, f"wrote {len(poses)} poses to {request.output}"))


def _plan_bai(request: PlanRequest, nominal, model, measurement, points) -> tuple[PoseSet, str]:
    rough = model.name == ROUGH
    where = "centre + middle circle" if rough else "centre + top and bottom circles"
    lines = []
    if request.n is not None:
        n = request.n
        lines.append(f"bai pose set, n = {n} given")
    else:
        eps0 = 0.01 if request.epsilon is None else request.epsilon
        curve = condition_curve(nominal, model, measurement, points,
                                n_max=20 if request.n_max is None else request.n_max)
        n = curve.least_n(eps0)
        k = int(np.flatnonzero(curve.n == n)[0])
        lines.append(
            f"κ(n) rule (Bai Eq. 21) for model {model.name}, {measurement} measurements of "
            f"{','.join(points)}, {len(curve.base_names)} base parameters, column-scaled κ:"
        )
        lines.append(curve.table())
        lines.append(
            f"chosen n = {n}: ε_n = {100.0 * curve.epsilon[k]:.3g} % <= ε0 = {100.0 * eps0:g} %, "
            f"κ_n = {curve.kappa[k]:.6g}"
        )
    poses = rough_poses(nominal, n) if rough else bai_poses(nominal, n)
    ws = require_workspace(nominal)
    lines.append(f"{len(poses)} poses ({where}, radius {ws.radius:g} mm)")
    return poses, "\n".join(lines)


def _plan_doptimal(request: PlanRequest, nominal, model, measurement, points,
                   notify: Callable[[str], None] | None) -> tuple[PoseSet, str]:
    pool_size = 1000 if request.pool is None else request.pool
    seed = 0 if request.seed is None else request.seed
    rows = 6 if measurement == "pose" else 3 * len(points)
    require_pool_memory(pool_size, rows, model.size)  # before drawing: a pool too large is refused at once
    rng = np.random.default_rng(seed)
    pool = candidate_pool(nominal, pool_size, rng)
    H = identification_matrix(nominal.geometry(), model, pool.q[:200], measurement, points)
    rank = base_parameters(H, model.names, rtol=RANK_RTOL).rank  # what such measurements can identify
    count = max(math.ceil(2 * rank / rows), 3) if request.count is None else request.count
    if pool_size >= LARGE_POOL and notify is not None:
        cost = pool_cost(len(pool), rows, model.size, rank, count)
        notify(f"plan: {len(pool):,} candidates: the selection takes about {cost.memory / 1e6:.0f} MB of "
               f"memory and {cost.step:.2g} s per step on one core ({cost.steps_min} steps, then {count} per "
               f"exchange pass, up to {cost.steps_max} in all: {_duration(cost.steps_min * cost.step)} to "
               f"{_duration(cost.steps_max * cost.step)})")
    payloads = tuple(request.payload or ())
    design = d_optimal(nominal, model, count, pool=pool, measurement=measurement, points=points,
                       payloads=payloads)
    chosen = identification_matrix(nominal.geometry(), model, design.poses.q, measurement, points)
    got = base_parameters(chosen, model.names, rtol=RANK_RTOL).rank
    if got < rank or not math.isfinite(design.log_det):
        need = math.ceil(rank / rows)
        raise PlanningError(
            f"{count} pose(s) of {measurement} measurements ({rows} equations each) identify {got} of the "
            f"{rank} base parameters of model {model.name} that such measurements identify: use --count "
            f"{need + 1} or more (about {max(2 * need, 3)} for a useful estimate)"
        )
    text = (
        f"D-optimal selection for model {model.name}, {measurement} measurements of {','.join(points)}: "
        f"{count} of {len(pool)} candidates (seed {seed}), {len(design.base_names)} base "
        f"parameters, log det(WᵀW) of the scaled base regressor = {design.log_det:.6g}"
    )
    if payloads:
        kept = [n for n in design.base_names if n in ("c1", "c2", "c3")]
        text += (f"; each pose to be measured at {', '.join(f'{p:g}' for p in payloads)} kg: compliances "
                 + (f"{', '.join(sorted(kept))} identifiable" if kept else "not identifiable (no gravity "
                    "torque: give the robot file [masses] or a payload)"))
    return design.poses, text


def _duration(seconds: float) -> str:
    """``"40 s"``, ``"2.5 min"``: a duration as a person reads it."""
    return f"{seconds:.2g} s" if seconds < 90.0 else f"{seconds / 60.0:.2g} min"
