"""``export --controller klipper``: the firmware values that fit an identified printer best (issue 24).

A kit printer (seeded) is probed and its planned object measured through Klipper's nominal
configuration; the identified calibration is exported; the values written are read back as
Klipper reads them, merged into the user's ``printer.cfg``, and judged on the TRUE printer against
Klipper's own enhanced calibration on measurements of the same kind.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.controller import corrected_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.geometry import Tolerances, Workspace
from deltacal.io import load_calibration, load_nominal, save_calibration, save_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.calibrate import klipper_enhanced, object_pairs, probe_points
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.fit import error_stats, printable_grid, values_of
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
from deltacal.printer.simulation import printed_distances, probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
PRINTER = load_printer(KOSSEL)
STEP = PRINTER.step_distance
#: The anchor's printable volume (issue 24): radius 92 mm, heights 0.2 to 100 mm.
VOLUME = Workspace(radius=92.0, height=100.0, top_z=100.0)
#: The shipped Kossel with the anchor's printable volume as its [workspace].
ROBOT = re.sub(r"\[workspace\].*", "[workspace]\nradius_mm = 92.0\nheight_mm = 100.0\n", KOSSEL.read_text(),
               flags=re.S)


def _config_text(firmware: KlipperDelta) -> str:
    text = ("[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 3000\n"
            f"delta_radius: {firmware.delta_radius}\n")
    for k, tower in enumerate("abc"):
        text += (f"\n[stepper_{tower}]\nstep_pin: PF0\nmicrosteps: 16\nrotation_distance: 40\n"
                 f"arm_length: {firmware.arm_length[k]}\nposition_endstop: {firmware.position_endstop[k]}\n")
    return text


def _merged(config: str, exported: str) -> str:
    """The user's printer.cfg with the exported keys replaced, as the file's header asks."""
    values: dict[str, dict[str, str]] = {}
    section = ""
    for line in exported.splitlines():
        if line.startswith("["):
            section = line.strip("[]")
            values[section] = {}
        elif ":" in line and not line.startswith("#"):
            key, value = (v.strip() for v in line.split(":", 1))
            values[section][key] = value
    out, section = [], ""
    for line in config.splitlines():
        if line.startswith("["):
            if section in values:  # keys the user's section did not have
                out += [f"{k}: {v}" for k, v in values.pop(section).items()]
            section = line.strip("[]")
            out.append(line)
            continue
        key = line.split(":", 1)[0].strip()
        if section in values and key in values[section]:
            line = f"{key}: {values[section].pop(key)}"
        out.append(line)
    out += [f"{k}: {v}" for k, v in values.pop(section, {}).items()]
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def printer(tmp_path_factory, kossel_plan):
    """A kit printer, its measurements through Klipper's nominal values, and its calibration file."""
    folder = tmp_path_factory.mktemp("export_klipper")
    firmware = KlipperDelta.from_printer(PRINTER)
    config = folder / "printer.cfg"
    config.write_text(_config_text(firmware))
    robot = folder / "kossel92.toml"
    robot.write_text(ROBOT)
    rng = np.random.default_rng(2431)
    truth = random_printer(PRINTER, rng, typical_kit())
    plan = kossel_plan  # plan_object(PRINTER, firmware)
    probe = probe_heights(truth, firmware, STEP, plan.probe[:, :2], 0.01, rng)
    pairs = plan.features[plan.pairs].reshape(-1, 6)
    distance = printed_distances(truth, firmware, STEP, pairs, 0.02, rng)
    data = PrinterMeasurements(firmware.inverse(probe, STEP), firmware.inverse(pairs.reshape(-1, 3), STEP)
                               .reshape(-1, 2, 3), distance)
    result = identify_printer(PRINTER.geometry(), data, "printer", method="iterated",
                              tolerances=Tolerances.printer_kit())
    calibration = folder / "cal.toml"
    save_calibration(result, calibration)
    klipper = {"probe": probe_heights(truth, firmware, STEP, probe_points(115.0), 0.01, rng),
               "pairs": object_pairs()}
    klipper["distances"] = printed_distances(truth, firmware, STEP, klipper["pairs"], 0.02, rng)
    return {"folder": folder, "config": config, "robot": robot, "truth": truth, "firmware": firmware,
            "calibration": calibration, "klipper": klipper}


