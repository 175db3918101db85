"""The live module on Klipper's rotary_delta (issue 48): ``export --live`` of a rotary printer's calibration,
``deltacal_geometry.py`` inside the real Klipper.

The truth: Klipper's example-rotary-delta.cfg printer imported, with the complete error model's small
deviations (tests/test_klipper_rotary_compensate.py), its geometry file the calibration. The module's
rotary limits and values are checked without Klipper first (against :class:`KlipperRotaryDelta`, whose
limits are rotary_delta.py's ``check_move``); then the pinned Klipper (``KLIPPER_DIR``) runs programs in
batch mode with the section included: Klipper's toolhead position at each point (the command it sends
to its rotary kinematics, exact) is turned into the true nozzle through Klipper's arm angles and the
true geometry, and compared with the same program corrected offline (``compensate``) and run alike.
"""

from __future__ import annotations

import contextlib
import io
import math
import re

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.controller import weighted_targets
from deltacal.holds import DEFAULT_BOUND
from deltacal.io import load_calibration
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.firmware import firmware_named
from deltacal.printer.firmware.config_file import RotaryFirmwareConfig
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.live import deltacal_geometry as live
from deltacal.printer.firmware.klipper.live.export import SECTION_FILE, section_text
from deltacal.printer.firmware.klipper.live.field import RotaryLiveVolume, SamplingError, exact_correction
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta
from deltacal.printer.robot import less_bed_motion
from tests.test_klipper_live import (
    DWELL_S,
    _example_delta_test,
    _max,
    _program,
    _Section,
    _smooth_field,
    gcode_positions,
    run_klippy,
    toolhead_positions,
)
from tests.test_klipper_rotary_compensate import EXAMPLE, _controller, _nozzle, _truth
from tests.test_rotary_printer_route import identified_route


def _calibration(model: KlipperRotaryDelta):
    """Klipper's RotaryDeltaCalibration's attributes and ``elbow_coord`` for these values."""
    return type("RotaryDeltaCalibration", (), {
        "shoulder_radius": model.shoulder_radius, "shoulder_height": model.shoulder_height,
        "angles": np.degrees(model.angle).tolist(), "upper_arms": model.upper_arm.tolist(),
        "lower_arms": model.lower_arm.tolist(), "endstops": model.position_endstop.tolist(),
        "stepdists": model.step_distance.tolist(), "abs_endstops": model.endstop_angles.tolist(),
        "elbow_coord": lambda self, i, angle: tuple(model.elbows(np.full((1, 3), angle))[0, i])})()


def _status(model: KlipperRotaryDelta) -> dict:
    r = model.max_radius
    return {"homed_axes": "xyz", "axis_minimum": (-r, -r, model.minimum_z_position),
            "axis_maximum": (r, r, model.max_z)}


def _rotary_section() -> str:
    """A section of a made-up field for the example's rotary values."""
    error = SamplingError(0.002, 0.0005, 0.001, 100, 0)
    return section_text(_smooth_field(), error, _controller().firmware, "c")


def test_the_modules_rotary_limits_are_klippers_check_move():
    """The module's RotaryLimits refuse what rotary_delta.py's check_move refuses (the model's codes).

    At random ends over and beyond the volume (radius to 230 mm, z -5 to 260 mm: its max_xy 203.9, its
    taper above limit_z, its top 252), and at chosen ones; the words are Klipper's.
    """
    model = _controller().firmware
    limits = live.RotaryLimits(_calibration(model), _status(model), tuple(model.home_position))
    assert limits.limit_z == pytest.approx(model.limit_z, abs=1e-9) and limits.max_xy == model.max_radius
    rng = np.random.default_rng(3)
    r, a = 230.0 * np.sqrt(rng.random(4000)), 2.0 * np.pi * rng.random(4000)
    ends = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(-5.0, 260.0, 4000)])
    ends[:400, 2] = rng.uniform(model.limit_z, model.max_z, 400)  # the taper's heights
    ends[:400, :2] *= 0.15
    theirs = model.outside(ends) != 0
    ours = np.array([bool(limits.refusal([*p, 0.0], True)) for p in ends])
    assert np.array_equal(ours, theirs)
    assert theirs[:400].any() and not theirs[:400].all() and theirs.any() and not theirs.all()
    assert limits.refusal([250.0, 0.0, 20.0, 0.0], True) == "Move out of range: 250.000 0.000 20.000 [0.000]"
    assert "no key admits it" in limits.outside(250.0, 0.0, 20.0)
    assert "set [printer] minimum_z_position: -0.24" in limits.outside(0.0, 0.0, -0.234)
    assert "taper near the top" in limits.outside(30.0, 0.0, 240.0)
    assert limits.outside(30.0, 0.0, 100.0) == ""


