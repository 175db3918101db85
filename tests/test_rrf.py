"""RepRapFirmware 3.x as a printer firmware: facts from its source (LinearDeltaKinematics.cpp,
GCodes2.cpp, GCodes4.cpp), its config.g read as RRF runs it, the fit and the written lines."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.controller import corrected_targets
from deltacal.exceptions import InputError
from deltacal.gcode.dialect import ArcP
from deltacal.geometry import Tolerances, Workspace
from deltacal.printer.comparison import PROBE_SIGMA, plan_measurements
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import config_firmware, firmwares
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.fit import fit_klipper, printable_grid
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.firmware.rrf.config import load_rrf, rrf_config_text
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.firmware.rrf.fit import error_stats, fit_rrf, values_of
from deltacal.printer.firmware.rrf.model import ABOVE_ENDSTOP, BELOW_MIN_Z, BEYOND_RADIUS, RRFDelta
from deltacal.printer.identification.fit import identify_printer
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.robot import NominalLinearDelta, less_bed_motion
from deltacal.printer.simulation import (
    bed_motion,
    nozzle_positions,
    printed_distances,
    probe_heights,
    random_true_printer,
    typical_kit,
)

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
DATA = Path(__file__).resolve().parent / "data" / "rrf"
WORKSPACE = Workspace(radius=92.0, height=100.0, top_z=100.0)


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def odd_rrf() -> RRFDelta:
    """RRF's values with every term away from the perfect printer's, tilt included."""
    return RRFDelta(
        np.array([269.0, 269.5, 268.8]),
        134.4,
        295.6,
        np.radians([0.1, -0.2, 0.05]),
        np.array([0.2, -0.1, -0.1]),
        np.array([0.0005, -0.0002]),
        np.array([0.0125, 0.01251, 0.01249]),
    )


def recalc_towers(radius: float, corrections_deg: np.ndarray) -> np.ndarray:
    """``LinearDeltaKinematics::Recalc()``'s towerX, towerY, written as RRF writes them."""
    a, b, c = np.radians(corrections_deg)
    s30 = math.radians(30.0)
    return np.array(
        [
            [-radius * math.cos(s30 + a), -radius * math.sin(s30 + a)],
            [radius * math.cos(s30 - b), -radius * math.sin(s30 - b)],
            [-radius * math.sin(c), radius * math.cos(c)],
        ]
    )


def test_towers_and_angle_corrections_as_recalc_places_them():
    rrf = odd_rrf()
    assert_allclose(
        rrf.towers, recalc_towers(rrf.radius, np.degrees(rrf.angle_correction)), atol=1e-12, rtol=0
    )
    # a positive correction turns each tower counter-clockwise
    turned = RRFDelta(rrf.diagonal, rrf.radius, rrf.homed_height, np.radians([1.0, 1.0, 1.0]))
    base = RRFDelta(rrf.diagonal, rrf.radius, rrf.homed_height)
    cross = base.towers[:, 0] * turned.towers[:, 1] - base.towers[:, 1] * turned.towers[:, 0]
    assert np.all(cross > 0.0)


def test_transform_carriage_heights_with_the_tilt_terms():
    rrf = odd_rrf()
    p = np.array([[12.0, -30.0, 40.0]])
    x, y, z = p[0]
    expected = [
        math.sqrt(rrf.diagonal[i] ** 2 - (x - rrf.towers[i, 0]) ** 2 - (y - rrf.towers[i, 1]) ** 2)
        + z
        + x * rrf.tilt[0]
        + y * rrf.tilt[1]
        for i in range(3)
    ]
    assert_allclose(rrf.carriage_heights(p)[0], expected, atol=1e-12, rtol=0)
    homed = rrf.homed_height + np.sqrt(rrf.diagonal**2 - rrf.radius**2) + rrf.endstop_adjustment
    assert_allclose(rrf.steps(p)[0], (homed - expected) / rrf.step_distance, rtol=1e-12)
    # ForwardTransform: the round trip, the tilt subtracted back
    assert_allclose(rrf.positions(rrf.steps(p)), p, atol=1e-9, rtol=0)