@pytest.mark.slow
def test_exported_values_read_as_klipper_reads_them_and_beat_klippers_own(printer, capsys):
    out = printer["folder"] / "calibrated.cfg"
    assert main(["export", str(printer["calibration"]), "--controller", "klipper", "-o", str(out),
                 "--config", str(printer["config"]), "--robot", str(printer["robot"])]) == 0
    printed = capsys.readouterr().out
    text = out.read_text()
    sections = re.findall(r"^\[(.+)\]$", text, flags=re.M)
    assert sections == ["printer", "stepper_a", "stepper_b", "stepper_c"]
    keys = {line.split(":")[0] for line in text.splitlines() if line and line[0] not in "#["}
    # minimum_z_position where the corrected bed needs it (test_exported_minimum_z_position_admits_...)
    assert keys - {"minimum_z_position"} == {"delta_radius", "angle", "arm_length", "position_endstop",
                                             "rotation_distance"}
    merged = printer["folder"] / "merged.cfg"
    merged.write_text(_merged(printer["config"].read_text(), text))
    exported = load_klipper(merged)
    calibration = load_calibration(printer["calibration"])
    # what it printed is what the values written leave on the identified printer
    stats = error_stats(calibration.geometry, exported, STEP, VOLUME, part_frame=True)
    assert f"these values: 3-D max {stats.max_3d:.3f} mm" in printed
    assert f"max |dz| {stats.flatness:.3f} mm" in printed
    # on the true printer: no worse than Klipper's own enhanced calibration, on 3-D and first layer
    truth, firmware, k = printer["truth"], printer["firmware"], printer["klipper"]
    # (errors of the printed part: less the shift along the bed and turn about its normal, for both)
    enhanced = klipper_enhanced(firmware, k["probe"], k["pairs"], k["distances"])
    theirs = error_stats(truth, enhanced, STEP, VOLUME, part_frame=True)
    ours = error_stats(truth, exported, STEP, VOLUME, part_frame=True)
    assert ours.max_3d < theirs.max_3d
    assert ours.flatness <= theirs.flatness
    assert ours.max_3d < 0.2 * error_stats(truth, firmware, STEP, VOLUME, part_frame=True).max_3d


def test_a_calibrated_config_whose_towers_step_differently_serves_compensate(printer, tmp_path):
    """The calibration's step distance is what readings count in, not the refitted rotation_distance."""
    out = tmp_path / "calibrated.cfg"
    assert main(["export", str(printer["calibration"]), "--controller", "klipper", "-o", str(out),
                 "--config", str(printer["config"])]) == 0
    merged = tmp_path / "merged.cfg"
    merged.write_text(_merged(printer["config"].read_text(), out.read_text()))
    exported = load_klipper(merged)
    assert np.ptp(exported.step_distance) > 0.0
    targets = printable_grid(VOLUME, per_radius=2, layers=3, ring=6)
    csv = tmp_path / "targets.csv"
    csv.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x:.4f},{y:.4f},{z:.4f}\n" for x, y, z in targets))
    assert main(["compensate", str(printer["calibration"]), str(csv), "--controller",
                 str(merged), "-o", str(tmp_path / "sent.csv")]) == 0
    table = np.loadtxt(tmp_path / "sent.csv", delimiter=",", skiprows=1)
    calibration = load_calibration(printer["calibration"])
    controller = KLIPPER.controller(exported, STEP)  # readings counted in the calibration's step distance
    read = table[:, :3]  # the targets as written
    assert_allclose(table[:, 3:], corrected_targets(calibration, controller, read).commands, atol=1e-8)
    # corrected wholly, the identified printer (put in the controller's frame along the bed) lands on them
    whole = corrected_targets(calibration, controller, read, bound=math.inf).commands
    geometry = aligned_to_controller(calibration.geometry, controller, float(calibration.holds.radius[-1]))
    landed = exact.forward(geometry, exported.inverse(whole, STEP)).point(geometry.tool)
    assert np.max(np.linalg.norm(landed - read, axis=1)) < 1e-6


def test_the_step_distance_is_kept_in_the_calibration(printer):
    calibration = load_calibration(printer["calibration"])
    steps = [calibration.geometry.step_distance, calibration.nominal.step_distance]
    assert steps[0].tolist() == steps[1].tolist() == STEP.tolist()
    start = KlipperDelta.from_geometry(calibration.nominal)
    assert np.allclose(values_of(start), values_of(printer["firmware"]), rtol=0.0, atol=1e-9)


