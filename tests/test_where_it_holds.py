"""Issue 38: a printer's calibration knows where it holds, and corrects only there.

The exact sensitivities against finite differences through the exact kinematics; the σ grid and its
weights; the controller's frame along the bed; the noise factors the evidence finds; a poor fit
refused; real saved runs of one printer agreeing where they correct; simulated printers measured the
way Klipper measures, against Klipper's own values (seeds no figure was tuned on).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from script_module import load_script as load_script_named

from deltacal.calibration import Calibration
from deltacal.cli.main import main
from deltacal.controller import corrected_targets, weighted_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.errormodels import get_model
from deltacal.exceptions import InputError, PoorFitError, UnreachableError
from deltacal.geometry import Tolerances, Workspace
from deltacal.holds import (
    UNREACHED,
    WhereItHolds,
    bed_points,
    correction_weight,
    in_plane_motion,
    significance_weight,
)
from deltacal.io import load_calibration, save_calibration
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.identification.errormodels import bed_modes, firmware_modes
from deltacal.printer.identification.evidence import noise_factors
from deltacal.printer.identification.fit import determined_values, identify_printer
from deltacal.printer.identification.where import correction_sensitivity, point_rows, readings_at
from deltacal.robots import load_robot

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "where_it_holds.py"
KOSSEL = load_printer(ROOT / "deltacal" / "models" / "kossel.toml")
REAL = ROOT / "tests" / "data" / "klipper" / "real"


def load_script():
    return load_script_named(SCRIPT.stem)


@pytest.fixture(scope="module")
def script():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield load_script()


@pytest.fixture(scope="module")
def run_a1(script):
    """Printer A's first saved run, identified as ``identify`` does."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = script.read_real_run(REAL / "flsun-v400-a-run1.cfg")
        result = identify_printer(run.nominal, run.data, workspace=Workspace(152.0, 379.0, 379.0),
                                  calibrated_start=True)
    return run, result


# ------------------------------------------------------------- exact sensitivities (finite differences)
def test_the_nozzle_sensitivity_is_the_exact_kinematics_derivative():
    """point_rows' J δθ against the nozzle moved by δθ through the exact forward kinematics."""
    rng = np.random.default_rng(3801)
    model = get_model("printer")
    geometry = KOSSEL.geometry()
    points = np.column_stack([rng.uniform(-60, 60, (8, 2)), rng.uniform(0.2, 150, 8)])
    q = readings_at(geometry, points)
    nozzle, J = point_rows(geometry, model, q, geometry.tool)
    assert_allclose(nozzle, points, atol=1e-9)
    for _ in range(3):
        delta = 1e-6 * model.prior_sigma(Tolerances.printer_kit()) * rng.normal(size=model.size)
        moved = model.apply(geometry, delta)
        fd = exact.forward(moved, q).point(moved.tool) - nozzle
        assert_allclose(J @ delta, fd, rtol=0, atol=1e-3 * np.max(np.abs(fd)))


def test_the_corrections_sensitivity_has_no_shift_or_turn_along_the_first_layer():
    """J' (the controller's frame): over the first layer, no parameter's mean in-plane motion."""
    model = get_model("printer")
    geometry = KOSSEL.geometry()
    points = bed_points(115.0)
    J, ok = correction_sensitivity(geometry, model, points, 115.0)
    assert ok.all()
    A = in_plane_motion(points)[:, :2].reshape(-1, 3)
    motion = np.linalg.lstsq(A, J[:, :2].reshape(-1, model.size), rcond=None)[0]
    assert np.max(np.abs(motion)) < 1e-9
    _, raw = point_rows(geometry, model, readings_at(geometry, points), geometry.tool)
    before = np.linalg.lstsq(A, raw[:, :2].reshape(-1, model.size), rcond=None)[0]
    assert np.max(np.abs(before)) > 0.5  # the parameters did move the layer along the bed before
    assert_allclose(J[:, 2], raw[:, 2], atol=1e-12)  # and nothing vertical is taken out


