"""The main job on a simulated robot: ``deltacal demo``.

On the robot of Bai et al. (models/bai2015.toml, shipped with the package) it
perturbs a seeded true robot with errors of the size of Bai's Tables 2-4, plans
D-optimal poses, simulates a laser tracker with a 6-DoF probe (σ 5 µm, 0.003°)
on the Pinocchio closed-loop model, identifies with the classical, Bai 42 and
complete models, compensates with each method, and validates every result on
the true robot over Bai's validation set (96 poses and home), for a tool at the
plate and 200 mm below it. It prints one comparison table and writes
``demo.json``, ``demo_errors.png`` (a plot), ``demo.html`` (a meshcat scene) and,
with Chromium, ``demo.png`` (its screenshot).
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .compensation import LinearCalibration, compensate
from .errormodels import get_model
from .geometry import NominalDelta, Tolerances
from .identification import identify
from .io import atomic_write_text
from .planning import d_optimal
from .simulation import Metrology, simulate_measurements
from .validation import validate, validation_poses

MODELS_DIR = Path(__file__).resolve().parent / "models"
#: Tools of the comparison: at the plate, and 200 mm below it [mm].
TOOLS = {"tool 0 mm": np.zeros(3), "tool 200 mm": np.array([0.0, 0.0, -200.0])}
MODELS = ("classical", "bai42", "complete")
METHODS = ("exact", "savoure", "bai")


@dataclass
class _Progress:
    start: float

    def step(self, text: str) -> None:
        print(f"[{time.perf_counter() - self.start:5.1f} s] {text}", file=sys.stderr, flush=True)


def run_demo(
    out_dir: Path = Path("results"), seed: int = 2015, quick: bool = False, views: bool = True
) -> dict:
    """Run the demo, print the comparison table and write the results.

    Args:
        out_dir: Folder for demo.json, demo_errors.png, demo.html, demo.png (created if needed).
        seed: Seed of the true robot, the poses and the measurement noise.
        quick: Fewer poses (30 instead of 60) for a fast check.
        views: Write the meshcat scene (and its screenshot) too.

    Returns:
        The results written to demo.json.
    """
    progress = _Progress(time.perf_counter())
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    nominal = NominalDelta.from_toml(MODELS_DIR / "bai2015.toml")
    rng = np.random.default_rng(seed)
    start = nominal.geometry()
    truth = start.perturbed(Tolerances.bai2015(), rng)
    progress.step(
        f"true robot (seed {seed}): encoder offsets "
        f"{np.round(np.degrees(truth.encoder_offset), 3).tolist()} deg"
    )

    count = 30 if quick else 60
    design = d_optimal(nominal, "complete", count, rng=rng, pool_size=400 if quick else 800)
    progress.step(f"planned {count} D-optimal poses from {len(design.pool)} candidates")

    metrology = Metrology(points=("smr_centre",), sigma_position=0.005, sigma_angle=math.radians(0.003))
    measurements = simulate_measurements(truth, design.poses.q, rng, metrology)
    progress.step(f"simulated {len(measurements)} tracker + probe measurements on the Pinocchio model")

    results = {}
    for name in MODELS:
        results[name] = identify(start, measurements, name, method="iterated")
        r = results[name]
        progress.step(
            f"identified {name}: rank {r.rank}/{len(r.base.names)}, {r.iterations} iterations, "
            f"residual RMS {r.after.position_rms * 1000:.1f} µm"
        )

    # the papers' pipeline: one linear identification around the nominal geometry
    one_shot = identify(start, measurements, "complete", method="linear")
    progress.step(
        f"identified complete in one linear step: residual RMS {one_shot.after.position_rms * 1000:.1f} µm"
    )

    rows = []
    for tool_name, tool in TOOLS.items():
        true_tool = truth.with_tool(tool)
        poses = validation_poses(nominal, tool=tool)
        targets = poses.targets
        before = validate(true_tool, poses.q, targets)
        rows.append(_row(tool_name, "uncalibrated", "-", before))
        for name, result in [*results.items(), ("complete (linear id.)", one_shot)]:
            linear = LinearCalibration(
                nominal=start.with_tool(tool),
                model=get_model(result.model),
                deviation=result.base.expand(result.values),
            )
            for method in METHODS:
                q = compensate(result.geometry.with_tool(tool), targets, method, linear)
                rows.append(_row(tool_name, name, method, validate(true_tool, q, targets)))
        progress.step(f"validated every model and method on the true robot, {tool_name}")

    tilt = _tilt_range(truth, nominal)
    summary = {
        "robot": nominal.name,
        "seed": seed,
        "poses": count,
        "measurements": len(measurements),
        "sigma_position_mm": metrology.sigma_position,
        "sigma_angle_deg": math.degrees(metrology.sigma_angle),
        "true_encoder_offsets_deg": np.degrees(truth.encoder_offset).tolist(),
        "plate_tilt_deg": {"min": tilt[0], "max": tilt[1]},
        "identification": {
            name: {
                "rank": r.rank,
                "parameters": len(r.base.names),
                "condition_number": r.condition_number,
                "iterations": r.iterations,
                "variance_factor": r.variance_factor,
                "residual_rms_mm": r.after.position_rms,
            }
            for name, r in results.items()
        },
        "validation": rows,
    }
    print(_table(rows, tilt))
    atomic_write_text(out_dir / "demo.json", json.dumps(summary, indent=2) + "\n")
    written = [out_dir / "demo.json"]
    plot = _plot(rows, out_dir / "demo_errors.png")
    if plot is not None:
        written.append(plot)
    if views:
        written += _views(start, truth, nominal, out_dir, progress)
    progress.step("wrote " + ", ".join(str(p) for p in written))
    return summary


def markdown_table(summary: dict) -> str:
    """The comparison table of a demo run as Markdown (the README quotes it verbatim)."""
    rows = summary["validation"]
    tools = list(dict.fromkeys(r["tool"] for r in rows))
    lines = [
        "| model | compensation | " + " | ".join(f"{t}: max | RMS" for t in tools) + " |",
        "| --- | --- | " + " | ".join("--- | ---" for _ in tools) + " |",
    ]
    for model, method in dict.fromkeys((r["model"], r["method"]) for r in rows):
        cells = []
        for t in tools:
            r = next(r for r in rows if (r["tool"], r["model"], r["method"]) == (t, model, method))
            cells += [f"{r['max_mm']:.4f}", f"{r['rms_mm']:.4f}"]
        lines.append(f"| {model} | {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _row(tool: str, model: str, method: str, metrics) -> dict:
    return {
        "tool": tool,
        "model": model,
        "method": method,
        "max_mm": metrics.max_mm,
        "rms_mm": metrics.rms_mm,
        "max_delta_rho_mm": metrics.max_delta_rho_mm,
        "max_delta_v_mm": metrics.max_delta_v_mm,
    }


def _tilt_range(truth, nominal: NominalDelta) -> tuple[float, float]:
    from .kinematics import exact

    poses = validation_poses(nominal)
    tilt = np.degrees(exact.forward(truth, poses.q).tilt())
    return float(tilt.min()), float(tilt.max())


def _table(rows: list[dict], tilt: tuple[float, float]) -> str:
    tools = list(dict.fromkeys(r["tool"] for r in rows))
    header = f"{'model':<22} {'method':<8}" + "".join(f" | {t + ' max':>16} {'RMS':>8}" for t in tools)
    lines = [
        "",
        f"TCP error on the true robot over Bai's validation set (97 poses), mm; plate tilt "
        f"{tilt[0]:.3f}-{tilt[1]:.3f} deg",
        header,
        "-" * len(header),
    ]
    keys = list(dict.fromkeys((r["model"], r["method"]) for r in rows))
    for model, method in keys:
        line = f"{model:<22} {method:<8}"
        for t in tools:
            r = next(r for r in rows if r["tool"] == t and r["model"] == model and r["method"] == method)
            line += f" | {r['max_mm']:16.4f} {r['rms_mm']:8.4f}"
        lines.append(line)
    lines.append(
        "methods: exact = Newton through the identified geometry; savoure = Eq. 29-33; bai = Eq. 22-25"
    )
    return "\n".join(lines)


def _plot(rows: list[dict], path: Path) -> Path | None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install 'deltacal[plot]'): no plot", file=sys.stderr)
        return None
    tools = list(dict.fromkeys(r["tool"] for r in rows))
    labels = list(dict.fromkeys(f"{r['model'].replace(' (', chr(10) + '(')}\n{r['method']}" for r in rows))
    fig, ax = plt.subplots(figsize=(11, 4.5))
    width = 0.8 / len(tools)
    for k, tool in enumerate(tools):
        values = [r["max_mm"] for r in rows if r["tool"] == tool]
        ax.bar(np.arange(len(labels)) + (k - 0.5) * width, values, width, label=tool)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(labels)))
    ax.set_xticklabels([lbl.replace("uncalibrated\n-", "uncalibrated") for lbl in labels], fontsize=8)
    ax.set_ylabel("max TCP error over 97 poses [mm]")
    ax.set_title("deltacal demo: accuracy on the true (Pinocchio) robot")
    ax.grid(axis="y", which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path


def _views(start, truth, nominal: NominalDelta, out_dir: Path, progress: _Progress) -> list[Path]:
    try:
        from .viz import write_demo_views
    except ImportError:
        print("meshcat is not installed (pip install 'deltacal[viz]'): no 3-D view", file=sys.stderr)
        return []
    paths = write_demo_views(start, truth, out_dir, workspace=nominal.workspace)
    progress.step("wrote the meshcat scene" + (" and its screenshot" if len(paths) > 1 else ""))
    return list(paths.values())


__all__ = ["run_demo"]
