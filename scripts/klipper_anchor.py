"""Issue 24's anchor: Klipper's own delta calibration on simulated Kossel-size printers.

For 5 seeded printers of each tolerance class (:func:`deltacal.printer.simulation.well_built`,
:func:`~deltacal.printer.simulation.typical_kit`): Klipper's nominal values (uncalibrated), its basic
calibration (7 probe points in its pattern, radius 115 mm, σ 10 µm), its enhanced calibration (the
same probes and its object's 12 caliper distances, σ 20 µm), and the best any firmware values can do
(:func:`deltacal.printer.firmware.klipper.fit.fit_klipper` on the TRUE printer, step distances free and
held) and what those leave of each error source alone
(:func:`~deltacal.printer.firmware.budget.error_budget`). Error over the printable volume (radius
92 mm, heights 0.2 to 100 mm): 3-D max and RMS; first-layer flatness: the largest |z error| at
z = 0.2 mm over the disc (and its peak to valley). Writes ``results/klipper_anchor.json``. Fixed
seeds.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from deltacal.io.atomic import atomic_write_text
from deltacal.printer.comparison import (
    BASIC,
    CLASSES,
    DISTANCE_SIGMA,
    ENHANCED,
    PROBE_RADIUS,
    PROBE_SIGMA,
    UNCALIBRATED,
    WORKSPACE,
    firmware_calibrations,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.budget import error_budget
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.fit import error_stats, fit_klipper
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.simulation import random_true_printer

REPO_ROOT = Path(__file__).resolve().parents[1]
#: The anchor's figures (issue 24): 3-D max / first-layer flatness [mm].
ISSUE = {
    "well built": {"uncalibrated": (1.22, 1.16), "basic": (0.21, 0.023), "enhanced": (0.23, 0.021)},
    "typical kit": {"uncalibrated": (1.62, 1.44), "basic": (0.70, 0.055), "enhanced": (0.73, 0.043)},
}
#: fit_klipper's weight of the first layer's z errors in the weighted variant.
FIRST_LAYER_WEIGHT = 10.0


def one_printer(seed: int, tolerances, tilt: float) -> dict[str, dict[str, float]]:
    """The figures of each method on one seeded printer [mm]."""
    nominal = load_printer(REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    firmware = KlipperDelta.from_printer(nominal)
    step = nominal.step_distance
    rng = np.random.default_rng(seed)
    made = random_true_printer(nominal, rng, tolerances, tilt)
    truth = made.geometry
    klipper = firmware_calibrations(truth, firmware, step, rng)
    absolute = {"part_frame": False}  # the errors judged raw, as the issue's anchor
    configs = {
        "uncalibrated": klipper[UNCALIBRATED],
        "basic": klipper[BASIC],
        "enhanced": klipper[ENHANCED],
        "best firmware values": fit_klipper(truth, firmware, step, WORKSPACE, **absolute).values,
        "best firmware values, step distances held": fit_klipper(truth, firmware, step, WORKSPACE,
                                                                 hold_step_distance=True, **absolute).values,
        "best firmware values, first layer weighted 10": fit_klipper(
            truth, firmware, step, WORKSPACE, first_layer_weight=FIRST_LAYER_WEIGHT, **absolute).values,
    }
    out = {name: error_stats(truth, config, step, WORKSPACE).as_dict() for name, config in configs.items()}
    budget = error_budget(KLIPPER, nominal.geometry(), made.errors, made.bed_rotation, made.bed_translation,
                          firmware, step, WORKSPACE)
    out.update({f"best firmware values, {label} alone": stats.as_dict() for label, stats in budget.items()})
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the anchor and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(REPO_ROOT / "results" / "klipper_anchor.json"))
    parser.add_argument("--printers", type=int, default=5)
    args = parser.parse_args(argv)
    out: dict[str, object] = {"workspace": {"radius_mm": WORKSPACE.radius, "z_mm": [0.2, WORKSPACE.top_z]},
                              "probe": {"points": 7, "radius_mm": PROBE_RADIUS, "sigma_mm": PROBE_SIGMA},
                              "distances": {"count": 12, "sigma_mm": DISTANCE_SIGMA}, "classes": {}}
    for label, (tolerances, tilt) in CLASSES.items():
        runs = [one_printer(1000 * (1 + list(CLASSES).index(label)) + seed, tolerances, tilt)
                for seed in range(args.printers)]
        methods = runs[0].keys()
        mean = {m: {k: float(np.mean([r[m][k] for r in runs])) for k in runs[0][m]} for m in methods}
        out["classes"][label] = {"tolerances": {k: float(getattr(tolerances, k))
                                                for k in tolerances.__dataclass_fields__},
                                 "bed_tilt_deg": tilt, "mean": mean, "printers": runs,
                                 "issue": ISSUE[label]}
        for m in methods:
            issue = ISSUE[label].get(m)
            ref = f"   issue {issue[0]:.2f} / {issue[1]:.3f}" if issue else ""
            print(f"{label:12s} {m:54s} {mean[m]['max_3d_mm']:.3f} / {mean[m]['flatness_mm']:.3f} "
                  f"(p-v {mean[m]['flatness_pv_mm']:.3f}) mm{ref}")
    atomic_write_text(args.output, json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
