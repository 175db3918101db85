"""Benchmarks of deltacal: run every benchmark, print a table, write results/bench.json.

Each benchmark is a function ``bench_*(setup: Setup) -> list[Row]`` listed in
``BENCHMARKS``; add a section by writing one and appending it there. Times are
measured without start-up: models and inputs are built before the clock starts,
each measurement is repeated and the median is kept.

Output ``bench.json``: ``{name: {"value": ..., "unit": ..., "target": ...}}``,
the target a string such as ``"<= 200"`` (or null when there is none).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deltacal.geometry import DeltaGeometry, NominalDelta, Tolerances
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "results"
SEED = 2024


@dataclass(frozen=True)
class Row:
    """One benchmark figure."""

    name: str
    value: float
    unit: str
    target: str | None = None  # "<= 200", ">= 100000"

    def met(self) -> str:
        """``yes``/``no`` against the target, ``-`` without one."""
        if self.target is None:
            return "-"
        op, bound = self.target.split()
        ok = self.value <= float(bound) if op == "<=" else self.value >= float(bound)
        return "yes" if ok else "NO"


@dataclass(frozen=True)
class Setup:
    """Inputs shared by the benchmarks, built before any timing."""

    nominal: NominalDelta
    geometry: DeltaGeometry
    repeat: int
    rng_seed: int

    def rng(self) -> np.random.Generator:
        """A fresh generator, so every benchmark sees the same numbers."""
        return np.random.default_rng(self.rng_seed)

    def workspace_points(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Random points [mm] in the nominal workspace cylinder, (n, 3)."""
        ws = self.nominal.workspace
        assert ws is not None
        radius = ws.radius * np.sqrt(rng.random(n))
        angle = rng.uniform(0.0, 2.0 * np.pi, n)
        z = ws.top_z - ws.height * rng.random(n)
        return np.stack([radius * np.cos(angle), radius * np.sin(angle), z], axis=1)


def median_time(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time [s] of ``repeat`` calls of fn (after one untimed call)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


# ------------------------------------------------------------------ benchmarks
def bench_pinocchio_forward(setup: Setup) -> list[Row]:
    """Pinocchio closed-loop FK, per pose: warm (along a path) and cold (closed-form start)."""
    rng = setup.rng()
    virtual = VirtualDelta.from_nominal(setup.nominal)
    mb = DeltaMultibody(setup.geometry)
    # warm: a path of 1 mm steps, each solve started from the previous assembly
    path = setup.nominal.workspace.centre + np.cumsum(rng.normal(0.0, 1.0 / np.sqrt(3), (200, 3)), axis=0)
    q_path = virtual.inverse(path)
    # cold: scattered workspace points, each solve from the closed-form pose
    q_scattered = virtual.inverse(setup.workspace_points(200, rng))

    def per_pose(q: np.ndarray, warm: bool) -> tuple[float, float]:
        times, iterations = [], []
        for _ in range(setup.repeat):
            mb.solve_forward(q[0], warm=False)
            for qn in q:
                t0 = time.perf_counter()
                sol = mb.solve_forward(qn, warm=warm)
                times.append(time.perf_counter() - t0)
                iterations.append(sol.iterations)
        return float(np.median(times)) * 1e6, float(np.mean(iterations))

    warm_us, warm_it = per_pose(q_path, warm=True)
    cold_us, cold_it = per_pose(q_scattered, warm=False)
    return [
        Row("pinocchio_fk_warm", warm_us, "us/pose", "<= 200"),
        Row("pinocchio_fk_warm_iterations", warm_it, "Newton iterations"),
        Row("pinocchio_fk_cold", cold_us, "us/pose"),
        Row("pinocchio_fk_cold_iterations", cold_it, "Newton iterations"),
    ]


def bench_exact_batch(setup: Setup, n: int = 10_000) -> list[Row]:
    """Vectorised numpy solvers of exact.py on N = 10,000 workspace points."""
    rng = setup.rng()
    points = setup.workspace_points(n, rng)
    q = VirtualDelta.from_nominal(setup.nominal).inverse(points)
    targets = exact.forward(setup.geometry, q).point(setup.geometry.tool)
    t_fk = median_time(lambda: exact.forward(setup.geometry, q), setup.repeat)
    t_ik = median_time(lambda: exact.inverse(setup.geometry, targets), setup.repeat)
    return [
        Row("exact_fk_batch", n / t_fk, "poses/s", ">= 100000"),
        Row("exact_ik_batch", n / t_ik, "targets/s", ">= 20000"),
    ]


BENCHMARKS: list[Callable[[Setup], list[Row]]] = [
    bench_pinocchio_forward,
    bench_exact_batch,
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", type=Path, default=REPO_ROOT / "models" / "bai2015.toml")
    parser.add_argument("--repeat", type=int, default=5, help="repetitions of each measurement")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    nominal = NominalDelta.from_toml(args.robot)
    geometry = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(SEED))
    setup = Setup(nominal, geometry, args.repeat, SEED)
    rows: list[Row] = []
    for bench in BENCHMARKS:
        rows += bench(setup)
    width = max(len(r.name) for r in rows)
    print(f"{'benchmark':<{width}}  {'value':>12}  {'unit':<18} {'target':<10} met")
    for r in rows:
        target = r.target or "-"
        print(f"{r.name:<{width}}  {r.value:>12.4g}  {r.unit:<18} {target:<10} {r.met()}")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench.json"
    results = {r.name: {"value": r.value, "unit": r.unit, "target": r.target} for r in rows}
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(results, indent=2) + "\n")
    tmp.replace(path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
