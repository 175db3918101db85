"""Controllers (issue 22): corrected targets, the controller file, the offsets and limbs fits.

The controller is emulated here from the conventions' text ("Controllers"), sharing no code with
the package, and drives the Pinocchio ground truth: the true robot is a perturbed bai2015 robot.
"""

from __future__ import annotations

import math
import re
import tomllib

import numpy as np
import pytest
from conftest import MODELS, workspace_points, write_targets
from numpy.testing import assert_allclose
from scipy.optimize import least_squares

from deltacal import NominalDelta, Tolerances, UnreachableError, identify
from deltacal.cli import main
from deltacal.compensation import compensate
from deltacal.controller import Controller, corrected_targets, fit_controller
from deltacal.exceptions import GeometryError
from deltacal.io import (
    calibration_from_result,
    load_calibration,
    load_nominal,
    save_calibration,
    save_controller,
)
from deltacal.kinematics import closed_form, exact
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.observations import Measurements
from deltacal.planning import bai_poses
from deltacal.report.accuracy import GRID, workspace_slices
from deltacal.robots import load_controller

NOMINAL = MODELS / "bai2015.toml"
KEYS = ("limb_azimuth", "base_radius", "plate_radius", "arm_length", "rod_length", "joint_offset", "tool")


class SpecController:
    """A controller written from the conventions' text alone (section "Controllers").

    For a TCP target x the plate centre is p = x - tool; for limb i (r_i, t_i from phi_i), theta_i
    solves |b_i r_i + L_i (cos theta_i r_i - sin theta_i z) - (p + a_i r_i)| = l_i, the solution with
    the larger cos theta_i; the commanded reading is theta_i - o_i.
    """

    def __init__(self, azimuth_deg, b, a, L, l, offset_deg, tool):  # noqa: E741 (the spec's names)
        self.phi = np.radians(np.asarray(azimuth_deg, dtype=float))
        self.b, self.a, self.L, self.l = (np.asarray(v, dtype=float) for v in (b, a, L, l))
        self.o = np.radians(np.asarray(offset_deg, dtype=float))
        self.tool = np.asarray(tool, dtype=float)

    def readings(self, x: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(x) - self.tool
        out = np.empty(p.shape)
        for i in range(3):
            r = np.array([math.cos(self.phi[i]), math.sin(self.phi[i]), 0.0])
            d = p + self.a[i] * r - self.b[i] * r  # from the actuator axis to the rod's plate end
            # |L u - d|^2 = l^2 with u = cos θ r - sin θ z:  (d.r) cos θ - d_z sin θ = K
            dr, dz = d @ r, d[:, 2]
            K = (self.L[i] ** 2 + np.sum(d * d, axis=1) - self.l[i] ** 2) / (2.0 * self.L[i])
            rho = np.hypot(dr, dz)
            alpha = np.arctan2(-dz, dr)  # (d.r) cos θ - d_z sin θ = ρ cos(θ - α)
            gamma = np.arccos(K / rho)
            t1, t2 = alpha + gamma, alpha - gamma
            theta = np.where(np.cos(t1) >= np.cos(t2), t1, t2)
            out[:, i] = theta - self.o[i]
        return out

    @classmethod
    def of_file(cls, path) -> SpecController:
        """From a controller file's keys, read with tomllib (the conventions' key names)."""
        with open(path, "rb") as f:
            c = tomllib.load(f)["controller"]
        return cls(c["limb_azimuth_deg"], c["base_radius_mm"], c["plate_radius_mm"], c["arm_length_mm"],
                   c["rod_length_mm"], c["joint_offset_deg"], c["tool_mm"])


def same_angles(a: np.ndarray, b: np.ndarray, atol: float) -> None:
    assert_allclose((a - b + np.pi) % (2.0 * np.pi) - np.pi, 0.0, atol=atol)


def as_package(spec: SpecController, name: str = "") -> Controller:
    return Controller(spec.phi, spec.b, spec.a, spec.L, spec.l, spec.o, spec.tool, name)


#: A controller of a cell whose values are not the robot's (another tool, per-limb lengths, offsets).
CELL = SpecController([-90.2, 30.1, 149.9], [200.3, 199.8, 200.1], [51.0, 51.2, 50.9], [375.2, 374.9, 375.0],
                      [950.1, 949.8, 950.3], [0.4, -0.3, 0.2], [0.0, 0.0, -100.0])


@pytest.fixture(scope="module")
def robot(bai):
    """The true robot (100 mm tool), its Pinocchio model, and a calibration identified from poses of it."""
    rng = np.random.default_rng(2201)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng).with_tool([0.0, 0.0, -100.0])
    q = bai_poses(bai, 9).q
    pose = exact.forward(truth, q)
    meas = Measurements(q, pose.point(truth.tool) + rng.normal(0.0, 0.005, (len(q), 3)),
                        rotation_vector=pose.rotation_vector())
    result = identify(bai.geometry().with_tool(truth.tool), meas, "complete")
    return {"truth": truth, "multibody": DeltaMultibody(truth), "result": result,
            "calibration": calibration_from_result(result)}


