"""Linear Delta printers (issue 24): the prismatic actuated chain in the geometry, the numpy exact
kinematics and the Pinocchio closed-loop model, and the printer's robot file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from deltacal.chains import carried_points, path_slopes, path_terms
from deltacal.exceptions import AssemblyError, GeometryError, InputError
from deltacal.geometry import DeltaGeometry, Tolerances, error_names, vector_from_rotation
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.robot import NominalLinearDelta
from deltacal.robots import load_robot
from deltacal.rotations import rotation_from_vector

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def printable_points(printer: NominalLinearDelta, n: int, rng: np.random.Generator) -> np.ndarray:
    """Random nozzle positions in the printable cylinder [mm]."""
    ws = printer.workspace
    assert ws is not None
    r = ws.radius * np.sqrt(rng.random(n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.column_stack([r * np.cos(a), r * np.sin(a), ws.height * rng.random(n)])


def perturbed(printer: NominalLinearDelta, seed: int) -> DeltaGeometry:
    """A real printer: towers placed and leaning, endstops, step distances, balls and rods off."""
    return printer.geometry().perturbed(Tolerances.printer_kit(), np.random.default_rng(seed))


# ------------------------------------------------------------------ the geometry
def test_nominal_printer_follows_the_conventions(kossel):
    """Carriage balls at R r_i + (H - s_i) z ± c/2 t_i; effector balls a r_i ± c/2 t_i in {E}."""
    g = kossel.geometry()
    assert g.joint == "prismatic" and g.is_perfect()
    s = np.array([[0.0, 10.0, 250.0], [3.5, 0.0, 120.25]])
    balls = g.arm_balls_in_base(s)
    r, t = kossel.radial, kossel.tangent
    half = 0.5 * kossel.rod_spacing
    for n in range(2):
        mid = kossel.tower_radius * r + (kossel.endstop_height - s[n])[:, None] * np.array([0.0, 0.0, 1.0])
        assert_allclose(balls[n, :, 0], mid + half * t, atol=1e-12)
        assert_allclose(balls[n, :, 1], mid - half * t, atol=1e-12)
    assert_allclose(g.plate_ball[:, 0], kossel.effector_radius * r + half * t, atol=1e-12)
    # a carriage slides without turning
    assert_allclose(g.arm_rotation(s)[1], g.actuator_rotation(), atol=0.0)


def test_chain_paths_and_slopes_by_finite_differences():
    rng = np.random.default_rng(3)
    theta = rng.uniform(-2.0, 2.0, 7)
    for joint in ("revolute", "prismatic"):
        f, g = path_terms(joint, theta)
        df, dg = path_slopes(joint, theta)
        h = 1e-6
        fp, gp = path_terms(joint, theta + h)
        fm, gm = path_terms(joint, theta - h)
        assert_allclose(df, (fp - fm) / (2 * h), atol=1e-9)
        assert_allclose(dg, (gp - gm) / (2 * h), atol=1e-9)
    with pytest.raises(ValueError, match="joint must be one of"):
        carried_points("spherical", np.zeros((3, 3)), np.tile(np.eye(3), (3, 1, 1)), np.zeros((3, 1, 3)))


def test_ball_and_elbow_velocities_match_finite_differences(kossel):
    g = perturbed(kossel, 1)
    q = np.array([[250.0, 260.0, 240.0], [180.0, 300.0, 210.0]])
    h = 1e-4
    for i in range(3):
        dq = np.zeros(3)
        dq[i] = h
        fd = (g.arm_balls_in_base(q + dq) - g.arm_balls_in_base(q - dq)) / (2 * h)
        assert_allclose(g.arm_ball_velocity(q)[:, i], fd[:, i], atol=1e-9)
        v = VirtualDelta.from_geometry(g)
        fd_e = (v.elbows(q + dq) - v.elbows(q - dq)) / (2 * h)
        assert_allclose(v.elbow_velocity(q)[:, i], fd_e[:, i], atol=1e-9)
    assert np.any(np.abs(g.joint_scale - 1.0) > 1e-4)  # the step distances are off: the scale is tested


def test_error_names_belong_to_their_chain(kossel):
    names = error_names("prismatic")
    assert "limb2.axis_tilt_t" in names and "limb3.joint_scale" in names
    assert "limb1.axis_tilt_z" not in names and len(names) == len(set(names)) == 3 * 21 + 3
    g = kossel.geometry()
    with pytest.raises(GeometryError, match="does not apply to a prismatic chain"):
        g.with_errors({"limb1.axis_tilt_z": 0.01})
    with pytest.raises(GeometryError, match="does not apply to a revolute chain"):
        load_nominal(MODELS / "bai2015.toml").geometry().with_errors({"limb1.joint_scale": 0.01})
    # a rotary printer's arm turns by its steps times a true step angle: a revolute joint scale is
    # its readings scaled (the exact kinematics, the closed form's inverse)
    rotary = load_nominal(MODELS / "bai2015.toml").geometry()
    scaled = DeltaGeometry(**{**_fields(rotary), "joint_scale": np.array([1.0, 1.001, 0.998])})
    q = np.radians([[10.0, 20.0, 30.0], [-5.0, 15.0, 40.0]])
    assert_allclose(exact.forward(scaled, q).position,
                    exact.forward(rotary, q * scaled.joint_scale).position, rtol=0, atol=1e-9)
    assert_allclose(VirtualDelta.from_geometry(scaled).inverse(exact.forward(scaled, q).position), q,
                    rtol=0, atol=1e-9)
    # a lean about t_i tilts tower i in its radial plane: its top moves outward, along r_i
    leaned = g.with_errors({"limb1.axis_tilt_t": 0.002})
    assert_allclose(leaned.axis_direction[0], [*(0.002 * kossel.radial[0, :2]), 1.0], atol=3e-6)
    errors = {"limb2.axis_tilt_r": 0.001, "limb2.axis_tilt_t": -0.002, "limb1.encoder_offset": 0.3,
              "limb3.joint_scale": 0.002, "limb1.arm_ball2.z": 0.04, "limb3.rod1.length": -0.07}
    found = g.with_errors(errors).deviation_from(g)
    assert list(found) == names
    for name, value in errors.items():
        assert found[name] == pytest.approx(value, abs=1e-5 if "tilt" in name else 1e-12)


def _fields(g: DeltaGeometry) -> dict:
    keys = ("limb_azimuth", "axis_point", "axis_direction", "encoder_offset", "arm_ball", "plate_ball",
            "rod_length", "tool", "points", "name", "chain", "joint_scale")
    return {k: getattr(g, k) for k in keys}


def test_moved_rigidly_moves_the_printer(kossel):
    g = perturbed(kossel, 2)
    R = rotation_from_vector(np.array([0.01, -0.02, 0.3]))
    t = np.array([5.0, -3.0, 2.0])
    moved = g.moved_rigidly(R, t)
    q = exact.inverse(g, printable_points(kossel, 20, np.random.default_rng(4)))
    before, after = exact.forward(g, q), exact.forward(moved, q)
    assert_allclose(after.position, before.position @ R.T + t, atol=1e-9)
    assert_allclose(moved.arm_balls_in_base(q), g.arm_balls_in_base(q) @ R.T + t, atol=1e-9)
    assert_allclose(moved.encoder_offset, g.encoder_offset, atol=0.0)


# ------------------------------------------------------------------ exact kinematics
def test_exact_kinematics_round_trip_on_a_real_printer(kossel):
    g = perturbed(kossel, 5)
    targets = printable_points(kossel, 300, np.random.default_rng(6))
    q = exact.inverse(g, targets)
    assert np.all(q > 0.0)  # every carriage below its endstop
    pose = exact.forward(g, q)
    assert_allclose(pose.point(g.tool), targets, atol=1e-9)
    assert np.max(np.degrees(pose.tilt())) > 0.01  # the real effector tilts
    # the nominal printer's virtual model is exact, both ways
    v = VirtualDelta.from_geometry(kossel.geometry())
    qn = v.inverse(targets - kossel.tool)
    assert_allclose(exact.inverse(kossel.geometry(), targets), qn, atol=1e-9)
    assert_allclose(v.forward(qn) + kossel.tool, targets, atol=1e-9)


def test_joint_jacobian_matches_finite_differences(kossel):
    g = perturbed(kossel, 7)
    q = exact.inverse(g, printable_points(kossel, 5, np.random.default_rng(8)))
    pose = exact.forward(g, q)
    J = exact.forward_jacobian(g, q, pose)
    h = 1e-4
    for i in range(3):
        dq = np.zeros(3)
        dq[i] = h
        plus, minus = exact.forward(g, q + dq), exact.forward(g, q - dq)
        assert_allclose(J[:, :3, i], (plus.position - minus.position) / (2 * h), atol=1e-7)
        dphi = vector_from_rotation(plus.rotation @ np.swapaxes(minus.rotation, 1, 2))
        assert_allclose(J[:, 3:, i], dphi / (2 * h), atol=1e-9)
    # the virtual model's Jacobian too
    v = VirtualDelta.from_geometry(kossel.geometry())
    qn = q[:2]
    Jv = v.jacobian(qn)
    for i in range(3):
        dq = np.zeros(3)
        dq[i] = h
        assert_allclose(Jv[:, :, i], (v.forward(qn + dq) - v.forward(qn - dq)) / (2 * h), atol=1e-8)


def test_forward_refuses_readings_without_a_working_assembly(kossel):
    g = kossel.geometry()
    with pytest.raises(AssemblyError, match="no assembly found at 1 reading"):
        exact.forward(g, np.array([[200.0, 200.0, 200.0], [0.0, 0.0, 400.0]]))


# ------------------------------------------------------------------ Pinocchio
def test_pinocchio_printer_agrees_with_the_numpy_solver(kossel):
    g = perturbed(kossel, 9)
    mb = DeltaMultibody(g)
    model = mb.model
    assert [model.joints[j].shortname() for j in (1, 4, 7)] == ["JointModelPY"] * 3
    assert (model.nq, model.nv) == (3 + 6 * 4 + 7, 3 + 6 * 3 + 6)
    targets = printable_points(kossel, 25, np.random.default_rng(10))
    q = exact.inverse(g, targets)
    numpy_pose = exact.forward(g, q)
    pin_pose = mb.forward(q)
    assert_allclose(pin_pose.position, numpy_pose.position, atol=1e-9)
    relative = np.swapaxes(pin_pose.rotation, 1, 2) @ numpy_pose.rotation
    angle = np.linalg.norm(vector_from_rotation(relative), axis=1)
    assert np.max(angle) < 1e-11
    assert_allclose(mb.point_positions(q[:5])[:, 0], targets[:5], atol=1e-9)
    # the carriages' ball centres of the tree are the geometry's
    x = mb.solve_forward(q[0]).configuration
    pin.forwardKinematics(model, mb.data, x)
    rods = [mb.data.oMi[j + 1].translation for j in (1, 2, 4, 5, 7, 8)]
    assert_allclose(np.array(rods), g.arm_balls_in_base(q[:1]).reshape(6, 3), atol=1e-9)
    assert_allclose(mb.readings_of(x), q[0], atol=1e-12)
    # and its inverse kinematics too
    assert_allclose(mb.inverse(targets[:5]), q[:5], atol=1e-9)


def test_pinocchio_finds_no_working_assembly_above_the_carriages(kossel):
    mb = DeltaMultibody(kossel.geometry())
    with pytest.raises(AssemblyError):
        mb.solve_forward(np.array([0.0, 0.0, 400.0]))


# ------------------------------------------------------------------ the robot file
def test_kossel_file_reads_as_the_spec_says(kossel):
    assert isinstance(load_robot(MODELS / "kossel.toml"), NominalLinearDelta)
    assert kossel.tower_radius - kossel.effector_radius == pytest.approx(134.4)  # Klipper's delta_radius
    assert kossel.rod_length.tolist() == [269.0] * 3 and kossel.step_distance.tolist() == [0.0125] * 3
    assert_allclose(np.degrees(kossel.tower_azimuth), [210.0, 330.0, 90.0])
    assert kossel.workspace is not None and kossel.workspace.bottom_z == 0.0
    assert kossel.workspace.top_z == kossel.workspace.height == 200.0
    assert load_robot(MODELS / "bai2015.toml").name == "bai2015"


GOOD = """name = "p"
kind = "linear"
[geometry]
tower_radius_mm = 164.4
effector_radius_mm = 30.0
rod_length_mm = 269.0
rod_spacing_mm = 50.0
tower_azimuth_deg = [210.0, 330.0, 90.0]
nozzle_mm = [0.0, 0.0, -30.0]
endstop_height_mm = 558.62
step_distance_mm = 0.0125
[workspace]
radius_mm = 115.0
height_mm = 200.0
"""


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('kind = "linear"', 'kind = "scara"', r"key kind: unknown robot kind 'scara'"),
        ("step_distance_mm = 0.0125", "step_distance_mm = 80.0",
         r"key geometry.step_distance_mm: 80.0 mm per step is not a printer's"),
        ("rod_length_mm = 269.0", "rod_length_mm = 120.0",
         r"key geometry.rod_length_mm: rods of 120.0 mm cannot"),
        ("tower_radius_mm = 164.4", "tower_radius_mm = 0.1644", r"key geometry.tower_radius_mm: 0.1644 mm is "
                                                                 r"implausible"),
        ("nozzle_mm = [0.0, 0.0, -30.0]\n", "", r"key geometry.nozzle_mm"),
        ("rod_spacing_mm = 50.0", "rod_spacing_mm = 50.0\narm_length_mm = 3.0", r"arm_length_mm"),
        ("tower_azimuth_deg = [210.0, 330.0, 90.0]", "tower_azimuth_deg = [210.0, 330.0, 210.0]",
         r"key geometry.tower_azimuth_deg: the three azimuths must differ"),
        ("height_mm = 200.0", "height_mm = 400.0",
         r"key workspace: the workspace reaches .* out of reach of the "
                                                   r"printer"),
        ("height_mm = 200.0", "height_mm = 200.0\ntop_z_mm = -5.0", r"top_z_mm"),
    ],
)
def test_printer_file_errors_name_key_and_value(tmp_path, old, new, message):
    assert old in GOOD
    path = tmp_path / "p.toml"
    path.write_text(GOOD.replace(old, new))
    with pytest.raises(InputError, match=message) as err:
        load_robot(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_a_printer_file_is_refused_where_a_rotary_robot_is_expected(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(GOOD)
    assert load_printer(path).endstop_height.tolist() == [558.62] * 3
    with pytest.raises(InputError, match="key kind: a linear Delta printer's file"):
        load_nominal(path)
    with pytest.raises(InputError, match="key kind: not a linear Delta printer's file"):
        load_printer(MODELS / "bai2015.toml")


def test_printer_tolerances_are_of_a_kit():
    tol = Tolerances.printer_kit()
    assert tol.axis_direction == pytest.approx(math.radians(0.15)) and tol.joint_scale == 0.003


def test_what_does_not_serve_printers_yet_says_so(kossel):
    """The rotary error models and linear compensation refuse a printer rather than answer as rotary."""
    from deltacal.compensation import compensate
    from deltacal.errormodels import get_model
    from deltacal.export.mjcf import mjcf_model

    g = kossel.geometry()
    q = np.array([[250.0, 260.0, 255.0]])
    for name in ("complete", "classical", "bai42"):
        with pytest.raises(GeometryError, match=f"the '{name}' error model serves rotary Delta robots; "
                                                "'kossel' is a prismatic chain"):
            get_model(name).sensitivity(g, q)
    with pytest.raises(GeometryError, match="the savoure compensation serves rotary Delta robots"):
        compensate(g, np.array([[0.0, 0.0, 50.0]]), "savoure")
    assert "carriage1" in mjcf_model(g)  # the MJCF export serves printers (tests/test_export_mjcf.py)
    with pytest.raises(GeometryError, match="balls move on lines"):
        g.arm_ball_circle  # noqa: B018
