"""Issue 24's "Done when": deltacal's whole path against Klipper's own calibration on fresh printers.

For seeded printers of each tolerance class (:data:`deltacal.printer.comparison.CLASSES`; seeds
24000 + k and 24100 + k, used by no test and not by ``klipper_anchor.py``), measured the same
way for both sides (probe triggers σ 10 µm, caliper distances σ 20 µm): Klipper's basic (7
probes) and enhanced (7 probes and its object's 12 distances) calibration; deltacal with the
planned object (49 probe heights, 40 distances): the G-code route (exact compensation through
Klipper's nominal configuration) and the exported firmware values alone (Klipper's values fitted
to the identified printer, for each first-layer weight swept). Every method is judged on the TRUE
printer (:func:`deltacal.printer.comparison.evaluate`): 3-D max and RMS over the printable volume
(radius 92 mm, z 0.2 to 100 mm), first-layer flatness (max |z| and peak to valley), raw and less
the bed motion nothing measures (the headline: a shift along the bed and a turn about its normal
move the printed part on the bed, not its shape, and no probe and no caliper sees them, for
Klipper or deltacal). Prints a table and whether each criterion holds; writes
``results/printer_compare.json``. Fixed seeds, about 3 s a printer; ``--printers N
--first-seed S`` runs others (kits: S + 100 + k), ``--caliper`` plans for another caliper and
``--sigma-distance`` gives both sides another caliper's σ.

``--firmware klipper|marlin|rrf|all`` runs the same printers through that firmware's nominal values
instead (seeds 25000 + k and 25100 + k: fresh, used by no test), beside its own calibration emulated
(Klipper's basic and enhanced, Marlin's ``G33``, RepRapFirmware's ``G32`` S6 and S8), with the
firmware's best possible values (fitted to the TRUE printer) and the firmwares' criteria: the G-code
route's 3-D max (mean) <= 0.05 mm and <= a tenth of the uncalibrated one's, every command of it
inside the firmware's limits, the exported values' 3-D max <= 1.25 times the best possible + 0.01
mm; writes ``results/printer_compare_firmwares.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from deltacal.io.atomic import atomic_write_text
from deltacal.printer.comparison import (
    BASIC,
    CLASSES,
    DISTANCE_SIGMA,
    ENHANCED,
    GCODE,
    PROBE_RADIUS,
    PROBE_SIGMA,
    UNCALIBRATED,
    WORKSPACE,
    best_name,
    evaluate,
    exported_name,
    gcode_refused,
    run_printer,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import firmwares
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.printed.object import CALIPER_RANGE
from deltacal.printer.printed.plan import plan_object

REPO_ROOT = Path(__file__).resolve().parents[1]
#: First-layer weights of the exported values swept.
WEIGHTS = (0.0, 3.0, 10.0, 30.0, 100.0)
#: The first seed of each class.
SEEDS = {"well built": 24000, "typical kit": 24100}
#: The first seed of each class with ``--firmware``.
FIRMWARE_SEEDS = {"well built": 25000, "typical kit": 25100}
#: The firmwares' criteria: G-code route's 3-D max [mm] and share of the uncalibrated; exported values
#: against the best possible: ratio and margin [mm].
GCODE_MAX_MM, GCODE_SHARE, BEST_RATIO, BEST_MARGIN_MM = 0.05, 0.1, 1.25, 0.01
HEADLINE = "less bed motion"
FIGURES = ("max_3d_mm", "rms_3d_mm", "flatness_mm", "flatness_pv_mm")


def summarise(runs: list[dict[str, dict[str, dict[str, float]]]]) -> dict:
    """Mean and worst over printers of each figure, per view (raw, less bed motion) and method."""
    out: dict = {}
    for view in runs[0]:
        out[view] = {}
        for method in runs[0][view]:
            values = {k: [r[view][method][k] for r in runs] for k in FIGURES}
            out[view][method] = {"mean": {k: float(np.mean(v)) for k, v in values.items()},
                                 "worst": {k: float(np.max(v)) for k, v in values.items()}}
    return out


def criteria(summary: dict, weight: float) -> dict[str, dict[str, float | bool]]:
    """Issue 24's criteria on the class's means (headline view): each ratio, and whether it holds."""
    head = summary[HEADLINE]
    enhanced, basic = head[ENHANCED]["mean"], head[BASIC]["mean"]
    gcode, exported = head[GCODE]["mean"], head[exported_name(weight)]["mean"]
    best_flat = min(enhanced["flatness_mm"], basic["flatness_mm"])
    checks = {
        "G-code route 3-D max <= 1/3 Klipper enhanced": (gcode["max_3d_mm"] / enhanced["max_3d_mm"], 1 / 3),
        "G-code route flatness <= Klipper enhanced": (gcode["flatness_mm"] / enhanced["flatness_mm"], 1.0),
        "G-code route flatness <= Klipper's best (basic, enhanced)": (gcode["flatness_mm"] / best_flat, 1.0),
        f"exported values (w {weight:g}) 3-D max <= Klipper enhanced":
            (exported["max_3d_mm"] / enhanced["max_3d_mm"], 1.0),
        f"exported values (w {weight:g}) flatness <= Klipper enhanced":
            (exported["flatness_mm"] / enhanced["flatness_mm"], 1.0),
    }
    return {name: {"ratio": float(r), "limit": float(limit), "holds": bool(r <= limit)}
            for name, (r, limit) in checks.items()}


def firmware_criteria(summary: dict, weight: float, refused: int) -> dict[str, dict[str, float | bool]]:
    """The firmwares' criteria on a class's means (headline view): each value, its limit, whether it holds."""
    head = summary[HEADLINE]
    gcode, raw = head[GCODE]["mean"]["max_3d_mm"], head[UNCALIBRATED]["mean"]["max_3d_mm"]
    exported = head[exported_name(weight)]["mean"]["max_3d_mm"]
    best = head[best_name(weight)]["mean"]["max_3d_mm"]
    checks = {
        f"G-code route 3-D max <= {GCODE_MAX_MM} mm": (gcode, GCODE_MAX_MM),
        f"G-code route 3-D max <= {GCODE_SHARE:g} of uncalibrated": (gcode, GCODE_SHARE * raw),
        "G-code route commands outside the firmware's limits": (float(refused), 0.0),
        f"exported values 3-D max <= {BEST_RATIO:g} x best possible + {BEST_MARGIN_MM} mm":
            (exported, BEST_RATIO * best + BEST_MARGIN_MM),
    }
    return {name: {"value": float(v), "limit": float(limit), "holds": bool(v <= limit)}
            for name, (v, limit) in checks.items()}


def compare_firmwares(names: list[str], printers: int, weight: float, plan_caliper: float) -> dict:
    """Each firmware on the same fresh printers (:data:`FIRMWARE_SEEDS`); prints and returns the results."""
    printer = load_printer(REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    out: dict = {"workspace": {"radius_mm": WORKSPACE.radius, "z_mm": [0.2, WORKSPACE.top_z]},
                 "probe_radius_mm": PROBE_RADIUS,
                 "sigma_mm": {"probe": PROBE_SIGMA, "distance": DISTANCE_SIGMA},
                 "headline": HEADLINE, "weight": weight, "firmwares": {}}
    for firmware in [f for f in firmwares() if f.name in names]:
        plan = plan_object(printer, firmware.nominal(printer), caliper=plan_caliper)
        classes: dict = {}
        for label, (tolerances, tilt) in CLASSES.items():
            seeds = [FIRMWARE_SEEDS[label] + k for k in range(printers)]
            runs, refused = [], 0
            for seed in seeds:
                run = run_printer(printer, plan, seed, tolerances, tilt, (weight,), firmware_type=firmware,
                                  best=True)
                refused += gcode_refused(run)
                runs.append({view: {m: s.as_dict() for m, s in methods.items()}
                             for view, methods in evaluate(run).items()})
            summary = summarise(runs)
            checks = firmware_criteria(summary, weight, refused)
            classes[label] = {"seeds": seeds, "summary": summary, "criteria": checks, "printers": runs,
                              "gcode_commands_refused": refused}
            print_class(f"{firmware.title}, {label}", summary)
            for name, c in checks.items():
                verdict = "HOLDS" if c["holds"] else "FAILS"
                print(f"  {verdict}  {name}: {c['value']:.4f} (limit {c['limit']:.4f})")
        out["firmwares"][firmware.name] = classes
    return out


def print_class(label: str, summary: dict) -> None:
    """The class's table: mean (worst) of each figure per method, both views."""
    for view in (HEADLINE, "raw"):
        print(f"\n{label}, {view}: mean (worst) over printers [mm]")
        print(f"  {'method':36s} {'3-D max':>15s} {'3-D RMS':>15s} {'flatness':>15s} {'flat. p-v':>15s}")
        for method, s in summary[view].items():
            cells = " ".join(f"{s['mean'][k]:7.3f} ({s['worst'][k]:.3f})" for k in FIGURES)
            print(f"  {method:36s} {cells}")