# --------------------------------------------------------------------------- the model
@pytest.mark.parametrize("name", ["bai2015", "flexpicker"])
def test_nominal_controller_is_the_closed_form_robot_and_the_spec(name):
    nominal = load_nominal(MODELS / f"{name}.toml")
    rng = np.random.default_rng(2202)
    x = workspace_points(nominal, 2000, rng) + nominal.tool
    controller = Controller.from_geometry(nominal)
    assert_allclose(controller.inverse(x), closed_form.inverse(nominal, x - nominal.tool), atol=1e-9, rtol=0)
    spec = SpecController(np.degrees(nominal.limb_azimuth), *(np.full(3, v) for v in (
        nominal.base_radius, nominal.plate_radius, nominal.arm_length, nominal.rod_length)), [0, 0, 0],
        nominal.tool)
    same_angles(controller.inverse(x), spec.readings(x), 1e-9)
    assert_allclose(controller.forward(controller.inverse(x)), x, atol=1e-9, rtol=0)
    # the geometry built to the nominal values reads as the same controller
    again = Controller.from_geometry(nominal.geometry())
    for key in KEYS:
        assert_allclose(getattr(again, key), getattr(controller, key), atol=1e-12, rtol=0)


def test_a_per_limb_controller_follows_the_spec_and_its_forward_inverts_its_inverse(bai):
    rng = np.random.default_rng(2203)
    x = workspace_points(bai, 3000, rng) + CELL.tool
    controller = as_package(CELL)
    q = controller.inverse(x)
    same_angles(q, CELL.readings(x), 1e-9)
    assert_allclose(controller.forward(q), x, atol=1e-9, rtol=0)
    # knee out: the larger cos θ of the two solutions; here every arm is above its lower solution
    assert np.all(np.cos(q + CELL.o) > 0.0)


def test_an_identified_geometry_is_not_a_controller(robot):
    with pytest.raises(GeometryError, match="not of a controller's classical form"):
        Controller.from_geometry(robot["truth"])


# --------------------------------------------------------------------------- corrected targets
@pytest.mark.parametrize("spec", ["nominal", "cell"])
def test_corrected_targets_put_the_true_tcp_where_compensation_does(bai, robot, spec):
    """A spec-emulated controller fed the corrected targets commands compensate's joints (Pinocchio)."""
    controller = SpecController(np.degrees(bai.limb_azimuth), [200.0] * 3, [51.0] * 3, [375.0] * 3,
                                [950.0] * 3, [0, 0, 0], robot["truth"].tool) if spec == "nominal" else CELL
    rng = np.random.default_rng(2204)
    targets = workspace_points(bai, 25, rng) + robot["truth"].tool
    commands, readings = corrected_targets(robot["calibration"], as_package(controller), targets)
    q_controller = controller.readings(commands)
    q_joints = compensate(robot["calibration"].geometry, targets)
    same_angles(readings, q_joints, 1e-12)
    mb = robot["multibody"]
    where_joints = mb.forward(q_joints).point(robot["truth"].tool)
    where_controller = mb.forward(q_controller).point(robot["truth"].tool)
    assert np.max(np.linalg.norm(where_controller - where_joints, axis=1)) < 1e-6
    # and the calibration (noise 5 µm) puts both within a few hundredths of a mm of the targets,
    # while the targets sent as they are would leave millimetres
    assert np.max(np.linalg.norm(where_controller - targets, axis=1)) < 0.05
    raw = mb.forward(controller.readings(targets)).point(robot["truth"].tool)
    assert np.max(np.linalg.norm(raw - targets, axis=1)) > 1.0