def test_signs_of_endstop_adjustment_and_tilt():
    base = RRFDelta(np.full(3, 269.0), 134.4, 295.6)
    p = np.array([[20.0, 10.0, 50.0]])
    raised = RRFDelta(np.full(3, 269.0), 134.4, 295.6, endstop_adjustment=np.array([0.5, 0.0, 0.0]))
    # M666 X+0.5 raises tower A's endstop: 0.5 mm more travel below it to the same point
    assert_allclose((raised.steps(p) - base.steps(p))[0] * base.step_distance, [0.5, 0.0, 0.0], atol=1e-9)
    tilted = RRFDelta(np.full(3, 269.0), 134.4, 295.6, tilt=np.array([0.01, 0.0]))  # M666 A1: 1 %
    # Z raised by 1 % of x: every carriage 0.2 mm higher at x = 20, so 0.2 mm less travel
    assert_allclose((base.steps(p) - tilted.steps(p))[0] * base.step_distance, np.full(3, 0.2), atol=1e-9)


def test_homing_leaves_the_nozzle_at_the_homed_height(kossel):
    rrf = RRF_FIRMWARE.nominal(kossel)
    assert_allclose(rrf.home_position, [0.0, 0.0, rrf.homed_height], atol=1e-9)
    assert_allclose(RRF_FIRMWARE.controller(rrf, kossel.step_distance).home, rrf.home_position)
    odd = odd_rrf()  # the carriages' heights on their endstops, through the forward transform
    assert_allclose(odd.carriage_heights(odd.home_position[None])[0], odd.carriage_top, atol=1e-9)


def test_same_as_klippers_model_where_the_values_coincide():
    rrf = RRFDelta(
        np.array([269.0, 269.5, 268.8]),
        134.4,
        295.6,
        np.radians([0.1, -0.2, 0.05]),
        np.array([0.2, -0.1, -0.1]),
        step_distance=np.array([0.0125, 0.01251, 0.01249]),
    )
    klipper = KlipperDelta(
        rrf.radius,
        rrf.angle,
        rrf.diagonal,
        rrf.carriage_top - np.sqrt(rrf.diagonal**2 - 134.4**2),
        rrf.step_distance,
    )
    rng = np.random.default_rng(4)
    targets = np.column_stack([rng.uniform(-80.0, 80.0, (200, 2)), rng.uniform(0.0, 200.0, 200)])
    assert_allclose(rrf.steps(targets), klipper.steps(targets), atol=1e-9, rtol=0)
    assert_allclose(
        rrf.positions(rrf.steps(targets)), klipper.positions(rrf.steps(targets)), atol=1e-9, rtol=0
    )


def test_limits_one_point_each_side():
    rrf = RRFDelta(np.full(3, 269.0), 134.4, 295.6, print_radius=100.0, z_min=-0.5)
    points = np.array(
        [
            [99.99, 0.0, 5.0],
            [100.01, 0.0, 5.0],
            [0.0, 0.0, -0.49],
            [0.0, 0.0, -0.51],
            [0.0, 0.0, 295.59],
            [0.0, 0.0, 295.61],
        ]
    )
    assert rrf.outside(points).tolist() == [0, BEYOND_RADIUS, 0, BELOW_MIN_Z, 0, ABOVE_ENDSTOP]
    assert "M665 B100.01" in rrf.refusal(points[1:2]) and "M208 S1 Z-0.51" in rrf.refusal(points[3:4])
    off = RRFDelta(
        np.full(3, 269.0), 134.4, 295.6, print_radius=100.0, z_min=-0.5, limit_axes=False
    )  # M564 S0
    assert off.outside(points).tolist() == [0, 0, 0, 0, 0, ABOVE_ENDSTOP]


def test_config_g_run_as_rrf_runs_it(tmp_path):
    rrf = load_rrf(DATA / "config.g")  # M501 reads config-override.g beside it: R134.5, H295.7 win
    assert_allclose(rrf.diagonal, [269.0, 269.5, 268.8])
    assert (rrf.radius, rrf.homed_height, rrf.print_radius, rrf.z_min, rrf.limit_axes) == (
        134.5,
        295.7,
        115.0,
        0.0,
        True,
    )
    assert_allclose(np.degrees(rrf.angle_correction), [0.1, -0.2, 0.0], atol=1e-12)
    assert_allclose(rrf.endstop_adjustment, [0.2, -0.1, -0.1])
    assert_allclose(rrf.tilt, [0.0005, -0.0002])
    assert_allclose(rrf.step_distance, np.full(3, 1 / 80))
    assert config_firmware(DATA / "config.g") is RRF_FIRMWARE and RRF_FIRMWARE in firmwares()
    alone = tmp_path / "config.g"
    shutil.copy(DATA / "config.g", alone)
    with pytest.warns(UserWarning, match="M501 runs config-override.g, not found"):
        assert load_rrf(alone).radius == 134.4


