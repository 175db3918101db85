"""``deltacal import``: a printer as its printer.cfg finds it, Klipper's saved measurements, probe logs."""

from __future__ import annotations

import csv
import os
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import kossel_printer_cfg
from numpy.testing import assert_allclose

from deltacal import Tolerances
from deltacal.chains import PRISMATIC
from deltacal.cli.main import main
from deltacal.exceptions import InputError, InputWarning
from deltacal.io import load_calibration, load_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import read_probe_heights, write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.calibrate import probe_points
from deltacal.printer.firmware.klipper.config import load_klipper, read_klipper_config
from deltacal.printer.firmware.klipper.importer import import_klipper
from deltacal.printer.firmware.klipper.model import KlipperController
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
from deltacal.printer.simulation import nozzle_positions, probe_heights, random_printer, typical_kit

DATA = Path(__file__).resolve().parent / "data" / "klipper"
KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
#: Klipper's own example configurations of linear deltas (GPLv3, kept unchanged).
KLIPPER_EXAMPLES = sorted(p.name for p in DATA.glob("*.cfg") if p.name != "flsun-qqs-as-found.cfg")
#: A FLSUN QQ-S Pro's configuration as found: missing includes, PID keys twice, [delta_calibrate] saved.
AS_FOUND = DATA / "flsun-qqs-as-found.cfg"


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path) as f:
        return list(csv.DictReader(f))


# ------------------------------------------------------------------ reading printer.cfg as found
def test_missing_includes_are_one_warning_and_quiet_duplicates_elsewhere():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        klipper = load_klipper(AS_FOUND)
    messages = [str(w.message) for w in caught if issubclass(w.category, InputWarning)]
    assert len(messages) == 1, messages  # the [extruder] and [heater_bed] PID keys in both places: quiet
    assert "include files not found, skipped" in messages[0]
    for name, line in (("mainsail.cfg", 30), ("timelapse.cfg", 31), ("macros.cfg", 32)):
        assert f"{name} (line {line})" in messages[0]
    assert klipper.delta_radius == 141.553523  # the SAVE_CONFIG block's values
    assert_allclose(klipper.position_endstop, [372.971746, 373.433577, 373.629930], rtol=0, atol=0)


def test_a_dangling_link_is_a_missing_include(tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    os.symlink(tmp_path / "gone.cfg", tmp_path / "macros.cfg")
    cfg.write_text("[include macros.cfg]\n" + cfg.read_text())
    with pytest.warns(InputWarning, match=r"not found, skipped .*: macros.cfg \(line 1\)"):
        assert load_klipper(cfg).delta_radius == 134.4


def test_a_key_not_found_names_the_missing_includes(tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    text = cfg.read_text().replace("delta_radius: 134.4\n", "")
    cfg.write_text("[include printer_params.cfg]\n[include mainsail.cfg]\n" + text)
    with pytest.warns(InputWarning), pytest.raises(
            InputError, match=r"section \[printer\]: missing required key 'delta_radius' .*it may be in the "
                              r"missing includes printer_params.cfg, mainsail.cfg\)") as err:
        load_klipper(cfg)
    assert "\n" not in str(err.value)


# ------------------------------------------------------------------ the robot file
@pytest.mark.parametrize("name", KLIPPER_EXAMPLES)
def test_klippers_examples_import_and_command_the_nozzle_exactly(tmp_path, name):
    assert main(["import", str(DATA / name), "-o", str(tmp_path / "out")]) == 0
    assert not (tmp_path / "out" / "probe.csv").exists()  # no SAVE_CONFIG block: nothing measured
    text = (tmp_path / "out" / "printer.toml").read_text()
    assert "taken by default: effector radius 30 mm, rod spacing 50 mm, nozzle drop 30 mm" in text
    printer, klipper = load_printer(tmp_path / "out" / "printer.toml"), load_klipper(DATA / name)
    # commanding the file's nominal printer through printer.cfg puts the nozzle where commanded
    ws = printer.workspace
    assert ws is not None
    rng = np.random.default_rng(7)
    r, a = ws.radius * np.sqrt(rng.random(200)), rng.uniform(0.0, 2.0 * np.pi, 200)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, ws.height, 200)])
    readings = KlipperController(klipper, printer.step_distance).inverse(targets)
    nozzle = exact.forward(printer.geometry(), readings).point(printer.tool)
    assert np.max(np.abs(nozzle - targets)) < 1e-9