def test_corrected_targets_on_a_robot_no_other_test_uses():
    """Odd azimuths, another size, a tool off the axis: the spec's controller puts the Pinocchio TCP on
    the targets (the calibration is the true geometry itself, so what is left is the solvers')."""
    nominal = NominalDelta(name="odd", base_radius=120.0, plate_radius=35.0, arm_length=250.0,
                           rod_length=600.0, rod_spacing=60.0, limb_azimuth=np.radians([10.0, 130.0, 250.0]),
                           tool=np.array([5.0, -3.0, -80.0]))
    truth = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(2207))
    spec = SpecController([10.0, 130.0, 250.0], [120.0] * 3, [35.0] * 3, [250.0] * 3, [600.0] * 3, [0, 0, 0],
                          nominal.tool)
    rng = np.random.default_rng(2208)
    radius, angle = 150.0 * np.sqrt(rng.random(30)), rng.uniform(0.0, 2.0 * np.pi, 30)
    z = rng.uniform(-620.0, -520.0, 30)
    targets = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), z])
    commands, _ = corrected_targets(truth, Controller.from_geometry(nominal), targets)
    reached = DeltaMultibody(truth).forward(spec.readings(commands)).point(truth.tool)
    assert np.max(np.linalg.norm(reached - targets, axis=1)) < 1e-6
    raw = DeltaMultibody(truth).forward(spec.readings(targets)).point(truth.tool)
    assert np.max(np.linalg.norm(raw - targets, axis=1)) > 0.5  # what the controller alone leaves


def test_targets_the_controller_model_cannot_command_are_refused_by_index(bai, robot):
    short = as_package(SpecController(np.degrees(bai.limb_azimuth), [200.0] * 3, [51.0] * 3, [375.0] * 3,
                                      [500.0] * 3, [0, 0, 0], robot["truth"].tool))
    tool = robot["truth"].tool
    targets = np.array([[0.0, 0.0, -1000.0], [0.0, 0.0, -800.0], [0.0, 0.0, -1100.0]]) + tool
    # the real robot reaches all three; at the second's joints (arms near horizontal, elbows 520 mm
    # from the axis) the controller's 500 mm rods cannot close its model
    compensate(robot["calibration"].geometry, targets)
    with pytest.raises(UnreachableError, match=r"controller's model.*index 1") as info:
        corrected_targets(robot["calibration"], short, targets)
    assert info.value.indices == [1] and info.value.reason == UnreachableError.CONTROLLER_OUT_OF_REACH
    # rods of (b - a) / cos 30° + L: at the arms' -30° the controller's rods fold back along its arms
    rod = 149.0 / math.cos(math.radians(30.0)) + 375.0
    folded = as_package(SpecController(np.degrees(bai.limb_azimuth), [200.0] * 3, [51.0] * 3, [375.0] * 3,
                                       [rod] * 3, [0, 0, 0], [0, 0, 0]))
    nominal = bai.geometry()
    targets = exact.forward(nominal, np.radians([[10.0] * 3, [-30.0] * 3])).point(nominal.tool)
    with pytest.raises(UnreachableError, match=r"singularity of the controller's model.*index 1") as info:
        corrected_targets(nominal, folded, targets)
    assert info.value.indices == [1] and info.value.reason == UnreachableError.CONTROLLER_SINGULAR
    corrected_targets(nominal, folded, targets[:1])
    with pytest.raises(UnreachableError) as info:  # beyond the real robot: compensate's own refusal
        corrected_targets(robot["calibration"], short, np.array([[0.0, 0.0, -850.0], [0.0, 0.0, -5000.0]]))
    assert info.value.indices == [1] and info.value.reason == UnreachableError.OUT_OF_REACH