def test_the_rotary_section_reads_back_and_changed_values_are_refused_naming_klippers_key():
    """The section says its kinematics and Klipper's rotary values; the module reads them from Klipper's
    get_calibration() and refuses a changed one in Klipper's section and key; a linear one's is refused."""
    model = _controller().firmware
    text = _rotary_section()
    assert "kinematics: rotary_delta" in text
    section = _Section(text)
    _, ours, _ = live.read_section(section)
    assert set(ours) == set(live.ROTARY_VALUE_KEYS)
    assert ours["upper_arm_length_b"] == 170.0 and ours["angle_c"] == pytest.approx(270.0)
    assert ours["step_distance_a"] == model.step_distance[0] and ours["shoulder_height"] == 412.9
    keys = live.ROTARY_VALUE_KEYS
    klipper = live.klipper_values(_calibration(model), keys)
    live.check_values(ours, klipper, ValueError, keys)  # the same: accepted
    for key, words in (("lower_arm_length_c", r"\[stepper_c\] lower_arm_length is 320\.2 in Klipper, .*320:"),
                       ("shoulder_height", r"\[printer\] shoulder_height is 413\.1 in Klipper, .* 412\.9:")):
        changed = dict(klipper, **{key: klipper[key] + 0.2})
        with pytest.raises(ValueError, match=words):
            live.check_values(ours, changed, ValueError, keys)
    assert live.klipper_values(_calibration(model), live.VALUE_KEYS) is None  # not a linear delta's
    with pytest.raises(_Section.error, match="key kinematics: 'polar': this module serves delta and rotary"):
        live.read_section(_Section(text.replace("kinematics: rotary_delta", "kinematics: polar")))
    # a section written before the key (a linear one): delta
    linear = _Section(text.replace("kinematics: rotary_delta\n", ""))
    assert live.kinematics_of(linear)[0] == "delta"


@pytest.fixture(scope="module")
def rotary(tmp_path_factory):
    """The perturbed example printer as the calibration, ``export --live`` for example-rotary-delta.cfg."""
    folder = tmp_path_factory.mktemp("rotary_live")
    with contextlib.redirect_stdout(io.StringIO()):
        _, truth = _truth(folder)
    save_geometry(truth, folder / "truth.toml")
    config = folder / "example-rotary-delta.cfg"  # SET_KINEMATIC_POSITION starts the programs
    config.write_text(EXAMPLE.read_text() + "\n[force_move]\nenable_force_move: True\n")
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        assert main(["export", str(folder / "truth.toml"), "--controller", "klipper", "--config", str(config),
                     "--live", "-o", str(folder / "live")]) == 0
    live_config = folder / "example_live.cfg"
    live_config.write_text(config.read_text() + f"\n[include {folder / 'live' / SECTION_FILE}]\n")
    controller = _controller()
    return {"folder": folder, "truth": truth, "bed": controller.in_bed_frame(truth), "controller": controller,
            "config": config, "live_config": live_config, "said": said.getvalue()}


@pytest.mark.long
def test_export_live_of_a_rotary_printer_says_its_frame_and_sampling_error(rotary):
    said = rotary["said"]
    print("\n" + said)
    assert "its bed (z = 0) at z = -452.9 mm" in said
    error = re.search(r"sampling error .* max ([\d.]+) mm within radius 50\.00 mm \(the printable radius\)",
                      said)
    assert error and float(error[1]) < 0.002, said
    text = (rotary["folder"] / "live" / SECTION_FILE).read_text()
    assert "kinematics: rotary_delta" in text and "shoulder_radius: 33.9" in text
    assert "holds_sigma" not in text  # a rotary calibration: the whole correction everywhere


def _layers() -> np.ndarray:
    """Points of a few layers over the printable volume (radius up to 90 mm, z 0.3 to 200 mm) [mm]."""
    rng = np.random.default_rng(48)
    points = []
    for z in (0.3, 0.6, 40.0, 120.0, 200.0):
        r, a = 90.0 * np.sqrt(rng.random(8)), 2.0 * np.pi * rng.random(8)
        points.append(np.column_stack([r * np.cos(a), r * np.sin(a), np.full(8, z)]))
    return np.concatenate(points)


