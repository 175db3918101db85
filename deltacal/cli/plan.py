"""``deltacal plan``: measurement poses (Bai's circles and κ(n) rule, or D-optimal)."""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from ..exceptions import PlanningError, UsageError
from ..identifiability import base_parameters
from ..io import load_nominal, write_poses
from ..planning import (
    MEASUREMENTS,
    PLAN_MODELS,
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
from ..planning.regressor import RANK_RTOL
from ..printer.robot import NominalLinearDelta
from ..robots import load_robot
from .common import check_input, check_output, int_at_most, non_negative_list, point_list, positive_int, seed
from .plan_object import add_object_arguments, refuse_object_options, run_object

#: Pools from this size on are told what they cost before the selection starts.
LARGE_POOL = 20_000

#: Largest --n-max: the κ(n) curve conditions one pose set per n (n = 200 takes minutes already).
N_MAX_LIMIT = 200


def parse_epsilon(text: str) -> float:
    """ε0 from the command line: a fraction (``0.01``) or a percentage (``1%``)."""
    try:
        value = float(text[:-1]) / 100.0 if text.strip().endswith("%") else float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number or percentage: {text!r}") from None
    if not (0.0 < value < 1.0):
        raise argparse.ArgumentTypeError(f"epsilon must be in (0, 1) or (0 %, 100 %), got {text!r}")
    return value


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``plan``."""
    p = subparsers.add_parser(
        "plan",
        help="plan measurement poses (Bai's circles and κ(n) rule, or D-optimal)",
        description=(
            "Plan measurement poses for a robot file and write a POSES CSV "
            "(q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm: readings, then the nominal TCP target). "
            "Strategy 'bai': the centre and n poses on each of the top and bottom circles of "
            "the workspace (the middle circle for --model rough), n given or chosen by Bai's "
            "κ(n) rule (Eq. 21). Strategy 'doptimal': COUNT poses of a random pool maximising "
            "log det of the scaled base regressor."
        ),
    )
    p.add_argument("nominal", metavar="NOMINAL", help="robot file (TOML) with a [workspace]")
    add_object_arguments(p)
    p.add_argument("--model", choices=PLAN_MODELS,
                   help="error model (default: complete; 'rough': encoder offsets only)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--n", type=positive_int, help="poses per circle (strategy bai)")
    group.add_argument("--epsilon", type=parse_epsilon,
                       help="ε0 of the κ(n) rule, fraction or percentage (default: 1%%)")
    p.add_argument("--strategy", choices=("bai", "doptimal"),
                   help="Bai's circles (default) or D-optimal selection from a random pool")
    p.add_argument("--measure", choices=MEASUREMENTS,
                   help="measurement kind for κ and D-optimality (default: distance for Bai's "
                        "distance models bai18/bai36/bai32 and rough, pose otherwise)")
    p.add_argument("--points", help="comma-separated plate points measured (default: by model)")
    p.add_argument("--count", type=positive_int, help="poses to select (strategy doptimal; "
                   "default: twice the number of base parameters, divided by the rows per pose)")
    p.add_argument("--pool", type=positive_int, metavar="N",
                   help="candidate pool size (doptimal; default 1000). Memory and time grow linearly with "
                        "it: each candidate keeps its scaled regressor (about 2 KB for the complete model "
                        "and pose measurements) and each selection step scores every candidate; 200,000 "
                        "take about 0.6 GB and one to a few minutes. From 20,000 on, plan says the "
                        "estimate before it starts")
    p.add_argument("--seed", type=seed, help="seed of the candidate pool (doptimal; default 0)")
    p.add_argument("--payload", type=non_negative_list, metavar="KG[,KG...]",
                   help="doptimal: plan for the actuators' compliances too, every pose measured at each "
                        "payload [kg] (simulate --payload with the same list; the robot file's [masses])")
    p.add_argument("--n-max", type=int_at_most(N_MAX_LIMIT, "each n is a pose set to condition"),
                   help="largest n of the κ(n) curve (default 20)")
    p.add_argument("-o", "--output", required=True, metavar="POSES.csv",
                   help="output file (with --object: the folder of object.stl, probe.csv, distances.csv)")
    p.set_defaults(func=run)
    return p


def _default_measurement(model: str) -> str:
    return "distance" if model in ("bai18", "bai36", "bai32", ROUGH) else "pose"


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal plan``: print what was chosen, write the POSES file, return 0."""
    check_input(args.nominal)
    if args.object:
        return run_object(args)
    refuse_object_options(args)
    check_output(args.output, (args.nominal,))
    if isinstance(load_robot(args.nominal), NominalLinearDelta):
        raise UsageError(f"{args.nominal}: a printer's plan is the object it prints and measures: use "
                         "--object --controller printer.cfg -o DIR")
    nominal = load_nominal(args.nominal)
    args.model = args.model or "complete"
    args.strategy = args.strategy or "bai"
    args.pool = 1000 if args.pool is None else args.pool
    args.seed = 0 if args.seed is None else args.seed
    args.n_max = 20 if args.n_max is None else args.n_max
    model = planning_model(args.model)
    measurement = args.measure or _default_measurement(args.model)
    geometry = nominal.geometry()
    if args.points:
        points = point_list(args.points, geometry.point_names)
    else:
        points = default_points(geometry, model, measurement)
    if args.strategy == "bai":
        if args.payload is not None:
            raise UsageError("--payload applies to --strategy doptimal (planning for the compliances)")
        if args.count is not None:
            raise UsageError("--count applies to --strategy doptimal; the bai strategy chooses n by Eq. 21 "
                             "(or --n)")
        poses, report = _plan_bai(args, nominal, model, measurement, points)
    else:
        poses, report = _plan_doptimal(args, nominal, model, measurement, points)
    write_poses(args.output, poses)
    print(report)
    print(f"wrote {len(poses)} poses to {args.output}")
    return 0


def _plan_bai(args, nominal, model, measurement, points) -> tuple[PoseSet, str]:
    rough = model.name == ROUGH
    where = "centre + middle circle" if rough else "centre + top and bottom circles"
    lines = []
    if args.n is not None:
        n = args.n
        lines.append(f"bai pose set, n = {n} given")
    else:
        eps0 = 0.01 if args.epsilon is None else args.epsilon
        curve = condition_curve(nominal, model, measurement, points, n_max=args.n_max)
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


def _plan_doptimal(args, nominal, model, measurement, points) -> tuple[PoseSet, str]:
    if args.n is not None or args.epsilon is not None:
        raise UsageError("--n and --epsilon apply to --strategy bai, not doptimal")
    if measurement == "distance":
        raise UsageError("D-optimal selection is for pose or position measurements (--measure)")
    rows = 6 if measurement == "pose" else 3 * len(points)
    require_pool_memory(args.pool, rows, model.size)  # before drawing: a pool too large is refused at once
    rng = np.random.default_rng(args.seed)
    pool = candidate_pool(nominal, args.pool, rng)
    H = identification_matrix(nominal.geometry(), model, pool.q[:200], measurement, points)
    rank = base_parameters(H, model.names, rtol=RANK_RTOL).rank  # what such measurements can identify
    count = max(math.ceil(2 * rank / rows), 3) if args.count is None else args.count
    if args.pool >= LARGE_POOL:
        cost = pool_cost(len(pool), rows, model.size, rank, count)
        print(f"plan: {len(pool):,} candidates: the selection takes about {cost.memory / 1e6:.0f} MB of "
              f"memory and {cost.step:.2g} s per step on one core ({cost.steps_min} steps, then {count} per "
              f"exchange pass, up to {cost.steps_max} in all: {_duration(cost.steps_min * cost.step)} to "
              f"{_duration(cost.steps_max * cost.step)})", file=sys.stderr)
    payloads = tuple(args.payload or ())
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
        f"{count} of {len(pool)} candidates (seed {args.seed}), {len(design.base_names)} base "
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

