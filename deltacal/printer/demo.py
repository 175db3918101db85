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

``--firmware marlin|rrf`` (``firmware``) runs the same printer (its seed) through Marlin's (``m503.txt``)
or RepRapFirmware's (``config.g``) nominal values instead, beside that firmware's own calibration
emulated (Marlin's ``G33``, RRF's ``G32`` with 6 and 8 factors); the exported values go to
``printer_calibrated.gcode`` or ``config-override.g``.

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
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..calibration import Calibration
from ..controller import corrected_targets
from ..gcode import DEFAULT_SEGMENT_MM, filter_gcode, marker_line
from ..io import atomic_write_text, load_calibration, save_calibration, write_stl
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
from .files.measurements import write_printed_distances, write_probe_heights
from .files.robot_file import load_printer
from .firmware.base import Firmware, FirmwareModel
from .firmware.config_file import FirmwareConfig
from .firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT, nozzle_errors
from .firmware.klipper.firmware import KLIPPER
from .identification.anchor import measured_record
from .identification.fit import PrinterFitOptions
from .printed.plan import plan_object
from .robot import less_bed_motion
from .simulation import nozzle_positions

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"
#: The first-layer weight of the exported values: ``export --controller klipper``'s.
FIRST_LAYER_WEIGHT = EXPORT_FIRST_LAYER_WEIGHT
#: The demo's default seed.
SEED = 2400
#: The exported values' row of the table (between the firmware's own calibrations and the G-code route).
EXPORTED_ROW = "deltacal exported values"
#: The rows of the table with Klipper (the default), in order.
ROWS = (UNCALIBRATED, BASIC, ENHANCED, EXPORTED_ROW, GCODE)
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


def nominal_title(firmware: Firmware) -> str:
    """The first line of the nominal configuration the demo writes."""
    return f"{firmware.title}'s nominal configuration of the demo printer (deltacal demo --printer)"


def _part(run: PrinterRun, out_dir: Path, quick: bool, limits: FirmwareModel,
          config: str) -> dict[str, float]:
    """Correct the part's program for the firmware's nominal values; each method's largest error on it [mm].

    The corrected program's moves (as written, 0.1 µm) go through the firmware's nominal values to the
    true printer; the other methods command the intended points with their values. Each method's
    errors are taken less the bed motion that fits them best (the part's shape, not its place), at
    the points within the printable volume (not the travel from the home position down to the part).
    Every command written is one ``limits`` (the demo's configuration, file name ``config``) accepts,
    or the filter refuses it.
    """
    source, corrected = out_dir / "part.gcode", out_dir / "part_corrected.gcode"
    atomic_write_text(source, part_gcode((0.2, 50.0) if quick else (0.2, 10.0, 30.0, 60.0, 100.0)))
    controller = run.firmware_type.controller(run.firmware, run.step_distance)
    calibration = load_calibration(out_dir / "printer_calibration.toml")  # what compensate reads
    intended: list[np.ndarray] = []

    def correct(points: np.ndarray) -> np.ndarray:
        intended.append(np.array(points))
        return corrected_targets(calibration, controller, points).commands

    filter_gcode(source, corrected, correct, DEFAULT_SEGMENT_MM, home=controller.home, limits=limits,
                 marker=marker_line(config, "printer_calibration.toml"))
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


def _admit_bed(run: PrinterRun, cfg: Path) -> FirmwareModel:
    """The configuration rewritten with the lowest Z the corrected bed needs; its values.

    The true bed is lower than the firmware's nominal model puts it where the corrected first layer
    goes below its z 0; the lowest Z commanded on the printable disk sets the key
    (:meth:`~deltacal.printer.firmware.base.Firmware.admit_bed`: Klipper's ``minimum_z_position``).
    """
    firmware = run.firmware_type
    admitted = firmware.admit_bed(run.firmware, load_calibration(cfg.parent / "printer_calibration.toml"),
                                  run.step_distance, WORKSPACE.radius)
    if admitted is not run.firmware:
        firmware.save_config(cfg, admitted, title=nominal_title(firmware), complete=True,
                             notes=[f"{firmware.minimum_z_key} admits "
                                    f"the bed corrected by deltacal over radius {WORKSPACE.radius:g} mm "
                                    "(part_corrected.gcode)"])
        _record(firmware, cfg, cfg.parent / "printer_calibration.toml")  # the configuration as it stays
    return firmware.read_config(cfg)


