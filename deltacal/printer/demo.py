"""The whole job on a simulated printer, beside Klipper's own calibration: ``deltacal demo --printer``.

One seeded typical-kit printer built around ``models/kossel.toml`` (shipped with the package) runs
Klipper's nominal configuration (``printer.cfg``, written first). The demo plans the calibration
object (``object.stl``, ``probe.csv`` and ``distances.csv``, the templates ``plan --object``
writes), simulates what a user measures on it (``probe_measured.csv``,
``distances_measured.csv``: commanded probe triggers σ 10 µm, caliper distances σ 20 µm),
identifies the printer (``printer_calibration.toml``), exports Klipper's values fitted to it
(``printer_calibrated.cfg``, the keys to replace in printer.cfg) and corrects a small part's
G-code for Klipper's nominal values (``part.gcode`` -> ``part_corrected.gcode``, the filter of
``deltacal compensate``). Klipper's basic and enhanced calibration are simulated on the same
printer with their own 7 probes and 12 distances (:mod:`deltacal.printer.comparison`).

Its table: each method's nozzle errors on the TRUE printer over the printable volume (3-D max and
RMS, less the shift along the bed and the turn about its normal that nothing measures; raw 3-D max
too), the first layer's flatness, and the largest error of the printed part's path (its shape:
less the bed motion too). Writes
``printer_demo.json``. Units: mm.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..controller import corrected_targets
from ..gcode import DEFAULT_SEGMENT_MM, filter_gcode, marker_line
from ..io import atomic_write_text, save_calibration, write_stl
from .comparison import (
    BASIC,
    CLASSES,
    ENHANCED,
    GCODE,
    UNCALIBRATED,
    WORKSPACE,
    PrinterRun,
    evaluate,
    exported_name,
    run_printer,
)
from .firmware.klipper.firmware import KLIPPER
from .firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT, nozzle_errors
from .firmware.klipper.model import KlipperDelta
from .measurement_files import write_printed_distances, write_probe_heights
from .plan import plan_object
from .robot import less_bed_motion
from .robot_file import load_printer
from .simulation import nozzle_positions

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"
#: The first-layer weight of the exported values: ``export --controller klipper``'s.
FIRST_LAYER_WEIGHT = EXPORT_FIRST_LAYER_WEIGHT
#: The demo's default seed.
SEED = 2400
#: The first line of the nominal ``printer.cfg`` the demo writes.
NOMINAL_TITLE = "Klipper's nominal configuration of the demo printer (deltacal demo --printer)"
#: The rows of the table, in order.
ROWS = (UNCALIBRATED, BASIC, ENHANCED, "deltacal exported values", GCODE)
_XYZ = re.compile(r"^G[01] X([-+.0-9]+) Y([-+.0-9]+) Z([-+.0-9]+)", re.MULTILINE)


def _silent(text: str) -> None:
    """The default progress callback: says nothing."""


def part_gcode(heights: tuple[float, ...]) -> str:
    """A small part: at each height a 120 mm square perimeter and a 40 mm radius circle (G2), extruding."""
    lines = ["; deltacal demo --printer: a square and a circle at a few heights", "G28", "G90", "M83", "G21"]
    for z in heights:
        lines += [f"G0 X-60 Y-60 Z{z:g} F6000", "G1 X60 Y-60 E4.0 F1800", "G1 X60 Y60 E4.0",
                  "G1 X-60 Y60 E4.0", "G1 X-60 Y-60 E4.0", "G0 X40 Y0", "G2 X40 Y0 I-40 J0 E8.4"]
    return "\n".join([*lines, ""])


def _part(run: PrinterRun, out_dir: Path, quick: bool, limits: KlipperDelta) -> dict[str, float]:
    """Correct the part's program for Klipper's nominal values; each method's largest error along it [mm].

    The corrected program's moves (as written, 0.1 µm) go through Klipper's nominal values to the
    true printer; the other methods command the intended points with their values. Each method's
    errors are taken less the bed motion that fits them best (the part's shape, not its place), at
    the points within the printable volume (not the travel from the home position down to the part).
    Every command written is one ``limits`` (the demo's ``printer.cfg``) accepts, or the filter refuses it.
    """
    source, corrected = out_dir / "part.gcode", out_dir / "part_corrected.gcode"
    atomic_write_text(source, part_gcode((0.2, 50.0) if quick else (0.2, 10.0, 30.0, 60.0, 100.0)))
    controller = KLIPPER.controller(run.firmware, run.step_distance)
    intended: list[np.ndarray] = []

    def correct(points: np.ndarray) -> np.ndarray:
        intended.append(np.array(points))
        return corrected_targets(run.result.geometry, controller, points).commands

    filter_gcode(source, corrected, correct, DEFAULT_SEGMENT_MM, home=controller.home, limits=limits,
                 marker=marker_line("printer.cfg", "printer_calibration.toml"))
    targets = np.concatenate(intended)
    sent = np.array(_XYZ.findall(corrected.read_text()), dtype=float)
    if sent.shape != targets.shape:
        raise RuntimeError(f"{corrected}: {len(sent)} moves written for {len(targets)} corrected points")
    inside = targets[:, 2] <= WORKSPACE.top_z  # the part, not the travel down from the home position
    targets, sent = targets[inside], sent[inside]
    truth = run.truth.geometry
    errors = {name: nozzle_errors(truth, config, run.step_distance, targets)
              for name, config in run.configs.items()}
    errors[GCODE] = nozzle_positions(truth, run.firmware, run.step_distance, sent) - targets
    return {name: float(np.max(np.linalg.norm(less_bed_motion(targets, e)[0], axis=1)))
            for name, e in errors.items()}


def _admit_bed(run: PrinterRun, cfg: Path) -> KlipperDelta:
    """``printer.cfg`` rewritten with the ``minimum_z_position`` the corrected bed needs; its values.

    The true bed is lower than Klipper's nominal model puts it where the corrected first layer goes
    below Klipper's z 0; the lowest Z commanded on the printable disk sets the key
    (:meth:`~deltacal.printer.firmware.base.Firmware.admit_bed`).
    """
    admitted = KLIPPER.admit_bed(run.firmware, run.result.geometry, run.step_distance, WORKSPACE.radius)
    if admitted is not run.firmware:
        KLIPPER.save_config(cfg, admitted, title=NOMINAL_TITLE, complete=True,
                            notes=[f"minimum_z_position admits the bed corrected by deltacal over radius "
                                   f"{WORKSPACE.radius:g} mm (part_corrected.gcode)"])
    return KLIPPER.read_config(cfg)


def run_printer_demo(out_dir: Path = Path("results"), seed: int = SEED, quick: bool = False,
                     progress: Callable[[str], None] = _silent) -> dict:
    """Run the printer demo, write its files and ``printer_demo.json``; :func:`printer_table` prints it.

    Args:
        out_dir: Folder for the files (created if needed).
        seed: Seed of the true printer and of the measurements' noise.
        quick: A shorter part program (2 heights instead of 5), for a fast check.
        progress: Called with one line of text after each long step.

    Returns:
        The results written to printer_demo.json.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    printer = load_printer(MODELS_DIR / "kossel.toml")
    cfg = KLIPPER.save_config(out_dir / "printer.cfg", KLIPPER.nominal(printer), title=NOMINAL_TITLE,
                              complete=True)
    firmware = KLIPPER.read_config(cfg)
    plan = plan_object(printer, firmware)
    write_stl(out_dir / "object.stl", plan.mesh())
    write_probe_heights(out_dir / "probe.csv", plan.probe)
    write_printed_distances(out_dir / "distances.csv", plan.pair_positions)
    progress(f"planned the object: {len(plan.probe)} probe points, {len(plan.pairs)} distances "
             f"(object.stl, probe.csv, distances.csv)")
    tolerances, tilt = CLASSES["typical kit"]
    run = run_printer(printer, plan, seed, tolerances, tilt, (FIRST_LAYER_WEIGHT,))
    write_probe_heights(out_dir / "probe_measured.csv", run.probe[:, :2], run.probe[:, 2])
    write_printed_distances(out_dir / "distances_measured.csv", plan.pair_positions, run.distances)
    save_calibration(run.result, out_dir / "printer_calibration.toml")
    progress(f"true printer (seed {seed}, typical kit) measured and identified: variance factor "
             f"{run.result.variance_factor:.2f} (printer_calibration.toml); Klipper's basic and enhanced "
             "calibration simulated")
    exported = run.configs.pop(exported_name(FIRST_LAYER_WEIGHT))
    run.configs[ROWS[3]] = exported
    KLIPPER.save_config(out_dir / "printer_calibrated.cfg", exported, cfg,
                        f"Klipper's values fitted to {printer.name} by deltacal (first-layer weight "
                        f"{FIRST_LAYER_WEIGHT:g})")
    figures = evaluate(run)
    progress("evaluated every method on the true printer (printer_calibrated.cfg written)")
    part = _part(run, out_dir, quick, _admit_bed(run, cfg))
    progress("corrected part.gcode for Klipper's nominal values (part_corrected.gcode)")
    rows = [{"method": name, **figures["less bed motion"][name].as_dict(),
             "raw_max_3d_mm": figures["raw"][name].max_3d, "part_max_mm": part[name]} for name in ROWS]
    summary = {"printer": printer.name, "seed": seed, "class": "typical kit", "first_layer_weight":
               FIRST_LAYER_WEIGHT, "probe_points": len(plan.probe), "distances": len(plan.pairs),
               "variance_factor": run.result.variance_factor, "rows": rows}
    atomic_write_text(out_dir / "printer_demo.json", json.dumps(summary, indent=1) + "\n")
    return summary


def printer_table(summary: dict) -> str:
    """The demo's table: each method's errors on the true printer [mm]."""
    lines = [f"Nozzle error on the true printer (seed {summary['seed']}, {summary['class']}; volume radius "
             "92 mm, z 0.2-100 mm; less the bed motion nothing measures) [mm]",
             f"  {'method':26s} {'3-D max':>8s} {'3-D RMS':>8s} {'flatness':>9s} {'raw max':>8s} "
             f"{'part max':>9s}"]
    for row in summary["rows"]:
        lines.append(f"  {row['method']:26s} {row['max_3d_mm']:8.3f} {row['rms_3d_mm']:8.3f} "
                     f"{row['flatness_mm']:9.3f} {row['raw_max_3d_mm']:8.3f} {row['part_max_mm']:9.3f}")
    return "\n".join(lines) + "\n"