# --------------------------------------------------------------------------- fits
def _grid(workspace, n: int) -> np.ndarray:
    points = np.concatenate([s.points.reshape(-1, 3) for s in workspace_slices(workspace, n)])
    return points[np.all(np.isfinite(points), axis=1)]


def test_the_offsets_fit_recovers_encoder_offsets(bai):
    offsets = np.radians([0.8, -1.1, 0.35])
    truth = bai.geometry().with_errors({f"limb{i + 1}.encoder_offset": v for i, v in enumerate(offsets)})
    fit = fit_controller(truth, Controller.from_geometry(bai), _grid(bai.workspace, 21), "offsets")
    assert fit.fitted == [f"limb{i}.joint_offset" for i in (1, 2, 3)] and fit.held == []
    assert_allclose(fit.controller.joint_offset, offsets, atol=1e-10, rtol=0)
    assert fit.max_error < 1e-6 and fit.max_error_before > 1.0
    # the spec's controller with these offsets drives the Pinocchio truth onto the targets
    spec = SpecController(np.degrees(bai.limb_azimuth), [200.0] * 3, [51.0] * 3, [375.0] * 3, [950.0] * 3,
                          np.degrees(fit.controller.joint_offset), bai.tool)
    targets = workspace_points(bai, 20, np.random.default_rng(2205))
    reached = DeltaMultibody(truth).forward(spec.readings(targets)).point(truth.tool)
    assert np.max(np.linalg.norm(reached - targets, axis=1)) < 1e-6


@pytest.mark.long
def test_the_limbs_fit_matches_an_independent_fit_on_the_true_robot(bai, robot):
    """scipy's least squares of the spec controller's values, the truth solved by Pinocchio."""
    truth, mb = robot["truth"], robot["multibody"]
    points = _grid(bai.workspace, 5)
    start = Controller.from_geometry(bai).replace(tool=truth.tool)
    fit = fit_controller(truth, start, points, "limbs")
    assert fit.held == [f"limb{i}.plate_radius" for i in (1, 2, 3)]  # b_i - a_i: b_i kept (earlier)
    assert len(fit.fitted) == 18

    def spec_of(v: np.ndarray) -> SpecController:
        phi, b, L, l_rod, o = v[:15].reshape(3, 5).T
        return SpecController(np.degrees(phi), b, [51.0] * 3, L, l_rod, np.degrees(o), v[15:])

    def residual(v: np.ndarray) -> np.ndarray:
        return (mb.forward(spec_of(v).readings(points)).point(truth.tool) - points).ravel()

    v0 = np.concatenate([np.column_stack([bai.limb_azimuth, [200.0] * 3, [375.0] * 3, [950.0] * 3,
                                          np.zeros(3)]).ravel(), truth.tool])
    # central differences: Pinocchio's closure to 1e-12 mm leaves forward differences too noisy for
    # the poorly conditioned directions (condition number about 2e4), and the fit stopping early
    independent = least_squares(residual, v0, jac="3-point", x_scale="jac", xtol=1e-15, ftol=1e-15,
                                gtol=1e-15)
    left = np.linalg.norm(independent.fun.reshape(-1, 3), axis=1)
    assert abs(fit.max_error - left.max()) < 1e-6
    assert abs(fit.rms_error - np.sqrt(np.mean(left**2))) < 1e-6
    ours = fit.controller
    phi, b, L, l_rod, o = independent.x[:15].reshape(3, 5).T
    assert_allclose(ours.limb_azimuth, phi, atol=1e-8, rtol=0)
    assert_allclose(ours.joint_offset, o, atol=1e-8, rtol=0)
    for got, want in ((ours.base_radius, b), (ours.arm_length, L), (ours.rod_length, l_rod),
                      (ours.tool, independent.x[15:])):
        assert_allclose(got, want, atol=1e-5, rtol=0)
    assert fit.max_error < 0.5 * fit.max_error_before


