"""Figures of RepRapFirmware's route on fresh simulated printers (docs/printers.md, "RepRapFirmware").

For each seed: a typical kit printer running RRF's nominal values is probed and prints deltacal's
object (simulated through RRF's model), is identified, then judged over the printable volume:
uncalibrated, corrected targets through RRF's model, the exported M665/M666/M92 values (as
``export`` fits them) and the best such values (fitted to the true printer: the least largest error
with the first layer as flat as the exported values leave it), each as the printed part's error
(less the shift along the bed and turn about its normal, which no measurement sees). Run:
``python scripts/rrf_figures.py``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from deltacal.controller import corrected_targets
from deltacal.geometry import Tolerances
from deltacal.printer.comparison import PROBE_SIGMA, WORKSPACE, plan_measurements
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from deltacal.printer.firmware.klipper.fit import printable_grid
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.firmware.rrf.fit import error_stats
from deltacal.printer.identification.fit import identify_printer
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.simulation import (
    nozzle_positions,
    printed_distances,
    probe_heights,
    random_true_printer,
    typical_kit,
)

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


def part_error(grid: np.ndarray, errors: np.ndarray) -> float:
    """3-D max of the printed part's errors: less the shift along the bed and turn about its normal [mm]."""
    return float(np.linalg.norm(less_bed_motion(grid, errors)[0], axis=1).max())


def run(seed: int, printer, plan) -> dict[str, float]:
    rrf = RRF_FIRMWARE.nominal(printer)
    step = printer.step_distance
    rng = np.random.default_rng(seed)
    truth = random_true_printer(printer, rng, typical_kit()).geometry
    probe = probe_heights(truth, rrf, step, plan.probe[:, :2], PROBE_SIGMA, rng)
    distances = printed_distances(truth, rrf, step, plan.pair_positions, 0.02, rng)
    data = plan_measurements(rrf, step, plan, probe, distances)
    result = identify_printer(
        printer.geometry(), data, "printer", method="iterated", tolerances=Tolerances.printer_kit()
    )
    grid = printable_grid(WORKSPACE)
    before = part_error(grid, nozzle_positions(truth, rrf, step, grid) - grid)
    commands = corrected_targets(result.geometry, RRF_FIRMWARE.controller(rrf, step), grid).commands
    after = part_error(grid, nozzle_positions(truth, rrf, step, commands) - grid)
    exported = RRF_FIRMWARE.fit(
        result.geometry, rrf, step, WORKSPACE, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, minimax=True
    )
    flatness = error_stats(truth, exported.values, step, WORKSPACE).flatness
    best = RRF_FIRMWARE.fit(truth, rrf, step, WORKSPACE, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT,
                            minimax=True, flatness=flatness)
    return {
        "uncalibrated": float(before),
        "corrected": float(after),
        "exported": error_stats(truth, exported.values, step, WORKSPACE).max_3d,
        "best": error_stats(truth, best.values, step, WORKSPACE).max_3d,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, nargs="+", default=[9101, 9102, 9103, 9104, 9105, 9106])
    args = parser.parse_args()
    printer = load_printer(MODELS / "kossel.toml")
    plan = plan_object(printer, RRF_FIRMWARE.nominal(printer))
    print("seed  uncalibrated  corrected  exported  best  (3-D max, mm)")
    for seed in args.seeds:
        f = run(seed, printer, plan)
        print(f"{seed}  {f['uncalibrated']:.3f}  {f['corrected']:.4f}  {f['exported']:.4f}  {f['best']:.4f}")


if __name__ == "__main__":
    main()