def test_the_written_values_follow_the_spec_per_tower(tmp_path):
    imported = import_klipper(AS_FOUND, effector_radius=25.0, rod_spacing=40.0, nozzle_drop=20.0)
    (tmp_path / "printer.toml").write_text(imported.text)
    printer = load_printer(tmp_path / "printer.toml")
    rho, arm = 141.553523, 280.0
    assert printer.tower_radius == rho + 25.0 and printer.effector_radius == 25.0
    assert printer.rod_length.tolist() == [arm] * 3 and printer.rod_spacing == 40.0
    assert_allclose(np.degrees(printer.tower_azimuth), [210.181908, 329.784204, 90.0], rtol=0, atol=1e-12)
    assert printer.tool.tolist() == [0.0, 0.0, -20.0]
    endstops = np.array([372.971746, 373.433577, 373.629930])
    assert_allclose(printer.endstop_height, endstops + np.sqrt(arm**2 - rho**2) + 20.0, rtol=0, atol=1e-12)
    assert printer.step_distance.tolist() == [32.0 / (200 * 16)] * 3
    geometry = tomllib.loads(imported.text)["geometry"]  # one number where the towers agree, else three
    assert geometry["rod_length_mm"] == arm and geometry["step_distance_mm"] == 32.0 / (200 * 16)
    assert len(geometry["endstop_height_mm"]) == 3
    ws = printer.workspace
    assert ws is not None and ws.radius == 125.0  # print_radius
    assert_allclose(ws.height, np.min(endstops) + np.sqrt(arm**2 - rho**2) - arm, atol=1e-6)
    assert "taken by default" not in imported.text


def test_the_flsun_robot_file_commands_the_nozzle_exactly(tmp_path):
    """Towers whose endstops and angles differ: the imported file's nominal through printer.cfg."""
    assert main(["import", str(AS_FOUND), "-o", str(tmp_path)]) == 0
    printer = load_printer(tmp_path / "printer.toml")
    klipper = load_klipper(AS_FOUND)
    assert np.ptp(printer.endstop_height) > 0.5 and np.ptp(klipper.position_endstop) > 0.5
    ws = printer.workspace
    assert ws is not None
    rng = np.random.default_rng(3)
    r, a = ws.radius * np.sqrt(rng.random(300)), rng.uniform(0.0, 2.0 * np.pi, 300)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, ws.height, 300)])
    readings = KlipperController(klipper, printer.step_distance).inverse(targets)
    nozzle = exact.forward(printer.geometry(), readings).point(printer.tool)
    assert np.max(np.abs(nozzle - targets)) < 1e-9


# ------------------------------------------------------------------ Klipper's saved measurements
def test_saved_heights_are_the_same_steps_through_printer_cfg(tmp_path):
    assert main(["import", str(AS_FOUND), "-o", str(tmp_path)]) == 0
    heights = read_probe_heights(tmp_path / "probe.csv")
    assert_allclose(heights.heights, 17.197, rtol=0, atol=0)
    steps = load_klipper(AS_FOUND).steps(heights.commanded)
    saved = read_klipper_config(AS_FOUND).sections["delta_calibrate"]
    expected = [[float(v) for v in saved[f"height{i}_pos"].split(",")] for i in range(7)]
    assert np.max(np.abs(steps - expected)) < 1e-6  # steps, saved to 1e-3


def _stable(steps: np.ndarray) -> str:
    """A stable position as Klipper saves it."""
    return ",".join(f"{v:.3f}" for v in steps)


def _saved_block(steps: np.ndarray, heights: np.ndarray, pairs: np.ndarray, distances: np.ndarray) -> str:
    lines = ["", "#*# <---------------------- SAVE_CONFIG ---------------------->",
             "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.", "#*#",
             "#*# [delta_calibrate]"]
    for i, (s, h) in enumerate(zip(steps, heights, strict=True)):
        lines += [f"#*# height{i} = {h}", f"#*# height{i}_pos = {_stable(s)}"]
    for i, (p, d) in enumerate(zip(pairs, distances, strict=True)):
        lines += [f"#*# distance{i} = {d}", f"#*# distance{i}_pos1 = {_stable(p[0])}",
                  f"#*# distance{i}_pos2 = {_stable(p[1])}"]
    return "\n".join(lines) + "\n"


