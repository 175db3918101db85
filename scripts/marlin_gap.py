"""Why Marlin's corrected targets measured 0.054 mm (``marlin_figures.py``), Klipper's 0.028 mm.

The same printers both ways: seeds 901-905 made as ``simulate --perturb`` makes them
(Tolerances.printer_kit(), ``simulate``'s default) and as the comparison makes them (typical kit),
each run through Klipper's and Marlin's nominal values (``run_printer``: 49 probe heights, 40
distances, 200 mm caliper, σ 10 / 20 µm), the G-code route judged less the bed motion over the
comparison's volume (r 92 mm, z 0.2-100 mm) and over the robot file's (r 115 mm, z 0.2-200 mm, what
``marlin_figures.py`` judges). Prints a table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from deltacal.geometry import Tolerances, Workspace
from deltacal.printer.comparison import WORKSPACE, gcode_route_errors, run_printer
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import firmwares
from deltacal.printer.firmware.klipper.fit import printable_grid
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.simulation import KIT_BED_TILT_DEG, typical_kit

ROOT = Path(__file__).resolve().parents[1]
SEEDS = (901, 902, 903, 904, 905)


def main() -> None:
    printer = load_printer(ROOT / "deltacal" / "models" / "kossel.toml")
    large = Workspace(printer.workspace.radius, printer.workspace.height, printer.workspace.height)
    volumes = {"r 92, z 0.2-100": printable_grid(WORKSPACE), "r 115, z 0.2-200": printable_grid(large)}
    kinds = [f for f in firmwares() if f.name in ("klipper", "marlin")]
    print("G-code route 3-D max, less bed motion, mean (max) over seeds 901-905 [mm]")
    for label, tolerances in (("printer-kit", Tolerances.printer_kit()), ("typical kit", typical_kit())):
        for firmware in kinds:
            plan = plan_object(printer, firmware.nominal(printer))
            figures = {name: [] for name in volumes}
            for seed in SEEDS:
                run = run_printer(printer, plan, seed, tolerances, KIT_BED_TILT_DEG, firmware_type=firmware)
                for name, grid in volumes.items():
                    errors = less_bed_motion(grid, gcode_route_errors(run, grid))[0]
                    figures[name].append(float(np.linalg.norm(errors, axis=1).max()))
            cells = "  ".join(f"{name}: {np.mean(v):.4f} ({np.max(v):.4f})" for name, v in figures.items())
            print(f"  {label:12s} {firmware.title:8s} {cells}")


if __name__ == "__main__":
    main()