def test_microstepping_scales_steps_per_mm(tmp_path):
    path = tmp_path / "config.g"
    path.write_text("M665 L269 R134.4 H295\nM92 X80 Y80 Z80\nM350 X32 Y32 Z32\n")  # M350 after M92: doubled
    assert_allclose(load_rrf(path).steps_per_mm, [160.0, 160.0, 160.0])
    path.write_text(
        "M665 L269 R134.4 H295\nM350 X32 Y16 Z16\nM92 X80 Y80 Z80 S16\n"
    )  # S16 values at x32: doubled
    assert_allclose(load_rrf(path).steps_per_mm, [160.0, 80.0, 80.0])


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("M665 L269 R1.3.4 H295\nM92 X80 Y80 Z80\n", "line 1, M665 R"),
        ("M665 L269 R134\nM92 X80 Y80 Z{global.steps}\n", "line 2, M92 Z"),
        ("M665 L269:270 R134\nM92 X80 Y80 Z80\n", "line 1, M665 L"),
        ("M665 L100 R134\nM92 X80 Y80 Z80\n", "line 1, M665 L"),
        ("M669 K0\nM665 L269 R134\nM92 X80 Y80 Z80\n", "line 1, M669 K"),
    ],
)
def test_bad_settings_name_file_line_and_key(tmp_path, text, where):
    path = tmp_path / "config.g"
    path.write_text(text)
    with pytest.raises(InputError, match=f"config.g.*{where}|{where}.*config.g"):
        load_rrf(path)


def test_written_lines_read_back(tmp_path):
    rrf = odd_rrf()
    text = rrf_config_text(rrf, DATA / "config.g", title="fitted")
    assert [line.split()[0] for line in text.splitlines() if not line.startswith(";")] == [
        "M665",
        "M666",
        "M92",
    ]
    path = tmp_path / "config-override.g"
    path.write_text(text)
    back = load_rrf(path)
    assert_allclose(values_of(back)[:13], values_of(rrf)[:13], atol=1e-4, rtol=0)
    assert_allclose(back.steps_per_mm, rrf.steps_per_mm, atol=1e-4, rtol=0)
    path.write_text(rrf_config_text(rrf, complete=True))
    exact = load_rrf(path)
    assert (
        np.array_equal(values_of(exact)[:13], values_of(rrf)[:13]) and exact.print_radius == rrf.print_radius
    )
    assert_allclose(exact.step_distance, rrf.step_distance, rtol=1e-15)  # M92 is 1 / d


def test_dialect_from_the_source(tmp_path):
    dialect = RRF_FIRMWARE.dialect(DATA / "config.g")
    assert dialect.e_by_m83 and not dialect.g91_moves_e and dialect.arc_p is ArcP.IGNORED
    assert_allclose(dialect.home, load_rrf(DATA / "config.g").home_position)
    from deltacal.gcode.state import Extrusion, ModalState

    state = ModalState((0.0, 0.0, 0.0), dialect.g91_moves_e, dialect.distance_sets_e, dialect.e_by_m83)
    state.set_distance(True)  # G91 without M83: E stays absolute in RRF
    assert state.extrusion is Extrusion.ABSOLUTE
    state.set_extruder(True)
    state.set_distance(False)  # G90 after M83: E stays relative
    assert state.extrusion is Extrusion.RELATIVE


def test_probe_program_echoes_each_point_then_g30_s_minus_1():
    text = RRF_FIRMWARE.probe_program(np.array([[1.0, -2.5], [30.1234, 0.0]]), title="grid")
    lines = text.splitlines()
    assert lines[0] == "; grid" and "G28 ; home" in lines
    assert lines.count("G30 S-1") == 2
    first = lines.index('echo "probe at 1.000,-2.500"')
    assert lines[first - 1].startswith("G1 X1.000 Y-2.500 ") and lines[first + 1] == "G30 S-1"
    assert 'echo "probe at 30.123,0.000"' in lines