def _offline(rotary, program: str, name: str) -> str:
    folder = rotary["folder"]
    (folder / f"{name}.gcode").write_text(program)
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["compensate", str(folder / "truth.toml"), str(folder / f"{name}.gcode"), "--controller",
                     str(rotary["config"]), "-o", str(folder / f"{name}_corrected.gcode")]) == 0
    return (folder / f"{name}_corrected.gcode").read_text()


@pytest.mark.long
def test_klipper_rotary_with_the_module_lands_the_nozzle_as_the_offline_route_does(rotary, klipper):
    """Done when (issue 48): the true nozzle's 3-D max within 1.2x the offline route's + 0.005 mm.

    Klipper's commands at each point (its toolhead, exact), through its rotary arm angles and the true
    geometry; the same program uncorrected misses by the errors' size.
    """
    points = np.round(_layers(), 4)  # as the program writes them
    program = _program(points)
    errors = {}
    for route, config, text in (("module", rotary["live_config"], program),
                                ("offline", rotary["config"], _offline(rotary, program, "layers")),
                                ("uncorrected", rotary["config"], program)):
        run = run_klippy(klipper, config, text, f"layers_{route}")
        assert run.status == 0, run.log[-3000:]
        commands = toolhead_positions(run.log)
        assert commands.shape == points.shape
        errors[route] = _max(_nozzle(rotary["bed"], rotary["controller"], commands) - points)
        if route == "module":
            assert np.max(np.abs(gcode_positions(run.log) - points)) < 1e-6  # the program's coordinates
    print(f"\nrotary, true nozzle's 3-D max over {len(points)} points [mm]: {errors}")
    assert errors["module"] <= 1.2 * errors["offline"] + 0.005
    assert errors["uncorrected"] > 0.1


@pytest.mark.long
def test_klippers_own_rotary_delta_calibrate_test_passes_with_the_module(klipper, tmp_path):
    """test/klippy/rotary_delta_calibrate.test (homing, DELTA_CALIBRATE manual, DELTA_ANALYZE extended) on
    its own configuration with the module loaded: the perturbed example printer as the calibration."""
    own = klipper / "test" / "klippy"
    (tmp_path / "rotary_delta_calibrate.cfg").write_text((own / "rotary_delta_calibrate.cfg").read_text())
    with contextlib.redirect_stdout(io.StringIO()):
        _, truth = _truth(tmp_path)
        save_geometry(truth, tmp_path / "truth.toml")
        cfg = str(tmp_path / "rotary_delta_calibrate.cfg")
        assert main(["export", str(tmp_path / "truth.toml"), "--controller", "klipper", "--config", cfg,
                     "--live", "-o", str(tmp_path / "live")]) == 0
    config = (own / "rotary_delta_calibrate.cfg").read_text()
    marker = "#*# <---------------------- SAVE_CONFIG"
    head, saved = config.split(marker, 1)  # the include before Klipper's saved block
    live_config = head + "\n[include live/deltacal_geometry.cfg]\n\n" + marker + saved
    commands = re.sub(r"^(CONFIG|DICTIONARY) .*$", "", (own / "rotary_delta_calibrate.test").read_text(),
                      flags=re.M)
    _example_delta_test(klipper, tmp_path, "rotary_live", live_config, commands)


@pytest.mark.slow
def test_a_changed_rotary_value_is_refused_at_start_naming_its_key(rotary, klipper):
    changed = rotary["folder"] / "example_changed.cfg"
    text = rotary["live_config"].read_text()
    assert "upper_arm_length: 170.000" in text
    changed.write_text(text.replace("upper_arm_length: 170.000", "upper_arm_length: 170.2", 1))
    run = run_klippy(klipper, changed, "G28\n", "changed")
    assert run.status != 0
    assert re.search(r"deltacal_geometry: \[stepper_a\] upper_arm_length is 170\.2 in Klipper, but the "
                     r"correction was computed for 170", run.log), run.log[-3000:]


