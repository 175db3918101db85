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
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from deltacal.compensation import compensate, linear_calibration_from_result
from deltacal.geometry import DeltaGeometry, Masses, NominalDelta, Tolerances, vector_from_rotation
from deltacal.identification import FitOptions, fit, identify
from deltacal.io import load_nominal, save_calibration, write_measurements
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.observations import Measurements
from deltacal.rotations import vector_from_rotation as rotvec
from deltacal.simulation import simulate_measurements

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "results"
SEED = 2024


@dataclass(frozen=True)
class Row:
    """One benchmark figure (and, where it was repeated, the least and greatest of the runs)."""

    name: str
    value: float
    unit: str
    target: str | None = None  # "<= 200", ">= 100000"
    spread: tuple[float, float] | None = None

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
    robot: Path
    quick: bool = False

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


def run_times(fn: Callable[[], object], repeat: int) -> list[float]:
    """Wall times [s] of ``repeat`` calls of fn (after one untimed call)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times


def median_time(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time [s] of ``repeat`` calls of fn (after one untimed call)."""
    return float(np.median(run_times(fn, repeat)))


def rate_row(name: str, n: int, times: list[float], unit: str, target: str | None = None) -> Row:
    """Items per second (n a run) at the median time, and at the slowest and fastest runs."""
    rates = [n / t for t in times]
    return Row(name, float(np.median(rates)), unit, target, (min(rates), max(rates)))


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
    repeat = max(setup.repeat, 7)
    t_fk = run_times(lambda: exact.forward(setup.geometry, q), repeat)
    t_ik = run_times(lambda: exact.inverse(setup.geometry, targets), repeat)
    return [
        rate_row("exact_fk_batch", n, t_fk, "poses/s", ">= 300000"),
        rate_row("exact_ik_batch", n, t_ik, "targets/s", ">= 20000"),
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
    # one linearised step from the nominal leaves the perturbation's second-order terms, which the
    # quality check rightly calls a poor fit (s0² 12) and reviews by refitting the data under other
    # readings (several fits): the figure is the step's own cost (fit), the review's apart
    t_linear = median_time(lambda: fit(start, meas, "complete", method="linear"), setup.repeat)
    t_review = median_time(lambda: identify(start, meas, "complete", method="linear", accept_poor_fit=True),
                           setup.repeat)
    t_iterated = median_time(lambda: identify(start, meas, "complete", method="iterated"), setup.repeat)
    iterations = identify(start, meas, "complete", method="iterated").iterations
    return [
        Row("identify_complete_linear", 1e3 * t_linear, "ms", "<= 20"),
        Row("identify_complete_linear_reviewed", 1e3 * t_review, "ms"),
        Row("identify_complete_iterated", 1e3 * t_iterated, "ms", "<= 300"),
        Row("identify_complete_iterations", iterations, "Gauss-Newton steps"),
    ]


def bench_identify_compliance(setup: Setup, n: int = 60) -> list[Row]:
    """Complete model and the actuators' compliances from n poses measured at 0 and 3 kg, iterated.

    The robot with masses (arms 0.35 kg, rods 0.04 kg, plate 0.4 kg) and compliances of 2e-5 rad/N m,
    simulated with the exact kinematics' statics (the bench measures the library, not Pinocchio).
    """
    masses = Masses(arm=0.35, rod=0.04, plate=0.4)
    start = replace(setup.nominal.geometry(), masses=masses)
    truth = replace(setup.geometry, masses=masses, compliance=np.full(3, 2e-5))
    q = exact.inverse(start, setup.workspace_points(n, setup.rng()))
    meas = simulate_measurements(truth, np.vstack([q, q]), setup.rng(), forward=exact.forward,
                                 payload=np.repeat([0.0, 3.0], n))
    options = FitOptions(compliance=True)
    t_iterated = median_time(lambda: identify(start, meas, "complete", options=options), setup.repeat)
    rigid = FitOptions(accept_poor_fit=True)
    t_rigid = median_time(lambda: identify(start, meas, "complete", options=rigid), setup.repeat)
    return [
        Row("identify_compliance_120_poses_iterated", 1e3 * t_iterated, "ms", "<= 1000"),
        Row("identify_rigid_120_loaded_poses_iterated", 1e3 * t_rigid, "ms"),
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


def _command() -> list[str]:
    exe = shutil.which("deltacal")
    return [exe] if exe else [sys.executable, "-m", "deltacal.cli"]


def timed_run(args: list[str], expect: int | tuple[int, ...] = 0,
              address_space: int | None = None) -> tuple[float, float]:
    """Wall time [s] and peak RSS [MB] of a command, from ``/usr/bin/time -v``.

    ``address_space`` limits the command's virtual memory [bytes] (``ulimit -v``).
    """
    import resource

    def limit() -> None:
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    out = subprocess.run(["/usr/bin/time", "-v", *args], capture_output=True, text=True, preexec_fn=limit)
    expected = (expect,) if isinstance(expect, int) else expect
    if out.returncode not in expected:
        raise RuntimeError(f"{' '.join(args)}: exit {out.returncode}, expected {expect}: {out.stderr[-500:]}")
    if out.returncode != 0:
        print(f"{args[-3] if len(args) > 3 else ''}: exit {out.returncode}: {out.stderr.splitlines()[0]}",
              file=sys.stderr)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)",
                     out.stderr)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", out.stderr)
    assert wall and rss, out.stderr
    seconds = 3600 * int(wall.group(1) or 0) + 60 * int(wall.group(2)) + float(wall.group(3))
    return seconds, int(rss.group(1)) / 1024