def test_the_bed_and_firmware_modes_move_the_printer_as_they_say():
    """A bed tilt mode turns the printer rigidly; a firmware mode moves the nozzle as Klipper's value does."""
    model, firmware = get_model("printer"), get_model("klipper")
    geometry = KOSSEL.geometry()
    q = readings_at(geometry, np.array([[50.0, 20.0, 0.2], [-30.0, 60.0, 40.0], [0.0, -80.0, 100.0]]))
    base = exact.forward(geometry, q).point(geometry.tool)
    eps = 1e-5
    modes = bed_modes(model, geometry)
    for k, axis in enumerate(np.eye(3)[:2]):
        turned = geometry.moved_rigidly(_rotation(axis, eps), np.zeros(3))
        want = exact.forward(turned, q).point(geometry.tool) - base
        got = exact.forward(model.apply(geometry, eps * modes[:, k]), q).point(geometry.tool) - base
        assert_allclose(got, want, rtol=0, atol=1e-3 * np.max(np.abs(want)))
    raised = exact.forward(model.apply(geometry, eps * modes[:, 2]), q).point(geometry.tool) - base
    assert_allclose(raised, np.tile([0.0, 0.0, eps], (3, 1)), atol=1e-9)
    values = firmware_modes(model, geometry)
    for k, name in enumerate(("delta_radius", "arm_length_b", "endstop_c")):
        column = ("delta_radius", "angle_a", "angle_b", "arm_length_a", "arm_length_b", "arm_length_c",
                  "endstop_a", "endstop_b", "endstop_c").index(name)
        step = np.zeros(firmware.size)
        step[firmware.names.index(name)] = 1e-4
        want = exact.forward(firmware.apply(geometry, step), q).point(geometry.tool) - base
        got = exact.forward(model.apply(geometry, 1e-4 * values[:, column]), q).point(geometry.tool) - base
        assert_allclose(got, want, rtol=0, atol=2e-3 * np.max(np.abs(want)) + 1e-9), (k, name)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


# ----------------------------------------------------------------------------------------- the σ grid
def _grid(rng) -> WhereItHolds:
    radius, azimuth, height = WhereItHolds.grid(120.0, 200.0)
    shape = (radius.size, azimuth.size, height.size)
    horizontal = rng.uniform(0.01, 0.2, shape)
    horizontal[0] = horizontal[0, :1]  # the centre is one point
    vertical = rng.uniform(0.005, 0.1, shape)
    vertical[0] = vertical[0, :1]
    values = {"scale_a": 0.5, "endstop_a": 0.1}
    return WhereItHolds(radius, azimuth, height, horizontal, vertical, 5.0, values)


def test_the_grid_is_its_nodes_at_its_nodes_and_continuous_between():
    rng = np.random.default_rng(3802)
    holds = _grid(rng)
    nodes = WhereItHolds.nodes(holds.radius, holds.azimuth, holds.height)
    sigma = holds.sigma(nodes)
    assert_allclose(sigma[:, 0], holds.horizontal.ravel(), atol=1e-12)
    assert_allclose(sigma[:, 1], holds.vertical.ravel(), atol=1e-12)
    # along a path crossing cells, the edge (r > 120, z < 0, z > 200) and the azimuth's wrap: no jump,
    # the largest step between points shrinks with the points' spacing (a jump would stay)
    largest = []
    for n in (2001, 20001):
        t = np.linspace(0.0, 1.0, n)
        path = np.column_stack([150.0 * np.cos(7.0 * t) * t, 150.0 * np.sin(7.0 * t) * t, -10.0 + 240.0 * t])
        largest.append(np.max(np.abs(np.diff(holds.sigma(path), axis=0))))
    assert largest[1] < 0.15 * largest[0]


def test_the_weights_are_continuous_one_where_the_correction_holds_and_zero_beyond_the_bound():
    sigma = np.linspace(0.0, 0.1, 100001)
    w = correction_weight(sigma, 0.05)
    assert np.all(w[sigma <= 0.025] == 1.0) and np.all(w[sigma >= 0.05] == 0.0)
    assert np.all(np.diff(w) <= 0.0) and np.max(np.abs(np.diff(w))) < 1e-4
    assert correction_weight(np.array([np.nan, np.inf]), 0.05).tolist() == [0.0, 0.0]
    size = np.linspace(0.0, 0.1, 1001)
    s = significance_weight(size, np.full(size.size, 0.02))
    assert np.all(s[size <= 0.02] == 0.0) and np.all(np.diff(s) >= 0.0) and np.all(s < 1.0)
    # beyond twice its σ, what stands out of 1.5 σ is applied
    assert_allclose((s * size)[size >= 0.04], size[size >= 0.04] - 0.03, rtol=0.0, atol=1e-12)


