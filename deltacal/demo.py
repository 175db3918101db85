"""The main job on a simulated robot: ``deltacal demo``.

On the robot of Bai et al. (models/bai2015.toml, shipped with the package) it
perturbs a seeded true robot with errors of the size of Bai's Tables 2-4, plans
D-optimal poses, simulates a laser tracker with a 6-DoF probe (σ 5 µm, 0.003°)
on the Pinocchio closed-loop model, identifies with the classical, Bai 42 and
complete models, compensates with each method, and validates every result on
the true robot over Bai's validation set (96 poses and home), for a tool at the
plate and 200 mm below it. Then it does the same as a real cell would: the
tracker stands 2.8 m away in its own frame, yawed and not levelled, and is
moved once for line of sight (two stations); the complete model is identified
with the instrument frames free and the targets are given in the tracker's
frame. It prints one comparison table and writes ``demo.json``,
``demo_errors.png`` (a plot), ``demo.html`` (a meshcat scene) and, with
Chromium, ``demo.png`` (its screenshot); and what a calibration hands over:
``demo_calibration.toml`` (the complete model's), ``demo_measurements.csv``,
``demo_report.html`` (the HTML report with its predicted-accuracy map) and
``demo_robot.xml`` (the calibrated robot as MJCF).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .compensation import METHODS, CompensationMethod, compensate, linear_calibration_from_result
from .controller import FIT_KINDS, Controller, corrected_targets, fit_controller
from .controller.fit import tcp_errors
from .exceptions import ViewerError
from .export import write_mjcf
from .geometry import DeltaGeometry, NominalDelta, Tolerances
from .identification import identify
from .identification.frames import InstrumentFrame, in_instrument_frames
from .identification.options import Frame
from .identification.result import IdentificationResult
from .io import atomic_write_text, load_nominal, save_calibration, write_measurements
from .kinematics import exact
from .observations import SIGMA_ANGLE, SIGMA_POSITION, Measurements
from .planning import d_optimal
from .report import write_report
from .report.accuracy import workspace_slices
from .simulation import Metrology, simulate_measurements
from .validation import validate, validation_poses
from .viz import export_views

MODELS_DIR = Path(__file__).resolve().parent / "models"
#: Tools of the comparison: at the plate, and 200 mm below it [mm].
TOOLS = {"tool 0 mm": np.zeros(3), "tool 200 mm": np.array([0.0, 0.0, -200.0])}
MODELS = ("classical", "bai42", "complete")
#: The tracker of the real-cell part: 2.8 m from the robot, yawed 35 deg, tilted about 1.5 deg
#: (station A), then moved to the other side for line of sight (station B). Pose of {O} in {T}.
TRACKER_STATIONS = {
    "A": InstrumentFrame.from_vectors(np.radians([1.1, -1.0, 35.0]), [2680.0, 830.0, 250.0]),
    "B": InstrumentFrame.from_vectors(np.radians([-0.6, 1.2, -140.0]), [-1900.0, 2100.0, -120.0]),
}


def _silent(text: str) -> None:
    """The default progress callback: says nothing."""


def _fit_summary(r) -> dict:
    """What demo.json keeps of a fit."""
    return {
        "rank": r.rank,
        "parameters": len(r.base.names),
        "condition_number": r.condition_number,
        "iterations": r.iterations,
        "variance_factor": r.variance_factor,
        "residual_rms_mm": r.after.position_rms,
    }


@dataclass(frozen=True)
class DemoResults:
    """What the demo finds, before anything is written.

    Attributes:
        summary: The results :func:`run_demo` writes to demo.json.
        complete: The complete model's identification (the calibration handed over).
        measurements: The simulated tracker and probe measurements.
        truth: The simulated true robot.
        nominal: The robot's nominal parameters (models/bai2015.toml).
    """

    summary: dict
    complete: IdentificationResult
    measurements: Measurements
    truth: DeltaGeometry
    nominal: NominalDelta


def demo_results(seed: int = 2015, quick: bool = False,
                 progress: Callable[[str], None] = _silent) -> DemoResults:
    """The demo's computations (:func:`run_demo` without its files): its figures and what they come from.

    Args:
        seed: Seed of the true robot, the poses and the measurement noise.
        quick: Fewer poses (30 instead of 60) for a fast check.
        progress: Called with one line of text after each long step.
    """
    nominal = load_nominal(MODELS_DIR / "bai2015.toml")
    rng = np.random.default_rng(seed)
    start = nominal.geometry()
    truth = start.perturbed(Tolerances.bai2015(), rng)
    progress(
        f"true robot (seed {seed}): encoder offsets "
        f"{np.round(np.degrees(truth.encoder_offset), 3).tolist()} deg"
    )

    count = 30 if quick else 60
    design = d_optimal(nominal, "complete", count, rng=rng, pool_size=400 if quick else 800)
    progress(f"planned {count} D-optimal poses from {len(design.pool)} candidates")

    metrology = Metrology(points=("smr_centre",), sigma_position=SIGMA_POSITION, sigma_angle=SIGMA_ANGLE)
    measurements = simulate_measurements(truth, design.poses.q, rng, metrology)
    progress(f"simulated {len(measurements)} tracker + probe measurements on the Pinocchio model")

    results = {}
    for name in MODELS:
        # the comparison keeps the fits of models too simple for the robot (classical): accepted
        results[name] = identify(start, measurements, name, method="iterated", accept_poor_fit=True)
        r = results[name]
        progress(
            f"identified {name}: rank {r.rank}/{len(r.base.names)}, {r.iterations} iterations, "
            f"residual RMS {r.after.position_rms * 1000:.1f} µm"
        )

    # the papers' pipeline: one linear identification around the nominal geometry
    one_shot = identify(start, measurements, "complete", method="linear", accept_poor_fit=True)
    progress(
        f"identified complete in one linear step: residual RMS {one_shot.after.position_rms * 1000:.1f} µm"
    )

    rows = _validation_rows(truth, nominal, {**results, "complete (linear id.)": one_shot}, progress)

    tracker = _tracker_cell(start, truth, nominal, design.poses.q, metrology, seed)
    progress(
        f"identified complete from a tracker 2.8 m away, two stations, frames free: max TCP error "
        f"{tracker['tracker_frame']['max_mm']:.4f} mm (tool 200 mm), "
        f"{tracker['base_frame']['max_mm']:.4f} mm with the same data given in {{O}}"
    )

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
        "identification": {name: _fit_summary(r) for name, r in results.items()},
        "validation": rows,
        "tracker": tracker,
        "controller_routes": _controller_routes(results["complete"], truth, nominal, progress),
    }
    return DemoResults(summary, results["complete"], measurements, truth, nominal)


def run_demo(
    out_dir: Path = Path("results"),
    seed: int = 2015,
    quick: bool = False,
    views: bool = True,
    progress: Callable[[str], None] = _silent,
) -> dict:
    """Run the demo and write the results; :func:`text_table` gives its comparison table.

    Args:
        out_dir: Folder for demo.json, demo_errors.png, demo.html, demo.png (created if needed).
        seed: Seed of the true robot, the poses and the measurement noise.
        quick: Fewer poses (30 instead of 60) for a fast check.
        views: Write the meshcat scene (and its screenshot) too.
        progress: Called with one line of text after each long step, and for each
            output skipped because an optional part is missing (``"skipped: ..."``).

    Returns:
        The results written to demo.json (:attr:`DemoResults.summary`).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    found = demo_results(seed, quick, progress)
    summary = found.summary
    atomic_write_text(out_dir / "demo.json", json.dumps(summary, indent=2) + "\n")
    written = [out_dir / "demo.json"]
    plot = _plot(summary["validation"], out_dir / "demo_errors.png", progress)
    if plot is not None:
        written.append(plot)
    written += _handover(found.complete, found.measurements, found.truth, found.nominal, out_dir, views,
                         progress)
    if views:
        written += _views(found.nominal.geometry(), found.truth, found.nominal, out_dir, progress)
    progress("wrote " + ", ".join(str(p) for p in written))
    return summary