def test_fit_recovers_a_printer_on_a_tilted_bed(kossel):
    rotation, translation = bed_motion(math.radians(0.1), math.radians(-0.05), 0.3)
    printer = kossel.geometry().moved_rigidly(rotation, translation)
    start = RRF_FIRMWARE.nominal(kossel)
    fit = fit_rrf(printer, start, kossel.step_distance, WORKSPACE)
    # the bed rises toward +x (tan 0.05 deg) and +y (tan 0.1 deg): RRF raises Z there (positive tilts)
    assert np.all(fit.values.tilt > 0.5 * np.tan(np.radians([0.05, 0.1])))
    klipper = fit_klipper(printer, KLIPPER.nominal(kossel), kossel.step_distance, WORKSPACE)
    assert fit.after.max_3d < 0.15 * fit.before.max_3d and fit.after.max_3d < klipper.after.max_3d
    assert "M665 Z" in fit.held
    assert abs(np.mean(fit.values.endstop_adjustment)) < 1e-12  # normalised as RRF leaves them


def test_fit_on_simulated_printers_beats_the_start(kossel):
    start = RRF_FIRMWARE.nominal(kossel)
    for seed in (31, 32):
        truth = random_true_printer(kossel, np.random.default_rng(seed), typical_kit()).geometry
        fit = RRF_FIRMWARE.fit(truth, start, kossel.step_distance, WORKSPACE)
        assert fit.after.max_3d < 0.25 * fit.before.max_3d
        assert error_stats(truth, fit.values, kossel.step_distance, WORKSPACE).max_3d == pytest.approx(
            fit.after.max_3d, abs=1e-9
        )


@pytest.mark.slow
@pytest.mark.parametrize("seed", [501, 502, 503, 504, 505])
def test_figures_on_fresh_printers(kossel, seed):
    rrf = RRF_FIRMWARE.nominal(kossel)
    step = kossel.step_distance
    plan = plan_object(kossel, rrf)
    rng = np.random.default_rng(seed)
    truth = random_true_printer(kossel, rng, typical_kit()).geometry
    probe = probe_heights(truth, rrf, step, plan.probe[:, :2], PROBE_SIGMA, rng)
    distances = printed_distances(truth, rrf, step, plan.pair_positions, 0.02, rng)
    result = identify_printer(
        kossel.geometry(),
        plan_measurements(rrf, step, plan, probe, distances),
        "printer",
        method="iterated",
        tolerances=Tolerances.printer_kit(),
    )
    grid = printable_grid(WORKSPACE)

    def part(errors):
        return float(np.linalg.norm(less_bed_motion(grid, errors)[0], axis=1).max())

    before = part(nozzle_positions(truth, rrf, step, grid) - grid)
    commands = corrected_targets(result.geometry, RRF_FIRMWARE.controller(rrf, step), grid).commands
    after = part(nozzle_positions(truth, rrf, step, commands) - grid)
    assert after <= 0.05 and after <= 0.1 * before
    exported = RRF_FIRMWARE.fit(
        result.geometry, rrf, step, WORKSPACE, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT
    )
    best = RRF_FIRMWARE.fit(truth, rrf, step, WORKSPACE, first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)
    assert (
        error_stats(truth, exported.values, step, WORKSPACE).max_3d
        <= 1.25 * error_stats(truth, best.values, step, WORKSPACE).max_3d + 0.01
    )


def test_klipper_configs_stay_klippers():
    assert config_firmware(Path(__file__).resolve().parent / "data" / "klipper" / "printer.cfg") is KLIPPER


def test_corrected_targets_through_a_tilted_config_land_on_the_targets(kossel):
    rrf = load_rrf(DATA / "config.g")  # tilt, endstop adjustments, corrections, per-tower diagonals
    truth = random_true_printer(kossel, np.random.default_rng(3), typical_kit()).geometry
    grid = printable_grid(WORKSPACE)
    commands = corrected_targets(truth, RRF_FIRMWARE.controller(rrf, kossel.step_distance), grid).commands
    landed = nozzle_positions(truth, rrf, kossel.step_distance, commands)
    assert_allclose(landed, grid, atol=1e-6, rtol=0)