# --------------------------------------------------------------------------- files and command line
def test_controller_file_round_trip_and_robot_file_as_controller(tmp_path):
    controller = as_package(CELL, "cell")
    save_controller(tmp_path / "c.toml", controller)
    again = load_controller(tmp_path / "c.toml")
    for key in KEYS:
        assert_allclose(getattr(again, key), getattr(controller, key), atol=1e-15, rtol=1e-15)
    assert again.name == "cell"
    nominal = load_controller(NOMINAL)
    assert_allclose(nominal.base_radius, 200.0) and assert_allclose(nominal.joint_offset, 0.0)


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


@pytest.fixture(scope="module")
def files(tmp_path_factory, robot, bai):
    folder = tmp_path_factory.mktemp("controller")
    cal = folder / "cal.toml"
    save_calibration(robot["result"], cal)
    targets = folder / "targets.csv"
    values = workspace_points(bai, 40, np.random.default_rng(2206)) + robot["truth"].tool
    write_targets(targets, values)
    controller = folder / "cell.toml"
    save_controller(controller, as_package(CELL, "cell"))
    return {"folder": folder, "cal": cal, "targets": targets, "values": values, "controller": controller}


def test_compensate_controller_writes_the_corrected_targets(files, robot, capsys, tmp_path):
    out = tmp_path / "corrected.csv"
    code, stdout, err = run(capsys, "compensate", files["cal"], files["targets"], "--controller",
                            files["controller"], "-o", out)
    assert code == 0, err
    lines = out.read_text().splitlines()
    assert lines[0] == "x_mm,y_mm,z_mm,x_cmd_mm,y_cmd_mm,z_cmd_mm"
    assert [s.rsplit(",", 3)[0] for s in lines[1:]] == files["targets"].read_text().splitlines()[1:]
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    reached = robot["multibody"].forward(CELL.readings(table[:, 3:])).point(robot["truth"].tool)
    where_joints = robot["multibody"].forward(compensate(robot["calibration"].geometry, files["values"]))
    # the commands are written to 1e-9 mm: the TCP moves by about as much
    assert np.max(np.linalg.norm(reached - where_joints.point(robot["truth"].tool), axis=1)) < 1e-6
    assert "wrote 40 corrected targets" in stdout


def test_compensate_controller_refusals_in_one_line(files, capsys, tmp_path):
    out = tmp_path / "corrected.csv"
    out.write_text("earlier\n")
    bad = tmp_path / "bad.toml"
    bad.write_text(files["controller"].read_text().replace("arm_length_mm", "arm_lenght_mm"))
    code, _, err = run(capsys, "compensate", files["cal"], files["targets"], "--controller", bad, "-o", out)
    assert code == 1
    assert err.strip() == f"deltacal compensate: error: {bad}: key controller.arm_lenght_mm: unknown key"
    bad.write_text(files["controller"].read_text().replace("rod_length_mm = [", "rod_length_mm = [-"))
    code, _, err = run(capsys, "compensate", files["cal"], files["targets"], "--controller", bad, "-o", out)
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert f"{bad}: key controller.rod_length_mm: value 1, -950.1 mm, is not a length" in err
    # a target the real robot reaches but the cell's model cannot command: named by its line
    short = tmp_path / "short.toml"
    short.write_text(files["controller"].read_text().replace("rod_length_mm = [950.1, 949.8, 950.3]",
                                                              "rod_length_mm = [500.0, 500.0, 500.0]"))
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-1100\n0,0,-900\n")
    code, _, err = run(capsys, "compensate", files["cal"], targets, "--controller", short, "-o", out)
    assert code == 1
    assert err.strip() == (f"deltacal compensate: error: {targets}: line 3 (data row 2), columns x_mm..z_mm: "
                           "target [0.0, 0.0, -900.0] mm is not commandable through the controller's model "
                           "(its model has no knee-out assembly at the joints that put the robot there)")
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-1100\n0,0,-3000\n")  # beyond the real robot
    code, _, err = run(capsys, "compensate", files["cal"], targets, "--controller", short, "-o", out)
    assert code == 1 and "line 3 (data row 2)" in err and "out of reach of the robot" in err
    code, _, err = run(capsys, "compensate", files["cal"], targets, "--controller", short, "--method", "bai",
                       "-o", out)
    assert code == 2 and "--method applies to joint readings" in err
    code, _, err = run(capsys, "compensate", files["cal"], targets, "--controller", files["cal"], "-o", out)
    assert code == 1 and "not a controller file" in err and "key format" in err
    assert out.read_text() == "earlier\n"