@pytest.mark.slow
def test_moves_beyond_the_rotary_limits_are_refused_whole_in_klippers_words(rotary, klipper):
    """Beyond max_xy (203.9 mm): Klipper's own words for the program's point, nothing moved; a bed point
    whose correction goes below Z 0: the key that admits it."""
    start = "SET_KINEMATIC_POSITION X=0 Y=0 Z=150\nG1 X0 Y0 Z20 F6000\n"
    run = run_klippy(klipper, rotary["live_config"], start + f"G4 P{DWELL_S * 1000:g}\nGET_POSITION\n"
                     "G1 X250 Y0 Z20\nGET_POSITION\n", "beyond_live")
    assert "Move out of range: 250.000 0.000 20.000 [0.000]" in run.log, run.log[-3000:]
    assert np.allclose(gcode_positions(run.log)[-1], [0.0, 0.0, 20.0], atol=1e-6)  # refused whole
    angle = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    ring = np.column_stack([80.0 * np.cos(angle), 80.0 * np.sin(angle), np.zeros(72)])
    below = ring[(exact_correction(rotary["bed"], rotary["controller"], ring)[:, 2] < -0.01)]
    assert len(below)
    x, y = below[0, :2]
    run = run_klippy(klipper, rotary["live_config"], start + f"G1 X{x:.4f} Y{y:.4f} Z0\n", "below_live")
    assert run.status != 0
    assert re.search(r"deltacal_geometry: the program's point X\S+ Y\S+ Z0\.0000, corrected, is .*: below "
                     r"minimum_z_position 0: set \[printer\] minimum_z_position: -0\.\d\d", run.log), \
        run.log[-3000:]
    assert not math.isnan(x)


def test_the_rotary_volume_tapers_as_klipper_does():
    model = _controller().firmware
    volume = RotaryLiveVolume.of_rotary(model, 50.0)
    points = np.array([[30.0, 0.0, 230.0], [10.0, 0.0, 235.0], [203.0, 0.0, 10.0], [205.0, 0.0, 10.0]])
    assert volume.admits(points).tolist() == (model.outside(points) == 0).tolist()
    assert volume.admits(points).tolist() == [False, True, True, False]


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """An owner's calibration: the simulated rotary printer identified through the CLI
    (tests/test_rotary_printer_route.py's route: ``[holds]``, ``[controller]``, ``[measured]``), ``export
    --live`` through a copy of the example (with [force_move]: the same values) and through a copy whose
    arm A endstop is 0.5 mm up (re-anchored)."""
    folder = tmp_path_factory.mktemp("rotary_live_identified")
    with contextlib.redirect_stdout(io.StringIO()):
        route = identified_route(folder)
    text = EXAMPLE.read_text() + "\n[force_move]\nenable_force_move: True\n"
    copies = {"same": text, "moved": text.replace("position_endstop: 252", "position_endstop: 252.5", 1)}
    assert copies["moved"] != text
    klipper = firmware_named("klipper")
    assert klipper is not None
    out = {}
    for name, config_text in copies.items():
        config = folder / f"{name}.cfg"
        config.write_text(config_text)
        said = io.StringIO()
        with contextlib.redirect_stdout(said):
            assert main(["export", str(route["cal"]), "--controller", "klipper", "--config", str(config),
                         "--live", "-o", str(folder / f"live_{name}")]) == 0
        live_config = folder / f"{name}_live.cfg"
        live_config.write_text(config_text + f"\n[include {folder / f'live_{name}' / SECTION_FILE}]\n")
        k = rotary_from_config(read_klipper_config(config))
        anchored, _ = RotaryFirmwareConfig(klipper, KlipperRotaryController(k), str(config)).anchor(
            load_calibration(route["cal"]), "cal")
        out[name] = {"config": config, "live_config": live_config, "said": said.getvalue(), "k": k,
                     "anchored": anchored, "section": (folder / f"live_{name}" / SECTION_FILE).read_text()}
    return {**route, **out}


def _identified_points() -> tuple[np.ndarray, np.ndarray]:
    """Points over the printable radius (50 mm: 5 layers), beyond it out to 150 mm (its weights turn to 0)
    and at Klipper's rim (r 195 to 200 mm, its reach 203.9) [mm], as the program writes them; which are the
    rim's."""
    rng = np.random.default_rng(4848)
    parts = []
    for radius, heights, count in ((50.0, (0.3, 0.6, 20.0, 60.0, 100.0), 6), (150.0, (0.3, 40.0, 100.0), 4),
                                   (200.0, (0.3, 40.0, 100.0), 3)):
        for z in heights:
            low = {50.0: 0.0, 150.0: 60.0, 200.0: 195.0}[radius]
            r, a = np.sqrt(rng.uniform(low**2, radius**2, count)), 2.0 * np.pi * rng.random(count)
            parts.append(np.column_stack([r * np.cos(a), r * np.sin(a), np.full(count, z)]))
    points = np.round(np.concatenate(parts), 4)
    return points, np.hypot(points[:, 0], points[:, 1]) > 190.0


