"""Benchmarks of deltacal: run every benchmark, print a table, write results/bench.json.

Each benchmark is a function ``bench_*(setup: Setup) -> list[Row]`` listed in
``BENCHMARKS``; add a section by writing one and appending it there. Times are
measured without start-up: models and inputs are built before the clock starts,
each measurement is repeated and the median is kept.

Output ``bench.json``: ``{name: {"value": ..., "unit": ..., "target": ...}}``,
the target a string such as ``"<= 200"`` (or null when there is none).
"""

from __future__ import annotations

import os

# deltacal's matrices are small: BLAS threads only contend (see deltacal/__init__.py)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deltacal.compensation import compensate, linear_calibration_from_result
from deltacal.geometry import DeltaGeometry, NominalDelta, Tolerances, vector_from_rotation
from deltacal.identification import identify
from deltacal.io import load_nominal, save_calibration
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.observations import Measurements

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


def _calibration_measurements(
    setup: Setup, n: int, rng: np.random.Generator
) -> tuple[DeltaGeometry, Measurements]:
    """The nominal robot (tool 180 mm below the plate) and n pose measurements of the real one.

    Exact kinematics of the perturbed robot, noise sigma 5 um and 0.003 deg.
    """
    tool = np.array([0.0, 0.0, -180.0])
    start = setup.nominal.geometry().with_tool(tool)
    truth = setup.geometry.with_tool(tool)
    plate = setup.workspace_points(n, rng) - setup.nominal.tool
    q = VirtualDelta.from_nominal(setup.nominal).inverse(plate)
    pose = exact.forward(truth, q)
    position = pose.point(truth.tool) + rng.normal(0.0, 0.005, (n, 3))
    rotation = vector_from_rotation(pose.rotation) + rng.normal(0.0, np.radians(0.003), (n, 3))
    return start, Measurements(q, position, rotation_vector=rotation)


def bench_identification(setup: Setup, n: int = 100) -> list[Row]:
    """Complete model (51 parameters) from 100 pose measurements, linear and iterated."""
    start, meas = _calibration_measurements(setup, n, setup.rng())
    t_linear = median_time(lambda: identify(start, meas, "complete", "linear"), setup.repeat)
    t_iterated = median_time(lambda: identify(start, meas, "complete", "iterated"), setup.repeat)
    iterations = identify(start, meas, "complete", "iterated").iterations
    return [
        Row("identify_complete_linear", 1e3 * t_linear, "ms", "<= 20"),
        Row("identify_complete_iterated", 1e3 * t_iterated, "ms", "<= 300"),
        Row("identify_complete_iterations", iterations, "Gauss-Newton steps"),
    ]


def bench_compensation(setup: Setup, n: int = 100_000) -> list[Row]:
    """Compensation of 100,000 workspace targets: exact (Newton) and linear (Savoure Eq. 29-33)."""
    rng = setup.rng()
    start, meas = _calibration_measurements(setup, 60, rng)
    result = identify(start, meas, "complete")
    linear = linear_calibration_from_result(result)
    targets = setup.workspace_points(n, rng) + (start.tool - setup.nominal.tool)
    repeat = max(1, min(setup.repeat, 3))
    t_exact = median_time(lambda: compensate(result.geometry, targets, "exact"), repeat)
    t_linear = median_time(lambda: compensate(result.geometry, targets, "savoure", linear), repeat)
    return [
        Row("compensate_exact", n / t_exact, "targets/s", ">= 20000"),
        Row("compensate_savoure", n / t_linear, "targets/s", ">= 200000"),
    ]


def bench_cli_compensate(setup: Setup, n: int = 100_000) -> list[Row]:
    """The whole ``deltacal compensate CAL TARGETS -o JOINTS`` of 100,000 targets, CSV in and out.

    Run as a subprocess: start-up, reading, compensation and writing.
    """
    rng = setup.rng()
    start, meas = _calibration_measurements(setup, 60, rng)
    targets = setup.workspace_points(n, rng) + (start.tool - setup.nominal.tool)
    exe = shutil.which("deltacal")
    command = [exe] if exe else [sys.executable, "-m", "deltacal.cli"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        save_calibration(identify(start, meas, "complete"), folder / "cal.toml")
        lines = ["x_mm,y_mm,z_mm"] + [f"{x:.6f},{y:.6f},{z:.6f}" for x, y, z in targets]
        (folder / "targets.csv").write_text("\n".join(lines) + "\n")
        args = command + ["compensate", str(folder / "cal.toml"), str(folder / "targets.csv"),
                          "-o", str(folder / "joints.csv")]

        def run() -> None:
            subprocess.run(args, check=True, capture_output=True)

        t_cli = median_time(run, max(1, min(setup.repeat, 3)))
    return [Row("cli_compensate_100k", t_cli, "s", "<= 10")]


BENCHMARKS: list[Callable[[Setup], list[Row]]] = [
    bench_pinocchio_forward,
    bench_exact_batch,
    bench_identification,
    bench_compensation,
    bench_cli_compensate,
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", type=Path, default=REPO_ROOT / "deltacal" / "models" / "bai2015.toml")
    parser.add_argument("--repeat", type=int, default=5, help="repetitions of each measurement")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    nominal = load_nominal(args.robot)
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