def _validation_rows(truth, nominal: NominalDelta, fits: dict, progress: Callable[[str], None]) -> list[dict]:
    """The comparison table: each tool, uncalibrated then each fit with each compensation method."""
    rows = []
    for tool_name, tool in TOOLS.items():
        true_tool = truth.with_tool(tool)
        poses = validation_poses(nominal, tool=tool)
        targets = poses.targets
        before = validate(true_tool, poses.q, targets)
        rows.append(_row(tool_name, "uncalibrated", "-", before))
        for name, result in fits.items():
            linear = linear_calibration_from_result(result, tool)
            for method in METHODS:
                q = compensate(result.geometry.with_tool(tool), targets, method,
                               linear if CompensationMethod(method).linear else None)
                rows.append(_row(tool_name, name, method, validate(true_tool, q, targets)))
        progress(f"validated every model and method on the true robot, {tool_name}")
    return rows


def _handover(result, measurements, truth, nominal: NominalDelta, out_dir: Path, views: bool,
              progress: Callable[[str], None]) -> list[Path]:
    """What a calibration hands over: its file, the measurements, the HTML report, the MJCF model."""
    paths = [out_dir / name for name in ("demo_calibration.toml", "demo_measurements.csv",
                                          "demo_report.html", "demo_robot.xml")]
    calibration, measured, report, mjcf = paths
    save_calibration(result, calibration)
    write_measurements(measured, measurements)
    summary = write_report(calibration, report, measurements=measured, truth=truth,
                           truth_source="the demo's simulated robot", tool=TOOLS["tool 200 mm"],
                           workspace=nominal.workspace, view=views)
    write_mjcf(mjcf, result.geometry, name=f"{nominal.name} (identified)", source=str(calibration))
    progress(f"wrote the calibration report (largest predicted TCP σ {summary.worst_sigma * 1000:.1f} µm) "
             "and the calibrated robot as MJCF")
    return paths