@pytest.mark.parametrize("kind", ["offsets", "limbs"])
@pytest.mark.slow
def test_export_controller_writes_the_fit_and_says_what_it_leaves(files, robot, capsys, kind):
    out = files["folder"] / f"{kind}.toml"
    code, stdout, err = run(capsys, "export", files["cal"], "--controller", kind, "--robot", NOMINAL,
                            "-o", out)
    assert code == 0, err
    with open(out, "rb") as f:
        data = tomllib.load(f)
    assert data["format"] == "deltacal-controller-1" and data["fit"]["kind"] == kind
    left = re.search(r"max ([0-9.]+) mm, RMS ([0-9.]+) mm \(the nominal", stdout)
    assert left is not None
    assert abs(float(left.group(1)) - data["fit"]["max_error_mm"]) < 1e-4
    held = data["fit"]["held_at_nominal"]
    if kind == "limbs":
        assert held == [f"limb{i}.plate_radius" for i in (1, 2, 3)] and "held at nominal" in stdout
    else:
        assert held == []
    # what the file's [fit] says it leaves is what the spec controller leaves on the true robot
    # (to the identification's error: the fit is on the calibration, the check on the truth)
    # the fit's grid: the report's, of the robot file's workspace, shifted by the calibration's tool
    grid = _grid(load_nominal(NOMINAL).workspace, GRID) + robot["truth"].tool
    assert len(grid) == data["fit"]["points"]
    spec = SpecController.of_file(out)
    if kind == "offsets":  # the controller's tool is the calibration's (the limbs fit moves it)
        assert_allclose(spec.tool, robot["truth"].tool)
    reached = robot["multibody"].forward(spec.readings(grid)).point(robot["truth"].tool)
    error = np.linalg.norm(reached - grid, axis=1)
    # to the calibration's own error (noise 5 µm: 2.2 µm and 0.7 µm measured)
    assert abs(error.max() - data["fit"]["max_error_mm"]) < 0.01
    rms = np.sqrt(np.mean(error**2))
    assert abs(rms - data["fit"]["rms_error_mm"]) < 0.005



def test_export_controller_refusals(files, capsys, tmp_path):
    out = tmp_path / "c.toml"
    code, _, err = run(capsys, "export", files["cal"], "--controller", "offsets")
    assert code == 2 and "--controller needs -o CONTROLLER.toml" in err
    code, _, err = run(capsys, "export", files["cal"], "--mjcf", tmp_path / "r.xml", "-o", out)
    assert code == 2 and "-o applies to --controller" in err
    code, _, err = run(capsys, "export", files["cal"], "--controller", "both", "-o", out)
    assert code == 2 and "invalid choice: 'both'" in err
    # a geometry file has no nominal controller: the robot file is asked for
    from deltacal.io import save_geometry

    geometry = tmp_path / "g.toml"
    perturbed = load_nominal(NOMINAL).geometry().perturbed(Tolerances(), np.random.default_rng(1))
    save_geometry(perturbed, geometry)
    code, _, err = run(capsys, "export", geometry, "--controller", "offsets", "-o", out)
    assert code == 1
    assert err.strip() == (f"deltacal export: error: {geometry}: key nominal: the calibration's nominal "
                           "geometry is not a classical Delta (a geometry file?): give the robot file with "
                           "--robot")
    assert not out.exists()


