"""Whether a correction along the bed measured over the volume should be weighted by its significance.

Seeded linear Kossels of each class (:data:`deltacal.printer.comparison.CLASSES`; seeds 48700 + k
kits, 48800 + k well built: used by no other figure), measured with deltacal's planned object (its 49
probe heights σ 0.01 mm and 40 distances σ 0.02 mm over levels up to 100 mm: a calibration measured over
the volume), plain and with what the model does not have (``scripts/where_it_holds.py``'s effects: a
probe trigger varying across the bed, a bed with a 0.03 mm bowl, an object printed 0.08 % small),
identified from Klipper's nominal values and corrected through them (``compensate``'s weights where the
calibration holds), the correction along the bed weighted by its significance as a calibration at one
height is (``weighted``) or not (``whole``, what ``deltacal.holds.WhereItHolds.weights`` does for this
calibration). Judged on the TRUE printer: the 3-D max at z 0.2 / 10 / 25 / 50 / 100 mm over r <= 80 mm
(less the bed motion nothing measures) and the local error (the largest change of the true 3-D error
between lattice targets 10 mm apart in a layer). About 3 s a printer. Prints a line per printer and the
counts docs/printers.md quotes ("compensate and export act only where it holds").
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import where_it_holds as W  # noqa: E402 (the effects and the judged layers: scripts/where_it_holds.py)

from deltacal.calibration import Calibration  # noqa: E402
from deltacal.controller import corrected_targets  # noqa: E402
from deltacal.geometry import Tolerances  # noqa: E402
from deltacal.holds import DEFAULT_BOUND  # noqa: E402
from deltacal.printer.comparison import CLASSES, DISTANCE_SIGMA, PROBE_SIGMA, plan_measurements  # noqa: E402
from deltacal.printer.files.robot_file import load_printer  # noqa: E402
from deltacal.printer.firmware.klipper.firmware import KLIPPER  # noqa: E402
from deltacal.printer.firmware.klipper.model import KlipperDelta  # noqa: E402
from deltacal.printer.identification.fit import identify_printer  # noqa: E402
from deltacal.printer.printed.plan import plan_object  # noqa: E402
from deltacal.printer.robot import less_bed_motion  # noqa: E402
from deltacal.printer.simulation import (  # noqa: E402
    nozzle_positions,
    printed_distances,
    probe_heights,
    random_true_printer,
)

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
#: The judged layers [mm] and radius [mm] (within the planned object's reach).
HEIGHTS = (0.2, 10.0, 25.0, 50.0, 100.0)
RADIUS = 80.0
#: The first seed of each class.
SEEDS = {"typical kit": 48700, "well built": 48800}
EFFECTS = ("plain", "probe bias", "bed bowl", "object small")


def calibrated(seed: int, label: str, effect: str):
    """A seeded printer measured with the planned object (with ``effect``), identified.

    Returns the truth, the calibration, the controller (Klipper's nominal values), its values and the
    step distance.
    """
    printer = load_printer(KOSSEL)
    firmware = KlipperDelta.from_printer(printer)
    plan = plan_object(printer, firmware, caliper=150.0)
    step = printer.step_distance
    tolerances, tilt = CLASSES[label]
    rng = np.random.default_rng(seed)
    truth = random_true_printer(printer, rng, tolerances, tilt).geometry
    xy = plan.probe[:, :2]
    trigger = W.probe_bias(xy) if effect == "probe bias" else W.bowl(xy) if effect == "bed bowl" else None
    probe = probe_heights(truth, firmware, step, xy, PROBE_SIGMA, rng, trigger_height=trigger)
    distances = printed_distances(truth, firmware, step, plan.pair_positions, DISTANCE_SIGMA, rng)
    if effect == "object small":
        distances = distances * (1.0 - W.OBJECT_SHRINK)
    data = plan_measurements(firmware, step, plan, probe, distances)
    result = identify_printer(printer.geometry(), data, "printer", method="iterated",
                              tolerances=Tolerances.printer_kit())
    return truth, Calibration.from_result(result), KLIPPER.controller(firmware, step), firmware, step


def judged(seed: int, label: str, effect: str) -> dict[str, dict[str, float]]:
    """Per weighting: the 3-D max and the local error, each the largest over the layers [mm]."""
    truth, calibration, controller, firmware, step = calibrated(seed, label, effect)
    holds = calibration.holds
    assert holds is not None and not holds.bed_level  # measured over the volume
    out = {}
    for name, measured_top in (("whole", holds.measured_top), ("weighted", 0.0)):
        cal = replace(calibration, holds=replace(holds, measured_top=measured_top))
        largest, local = 0.0, 0.0
        for z in HEIGHTS:
            targets = W.disc(RADIUS, z)
            commands = corrected_targets(cal, controller, targets, bound=DEFAULT_BOUND).commands
            errors = nozzle_positions(truth, firmware, step, commands) - targets
            largest = max(largest, float(np.linalg.norm(less_bed_motion(targets, errors)[0], axis=1).max()))
            lattice, pairs = W.lattice(RADIUS, z)
            sent = corrected_targets(cal, controller, lattice, bound=DEFAULT_BOUND).commands
            local = max(local, W.local_error(truth, firmware, step, lattice, sent, pairs))
        out[name] = {"max_3d_mm": largest, "local_mm": local}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--printers", type=int, default=3, help="printers of each class and effect")
    args = parser.parse_args(argv)
    rows = []
    for label, first in SEEDS.items():
        for effect in EFFECTS:
            for k in range(args.printers):
                found = judged(first + k, label, effect)
                rows.append((effect, found))
                w, h = found["weighted"], found["whole"]
                print(f"{label:12s} {effect:13s} {first + k}: 3-D max weighted {w['max_3d_mm']:.4f} whole "
                      f"{h['max_3d_mm']:.4f}; local error weighted {w['local_mm']:.4f} whole "
                      f"{h['local_mm']:.4f}", flush=True)
    larger = [r["weighted"]["max_3d_mm"] - r["whole"]["max_3d_mm"] for _, r in rows]
    local = [r["weighted"]["local_mm"] - r["whole"]["local_mm"] for _, r in rows]
    weighted = [r["weighted"]["local_mm"] for _, r in rows]
    whole = [r["whole"]["local_mm"] for _, r in rows]
    print(f"{len(rows)} printers: weighted 3-D max larger on {sum(d > 0 for d in larger)} (by up to "
          f"{max(larger):.4f} mm), smaller on {sum(d < 0 for d in larger)} (by up to {-min(larger):.4f} mm); "
          f"local error larger on {sum(d > 0 for d in local)} (weighted {min(weighted):.3f}-"
          f"{max(weighted):.3f}, whole {min(whole):.3f}-{max(whole):.3f} mm)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