def _tracker_cell(start, truth, nominal: NominalDelta, q: np.ndarray, metrology: Metrology,
                  seed: int) -> dict:
    """The real-cell path: measurements and targets in a tracker's frames, two stations.

    The same noisy measurements are identified twice with the complete model: given in {O}
    (the simulator's privilege) and given in the stations' frames with the frames free. The
    targets of the tool 200 mm below the plate are given in station A's frame and compensated
    through the identified frame A; both are validated on the true robot.
    """
    rng = np.random.default_rng([seed, 11])  # its own stream: the table above stays as it was
    measured = simulate_measurements(truth, q, rng, metrology)
    half = len(measured) // 2
    measured = replace(measured, station=["A"] * half + ["B"] * (len(measured) - half))
    in_tracker = in_instrument_frames(measured, TRACKER_STATIONS)
    tool = TOOLS["tool 200 mm"]
    poses = validation_poses(nominal, tool=tool)
    targets_in_tracker = TRACKER_STATIONS["A"].from_base(poses.targets)
    out: dict = {"stations": {
        name: {"rotation_deg": np.degrees(f.rotation_vector).tolist(),
               "translation_mm": f.translation.tolist()}
        for name, f in TRACKER_STATIONS.items()
    }}
    cases: tuple[tuple[str, Measurements, Frame], ...] = (
        ("base_frame", measured, "base"), ("tracker_frame", in_tracker, "free"))
    for key, data, frame in cases:
        result = identify(start, data, "complete", frame=frame)
        targets = result.frames["A"].to_base(targets_in_tracker) if result.frames else poses.targets
        q_cmd = compensate(result.geometry.with_tool(tool), targets)
        metrics = validate(truth.with_tool(tool), q_cmd, poses.targets)
        out[key] = {"max_mm": metrics.max_mm, "rms_mm": metrics.rms_mm,
                    "variance_factor": result.variance_factor, "iterations": result.iterations}
    return out


def markdown_table(summary: dict) -> str:
    """The comparison table of a demo run as Markdown (docs/results.md quotes it verbatim)."""
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


def _controller_routes(result, truth, nominal: NominalDelta, progress: Callable[[str], None]) -> dict:
    """What each route to a Cartesian controller leaves on the true robot, tool 200 mm.

    The routes (docs/controllers.md, "Using a calibration on your controller"): the nominal controller fed the
    targets as they are, its joint offsets or per-limb values fitted to the complete model's
    calibration, and corrected targets for it.

    Each route is validated on the true robot over Bai's validation set and, for the fits, over
    the fit's grid (the report's accuracy-map grid of the workspace), beside what the fit says it
    leaves there (computed on the identified robot: its ``[fit]``).
    """
    tool = TOOLS["tool 200 mm"]
    identified, true_tool = result.geometry.with_tool(tool), truth.with_tool(tool)
    controller = Controller.from_geometry(nominal).replace(tool=tool)
    targets = validation_poses(nominal, tool=tool).targets
    assert nominal.workspace is not None  # the demo robot's file has one
    grid = np.concatenate([s.points.reshape(-1, 3) for s in workspace_slices(nominal.workspace)]) + tool
    grid = grid[np.all(np.isfinite(grid), axis=1)]

    def on_truth(commanded: Controller, sent: np.ndarray) -> dict:
        metrics = validate(true_tool, commanded.inverse(sent), targets)
        return {"max_mm": metrics.max_mm, "rms_mm": metrics.rms_mm}

    routes = {"nominal": on_truth(controller, targets)}
    for kind in FIT_KINDS:
        fit = fit_controller(identified, controller, grid, kind)
        left = np.linalg.norm(tcp_errors(true_tool, fit.controller, grid), axis=1)
        routes[kind] = {**on_truth(fit.controller, targets), "held": fit.held,
                        "fit_max_mm": fit.max_error, "fit_rms_mm": fit.rms_error,
                        "grid_max_mm": float(left.max()), "grid_rms_mm": float(np.sqrt(np.mean(left**2)))}
    routes["corrected"] = on_truth(controller, corrected_targets(identified, controller, targets).commands)
    progress("fitted the controller's joint offsets and per-limb values; corrected targets for it")
    return routes