def _record(firmware: Firmware, cfg: Path, path: Path) -> None:
    """The calibration at ``path`` recording ``cfg`` as its controller (identify's ``[controller]``)."""
    record = FirmwareConfig.read(firmware, cfg).record()
    save_calibration(replace(load_calibration(path), controller=record), path)


def run_printer_demo(out_dir: Path = Path("results"), seed: int = SEED, quick: bool = False,
                     progress: Callable[[str], None] = _silent, firmware: Firmware = KLIPPER) -> dict:
    """Run the printer demo, write its files and ``printer_demo.json``; :func:`printer_table` prints it.

    Args:
        out_dir: Folder for the files (created if needed).
        seed: Seed of the true printer and of the measurements' noise.
        quick: A shorter part program (2 heights instead of 5), for a fast check.
        progress: Called with one line of text after each long step.
        firmware: The firmware the printer runs (default Klipper).

    Returns:
        The results written to printer_demo.json.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    printer = load_printer(MODELS_DIR / "kossel.toml")
    cfg = firmware.save_config(out_dir / firmware.config_file, firmware.nominal(printer),
                               title=nominal_title(firmware), complete=True)
    plan = plan_object(printer, firmware.read_config(cfg))
    write_stl(out_dir / "object.stl", plan.mesh())
    write_probe_heights(out_dir / "probe.csv", plan.probe)
    write_printed_distances(out_dir / "distances.csv", plan.pair_positions)
    progress(f"planned the object: {len(plan.probe)} probe points, {len(plan.pairs)} distances "
             f"(object.stl, probe.csv, distances.csv)")
    tolerances, tilt = CLASSES["typical kit"]
    run = run_printer(printer, plan, seed, tolerances, tilt, (FIRST_LAYER_WEIGHT,), firmware_type=firmware)
    write_probe_heights(out_dir / "probe_measured.csv", run.probe[:, :2], run.probe[:, 2])
    write_printed_distances(out_dir / "distances_measured.csv", plan.pair_positions, run.distances)
    # what identify records: the configuration the measurements were made through (compensate compares it)
    record = FirmwareConfig.read(firmware, cfg).record()
    measured = None if run.data is None else measured_record(run.data, PrinterFitOptions(),
                                                             run.result.tolerance_scale)
    save_calibration(replace(Calibration.from_result(run.result), controller=record, measured=measured),
                     out_dir / "printer_calibration.toml")
    own = [name for name in run.configs if name not in (UNCALIBRATED, exported_name(FIRST_LAYER_WEIGHT))]
    progress(f"true printer (seed {seed}, typical kit) measured and identified: variance factor "
             f"{run.result.variance_factor:.2f} (printer_calibration.toml); "
             f"{_calibrations_said(firmware, own)} simulated")
    run.configs[EXPORTED_ROW] = exported = run.configs.pop(exported_name(FIRST_LAYER_WEIGHT))
    firmware.save_config(out_dir / firmware.calibrated_file, exported, cfg,
                         f"{firmware.title}'s values fitted to {printer.name} by deltacal (first-layer "
                         f"weight {FIRST_LAYER_WEIGHT:g})")
    figures = evaluate(run)
    progress(f"evaluated every method on the true printer ({firmware.calibrated_file} written)")
    part = _part(run, out_dir, quick, _admit_bed(run, cfg), cfg.name)
    progress(f"corrected part.gcode for {firmware.title}'s nominal values (part_corrected.gcode)")
    rows = [{"method": name, **figures["less bed motion"][name].as_dict(),
             "raw_max_3d_mm": figures["raw"][name].max_3d, "part_max_mm": part[name]}
            for name in (UNCALIBRATED, *own, EXPORTED_ROW, GCODE)]
    summary = {"printer": printer.name, "seed": seed, "class": "typical kit", "first_layer_weight":
               FIRST_LAYER_WEIGHT, "probe_points": len(plan.probe), "distances": len(plan.pairs),
               "variance_factor": run.result.variance_factor, "rows": rows}
    atomic_write_text(out_dir / "printer_demo.json", json.dumps(summary, indent=1) + "\n")
    return summary


def _calibrations_said(firmware: Firmware, names: list[str]) -> str:
    """The firmware's own calibrations in words: "Klipper's basic and enhanced calibration"."""
    title = f"{firmware.title} "
    kinds = [name[len(title):] if name.startswith(title) else name for name in names]
    said = " and ".join(kinds) if len(kinds) <= 2 else ", ".join(kinds[:-1]) + " and " + kinds[-1]
    return f"{firmware.title}'s {said} calibration"


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
