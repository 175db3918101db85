"""The live module's cost in Klipper (issue 41): Klipper's batch run of one program, three ways.

The pinned Klipper (``KLIPPER_DIR``, copied to a temporary folder: it builds its C helper in place)
runs a printing-like program in batch mode (``klippy.py printer.cfg -i program.gcode -o out.serial``)
on a Kossel-sized printer: without any move transform (the baseline), with a loaded ``bed_mesh``
(a 7 x 7 bicubic profile of a 0.1 mm bowl, loaded by ``BED_MESH_PROFILE LOAD``), and with the live
module (``[include deltacal_geometry.cfg]``, exported for a typical kit printer identified from the
planned object's simulated measurements: its calibration knows where it holds, so the module
weights each point's correction as the offline route does). The figure is the
CPU time of the klippy process (user + system: the machine's other load counts less than in wall
time), the median of ``repeat`` runs each, the three interleaved; the ratio module / bed_mesh is the
issue's (at most 1.25). ``python scripts/bench_klipper_live.py`` prints them; ``scripts/bench.py``
adds them to its table.
"""

from __future__ import annotations

import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
#: The program's layers and the sizes of its part [mm].
LAYERS, RADIUS, SQUARE, INFILL = 40, 40.0, 60.0, 4.0
#: What a printer.cfg of the bench holds besides the delta's values (pins of example-delta.cfg).
REST = """[extruder]
step_pin: PA4
dir_pin: PA6
enable_pin: !PA2
microsteps: 16
rotation_distance: 33.5
nozzle_diameter: 0.4
filament_diameter: 1.75
heater_pin: PB4
sensor_type: ATC Semitec 104GT-2
sensor_pin: PK5
control: pid
pid_Kp: 22.2
pid_Ki: 1.08
pid_Kd: 114
min_temp: 0
max_temp: 250
min_extrude_temp: 0

[mcu]
serial: /dev/ttyACM0

[force_move]
enable_force_move: True

[printer]
kinematics: delta
max_velocity: 300
max_accel: 3000
max_z_velocity: 150
"""


def program() -> str:
    """A printing-like program: per layer a circle in 1 mm moves, a square, infill lines, travels."""
    lines = ["SET_KINEMATIC_POSITION X=0 Y=0 Z=150", "G90", "M83", "G1 X0 Y0 Z5 F6000"]
    for layer in range(LAYERS):
        z = 0.2 + 0.2 * layer
        lines += [f";LAYER:{layer}", f"G1 Z{z:.2f} F3000", f"G1 X{RADIUS:.3f} Y0 F9000", ";TYPE:WALL-OUTER"]
        n = int(2.0 * math.pi * RADIUS)
        for k in range(1, n + 1):
            a = 2.0 * math.pi * k / n
            lines.append(f"G1 X{RADIUS * math.cos(a):.3f} Y{RADIUS * math.sin(a):.3f} E0.033 F1800")
        h = SQUARE / 2.0
        lines += [f"G1 X{-h} Y{-h} F9000", f"G1 X{h} Y{-h} E2.0 F1800", f"G1 X{h} Y{h} E2.0",
                  f"G1 X{-h} Y{h} E2.0", f"G1 X{-h} Y{-h} E2.0", ";TYPE:FILL"]
        for k in range(int(SQUARE / INFILL) + 1):
            y = -h + INFILL * k
            start, end = (-h, h) if k % 2 == 0 else (h, -h)
            lines += [f"G1 X{start} Y{y} F9000", f"G1 X{end} Y{y} E2.0 F2400"]
    return "\n".join(lines) + "\n"


def printer_cfg(firmware, extra: str = "") -> str:
    """A whole printer.cfg of Klipper's delta with these values (16 microsteps), and more."""
    pins = [("PF0", "PF1", "!PD7", "^PE4"), ("PF6", "PF7", "!PF2", "^PJ0"), ("PL3", "PL1", "!PK0", "^PD2")]
    text = ""
    for k, tower in enumerate("abc"):
        step, direction, enable, endstop = pins[k]
        text += (f"[stepper_{tower}]\nstep_pin: {step}\ndir_pin: {direction}\nenable_pin: {enable}\n"
                 f"microsteps: 16\nrotation_distance: {float(firmware.step_distance[k]) * 3200!r}\n"
                 f"endstop_pin: {endstop}\nposition_endstop: {float(firmware.position_endstop[k])!r}\n"
                 f"arm_length: {float(firmware.arm_length[k])!r}\n"
                 f"angle: {math.degrees(firmware.angle[k])!r}\n\n")
    return text + REST + f"delta_radius: {float(firmware.delta_radius)!r}\n" + extra