def test_the_applied_correction_never_grows_faster_than_the_correction():
    """Issue 46: the part of a correction applied along the bed, significance_weight(c, σ) |c|, has a
    slope in |c| between 0 and 1 and a continuous one (its second difference bounded): a correction
    growing across the bed past its σ is eased in, not switched on (the smooth step from 1 to 2 σ
    applied 2 σ over σ: a slope of 2.75)."""
    sigma = 0.02
    size = np.linspace(0.0, 0.2, 200001)
    applied = significance_weight(size, np.full(size.size, sigma)) * size
    slope = np.diff(applied) / np.diff(size)
    assert np.all(slope >= -1e-9) and np.max(slope) <= 1.0 + 1e-6
    assert np.max(np.abs(np.diff(slope))) < 1e-3  # no kink: the slope changes by a step's share only


def test_the_grid_reads_back_from_a_calibration_file(tmp_path, run_a1):
    _, result = run_a1
    path = tmp_path / "cal.toml"
    save_calibration(result, path)
    read = load_calibration(path).holds
    holds = result.holds
    assert read is not None and holds is not None
    assert_allclose(read.horizontal, holds.horizontal, atol=1e-7)
    assert_allclose(read.vertical, holds.vertical, atol=1e-7)
    assert_allclose(read.azimuth, holds.azimuth, atol=1e-12)
    assert read.values.keys() == holds.values.keys() and read.measured_top == holds.measured_top
    path.write_text(path.read_text().replace("measured_top_mm", "measured_tip_mm"))
    (tmp_path / "t.csv").write_text("x_mm,y_mm,z_mm\n0,0,1\n")
    assert main(["compensate", str(path), str(tmp_path / "t.csv"), "-o", str(tmp_path / "o.csv")]) == 1


def test_a_node_out_of_reach_is_finite_and_no_correction_there():
    holds = _grid(np.random.default_rng(3803))
    horizontal = holds.horizontal.copy()
    horizontal[-1, :, -1] = np.inf
    far = dataclasses.replace(holds, horizontal=horizontal)
    assert np.all(far.horizontal[-1, :, -1] == UNREACHED)
    assert far.weights(np.array([[120.0, 0.0, 200.0]]))[0, 0] == 0.0


# ---------------------------------------------------------------------- the controller's frame, the blend
def test_the_identified_printer_in_the_controllers_frame_predicts_the_same_measurements(run_a1):
    run, result = run_a1
    controller = KLIPPER.controller(load_klipper(REAL / "flsun-v400-a-run1.cfg"), run.step)
    aligned = aligned_to_controller(result.geometry, controller, 120.0)
    for readings in (run.data.probe, run.data.pairs.reshape(-1, 3)):
        ours, theirs = (exact.forward(g, readings).point(g.tool) for g in (result.geometry, aligned))
        assert_allclose(ours[:, 2], theirs[:, 2], atol=1e-9)  # heights
    pairs = [exact.forward(g, run.data.pairs.reshape(-1, 3)).point(g.tool).reshape(-1, 2, 3)
             for g in (result.geometry, aligned)]
    lengths = [np.linalg.norm(p[:, 0] - p[:, 1], axis=1) for p in pairs]
    assert_allclose(lengths[0], lengths[1], atol=1e-9)
    points = bed_points(120.0)
    moved = exact.forward(aligned, controller.inverse(points)).point(aligned.tool) - points
    A = in_plane_motion(points)[:, :2].reshape(-1, 3)
    motion = np.linalg.lstsq(A, moved[:, :2].reshape(-1), rcond=None)[0]
    assert np.max(np.abs(motion)) < 1e-6  # no shift, no turn left
    before = exact.forward(result.geometry, controller.inverse(points)).point(aligned.tool) - points
    assert np.max(np.abs(np.linalg.lstsq(A, before[:, :2].reshape(-1), rcond=None)[0][:2])) > 0.1