def _figures(points: np.ndarray, rim: np.ndarray, errors: dict, commands: dict) -> dict:
    """A run's figures [mm]: the true nozzle's 3-D max where corrected (as is, and less the motion along the
    bed no measurement sees), over the printable radius, at the rim; the commands apart, at the rim moved."""
    inner = np.hypot(points[:, 0], points[:, 1]) <= 50.0

    def worst(part: np.ndarray, less: bool) -> dict:
        return {route: round(_max(less_bed_motion(points[part], e[part])[0] if less else e[part]), 5)
                for route, e in errors.items()}

    return {"corrected": worst(~rim, False), "corrected less": worst(~rim, True),
            "printable radius less": worst(inner, True), "rim": worst(rim, False),
            "commands apart": round(_max(commands["module"] - commands["offline"]), 5),
            "rim commands moved": {route: float(np.max(np.abs(c[rim] - points[rim])))
                                   for route, c in commands.items()}}


def _check_identified_section(copy: dict, points: np.ndarray, rim: np.ndarray) -> None:
    """The section carries the re-anchored calibration's σ grid and the bound, as the linear module's does;
    the points' weights (the offline route's): 0 at the rim, of every kind inside."""
    said = copy["said"]
    assert f"(weighted where the calibration holds within σ {DEFAULT_BOUND:g} mm, as compensate " \
           f"--sigma-bound {DEFAULT_BOUND:g} does: its σ grid goes with the section)" in said, said
    holds = copy["anchored"].holds
    grid = live.read_section(_Section(copy["section"]))[0]
    assert grid.holds is not None and grid.holds.bound == DEFAULT_BOUND
    assert list(grid.holds.radius) == list(holds.radius) and list(grid.holds.height) == list(holds.height)
    assert list(grid.holds.sigma_values) == [*holds.horizontal.ravel(), *holds.vertical.ravel()]
    weights = weighted_targets(copy["anchored"], KlipperRotaryController(copy["k"]), points).weights
    assert np.all(weights[rim] == 0.0) and np.all(weights[~rim, 1] > 0.0)
    assert np.any((weights[~rim] > 0.0) & (weights[~rim] < 1.0)) and np.any(weights[~rim] == 0.0)


@pytest.mark.long
def test_an_identified_rotary_calibration_live_lands_the_nozzle_as_offline(identified, klipper):
    """Done when (issue 48), for an owner's calibration (identified: weighted where it holds): the true
    nozzle's 3-D max within 1.2x the offline route's (``compensate``, the same σ bound) + 0.005 mm (as it is,
    and less the motion along the bed that no measurement sees, which both leave alike), the module's
    commands the offline route's; at Klipper's rim (r 195 to 200 mm, beyond the measured bed) both leave
    Klipper's own commands (weights 0). The section carries the σ grid and the bound, as the linear module's
    does. The same through a copy of the configuration whose endstop changed: ``export --live`` re-anchors
    (said in one line), the module still the offline route's.
    """
    points, rim = _identified_points()
    printer, folder = identified["printer"], identified["folder"]
    program = _program(points)
    figures = {}
    for name in ("same", "moved"):
        copy = identified[name]
        lines = [line for line in copy["said"].splitlines() if "values changed" in line]
        if name == "moved":
            assert len(lines) == 1 and "stepper_a.position_endstop 252 -> 252.5" in lines[0], copy["said"]
            assert "re-anchored" in lines[0], copy["said"]
        else:
            assert lines == [], copy["said"]
        _check_identified_section(copy, points, rim)
        (folder / f"{name}.gcode").write_text(program)
        corrected = folder / f"{name}_corrected.gcode"
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["compensate", str(identified["cal"]), str(folder / f"{name}.gcode"), "--controller",
                         str(copy["config"]), "-o", str(corrected)]) == 0
        commands = {}
        for route, config, text in (("module", copy["live_config"], program),
                                    ("offline", copy["config"], corrected.read_text())):
            run = run_klippy(klipper, config, text, f"identified_{name}_{route}")
            assert run.status == 0, run.log[-3000:]
            commands[route] = toolhead_positions(run.log)
            assert commands[route].shape == points.shape
        errors = {route: printer.nozzle(copy["k"], c) - points for route, c in commands.items()}
        errors["uncorrected"] = printer.nozzle(copy["k"], points) - points  # Klipper's own commands
        got = figures[name] = _figures(points, rim, errors, commands)
        for key in ("corrected", "corrected less"):
            assert got[key]["module"] <= 1.2 * got[key]["offline"] + 0.005, figures
        assert got["corrected less"]["offline"] < 0.5 * got["corrected less"]["uncorrected"], figures
        assert got["commands apart"] < 0.005, figures
        for route in commands:  # Klipper's own commands at the rim
            assert got["rim commands moved"][route] < 1e-6, figures
    print(f"\nidentified rotary printer, true nozzle [mm]: {figures}")
