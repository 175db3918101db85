"""Marlin through the whole path on simulated printers: plan, simulate, identify, compensate, export.

For each seed (none used by a test): the printer's M503 settings (the nominal printer's values),
``plan --object``, ``simulate --perturb SEED``, ``identify``, then ``compensate`` of a target grid
with ``--controller SETTINGS --firmware marlin`` and ``export --controller marlin``. Measured on the
true printer: the nozzle error of the corrected targets, of the targets sent as they are, and of the
exported values beside the best M665/M666/M92 values (fitted to the truth: the least largest error
with the first layer as flat as the exported values leave it). Writes results/marlin_figures.txt.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from deltacal.io import load_geometry  # noqa: E402
from deltacal.kinematics import exact  # noqa: E402
from deltacal.printer.files.robot_file import load_printer  # noqa: E402
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT, error_stats  # noqa: E402
from deltacal.printer.firmware.klipper.fit import printable_grid  # noqa: E402
from deltacal.printer.firmware.marlin.firmware import MARLIN  # noqa: E402
from deltacal.printer.firmware.marlin.settings import load_marlin  # noqa: E402
from deltacal.printer.robot import less_bed_motion  # noqa: E402


def deltacal(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "deltacal.cli", *args], check=True, capture_output=True, cwd=ROOT)


def one(seed: int, folder: Path) -> str:
    robot = ROOT / "deltacal" / "models" / "kossel.toml"
    printer = load_printer(robot)
    settings = MARLIN.save_config(folder / "m503.gcode", MARLIN.nominal(printer), complete=True)
    deltacal("plan", str(robot), "--object", "--controller", str(settings), "--firmware", "marlin",
             "-o", str(folder / "plan"))
    plan = folder / "plan"
    deltacal("simulate", str(robot), str(plan / "probe.csv"), str(plan / "distances.csv"),
             "--controller", str(settings), "--perturb", str(seed), "-o", str(folder / "probe.csv"),
             "--distances-output", str(folder / "distances.csv"))
    deltacal("identify", str(robot), str(folder / "probe.csv"), str(folder / "distances.csv"),
             "--controller", str(settings), "--firmware", "marlin", "-o", str(folder / "cal.toml"))
    grid = printable_grid(printer.workspace)
    np.savetxt(folder / "targets.csv", grid, delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    deltacal("compensate", str(folder / "cal.toml"), str(folder / "targets.csv"), "--controller",
             str(settings), "--firmware", "marlin", "-o", str(folder / "commands.csv"))
    deltacal("export", str(folder / "cal.toml"), "--controller", "marlin", "--config", str(settings),
             "--robot", str(robot), "-o", str(folder / "calibrated.gcode"))
    truth = load_geometry(folder / "probe.truth.toml")
    step = printer.step_distance
    nominal = load_marlin(settings)
    commands = np.loadtxt(folder / "commands.csv", delimiter=",", skiprows=1)[:, 3:6]

    def error(values, targets, sent):  # of the printed part: less the in-plane motion no probe sees
        landed = exact.forward(truth, values.inverse(sent, step)).point(truth.tool)
        return float(np.linalg.norm(less_bed_motion(targets, landed - targets)[0], axis=1).max())


    corrected, raw = error(nominal, grid, commands), error(nominal, grid, grid)
    exported_values = load_marlin(folder / "calibrated.gcode")
    exported = error(exported_values, grid, grid)
    flatness = error_stats(truth, exported_values, step, printer.workspace).flatness
    best = MARLIN.fit(truth, nominal, step, printer.workspace, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT,
                      minimax=True, flatness=flatness)
    return (f"seed {seed}: uncalibrated 3-D max {raw:.3f} mm; corrected targets {corrected:.4f} mm "
            f"({corrected / raw:.3f} of it); exported values {exported:.3f} mm, best possible "
            f"{best.after.max_3d:.3f} mm (ratio {exported / best.after.max_3d:.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[901, 902, 903, 904, 905])
    args = parser.parse_args()
    lines = []
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            lines.append(one(seed, Path(tmp)))
            print(lines[-1], flush=True)
    (ROOT / "results").mkdir(exist_ok=True)
    (ROOT / "results" / "marlin_figures.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