def test_commands_are_the_controllers_own_where_the_calibration_does_not_hold(run_a1):
    run, result = run_a1
    calibration = Calibration.from_result(result)
    controller = KLIPPER.controller(load_klipper(REAL / "flsun-v400-a-run1.cfg"), run.step)
    # the heights where the probe measured them (its z_offset is 18 mm), then heights no measurement saw
    targets = np.array([[0.0, 0.0, 18.0], [60.0, -40.0, 18.0], [0.0, 0.0, 150.0], [80.0, 50.0, 300.0]])
    held = weighted_targets(calibration, controller, targets)
    assert np.all(held.weights[:2, 1] == 1.0)
    assert np.all(held.weights[2:] == 0.0)
    assert_allclose(held.commands[2:], targets[2:], atol=0.0)
    everywhere = corrected_targets(calibration, controller, targets, bound=math.inf).commands
    assert np.max(np.abs(everywhere[2:, 2] - targets[2:, 2])) > 0.01  # what it would have guessed
    assert_allclose(held.commands[:2, 2], everywhere[:2, 2], atol=1e-12)
    with pytest.raises(UnreachableError, match="does not hold") as caught:
        corrected_targets(calibration, controller, targets, refuse=True)
    assert caught.value.reason == UnreachableError.NOT_HELD and {2, 3} <= set(caught.value.indices)
    blended = weighted_targets(calibration, controller, targets, bound=1.0)  # a looser bound: more corrected
    assert blended.weights[2, 1] > 0.0