def test_the_fit_jacobian_matches_finite_differences_through_the_exact_kinematics(bai, robot):
    from deltacal.controller.fit import _jacobian, parameter_names, tcp_errors, values_of, with_values

    truth = robot["truth"]  # plate tilted, tool 100 mm below: the lever term counts
    controller = as_package(CELL)
    points = workspace_points(bai, 40, np.random.default_rng(2209)) + truth.tool
    names = parameter_names("limbs")
    residual, J = _jacobian(truth, controller, points, names)
    assert_allclose(residual, tcp_errors(truth, controller, points).ravel(), atol=1e-12, rtol=0)
    start = values_of(controller, names)
    for k, name in enumerate(names):
        h = 1e-6 if name.endswith(("azimuth", "offset")) else 1e-3
        moved = []
        for sign in (1.0, -1.0):
            v = start.copy()
            v[k] += sign * h
            moved.append(tcp_errors(truth, with_values(controller, names, v), points).ravel())
        fd = (moved[0] - moved[1]) / (2.0 * h)
        assert_allclose(J[:, k], fd, atol=1e-5 * max(1.0, np.abs(fd).max()), rtol=0, err_msg=name)


def test_compensate_controller_with_targets_in_the_tracker_frame(bai, robot, capsys, tmp_path):
    """``--frame instrument``: the targets are taken to {O} as joint compensation takes them; the
    commands are in the controller's frame {O}."""
    truth = robot["truth"]
    q = bai_poses(bai, 9).q
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    rng = np.random.default_rng(2210)
    pose = exact.forward(truth, q)
    position = pose.point(truth.tool) @ turn.T + [1500.0, 200.0, 100.0] + rng.normal(0.0, 0.005, (len(q), 3))
    result = identify(bai.geometry().with_tool(truth.tool), Measurements(q, position), "complete",
                      frame="free")
    cal = tmp_path / "free.toml"
    save_calibration(result, cal)
    station = load_calibration(cal).instrument["default"]
    in_base = workspace_points(bai, 10, rng) + truth.tool
    targets = tmp_path / "t.csv"
    write_targets(targets, station.from_base(in_base))
    out = tmp_path / "c.csv"
    code, _, err = run(capsys, "compensate", cal, targets, "--controller", NOMINAL, "--frame", "instrument",
                       "-o", out)
    assert code == 0, err
    commands = np.loadtxt(out, delimiter=",", skiprows=1)[:, 3:]
    controller = Controller.from_geometry(bai).replace(tool=truth.tool)
    want = corrected_targets(load_calibration(cal), controller, station.to_base(station.from_base(in_base)))
    # the robot file's nominal controller has tool 0: the commands differ by the tool only
    assert_allclose(commands, want.commands - truth.tool, atol=2e-9, rtol=0)


@pytest.mark.long
def test_the_report_shows_what_each_controller_route_leaves(files, robot, tmp_path):
    from deltacal.report import accuracy_map, controller_routes, write_report

    calibration = load_calibration(files["cal"])
    workspace = load_nominal(NOMINAL).workspace
    amap = accuracy_map(calibration, workspace, truth=robot["truth"], n=9)
    routes = controller_routes(calibration, amap, robot["truth"])
    assert [r.name for r in routes.routes] == ["nominal", "offsets", "limbs"]
    points = np.concatenate([s.points.reshape(-1, 3) for s in amap.slices])
    points = points[np.all(np.isfinite(points), axis=1)]
    assert routes.points == len(points)
    start = Controller.from_geometry(calibration.nominal).replace(tool=amap.tool)
    fit = fit_controller(calibration, start, points, "limbs")
    limbs = routes.routes[2]
    assert limbs.max_error == pytest.approx(fit.max_error, abs=1e-9) and limbs.held == fit.held
    nominal, offsets = routes.routes[0], routes.routes[1]
    assert nominal.max_error > offsets.max_error > limbs.max_error
    for r in routes.routes:  # on the true robot: the same to the calibration's own error
        assert abs(r.true_max_error - r.max_error) < 0.01 and abs(r.true_rms_error - r.rms_error) < 0.005
    html = tmp_path / "r.html"
    write_report(files["cal"], html, truth=robot["truth"], truth_source="test", workspace=workspace,
                 view=False, grid=9)
    text = html.read_text()
    assert 'id="controller-routes"' in text
    assert "per-limb values fitted" in text and "corrected targets" in text