def test_refusals(printer, tmp_path, capsys):
    cal = str(printer["calibration"])
    assert main(["export", cal, "--controller", "klipper"]) == 2
    assert "needs -o CALIBRATED.cfg" in capsys.readouterr().err
    rotary = tmp_path / "rotary.toml"
    save_geometry(load_nominal(KOSSEL.parent / "bai2015.toml").geometry(), rotary)
    assert main(["export", str(rotary), "--controller", "klipper", "-o", str(tmp_path / "o.cfg")]) == 2
    assert "is a rotary Delta's calibration" in capsys.readouterr().err
    assert main(["export", cal, "--controller", "limbs", "-o", str(tmp_path / "o.toml")]) == 2
    assert "--controller klipper" in capsys.readouterr().err
    assert main(["export", cal, "--controller", "limbs", "-o", str(tmp_path / "o.toml"),
                 "--config", str(printer["config"])]) == 2
    assert "--config and --keep-rotation-distance apply to --controller klipper" in capsys.readouterr().err
    # a geometry file without its step distance, and no configuration to take it from
    geometry = load_calibration(printer["calibration"]).geometry
    bare = tmp_path / "bare.toml"
    save_geometry(replace(geometry, step_distance=None), bare)
    assert main(["export", str(bare), "--controller", "klipper", "-o", str(tmp_path / "o.cfg")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{bare}: key step_distance_mm: no step_distance_mm" in err
    assert not any(tmp_path.glob("o.*"))


def test_without_config_rotation_distance_is_not_guessed(printer, tmp_path, capsys):
    """A 32-microstep printer's rotation_distance is not half its own because 16 microsteps were assumed."""
    cal, out = str(printer["calibration"]), tmp_path / "o.cfg"
    assert main(["export", cal, "--controller", "klipper", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "give --config printer.cfg" in err
    assert "--keep-rotation-distance" in err
    assert not out.exists()
    # the same printer (step distance 0.0125 mm) driven at 32 microsteps: rotation_distance 80
    thirty_two = tmp_path / "printer32.cfg"
    thirty_two.write_text(printer["config"].read_text().replace("microsteps: 16\nrotation_distance: 40",
                                                                "microsteps: 32\nrotation_distance: 80"))
    assert np.all(load_klipper(thirty_two).step_distance == STEP)
    # keeping the printer's own: none written, and its rotation_distance stays what it was
    assert main(["export", cal, "--controller", "klipper", "-o", str(out), "--keep-rotation-distance"]) == 0
    text = out.read_text()
    assert "rotation_distance:" not in text and "# no rotation_distance for stepper_a" in text
    merged = tmp_path / "merged.cfg"
    merged.write_text(_merged(thirty_two.read_text(), text))
    assert np.all(load_klipper(merged).step_distance == STEP)
    # with the configuration, its microstepping
    assert main(["export", cal, "--controller", "klipper", "-o", str(out), "--config", str(thirty_two),
                 "--keep-rotation-distance"]) == 0
    assert re.findall(r"rotation_distance: (\S+)", out.read_text()) == ["80.000000"] * 3


def test_exported_minimum_z_position_admits_the_corrected_first_layer(printer, tmp_path, capsys):
    """The true bed is below the exported values' z 0: the cfg written admits the corrected first layer."""
    out = tmp_path / "calibrated.cfg"
    assert main(["export", str(printer["calibration"]), "--controller", "klipper", "-o", str(out),
                 "--config", str(printer["config"]), "--robot", str(printer["robot"])]) == 0
    assert "minimum_z_position " in capsys.readouterr().out
    value = float(re.findall(r"^minimum_z_position: (\S+)$", out.read_text(), flags=re.M)[0])
    assert value < 0.0
    merged, bare = tmp_path / "merged.cfg", tmp_path / "bare.cfg"
    merged.write_text(_merged(printer["config"].read_text(), out.read_text()))
    bare.write_text("\n".join(line for line in merged.read_text().splitlines()
                              if not line.startswith("minimum_z_position")) + "\n")
    layer = printable_grid(VOLUME, per_radius=6, layers=1, ring=24)
    layer[:, 2] = 0.0
    csv = tmp_path / "bed.csv"
    csv.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x:.4f},{y:.4f},{z:.4f}\n" for x, y, z in layer))
    command = ["compensate", str(printer["calibration"]), str(csv), "-o", str(tmp_path / "sent.csv"),
               "--controller"]
    assert main([*command, str(bare)]) == 1
    assert "set [printer] minimum_z_position: " in capsys.readouterr().err
    assert main([*command, str(merged)]) == 0
    z_cmd = np.loadtxt(tmp_path / "sent.csv", delimiter=",", skiprows=1)[:, 5]
    assert value < np.min(z_cmd) < 0.0