# ------------------------------------------------------------------- along the bed, what is determined
def test_the_determined_values_keep_exactly_the_combinations_a_third_as_uncertain():
    """Each combination's σ after the measurements from the posterior itself, not from the SVD's formula."""
    rng = np.random.default_rng(3806)
    n = 12
    factor = np.linalg.cholesky(np.diag(rng.uniform(0.1, 2.0, n)) + 0.05 * np.ones((n, n)))
    # singular values in prior units spread from 0.1 to 30 (some combinations barely seen)
    U, _ = np.linalg.qr(rng.normal(size=(40, n)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    s = np.geomspace(0.1, 30.0, n)
    W = U @ np.diag(s) @ V.T @ np.linalg.inv(factor)
    values = factor @ rng.normal(size=n)
    kept = determined_values(values, W, factor)
    posterior = np.linalg.inv(np.eye(n) + (W @ factor).T @ (W @ factor))  # in prior units
    u, u_kept = (np.linalg.solve(factor, v) for v in (values, kept))
    for k in range(n):
        v = V[:, k]
        ratio = math.sqrt(v @ posterior @ v)  # the prior's σ along v is 1
        if ratio <= 1.0 / 3.0:
            assert v @ u_kept == pytest.approx(v @ u, abs=1e-9)
        else:
            assert abs(v @ u_kept) < 1e-9
    assert 0 < int(np.sum(s >= math.sqrt(8.0))) < n  # both kinds are there
    assert_allclose(determined_values(values, 1e6 * W, factor), values, atol=1e-9)  # all determined
    assert_allclose(determined_values(values, np.zeros_like(W), factor), 0.0, atol=0.0)  # none


@pytest.mark.slow
def test_along_the_bed_a_saved_calibration_follows_what_its_measurements_determine(tmp_path, run_a1):
    """Klipper's own saved run: along the bed the printer of what is determined; in height the whole fit.

    The file keeps it (``[holds.along_bed]``); a correction's x, y are that printer's exact commands,
    its z the identified printer's, each in the controller's frame.
    """
    run, result = run_a1
    along = result.holds.along_bed
    assert along is not None
    path = tmp_path / "cal.toml"
    save_calibration(result, path)
    calibration = load_calibration(path)
    read = calibration.holds.along_bed
    assert read is not None
    readings = run.data.pairs.reshape(-1, 3)
    assert_allclose(exact.forward(read, readings).point(read.tool),
                    exact.forward(along, readings).point(along.tool), atol=1e-6)  # as written
    controller = KLIPPER.controller(load_klipper(REAL / "flsun-v400-a-run1.cfg"), run.step)
    targets = np.column_stack([np.random.default_rng(3807).uniform(-80, 80, (20, 2)), np.full(20, 18.0)])
    whole = corrected_targets(calibration, controller, targets, bound=math.inf).commands
    for geometry, columns in ((calibration.geometry, [2]), (read, [0, 1])):
        exact_commands = controller.forward(exact.inverse(aligned_to_controller(geometry, controller, 152.0),
                                                          targets))
        assert_allclose(whole[:, columns], exact_commands[:, columns], atol=1e-9)
    plain = dataclasses.replace(calibration, holds=dataclasses.replace(calibration.holds, along_bed=None))
    alone = corrected_targets(plain, controller, targets, bound=math.inf).commands
    assert_allclose(alone[:, 2], whole[:, 2], atol=1e-9)
    assert np.max(np.abs(alone[:, :2] - whole[:, :2])) > 1e-4  # the two printers differ along the bed
    rotary = load_robot(ROOT / "deltacal" / "models" / "bai2015.toml").geometry()
    pasted = dataclasses.replace(calibration, holds=dataclasses.replace(calibration.holds, along_bed=rotary))
    kinds = r"\[holds.along_bed\] is a rotary Delta's geometry, \[geometry\] a linear Delta printer's"
    with pytest.raises(InputError, match=kinds):
        pasted.check()
    fresh = identify_printer(run.nominal, run.data, workspace=Workspace(152.0, 379.0, 379.0))
    assert fresh.holds.along_bed is None  # not Klipper's own calibration: the whole fit everywhere
    path.write_text(path.read_text().replace("[holds.along_bed]", "[holds.along_bed_x]"))
    (tmp_path / "t.csv").write_text("x_mm,y_mm,z_mm\n0,0,1\n")
    assert main(["compensate", str(path), str(tmp_path / "t.csv"), "-o", str(tmp_path / "o.csv")]) == 1


# ----------------------------------------------------------------------------------------------- statistics
def test_the_noise_factors_are_each_kinds_own_misfit():
    """Heights at their σ, distances three times theirs: the distances' factor alone rises (to about 9)."""
    rng = np.random.default_rng(3804)
    n, m, p = 200, 200, 20
    W = rng.normal(size=(n + m, p))
    prior = np.full(p, 0.5)
    kind = np.repeat([0, 1], [n, m])
    y = W @ (prior * rng.normal(size=p)) + rng.normal(size=n + m) * np.where(kind == 1, 3.0, 1.0)
    factor, _ = noise_factors(y, W, prior, kind)
    assert factor[0] < 1.3 and 6.0 < factor[-1] < 12.0


def test_a_misfit_raises_the_noise_not_the_tolerances(run_a1):
    """A's distances read with 0.08 mm of scatter (4 σ): their σ rises, the tolerances' scale does not."""
    run, result = run_a1
    scatter = 0.08 * np.random.default_rng(3805).normal(size=run.data.distance.size)
    read = dataclasses.replace(run.data, distance=run.data.distance + scatter)
    moved = identify_printer(run.nominal, read, workspace=Workspace(152.0, 379.0, 379.0),
                             calibrated_start=True)
    assert any("distances' σ taken as" in h for h in moved.hints), moved.hints
    assert float(moved.hints[0].split()[5]) < 1.5 * float(result.hints[0].split()[5])


@pytest.mark.long
def test_a_poor_fit_is_refused_in_one_line_naming_the_causes(tmp_path, capsys):
    """A printer's saved run whose probe heights jump 0.6 mm after the third point: a bed that moved."""
    run = REAL / "flsun-v400-a-run1.cfg"
    out, cal = tmp_path / "v400", tmp_path / "cal.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["import", str(run), "-o", str(out)]) == 0
    rows = (out / "probe.csv").read_text().splitlines()
    for k in range(4, len(rows)):  # the trigger 0.6 mm higher from the fourth point on
        cells = rows[k].split(",")
        cells[3] = repr(float(cells[3]) + 0.6)
        rows[k] = ",".join(cells)
    (out / "probe.csv").write_text("\n".join(rows) + "\n")
    args = ["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
            "--controller", str(run), "-o", str(cal)]
    assert main(args) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "poor fit" in err and "a bed that moved" in err
    assert "--accept-poor-fit" in err and not cal.exists()
    assert main([*args, "--accept-poor-fit"]) == 0
    assert "poor fit accepted" in capsys.readouterr().out


@pytest.mark.long
def test_poor_fit_is_a_library_refusal_too(run_a1):
    run, _ = run_a1
    jump = np.r_[0.0, 0.0, 0.0, 0.6, 0.6, 0.6, 0.6]
    data = dataclasses.replace(run.data, trigger_height=run.data.trigger_height + jump)
    with pytest.raises(PoorFitError, match="a wrong trigger height"):
        identify_printer(run.nominal, data, calibrated_start=True)
    kept = identify_printer(run.nominal, data, accept_poor_fit=True, calibrated_start=True)
    assert any("poor fit accepted" in w for w in kept.warnings)


# ------------------------------------------------------------------------------ the command line's words
@pytest.mark.long
def test_identify_says_where_it_holds_and_export_keeps_what_it_does_not_determine(tmp_path, capsys):
    run = REAL / "flsun-v400-a-run2.cfg"
    out, cal, exported = tmp_path / "v400", tmp_path / "cal.toml", tmp_path / "calibrated.cfg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["import", str(run), "-o", str(out)]) == 0
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(run), "-o", str(cal)]) == 0
    said = capsys.readouterr().out
    assert "where it holds: the nozzle is known within 0.05 mm (σ) up to z = " in said
    assert "print the tall object (`deltacal plan --object`) to calibrate heights" in said
    # the firmware's values in its own words (printer.cfg's keys)
    assert "firmware values: the measurements determine the firmware's [printer] delta_radius" in said
    assert ("not [stepper_a] rotation_distance, [stepper_b] rotation_distance, [stepper_c] rotation_distance"
            in said)
    assert main(["report", str(cal), "-o", str(tmp_path / "report.html"), "--no-view", "--robot",
                 str(out / "printer.toml")]) == 0
    page = (tmp_path / "report.html").read_text()
    assert '<p id="holds"><b>Where it holds.</b> the nozzle is known within 0.05 mm' in page
    assert main(["export", str(cal), "--controller", "klipper", "--config", str(run), "--robot",
                 str(out / "printer.toml"), "-o", str(exported)]) == 0
    said = capsys.readouterr().out
    assert "where the calibration holds (σ within 0.05 mm)" in said
    assert "kept at the --config values (the measurements do not determine them" in said
    assert "tolerances): [stepper_a] rotation_distance" in said
    written = exported.read_text()
    assert written.count("rotation_distance: 40.000000") == 3  # each tower's as it was
    endstops = [float(line.split(":")[1]) for line in written.splitlines()
                if line.startswith("position_endstop")]
    assert np.max(np.abs(np.array(endstops) - load_klipper(run).position_endstop)) > 0.01  # refitted