def bed_mesh_section() -> str:
    """``[bed_mesh]`` with a saved 7 x 7 profile: a 0.1 mm bowl and a tilt, bicubic."""
    axis = np.linspace(-100.0, 100.0, 7)
    x, y = np.meshgrid(axis, axis)
    z = 0.1 * (x**2 + y**2) / 20000.0 + 0.0004 * x - 0.0003 * y
    rows = "\n".join("  " + ", ".join(f"{v:.6f}" for v in row) for row in z)
    return ("\n[probe]\npin: PA1\nz_offset: 1\n\n[bed_mesh]\nmesh_radius: 100\nround_probe_count: 7\n"
            "algorithm: bicubic\n\n[bed_mesh default]\nversion = 1\npoints =\n" + rows +
            "\nx_count = 7\ny_count = 7\nmesh_x_pps = 2\nmesh_y_pps = 2\nalgo = bicubic\ntension = 0.2\n"
            "min_x = -100.0\nmax_x = 100.0\nmin_y = -100.0\nmax_y = 100.0\n")


def cpu_time(args: list[str], cwd: Path) -> float:
    """CPU time (user + system) [s] of a command, which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: exit {done.returncode}: {done.stderr[-1000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def identified(printer, firmware, seed: int, path: Path) -> None:
    """A typical kit printer identified from the planned object's simulated measurements, saved."""
    from deltacal.geometry import Tolerances
    from deltacal.io import save_calibration
    from deltacal.printer.identification import PrinterMeasurements, identify_printer
    from deltacal.printer.printed.plan import plan_object
    from deltacal.printer.simulation import printed_distances, probe_heights, random_printer, typical_kit

    rng = np.random.default_rng(seed)
    truth = random_printer(printer, rng, typical_kit())
    step = printer.step_distance
    plan = plan_object(printer, firmware)
    probe = probe_heights(truth, firmware, step, plan.probe[:, :2], 0.01, rng)
    pairs = plan.features[plan.pairs].reshape(-1, 6)
    distance = printed_distances(truth, firmware, step, pairs, 0.02, rng)
    data = PrinterMeasurements(firmware.inverse(probe, step),
                               firmware.inverse(pairs.reshape(-1, 3), step).reshape(-1, 2, 3), distance)
    save_calibration(identify_printer(printer.geometry(), data, "printer", method="iterated",
                                      tolerances=Tolerances.printer_kit()), path)


def live_rows(repeat: int, seed: int) -> list[tuple]:
    """The rows (name, value, unit, target, (least, greatest)); none without ``KLIPPER_DIR``."""
    from deltacal.io import load_calibration
    from deltacal.printer.files.robot_file import load_printer
    from deltacal.printer.firmware.klipper.firmware import KLIPPER
    from deltacal.printer.firmware.klipper.live.export import export_live, module_text

    source = os.environ.get("KLIPPER_DIR")
    if not source or not (Path(source) / "klippy" / "klippy.py").is_file():
        print("bench_klipper_live: KLIPPER_DIR is not a Klipper folder: skipped", file=sys.stderr)
        return []
    printer = load_printer(REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    firmware = KLIPPER.nominal(printer)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        klipper = folder / "klipper"
        shutil.copytree(source, klipper, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so", "*.o"))
        subprocess.run([sys.executable, "-c", "import chelper; chelper.get_ffi()"], cwd=klipper / "klippy",
                       check=True, capture_output=True)
        (klipper / "klippy" / "extras" / "deltacal_geometry.py").write_text(module_text(), encoding="utf-8")
        identified(printer, firmware, seed, folder / "cal.toml")
        (folder / "printer.cfg").write_text(printer_cfg(firmware))
        export_live(load_calibration(folder / "cal.toml"), folder / "printer.cfg", folder / "live")
        text = program()
        mesh = printer_cfg(firmware, bed_mesh_section())
        runs = {"baseline": (printer_cfg(firmware), text),
                "bed_mesh": (mesh, "BED_MESH_PROFILE LOAD=default\n" + text),
                "live": (printer_cfg(firmware, "\n[include live/deltacal_geometry.cfg]\n"), text)}
        times: dict[str, list[float]] = {name: [] for name in runs}
        for name, (config, gcode) in runs.items():
            (folder / f"{name}.cfg").write_text(config)
            (folder / f"{name}.gcode").write_text(gcode)
        for _ in range(repeat):
            for name in runs:
                times[name].append(cpu_time(
                    [sys.executable, str(klipper / "klippy" / "klippy.py"), f"{name}.cfg", "-i",
                     f"{name}.gcode", "-o", f"{name}.serial", "-d", str(klipper / "dict" / "atmega2560.dict"),
                     "-l", f"{name}.log"], folder))
    moves = sum(1 for line in text.splitlines() if line.startswith("G1"))
    rows = [(f"klipper_batch_{name}_s", float(np.median(t)), f"s CPU ({moves} moves)", None, (min(t), max(t)))
            for name, t in times.items()]
    ratio = [live / mesh for live, mesh in zip(times["live"], times["bed_mesh"], strict=True)]
    rows.append(("klipper_live_vs_bed_mesh", float(np.median(times["live"]) / np.median(times["bed_mesh"])),
                 "ratio", "<= 1.25", (min(ratio), max(ratio))))
    rows.append(("klipper_live_vs_baseline", float(np.median(times["live"]) / np.median(times["baseline"])),
                 "ratio", None, None))
    return rows


if __name__ == "__main__":
    for row in live_rows(int(sys.argv[1]) if len(sys.argv) > 1 else 5, 2024):
        print(row)