def test_import_then_identify_a_printers_saved_calibration(tmp_path, capsys):
    """A kossel's DELTA_CALIBRATE (probe z_offset 15 mm) and DELTA_ANALYZE distances, then identify."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    printer, klipper = load_printer(KOSSEL), load_klipper(cfg)
    rng = np.random.default_rng(11)
    truth = random_printer(printer, rng, typical_kit())
    xy = np.vstack([probe_points(115.0), probe_points(60.0)[1:]])
    offset = np.array([0.0, 0.0, -15.0])  # the probe's tip 15 mm below the nozzle: z_offset 15
    commanded = probe_heights(truth, klipper, printer.step_distance, xy, 0.01, rng, offset)
    steps = klipper.steps(commanded)
    ends = np.array([[[0.0, 0.0, 0.0], [69.5, 0.0, 0.0]], [[0.0, 0.0, 0.0], [0.0, 69.5, 0.0]],
                     [[-60.0, -30.0, 0.0], [60.0, -30.0, 0.0]]])
    first = nozzle_positions(truth, klipper, printer.step_distance, ends[:, 0])
    second = nozzle_positions(truth, klipper, printer.step_distance, ends[:, 1])
    distance = np.round(np.linalg.norm(second - first, axis=1), 3)
    pair_steps = klipper.steps(ends.reshape(-1, 3)).reshape(-1, 2, 3)
    cfg.write_text(cfg.read_text() + _saved_block(steps, np.full(len(steps), 15.0), pair_steps, distance))
    out = tmp_path / "imported"
    assert main(["import", str(cfg), "-o", str(out), "--effector-radius", "30", "--rod-spacing", "50",
                 "--nozzle-drop", "30"]) == 0
    assert "taken by default" not in (out / "printer.toml").read_text()
    rows = _rows(out / "distances.csv")
    assert [float(r["distance_mm"]) for r in rows] == distance.tolist()
    cal = tmp_path / "cal.toml"
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(cfg), "-o", str(cal)]) == 0
    report = capsys.readouterr().out
    assert "probe" in report
    result = load_calibration(cal)
    # the trigger height is used: the identified bed is where the truth's is, not 15 mm off
    found = nozzle_positions(result.geometry, klipper, printer.step_distance, commanded, result.geometry.tool)
    true = nozzle_positions(truth, klipper, printer.step_distance, commanded, truth.tool)
    assert np.max(np.abs(found[:, 2] - true[:, 2])) < 0.1


def test_the_saved_flsun_calibration_identifies(tmp_path):
    """The real FLSUN QQ-S Pro's seven saved heights, identified on its imported per-tower nominal."""
    imported = import_klipper(AS_FOUND)
    (tmp_path / "printer.toml").write_text(imported.text)
    printer = load_printer(tmp_path / "printer.toml")
    nominal = printer.geometry()
    readings = imported.klipper.inverse(imported.probe, printer.step_distance)
    assert_allclose(exact.forward(nominal, readings).point(nominal.tool), imported.probe, atol=1e-9)
    data = PrinterMeasurements(readings, trigger_height=imported.saved.height)
    result = identify_printer(nominal, data, "printer", tolerances=Tolerances.printer_kit(),
                              tolerance_scale="evidence")
    assert result.after.height_rms < result.before.height_rms


def test_import_then_identify_the_saved_flsun_calibration_through_the_cli(tmp_path):
    out, cal = tmp_path / "qqs", tmp_path / "cal.toml"
    assert main(["import", str(AS_FOUND), "-o", str(out)]) == 0
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), "--controller", str(AS_FOUND),
                 "-o", str(cal)]) == 0
    result = load_calibration(cal)
    assert result.geometry.chain is PRISMATIC
    # the per-tower nominal was read: identification started from the file's three endstops
    endstops = load_printer(out / "printer.toml").endstop_height
    assert_allclose(result.nominal.axis_point[:, 2], endstops, rtol=0, atol=1e-12)
    assert result.residuals_after.height_rms < 0.1 * result.residuals_before.height_rms


# ------------------------------------------------------------------ probe logs
LOG = """Start printer at Sat Mar  2 10:00:00 2024 (1709373600.0 12.3)
===== Config file =====
[printer]
kinematics = delta
=======================
// probe at 0.000,0.000 is z=15.212500
// probe at 0.000,100.000 is z=15.187500 [discarded]
// probe at -86.603,-50.000 is z=15.262500
Result is z=15.212500
// probe at 86.603,-50.000 is z=15.175000
"""


def test_a_log_gives_its_probe_results(tmp_path, capsys):
    (tmp_path / "klippy.log").write_text(LOG)
    assert main(["import", str(tmp_path / "klippy.log"), "-o", str(tmp_path / "probe.csv")]) == 0
    heights = read_probe_heights(tmp_path / "probe.csv")
    assert heights.commanded.tolist() == [[0.0, 0.0, 15.2125], [-86.603, -50.0, 15.2625],
                                          [86.603, -50.0, 15.175]]
    assert "3 probe results" in capsys.readouterr().out


def test_a_log_without_probe_results_is_refused_in_one_line(tmp_path, capsys):
    (tmp_path / "klippy.log").write_text(LOG.split("//")[0])
    assert main(["import", str(tmp_path / "klippy.log"), "-o", str(tmp_path / "probe.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "klippy.log: no probe result in this log" in err
    assert not (tmp_path / "probe.csv").exists()


# ------------------------------------------------------------------ the trigger height elsewhere
def test_simulate_fills_z_for_rows_with_a_trigger_height(tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    printer, klipper = load_printer(KOSSEL), load_klipper(cfg)
    xy = probe_points(100.0)
    heights = np.array([0.0, 2.0, 5.0, 0.5, 1.0, 3.0, 0.0])
    write_probe_heights(tmp_path / "template.csv", xy, None, trigger_height=heights)
    assert main(["simulate", str(KOSSEL), str(tmp_path / "template.csv"), "--controller", str(cfg),
                 "--perturb", "3", "--sigma-height", "0", "-o", str(tmp_path / "probe.csv")]) == 0
    measured = read_probe_heights(tmp_path / "probe.csv")
    assert_allclose(measured.heights, heights, rtol=0, atol=0)
    truth = load_geometry(next(tmp_path.glob("probe*truth*.toml")))
    nozzle = nozzle_positions(truth, klipper, printer.step_distance, measured.commanded)
    assert_allclose(nozzle[:, 2], heights, atol=1e-6)