def controller_table(summary: dict) -> str:
    """The controller routes of a demo run as plain text (what ``deltacal demo`` prints after its table)."""
    routes = summary.get("controller_routes")
    if not routes:
        return ""
    names = {"nominal": "nominal model, targets as they are", "offsets": "joint offsets fitted",
             "limbs": "per-limb values fitted", "corrected": "nominal model, corrected targets"}
    lines = ["", "", "a Cartesian controller (classical model), complete model's calibration, tool 200 mm, "
             "mm:",
             f"{'route':<36} | {'validation max':>14} {'RMS':>7} | {'grid: [fit] max':>15} {'RMS':>7} | "
             f"{'true max':>8} {'RMS':>7}"]
    for key, name in names.items():
        r = routes[key]
        line = f"{name:<36} | {r['max_mm']:14.4f} {r['rms_mm']:7.4f}"
        if "fit_max_mm" in r:
            line += (f" | {r['fit_max_mm']:15.4f} {r['fit_rms_mm']:7.4f} | {r['grid_max_mm']:8.4f} "
                     f"{r['grid_rms_mm']:7.4f}")
        lines.append(line)
    return "\n".join(lines)


def _tilt_range(truth, nominal: NominalDelta) -> tuple[float, float]:
    poses = validation_poses(nominal)
    tilt = np.degrees(exact.forward(truth, poses.q).tilt())
    return float(tilt.min()), float(tilt.max())


def text_table(summary: dict) -> str:
    """The comparison table of a demo run as plain text (what ``deltacal demo`` prints)."""
    rows = summary["validation"]
    tilt = (summary["plate_tilt_deg"]["min"], summary["plate_tilt_deg"]["max"])
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
    tracker = summary.get("tracker")
    if tracker:
        lines += [
            "",
            "a real cell: tracker 2.8 m away, yawed 35 deg, tilted 1.5 deg, moved once (2 stations); "
            "complete model, exact compensation, tool 200 mm",
            f"{'measurements and targets in':<31} | {'max':>8} {'RMS':>8}",
            f"{'the robot base {O}':<31} | {tracker['base_frame']['max_mm']:8.4f} "
            f"{tracker['base_frame']['rms_mm']:8.4f}",
            f"{'the tracker, frames identified':<31} | {tracker['tracker_frame']['max_mm']:8.4f} "
            f"{tracker['tracker_frame']['rms_mm']:8.4f}",
        ]
    return "\n".join(lines)


def _plot(rows: list[dict], path: Path, progress: Callable[[str], None]) -> Path | None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        progress(f"skipped: {path.name} (matplotlib, a dependency of deltacal, is missing: "
                 "pip install 'matplotlib>=3.7')")
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


def _views(start, truth, nominal: NominalDelta, out_dir: Path, progress: Callable[[str], None]) -> list[Path]:
    """Write ``demo.html`` (animated, error arrows) and, with Chromium, ``demo.png``."""
    try:
        paths = export_views(start, truth, out_dir / "demo.html", out_dir / "demo.png", nominal.workspace)
    except ViewerError as exc:
        progress(f"skipped: demo.html and demo.png ({exc})")
        return []
    if "png" not in paths:
        progress("skipped: demo.png (no Chromium to take the screenshot: apt-get install chromium)")
    progress("wrote the meshcat scene" + (" and its screenshot" if "png" in paths else ""))
    return list(paths.values())