def test_compensate_says_where_it_corrected_and_refuses_when_asked(tmp_path, capsys):
    run = REAL / "flsun-v400-b-run1.cfg"
    out, cal = tmp_path / "v400", tmp_path / "cal.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["import", str(run), "-o", str(out)]) == 0
    assert main(["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(run), "-o", str(cal)]) == 0
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,0.2\n20,10,0.4\n0,0,120\n")
    capsys.readouterr()
    assert main(["compensate", str(cal), str(targets), "--controller", str(run), "-o",
                 str(tmp_path / "c.csv")]) == 0
    said = capsys.readouterr().out
    assert "corrections applied where their σ is at most 0.025 mm" in said and "--sigma-bound" in said
    rows = (tmp_path / "c.csv").read_text().splitlines()
    assert rows[3].split(",")[3:] == ["0.000000000", "0.000000000", "120.000000000"]  # the controller's own
    assert main(["compensate", str(cal), str(targets), "--controller", str(run), "-o",
                 str(tmp_path / "r.csv"), "--refuse-unheld"]) == 1
    err = capsys.readouterr().err.strip()  # B's probe was 18 mm up: even its first layer is not wholly held
    assert len(err.splitlines()) == 1 and "t.csv: line 2 (data row 1)" in err and "does not hold" in err
    assert "3 targets in all, lines 2, 3, 4" in err and not (tmp_path / "r.csv").exists()


# ------------------------------------------------------------------------------------ the "Done when"
@pytest.mark.long
@pytest.mark.parametrize("printer", ["a", "b"])
def test_one_printers_saved_runs_agree_where_they_correct(script, printer):
    """Each run identified alone, the same targets through the first run's printer.cfg (Done when)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = script.real_printer(script.PRINTERS[printer])
    for z, apart in found["largest_disagreement_where_both_correct_mm"].items():
        assert apart <= 0.15, (z, apart)
    for row in found["runs"]:
        assert row["first_layer_weights"]["vertical"] > 0.5, row["run"]  # it corrects the first layer
        assert row["first_layer_xy_move_mm"] <= 0.05, row["run"]  # and does not move the part


#: Simulated printers no figure was tuned on (scripts/where_it_holds.py's are 38000 and 38100).
FRESH_SEEDS = {"typical kit": 38600, "well built": 38700}
#: What the issue asks and this work does not reach, as measured on these printers (docs/printers.md,
#: "What is left"): a strict xfail turns into a failure the day it holds.
NOT_REACHED = {
    ("typical kit", "probe bias"): "first layer 0.028 mm against Klipper's 0.028 (limit 0.025): the biased "
                                   "probe is followed",
    ("well built", "plain"): "first layer 0.019 mm against Klipper's 0.017 (limit 0.017): seven heights, "
                             "the noise floor",
    ("well built", "probe bias"): "first layer 0.034 mm against Klipper's 0.032 (limit 0.028)",
    ("well built", "bed bowl"): "first layer 0.021 mm against Klipper's 0.019 (limit 0.018)",
    ("well built", "object small"): "first layer 0.018 mm against Klipper's 0.017 (limit 0.016)",
}


EFFECTS = ("plain", "probe bias", "bed bowl", "object small")


def _done_when(label: str, effect: str, reached: dict[tuple[str, str], str]):
    marks = [pytest.mark.slow]
    if (label, effect) in reached:
        marks.append(pytest.mark.xfail(strict=True, reason=reached[(label, effect)]))
    return pytest.param(label, effect, marks=marks, id=f"{label}-{effect}")


@pytest.fixture(scope="module")
def fresh(script, tmp_path_factory):
    """The mean figures of 3 fresh printers of a class and effect (each pair simulated once)."""
    found: dict[tuple[str, str], dict] = {}

    def summary(label: str, effect: str) -> dict:
        if (label, effect) not in found:
            folder = tmp_path_factory.mktemp("fresh")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rows = [script.simulated_printer(FRESH_SEEDS[label] + k, label, effect, folder)
                        for k in range(3)]
            found[(label, effect)] = script.summary(rows)
        return found[(label, effect)]

    return summary


@pytest.mark.parametrize("label, effect", [_done_when(label, effect, {}) for label in FRESH_SEEDS
                                           for effect in EFFECTS])
@pytest.mark.long
def test_klippers_data_alone_correct_no_worse_than_klippers_values(fresh, label, effect):
    """Simulated printers with only Klipper's saved data: never worse than its values, the part not moved.

    Issue 38's Done when, on the mean of 3 fresh printers: the corrected commands' 3-D max at z 0.2 /
    10 / 25 / 50 / 100 mm within 0.005 mm of Klipper's own values'; the first layer not moved along
    the bed by more than 0.05 mm.
    """
    summary = fresh(label, effect)
    klipper, corrected = summary["klipper"], summary["corrected"]
    for z, theirs in klipper["max_3d_mm"].items():
        assert corrected["max_3d_mm"][z] <= theirs + 0.005, (z, corrected["max_3d_mm"][z], theirs)
    assert corrected["first_layer_xy_move_mm"] <= 0.05


@pytest.mark.parametrize("label, effect", [_done_when(label, effect, NOT_REACHED) for label in FRESH_SEEDS
                                           for effect in EFFECTS])
@pytest.mark.long
def test_klippers_data_alone_give_a_better_first_layer(fresh, label, effect):
    """The same printers: the first layer's height error at most 0.8 times Klipper's + 0.003 mm."""
    summary = fresh(label, effect)
    first = summary["klipper"]["first_layer_height_error_mm"]
    assert summary["corrected"]["first_layer_height_error_mm"] <= 0.8 * first + 0.003, (summary, first)


#: Issue 46: fresh printers whose corrected commands, through a re-calibrated printer.cfg, stepped within
#: a layer (local error 0.019 / 0.020 / 0.014 mm above the printer.cfg's own with the smooth step of the
#: correction's significance between 1 and 2 σ).
LOCAL_CASES = (("typical kit", 38600, "object small"), ("well built", 38700, "object small"),
               ("well built", 38701, "plain"))


@pytest.mark.long
@pytest.mark.parametrize("label, seed, effect", LOCAL_CASES, ids=[f"{c[0]}-{c[2]}" for c in LOCAL_CASES])
def test_corrections_add_no_step_within_a_layer(script, tmp_path, label, seed, effect):
    """The local error (the change of the true 3-D error between targets 10 mm apart in a layer) of the
    corrected commands at most the printer.cfg's own + 0.01 mm at every layer from the first to z 100,
    through the printer.cfg it was identified with and through a re-calibrated one (issue 46)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = script.local_study(seed, label, effect, tmp_path)
    for route in ("own", "recalibrated"):
        figures = found[route]
        for z, own in figures["klipper"].items():
            assert figures["corrected"][z] <= own + 0.01, (route, z, figures["corrected"][z], own)


# ------------------------------------------------------------- one real printer's six saved runs (issue 46)
#: Printer A's runs that carry the printed object's distances (the other two are heights alone).
A_OBJECT_RUNS = ("flsun-v400-a-run1", "flsun-v400-a-run2", "flsun-v400-a-run3", "flsun-v400-a-run4")


def test_printer_a_has_six_distinct_saved_runs(script):
    """Six saved runs of one printer (same steps, same nominal), no two with the same probe positions."""
    runs = [script.read_real_run(path) for path in script.A_LIFE]
    assert len(runs) == 6 and [r.name for r in runs][1:5] == list(A_OBJECT_RUNS)
    for run in runs:
        assert_allclose(run.step, runs[-1].step, rtol=0, atol=0)
        assert len(run.data.trigger_height) == 7
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            assert not np.allclose(a.data.probe, b.data.probe, rtol=0, atol=1e-3), (a.name, b.name)
    assert [len(r.data.distance) for r in runs] == [0, 12, 12, 12, 12, 0]


@pytest.fixture(scope="module")
def a_life(script):
    """A's six runs, each identified alone, through its latest run's printer.cfg."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return script.real_printer(script.A_LIFE, through=script.A_LIFE[-1])


@pytest.mark.long
def test_printer_a_six_runs_never_move_the_part_and_its_object_runs_agree(a_life):
    """Through the latest printer.cfg: no run moves the part over 0.05 mm; the four runs with the
    printed object agree within 0.15 mm wherever two of them correct, and correct the first layer."""
    assert a_life["controller"] == "flsun-v400-a-heights-2023-05.cfg"
    for row in a_life["runs"]:
        assert row["first_layer_xy_move_mm"] <= 0.05, row["run"]
        if row["run"] in A_OBJECT_RUNS:
            assert row["first_layer_weights"]["vertical"] > 0.5, row["run"]
    for z, pairs in a_life["disagreement_where_both_correct_by_pair_mm"].items():
        for pair, apart in pairs.items():
            if all(name in A_OBJECT_RUNS for name in pair.split()):
                assert apart <= 0.15, (z, pair, apart)


@pytest.mark.long
def test_printer_a_six_runs_agree_in_each_part_where_both_correct_it(a_life):
    """All six, each part of the correction (along the bed, in height) where two runs both apply it: within
    0.15 mm (measured 0.043 / 0.072 mm at the first layer, 0.095 / 0.092 at z 10). A run from heights alone
    applies no correction along the bed: its x, y are the controller's own, not a correction of its own."""
    for z, parts in a_life["largest_disagreement_of_each_part_where_both_correct_it_mm"].items():
        for part, apart in parts.items():
            assert apart <= 0.15, (z, part, apart)


@pytest.mark.long
@pytest.mark.xfail(strict=True, reason=(
    "not reached (measured): A's two heights-alone runs correct the first layer with a mean vertical "
    "weight of 0.13 and 0.40 (their σ in height 0.04-0.05 mm between the centre and the ring of probe points:"
    " seven heights do not tell the bowl an arm error leaves there), and the 3-D commands of a run that "
    "corrects only heights differ from the object runs' by 0.30-0.34 mm at the first layer (its x, y are "
    "the controller's; each part where both correct it agrees within 0.095 mm)"))
def test_printer_a_six_runs_meet_the_done_when(a_life):
    for z, apart in a_life["largest_disagreement_where_both_correct_mm"].items():
        assert apart <= 0.15, (z, apart)
    for row in a_life["runs"]:
        assert row["first_layer_weights"]["vertical"] > 0.5, row["run"]
        assert row["first_layer_xy_move_mm"] <= 0.05, row["run"]