def main(argv: list[str] | None = None) -> int:
    """Run the comparison, print the tables and the criteria, write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(REPO_ROOT / "results" / "printer_compare.json"))
    parser.add_argument("--printers", type=int, default=10, help="printers per class (default 10)")
    parser.add_argument("--first-seed", type=int, default=None,
                        help="seed of the first well-built printer (kits: 100 more; default 24000: the "
                             "comparison's printers)")
    parser.add_argument("--sigma-distance", type=float, default=DISTANCE_SIGMA,
                        help=f"σ of every distance [mm] (default {DISTANCE_SIGMA}, a caliper's; 0.01: a "
                             "micrometer's)")
    parser.add_argument("--caliper", type=float, default=CALIPER_RANGE,
                        help=f"the caliper's longest reading the object is planned for [mm] (default "
                             f"{CALIPER_RANGE:g})")
    parser.add_argument("--weight", type=float, default=30.0,
                        help="the first-layer weight whose exported values the criteria judge (default 30)")
    parser.add_argument("--firmware", choices=[*(f.name for f in firmwares()), "all"],
                        help="the firmwares' comparison (see above) for this firmware or all three")
    args = parser.parse_args(argv)
    if args.firmware is not None:
        start = time.perf_counter()
        names = [f.name for f in firmwares()] if args.firmware == "all" else [args.firmware]
        out = compare_firmwares(names, args.printers, args.weight, args.caliper)
        output = (REPO_ROOT / "results" / "printer_compare_firmwares.json"
                  if args.output == parser.get_default("output") else Path(args.output))
        atomic_write_text(output, json.dumps(out, indent=1) + "\n")
        print(f"\n{time.perf_counter() - start:.0f} s; wrote {output}")
        return 0
    weights = tuple(sorted(set(WEIGHTS) | {args.weight}))
    start = time.perf_counter()
    printer = load_printer(REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    plan = plan_object(printer, KlipperDelta.from_printer(printer), caliper=args.caliper)
    out: dict = {"workspace": {"radius_mm": WORKSPACE.radius, "z_mm": [0.2, WORKSPACE.top_z]},
                 "klipper": {"probes": 7, "probe_radius_mm": PROBE_RADIUS, "distances": 12},
                 "deltacal": {"probes": len(plan.probe), "distances": len(plan.pairs),
                              "caliper_mm": args.caliper,
                              "feature_levels_mm": sorted(set(plan.features[:, 2].tolist()))},
                 "sigma_mm": {"probe": PROBE_SIGMA, "distance": args.sigma_distance},
                 "headline": HEADLINE, "weights": list(weights), "criteria_weight": args.weight,
                 "classes": {}}
    verdicts = []
    for label, (tolerances, tilt) in CLASSES.items():
        first = SEEDS[label] + (0 if args.first_seed is None else args.first_seed - SEEDS["well built"])
        seeds = [first + k for k in range(args.printers)]
        runs = []
        for seed in seeds:
            run = run_printer(printer, plan, seed, tolerances, tilt, weights, args.sigma_distance)
            figures = evaluate(run)
            runs.append({view: {m: s.as_dict() for m, s in methods.items()}
                         for view, methods in figures.items()})
        summary = summarise(runs)
        checks = criteria(summary, args.weight)
        out["classes"][label] = {"seeds": seeds, "bed_tilt_deg": tilt, "summary": summary, "criteria": checks,
                                 "printers": runs}
        print_class(label, summary)
        for name, c in checks.items():
            verdicts.append(c["holds"])
            verdict = "HOLDS" if c["holds"] else "FAILS"
            print(f"  {verdict}  {name}: ratio {c['ratio']:.2f} (limit {c['limit']:.2f})")
    for label in CLASSES:
        order = [exported_name(w) for w in weights]
        print(f"\n{label}: exported values by first-layer weight, mean 3-D max / flatness, {HEADLINE} [mm]")
        head = out["classes"][label]["summary"][HEADLINE]
        for name in [UNCALIBRATED, BASIC, ENHANCED, *order, GCODE]:
            mean = head[name]["mean"]
            print(f"  {name:36s} {mean['max_3d_mm']:.3f} / {mean['flatness_mm']:.3f}")
    atomic_write_text(args.output, json.dumps(out, indent=1) + "\n")
    print(f"\n{'every criterion holds' if all(verdicts) else 'a criterion FAILS'}; "
          f"{time.perf_counter() - start:.0f} s; wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