def spread_rows(name: str, runs: list[tuple[float, float]], time_target: str | None,
                rss_target: str | None = None) -> list[Row]:
    """Median wall time and peak RSS of runs, with their least and greatest values."""
    t = [r[0] for r in runs]
    m = [r[1] for r in runs]
    return [Row(f"{name}_s", float(np.median(t)), "s", time_target, (min(t), max(t))),
            Row(f"{name}_rss", float(np.median(m)), "MB", rss_target, (min(m), max(m)))]


def bench_startup(setup: Setup) -> list[Row]:
    """``deltacal --version``: Python, the package and the command line, nothing else."""
    args = _command() + ["--version"]
    runs = []
    for _ in range(max(5, setup.repeat)):
        t0 = time.perf_counter()
        subprocess.run(args, check=True, capture_output=True)
        runs.append(time.perf_counter() - t0)
    return [Row("startup_version", float(np.median(runs)), "s", "<= 0.25", (min(runs), max(runs)))]


def bench_fk_versus_least_squares(setup: Setup, n: int = 200) -> list[Row]:
    """The batch FK against scipy ``least_squares`` on the six rod equations one pose at a time.

    The same robot and readings; each least-squares solve starts from the virtual model's
    pose (as the batch does). Figures: the ratio of the times per pose (the batch of the same
    200 poses, and a batch of 10,000) and the largest distance between the two solutions'
    plate positions [mm].
    """
    from scipy.optimize import least_squares

    g = setup.geometry
    rng = setup.rng()
    q = VirtualDelta.from_nominal(setup.nominal).inverse(setup.workspace_points(n, rng) - setup.nominal.tool)
    start = exact.initial_pose(g, q)
    plate = g.plate_ball.reshape(6, 3)
    arm = g.arm_balls_in_base(q).reshape(n, 6, 3)

    def rods(x: np.ndarray, k: int) -> np.ndarray:
        from deltacal.rotations import rotation_from_vector

        d = x[:3] + plate @ rotation_from_vector(x[3:]).T - arm[k]
        return np.linalg.norm(d, axis=1) - g.rod_length.reshape(6)

    def per_pose() -> np.ndarray:
        out = np.empty((n, 6))
        for k in range(n):
            x0 = np.concatenate([start.position[k], np.zeros(3)])
            out[k] = least_squares(rods, x0, args=(k,), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        return out

    # the batch's cost per pose falls with the batch's size: 10,000 poses as in bench_exact_batch
    q_many = VirtualDelta.from_nominal(setup.nominal).inverse(
        setup.workspace_points(10_000, rng) - setup.nominal.tool)
    # the three timed one after the other in each round, so a round's ratios share the machine's state
    rounds = []
    for _ in range(max(3, setup.repeat)):
        t_ls = run_times(per_pose, 1)[0]
        t_batch = float(np.median(run_times(lambda: exact.forward(g, q), 5)))
        t_many = float(np.median(run_times(lambda: exact.forward(g, q_many), 3))) / 10_000
        rounds.append((t_ls, t_ls / t_batch, t_ls / n / t_many))
    t_ls, ratio, ratio_many = (np.array(v) for v in zip(*rounds, strict=True))
    ls = per_pose()
    batch = exact.forward(g, q)
    gap = float(np.max(np.linalg.norm(ls[:, :3] - batch.position, axis=1)))
    tilt = float(np.max(np.abs(ls[:, 3:] - rotvec(batch.rotation))))
    return [
        Row("fk_least_squares_per_pose", 1e6 * float(np.median(t_ls)) / n, "us/pose"),
        Row("fk_batch_vs_least_squares", float(np.median(ratio)), "times faster", ">= 200",
            (float(ratio.min()), float(ratio.max()))),
        Row("fk_batch_10k_vs_least_squares", float(np.median(ratio_many)), "times faster", None,
            (float(ratio_many.min()), float(ratio_many.max()))),
        Row("fk_least_squares_agreement", gap, "mm", "<= 1e-6"),
        Row("fk_least_squares_agreement_rotation", tilt, "rad"),
    ]


def bench_identify_free_frame(setup: Setup, n: int = 200) -> list[Row]:
    """Issue 11: the complete model and a free instrument frame from 200 poses, iterated (library)."""
    start, meas = _calibration_measurements(setup, n, setup.rng())
    t = median_time(lambda: identify(start, meas, "complete", method="iterated", frame="free"), setup.repeat)
    return [Row("identify_free_frame_200", 1e3 * t, "ms", "<= 50")]


def _write_targets(path: Path, targets: np.ndarray) -> None:
    with open(path, "w") as f:
        f.write("x_mm,y_mm,z_mm\n")
        for block in np.array_split(targets, max(1, targets.shape[0] // 100_000)):
            f.write("".join(f"{x:.6f},{y:.6f},{z:.6f}\n" for x, y, z in block.tolist()))


def bench_cli_streaming(setup: Setup) -> list[Row]:
    """``deltacal compensate`` on 10^5 and 10^6 targets, exact and savoure: wall time and peak RSS.

    Also the time to fail on a bad value, and on an unreachable target, in the last row of 10^6.
    """
    rng = setup.rng()
    start, meas = _calibration_measurements(setup, 60, rng)
    command = _command() + ["compensate"]
    repeat = max(1, min(setup.repeat, 3)) if not setup.quick else 1
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cal = folder / "cal.toml"
        save_calibration(identify(start, meas, "complete"), cal)
        sizes = (100_000,) if setup.quick else (100_000, 1_000_000)
        for n in sizes:
            targets = setup.workspace_points(n, rng) + (start.tool - setup.nominal.tool)
            path = folder / f"t{n}.csv"
            _write_targets(path, targets)
            label = "1e5" if n == 100_000 else "1e6"
            for method in ("exact", "savoure"):
                args = command + [str(cal), str(path), "--method", method, "-o", str(folder / "j.csv")]
                target = "<= 15" if n == 1_000_000 else None
                rows += spread_rows(f"compensate_{method}_{label}", [timed_run(args) for _ in range(repeat)],
                                    target, "<= 1024")
            if n == 1_000_000:
                text = path.read_text()
                bad = folder / "bad.csv"
                bad.write_text(text[: text.rstrip("\n").rfind("\n") + 1] + "0,0,-9x0\n")
                args = command + [str(cal), str(bad), "-o", str(folder / "j.csv")]
                rows += spread_rows("compensate_bad_last_row", [timed_run(args, 1) for _ in range(repeat)],
                                    None)
                bad.write_text(text[: text.rstrip("\n").rfind("\n") + 1] + "0,0,-200\n")
                rows += spread_rows("compensate_unreachable_last_row",
                                    [timed_run(args, 1) for _ in range(repeat)], None)
    return rows


def bench_controller(setup: Setup) -> list[Row]:
    """Corrected targets for a controller (issue 22), and the fits of its values.

    The library on 10^5 targets; ``compensate --controller`` on 10^5 and 10^6 (wall time, peak
    RSS); ``export --controller`` of both kinds.
    """
    from deltacal.controller import Controller, corrected_targets

    rng = setup.rng()
    start, meas = _calibration_measurements(setup, 60, rng)
    result = identify(start, meas, "complete")
    controller = Controller.from_geometry(setup.nominal).replace(tool=start.tool)
    targets = setup.workspace_points(100_000, rng) + (start.tool - setup.nominal.tool)
    repeat = max(1, min(setup.repeat, 3)) if not setup.quick else 1
    t_lib = median_time(lambda: corrected_targets(result.geometry, controller, targets), repeat)
    rows = [Row("corrected_targets", targets.shape[0] / t_lib, "targets/s", ">= 100000")]
    command = _command()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cal, robot = folder / "cal.toml", folder / "controller.toml"
        save_calibration(result, cal)
        from deltacal.io import save_controller

        save_controller(robot, controller)
        for n in (100_000,) if setup.quick else (100_000, 1_000_000):
            path = folder / f"t{n}.csv"
            _write_targets(path, setup.workspace_points(n, rng) + (start.tool - setup.nominal.tool))
            args = command + ["compensate", str(cal), str(path), "--controller", str(robot), "-o",
                              str(folder / "c.csv")]
            label = "1e5" if n == 100_000 else "1e6"
            rows += spread_rows(f"compensate_controller_{label}", [timed_run(args) for _ in range(repeat)],
                                "<= 10" if n == 1_000_000 else None, "<= 300" if n == 1_000_000 else None)
        for kind in ("offsets", "limbs"):
            args = command + ["export", str(cal), "--controller", kind, "--robot", str(setup.robot),
                              "-o", str(folder / f"{kind}.toml")]
            rows += spread_rows(f"export_controller_{kind}", [timed_run(args) for _ in range(repeat)], None)
    return rows


def _distance_rows(setup: Setup, folder: Path, n: int, model: str,
                   limit_gb: float | None = None) -> list[Row]:
    """``identify --distances`` (all pairs) of ``n`` positions of the TCP with ``model``."""
    g = setup.geometry
    rng = np.random.default_rng(n)
    points = setup.workspace_points(n, rng)
    q = VirtualDelta.from_nominal(setup.nominal).inverse(points - setup.nominal.tool)
    position = exact.forward(g, q).point(g.tool) + rng.normal(0.0, 0.005, (n, 3))
    meas = folder / f"m{n}.csv"
    if not meas.exists():
        write_measurements(meas, Measurements(q, position))
    args = _command() + ["identify", str(setup.robot), str(meas), "--model", model, "--distances",
                         "-o", str(folder / "cal.toml")]
    if limit_gb is not None:
        run = timed_run(args, expect=(0, 1), address_space=int(limit_gb * 2**30))
        return spread_rows(f"identify_distances_{model}_{n}_limit_{limit_gb:g}GB", [run], "<= 300", None)
    runs = [timed_run(args) for _ in range(max(1, min(setup.repeat, 3) if n <= 1000 else 1))]
    target = {1000: ("<= 20", "<= 1024"), 10000: ("<= 120", "<= 2048")}.get(n, (None, None))
    return spread_rows(f"identify_distances_{model}_{n}", runs, *target)


def bench_cli_distances(setup: Setup) -> list[Row]:
    """``deltacal identify --distances`` (all pairs) at 60 to 10,000 tracker positions, three models.

    Bai's model 18 fixes the gauge by its parameters; bai42 and complete leave it to the
    base-parameter QR. Then 20,000 positions with bai42 in a process limited to 3 GB of
    address space: it must finish or be refused in one line within 5 minutes.
    """
    rows: list[Row] = []
    sizes = (60, 200) if setup.quick else (60, 300, 1000, 10000)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for n in sizes:
            for model in ("bai18", "bai42", "complete"):
                if n == 10000 and model == "bai18":
                    continue
                rows += _distance_rows(setup, folder, n, model)
        if not setup.quick:
            rows += _distance_rows(setup, folder, 20000, "bai42", limit_gb=3.0)
    return rows


def _write_gcode(path: Path, n: int, rng: np.random.Generator,
                 start: str = "G28\nG1 X0 Y0 Z-800 F3000\n") -> None:
    """A printing-like program of about n lines: short extrusions, travels, comments, M codes.

    ``start``: its first lines after the modes (homing, the first move: a rotary robot's by default).

    Of each 1,000 lines: 850 extrusion moves of 0.5-3 mm (``G1 X Y E``, absolute E), 50 travels
    of 5-100 mm (``G0 X Y F``, cut in 1-20 segments at the default 5 mm), 50 comments, 50 M codes.
    """
    with open(path, "w") as f:
        f.write("G21\nG90\nM82\nG92 E0\n" + start)
        x, y, e = 0.0, 0.0, 0.0
        for _ in range(max(1, n // 1000)):
            kind = rng.random(1000)
            step = rng.uniform(0.5, 3.0, 1000)
            turn = rng.uniform(0.0, 2.0 * np.pi, 1000)
            travel = rng.uniform(5.0, 100.0, 1000)
            lines = []
            for k in range(1000):
                if kind[k] < 0.85:
                    x, y, e = x + step[k] * np.cos(turn[k]), y + step[k] * np.sin(turn[k]), e + 0.04 * step[k]
                    lines.append(f"G1 X{x:.3f} Y{y:.3f} E{e:.5f}\n")
                elif kind[k] < 0.90:
                    x, y = travel[k] * np.cos(turn[k]) / 2.0, travel[k] * np.sin(turn[k]) / 2.0
                    lines.append(f"G0 X{x:.3f} Y{y:.3f} F9000\n")
                elif kind[k] < 0.95:
                    lines.append(";TYPE:WALL-OUTER\n")
                else:
                    lines.append("M106 S255\n")
            f.write("".join(lines))


#: The library's G-code filter in a process of its own, with a cheap vectorised correction.
_GCODE_FILTER = """
import sys
import numpy as np
from deltacal.gcode import filter_gcode
def correct(p):
    x, y = p[:, 0], p[:, 1]
    return p + np.stack([0.3 * np.sin(y / 50.0), 0.2 * np.cos(x / 40.0), 1e-5 * x * y], axis=1)
filter_gcode(sys.argv[1], sys.argv[2], correct)
"""


def bench_gcode_filter(setup: Setup) -> list[Row]:
    """``gcode.filter_gcode`` on 10^5 and 10^6 lines of G-code: wall time and peak RSS (flat).

    A process per run (Python and numpy start-up included, about 0.3 s), the correction a
    cheap smooth map: the figure is the filter's own cost.
    """
    rng = setup.rng()
    repeat = max(1, min(setup.repeat, 3)) if not setup.quick else 1
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for n in (100_000,) if setup.quick else (100_000, 1_000_000):
            src = folder / f"p{n}.gcode"
            _write_gcode(src, n, rng)
            args = ["env", f"PYTHONPATH={REPO_ROOT}", sys.executable, "-c", _GCODE_FILTER, str(src),
                    str(folder / "out.gcode")]
            label = "1e5" if n == 100_000 else "1e6"
            rows += spread_rows(f"gcode_filter_{label}", [timed_run(args) for _ in range(repeat)],
                                "<= 20" if n == 1_000_000 else None, "<= 300")
    return rows


def bench_klipper(setup: Setup) -> list[Row]:
    """Corrected targets and G-code through Klipper for a kit printer (issue 24 item 4).

    The Kossel model perturbed with a kit's tolerances, Klipper's model of the nominal printer:
    the library on 10^5 targets; ``compensate --controller printer.cfg`` on 10^5 targets and on a
    printing-like program of 10^5 lines (wall time, peak RSS).
    """
    from deltacal.controller import corrected_targets
    from deltacal.io import save_geometry
    from deltacal.printer.files.robot_file import load_printer
    from deltacal.printer.firmware.klipper.firmware import KLIPPER

    printer = load_printer(REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    truth = printer.geometry().perturbed(Tolerances.printer_kit(), np.random.default_rng(SEED))
    firmware = KLIPPER.nominal(printer)
    controller = KLIPPER.controller(firmware, printer.step_distance)
    rng = setup.rng()
    n = 100_000
    r, a = 115.0 * np.sqrt(rng.random(n)), rng.uniform(0.0, 2.0 * np.pi, n)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, 200.0, n)])
    repeat = max(1, min(setup.repeat, 3)) if not setup.quick else 1
    t_lib = median_time(lambda: corrected_targets(truth, controller, targets), repeat)
    rows = [Row("klipper_corrected_targets", n / t_lib, "targets/s", ">= 100000")]
    command = _command()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cal, cfg, path, program = (folder / name for name in ("true.toml", "printer.cfg", "t.csv", "p.gcode"))
        save_geometry(truth, cal)
        # the minimum_z_position the corrected bed needs (Klipper refuses a command below it)
        admitted = KLIPPER.admit_bed(firmware, truth, printer.step_distance, 115.0)
        KLIPPER.save_config(cfg, admitted, complete=True)
        _write_targets(path, targets)
        args = command + ["compensate", str(cal), str(path), "--controller", str(cfg), "-o",
                          str(folder / "c.csv")]
        rows += spread_rows("compensate_klipper_1e5", [timed_run(args) for _ in range(repeat)], None)
        _write_gcode(program, n, rng, "G28\nG1 X0 Y0 Z0.3 F3000\n")
        args = command + ["compensate", str(cal), str(program), "--controller", str(cfg), "-o",
                          str(folder / "out.gcode")]
        rows += spread_rows("compensate_klipper_gcode_1e5", [timed_run(args) for _ in range(repeat)], None)
    return rows


def bench_cli_doptimal_pool(setup: Setup) -> list[Row]:
    """``deltacal plan --strategy doptimal --pool N`` (complete model, pose measurements).

    The pool is processed in chunks (issue 21, item 7): the memory grows by the scaled
    regressor kept per candidate (about 2 KB) and nothing else; before, 200,000 candidates
    took 4.7 GB and 4.4 minutes, 50,000 took 1.2 GB and 62 s. Once each: a run takes minutes.
    """
    rows: list[Row] = []
    sizes = (20000,) if setup.quick else (50000, 200000)
    targets = {20000: "<= 300", 50000: "<= 400", 200000: "<= 800"}
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            args = _command() + ["plan", str(setup.robot), "--strategy", "doptimal", "--pool", str(n),
                                 "-o", str(Path(tmp) / f"poses{n}.csv")]
            rows += spread_rows(f"cli_plan_doptimal_pool{n}", [timed_run(args)], None, targets[n])
    return rows


def bench_printer(setup: Setup) -> list[Row]:
    """A printer's identification (49 heights, 40 distances) and Klipper's fit: scripts/bench_printer.py."""
    from bench_printer import printer_rows

    return [Row(*row) for row in printer_rows(setup.repeat, run_times, SEED)]


def bench_klipper_live(setup: Setup) -> list[Row]:
    """Klipper's batch run of a program: baseline, bed_mesh, the live module (bench_klipper_live.py)."""
    from bench_klipper_live import live_rows

    return [Row(*row) for row in live_rows(max(3, setup.repeat), SEED)]


BENCHMARKS: list[Callable[[Setup], list[Row]]] = [
    bench_pinocchio_forward,
    bench_exact_batch,
    bench_identification,
    bench_compensation,
    bench_cli_compensate,
    bench_startup,
    bench_fk_versus_least_squares,
    bench_identify_free_frame,
    bench_cli_distances,
    bench_cli_streaming,
    bench_controller,
    bench_identify_compliance,
    bench_gcode_filter,
    bench_klipper,
    bench_klipper_live,
    bench_printer,
    bench_cli_doptimal_pool,
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", type=Path, default=REPO_ROOT / "deltacal" / "models" / "bai2015.toml")
    parser.add_argument("--repeat", type=int, default=5, help="repetitions of each measurement")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--quick", action="store_true", help="small sizes only (no 10^6 targets)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run only these bench_* functions")
    args = parser.parse_args()
    nominal = load_nominal(args.robot)
    geometry = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(SEED))
    setup = Setup(nominal, geometry, args.repeat, SEED, args.robot, args.quick)
    rows: list[Row] = []
    for bench in BENCHMARKS:
        if args.only and bench.__name__.removeprefix("bench_") not in args.only \
                and bench.__name__ not in args.only:
            continue
        rows += bench(setup)
        print(f"done {bench.__name__}", file=sys.stderr, flush=True)
    width = max(len(r.name) for r in rows)
    print(f"{'benchmark':<{width}}  {'value':>12}  {'runs':<21} {'unit':<18} {'target':<10} met")
    for r in rows:
        target = r.target or "-"
        runs = f"{r.spread[0]:.4g}-{r.spread[1]:.4g}" if r.spread else "-"
        print(f"{r.name:<{width}}  {r.value:>12.4g}  {runs:<21} {r.unit:<18} {target:<10} {r.met()}")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench.json"
    results = json.loads(path.read_text()) if args.only and path.exists() else {}
    results.update({r.name: {"value": r.value, "unit": r.unit, "target": r.target,
                             "runs": list(r.spread) if r.spread else None} for r in rows})
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(results, indent=2) + "\n")
    tmp.replace(path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
