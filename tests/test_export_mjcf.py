"""``deltacal export --mjcf``: the identified robot in MuJoCo and Pinocchio puts its TCP where deltacal says.

Each model is loaded by MuJoCo and by Pinocchio; the arms are set to the readings ``deltacal
compensate`` wrote for a set of targets, the closures are solved by Newton on the passive joints
with each program's own constraint residual and Jacobian, and the TCP site (frame) is compared
with the targets (MuJoCo) and with deltacal's exact forward kinematics (Pinocchio).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS, read_joints, write_targets

from deltacal.cli import main
from deltacal.compensation import compensate
from deltacal.exceptions import GeometryError
from deltacal.export import HOME_KEY, mjcf_model
from deltacal.export.mjcf import home_configuration
from deltacal.geometry import Masses, Tolerances
from deltacal.io import load_geometry, load_instrument, load_nominal, save_geometry
from deltacal.kinematics import exact
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.robots import load_robot

mujoco = pytest.importorskip("mujoco")

BAI = str(MODELS / "bai2015.toml")
FLEX = str(MODELS / "flexpicker.toml")
EAST = "east:1.1,-1.0,35.0:2680.0,830.0,250.0"
WEST = "west:-0.6,1.2,-140.0:-1900.0,2100.0,-120.0"
#: MuJoCo's TCP on the targets [mm] (the brief: 1e-6 mm); Pinocchio's on deltacal's exact FK [mm].
MUJOCO_TOL_MM = 1e-6
PINOCCHIO_TOL_MM = 1e-9


# --------------------------------------------------------------------- helpers
def targets_of(centre_z: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r = 150.0 * np.sqrt(rng.uniform(0.0, 1.0, 8))
    a = rng.uniform(0.0, 2.0 * np.pi, 8)
    z = centre_z + rng.uniform(-60.0, 60.0, 8)
    return np.column_stack([r * np.cos(a), r * np.sin(a), z])


def compensated(folder, robot: str, targets: np.ndarray, tag: str) -> np.ndarray:
    """Readings written by ``deltacal compensate`` for the targets (in {O}).

    ``compensate`` reads calibration files; for a robot file, the library's compensate.
    """
    if robot in (BAI, FLEX):
        return compensate(load_nominal(robot).geometry(), targets)
    tfile, jfile = folder / f"{tag}.targets.csv", folder / f"{tag}.joints.csv"
    write_targets(tfile, targets)
    assert main(["compensate", robot, str(tfile), "-o", str(jfile)]) == 0
    return read_joints(jfile)


ARMS = ("arm1", "arm2", "arm3")


def mujoco_solve(
    m, readings: np.ndarray, actuated: tuple[str, ...] = ARMS, stages: int = 1
) -> tuple[np.ndarray, float]:
    """Actuated joints at the values given, closures solved from ``home`` by Newton on MuJoCo's equality rows.

    With ``stages`` > 1 the actuated joints get there in equal steps, each solved in turn (a
    continuation: a carriage's travel of 300 mm from its endstop is too far for one Newton solve).
    Returns the data after the solve and the largest closure residual reached [m].
    """
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(HOME_KEY).id)
    arms = [m.joint(name).id for name in actuated]
    start = np.array(d.qpos[m.jnt_qposadr[arms]])
    passive = np.setdiff1d(np.arange(m.nv), m.jnt_dofadr[arms])
    for stage in range(1, stages + 1):
        values = readings if stage == stages else start + stage / stages * (readings - start)
        d.qpos[m.jnt_qposadr[arms]] = values
        best = np.inf
        for _ in range(30):
            mujoco.mj_fwdPosition(m, d)  # kinematics, then the constraint rows efc_pos, efc_J
            rows = d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
            assert rows.sum() == 18
            e = np.array(d.efc_pos[rows])
            if mujoco.mj_isSparse(m):
                J = np.zeros((d.nefc, m.nv))
                mujoco.mju_sparse2dense(J, d.efc_J, d.efc_J_rownnz, d.efc_J_rowadr, d.efc_J_colind)
            else:
                J = np.array(d.efc_J).reshape(d.nefc, m.nv)
            J = J[rows][:, passive]
            res = float(np.max(np.abs(e)))
            if res >= 0.5 * best and res < 1e-14:  # on the floating-point floor
                break
            best = min(best, res)
            v = np.zeros(m.nv)
            v[passive] = -J.T @ np.linalg.solve(J @ J.T, e)  # minimum norm: the rod spins stay put
            mujoco.mj_integratePos(m, d.qpos, v, 1.0)
    mujoco.mj_kinematics(m, d)
    return d, res


def mujoco_sites(
    path, readings: np.ndarray, names: list[str], actuated: tuple[str, ...] = ARMS, stages: int = 1
) -> tuple[np.ndarray, float]:
    """Site positions [mm], shape (N, k, 3), at each joint value, and the largest closure residual [m]."""
    m = mujoco.MjModel.from_xml_path(str(path))
    out, worst = [], 0.0
    for q in readings:
        d, res = mujoco_solve(m, q, actuated, stages)
        out.append([np.array(d.site(n).xpos) * 1000.0 for n in names])
        worst = max(worst, res)
    return np.array(out), worst


def pinocchio_frames(
    path, readings: np.ndarray, names: list[str], actuated: tuple[str, ...] = ARMS, stages: int = 1
) -> tuple[np.ndarray, float]:
    """Frame positions [mm], (N, k, 3), after Newton on Pinocchio's closures from ``home`` (in stages)."""
    model, points, frames = pin.buildModelAndConstraintsFromMJCF(str(path))
    assert len(points) == 6 and len(frames) == 0
    data = model.createData()
    models = pin.StdVec_ConstraintModel()
    for c in points:
        models.append(pin.ConstraintModel(c))
    datas = pin.StdVec_ConstraintData()
    for c in models:
        datas.append(c.createData())
    arms = [model.joints[model.getJointId(name)] for name in actuated]
    passive = np.setdiff1d(np.arange(model.nv), [j.idx_v for j in arms])
    ids = [model.getFrameId(n) for n in names]
    out, worst = [], 0.0
    for q in readings:
        x = np.array(model.referenceConfigurations[HOME_KEY])
        start = x[[j.idx_q for j in arms]]
        for stage in range(1, stages + 1):
            x[[j.idx_q for j in arms]] = q if stage == stages else start + stage / stages * (q - start)
            best = np.inf
            for _ in range(30):
                pin.computeJointJacobians(model, data, x)
                for c, cd in zip(models, datas, strict=True):
                    c.calc(model, data, cd)
                e = np.concatenate([cd.extract().constraint_position_error for cd in datas])
                J = pin.getConstraintsJacobian(model, data, models, datas)[:, passive]
                res = float(np.max(np.abs(e)))
                if res >= 0.5 * best and res < 1e-14:
                    break
                best = min(best, res)
                v = np.zeros(model.nv)
                v[passive] = -J.T @ np.linalg.solve(J @ J.T, e)
                x = pin.integrate(model, x, v)
        worst = max(worst, res)
        pin.framesForwardKinematics(model, data, x)
        out.append([np.array(data.oMf[k].translation) * 1000.0 for k in ids])
    return np.array(out), worst


def exact_points(geometry, readings: np.ndarray, names: list[str]) -> np.ndarray:
    pose = exact.forward(geometry, readings)
    return np.stack([pose.point(geometry.point(n)) for n in names], axis=1)


# --------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    """Robot files: a plain robot, a calibration identified in {O}, one identified with a free frame."""
    folder = tmp_path_factory.mktemp("export")
    poses = folder / "poses.csv"
    assert main(["plan", BAI, "--strategy", "doptimal", "--count", "60", "--seed", "3",
                 "-o", str(poses)]) == 0
    # in the robot base frame, pose measurements of the TCP
    meas = folder / "meas.csv"
    assert main(["simulate", BAI, str(poses), "--perturb", "11", "--seed", "5", "-o", str(meas)]) == 0
    assert main(["identify", BAI, str(meas), "-o", str(folder / "cal.toml")]) == 0
    # a tracker in two stations' frames, identified with --frame free
    meas_free = folder / "meas_free.csv"
    assert main(["simulate", BAI, str(poses), "--perturb", "7", "--seed", "6", "--points", "smr_centre",
                 "--station", EAST, "--station", WEST, "-o", str(meas_free)]) == 0
    assert main(["identify", BAI, str(meas_free), "--frame", "free",
                 "-o", str(folder / "cal_free.toml")]) == 0
    return folder


CASES = {
    "robot file": (lambda folder: BAI, -850.0),
    "flexpicker": (lambda folder: FLEX, -650.0),
    "calibration": (lambda folder: str(folder / "cal.toml"), -850.0),
    "calibration, free frame": (lambda folder: str(folder / "cal_free.toml"), -850.0),
}


def geometry_of(path: str):
    if path in (BAI, FLEX):
        return load_nominal(path).geometry()
    return load_geometry(path)


@pytest.fixture(scope="module", params=list(CASES))
def exported(request, robots):
    """(robot file, its geometry, the MJCF path, readings compensated for targets, the targets)."""
    source, centre_z = CASES[request.param]
    path = source(robots)
    tag = f"case{list(CASES).index(request.param)}"
    xml = robots / f"{tag}.xml"
    assert main(["export", path, "--mjcf", str(xml)]) == 0
    targets = targets_of(centre_z, seed=list(CASES).index(request.param))
    q = compensated(robots, path, targets, tag)
    return path, geometry_of(path), xml, q, targets


# --------------------------------------------------------------------- (a) MuJoCo
def test_mujoco_puts_the_tcp_on_the_targets(exported):
    path, geometry, xml, q, targets = exported
    sites, residual = mujoco_sites(xml, q, ["tcp"])
    error = np.max(np.abs(sites[:, 0] - targets))
    print(f"MuJoCo tcp vs targets, {path}: max {error:.3g} mm (closure residual {residual:.3g} m)")
    assert residual < 1e-13
    assert error < MUJOCO_TOL_MM


def test_mujoco_named_points_follow_the_exact_kinematics(exported):
    path, geometry, xml, q, targets = exported
    names = geometry.point_names
    sites, _ = mujoco_sites(xml, q, names)
    assert np.max(np.abs(sites - exact_points(geometry, q, names))) < MUJOCO_TOL_MM


def test_home_keyframe_is_an_assembly(exported):
    path, geometry, xml, q, targets = exported
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(HOME_KEY).id)
    mujoco.mj_fwdPosition(m, d)
    rows = d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert rows.sum() == 18 and np.max(np.abs(d.efc_pos[rows])) < 1e-13  # [m]
    home_tcp = exact.forward(geometry, np.zeros(3)).point(geometry.tool)[0]
    assert np.max(np.abs(d.site("tcp").xpos * 1000.0 - home_tcp)) < 1e-9
    # the arm servos hold the home readings
    assert np.array_equal(m.key(HOME_KEY).ctrl, np.zeros(3))


# --------------------------------------------------------------------- (b) Pinocchio
def test_pinocchio_agrees_with_the_exact_forward_kinematics(exported):
    path, geometry, xml, q, targets = exported
    names = geometry.point_names
    frames, residual = pinocchio_frames(xml, q, names)
    error = np.max(np.abs(frames - exact_points(geometry, q, names)))
    print(f"Pinocchio vs exact FK, {path}: max {error:.3g} mm (closure residual {residual:.3g} m)")
    assert residual < 1e-13
    assert error < PINOCCHIO_TOL_MM


def test_pinocchio_model_mirrors_deltacal_multibody(exported):
    """Arm placements as in DeltaMultibody (mm there, m here); rods at the arm balls; the home keyframe."""
    path, geometry, xml, q, targets = exported
    model, _, _ = pin.buildModelAndConstraintsFromMJCF(str(xml))
    ours = DeltaMultibody(geometry).model
    for name in ("arm1", "arm2", "arm3", "rod11", "rod12", "rod21", "rod22", "rod31", "rod32"):
        a = model.jointPlacements[model.getJointId(name)]
        b = ours.jointPlacements[ours.getJointId(name)]
        assert np.max(np.abs(a.rotation - b.rotation)) < 1e-15
        assert np.max(np.abs(a.translation * 1000.0 - b.translation)) < 1e-12
        kind = model.joints[model.getJointId(name)].shortname()
        assert kind == ours.joints[ours.getJointId(name)].shortname()
    # the keyframe, quaternions reordered by Pinocchio to x y z w
    key = np.array(model.referenceConfigurations[HOME_KEY])
    mj = home_configuration(geometry)
    rod = model.joints[model.getJointId("rod11")].idx_q
    assert np.max(np.abs(key[rod:rod + 4] - np.roll(mj[1:5], -1))) < 1e-15


# --------------------------------------------------------------------- the file itself
def test_the_file_holds_the_geometry_unrounded(robots):
    cal = robots / "cal.toml"
    geometry = load_geometry(cal)
    root = ET.fromstring(mjcf_model(geometry))
    bodies = root.find("worldbody").findall("body")
    assert [b.get("name") for b in bodies] == ["base"]
    for i in range(3):
        arm = root.find(f".//body[@name='arm{i + 1}_link']")
        pos = [float(v) for v in arm.get("pos").split()]
        assert pos == (geometry.axis_point[i] / 1000.0).tolist()
        joint = arm.find("joint")
        assert (joint.get("name"), joint.get("type"), joint.get("axis")) == (f"arm{i + 1}", "hinge", "0 1 0")
        for j in range(2):
            rod = arm.find(f"body[@name='rod{i + 1}{j + 1}_link']")
            assert rod.find("joint").get("type") == "ball"
            end = [float(v) for v in rod.find("site").get("pos").split()]
            assert end == [0.0, 0.0, -geometry.rod_length[i, j] / 1000.0]
    connects = root.findall("equality/connect")
    assert [(c.get("site1"), c.get("site2")) for c in connects] == [
        (f"rod{i}{j}_end", f"plate_ball{i}{j}") for i in (1, 2, 3) for j in (1, 2)]
    sites = {s.get("name") for s in root.findall(".//body[@name='plate']/site")}
    assert {"tcp", *geometry.points} <= sites


def test_masses_are_plausible():
    m = mujoco.MjModel.from_xml_string(mjcf_model(load_nominal(BAI).geometry()))
    mass = {m.body(k).name: float(m.body_mass[k]) for k in range(m.nbody)}
    assert 0.2 < mass["arm1_link"] < 2.0  # aluminium tube of 375 mm
    assert 0.02 < mass["rod11_link"] < 0.2  # carbon tube of 950 mm
    assert 0.2 < mass["plate"] < 3.0
    assert np.all(m.body_inertia[1:] > 0.0)


def test_instrument_frame_calibration_says_its_frame(robots):
    cal = robots / "cal_free.toml"
    assert set(load_instrument(cal)) == {"east", "west"}
    out = robots / "free.xml"
    assert main(["export", str(cal), "--mjcf", str(out)]) == 0
    text = out.read_text()
    assert "robot base frame {O}" in text and "stations east, west" in text


# --------------------------------------------------------------------- (c) command line
def test_bad_calibration_file_exits_1_with_one_line_and_keeps_the_output(tmp_path, capsys):
    out = tmp_path / "robot.xml"
    out.write_text("earlier output\n")
    bad = tmp_path / "bad.toml"
    for text in ('format = "deltacal-calibration-1"\n',
                 'format = "deltacal-geometry-1"\nname = "x"\ntool_mm = [0, 0, "a"]\n',
                 "not toml [\n"):
        bad.write_text(text)
        assert main(["export", str(bad), "--mjcf", str(out)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "bad.toml" in err[0], err
        assert out.read_text() == "earlier output\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "robot.xml"]  # no temporary left


def test_a_point_named_like_a_model_element_is_refused(tmp_path, capsys):
    geometry = load_nominal(BAI).geometry()
    clash = replace(geometry, points={**geometry.points, "rod11_end": np.array([0.0, 0.0, -10.0])})
    with pytest.raises(GeometryError, match="rod11_end"):
        mjcf_model(clash)
    save_geometry(clash, tmp_path / "clash.toml")
    assert main(["export", str(tmp_path / "clash.toml"), "--mjcf", str(tmp_path / "x.xml")]) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "x.xml").exists()


def test_usage_errors_exit_2(tmp_path, capsys):
    assert main(["export", BAI]) == 2
    assert main(["export", str(tmp_path / "missing.toml"), "--mjcf", str(tmp_path / "x.xml")]) == 2
    assert main(["export", BAI, "--mjcf", str(tmp_path / "no" / "x.xml")]) == 2
    assert main(["export", BAI, "--mjcf", str(tmp_path / "x.xml"), "--home", "1,2"]) == 2
    for line in capsys.readouterr().err.strip().splitlines():
        assert line.startswith("deltacal")
    assert not (tmp_path / "x.xml").exists()


@pytest.mark.parametrize("robot", [BAI, FLEX])
def test_both_robot_files_export_and_load(robot, tmp_path):
    out = tmp_path / "robot.xml"
    assert main(["export", robot, "--mjcf", str(out), "--home", "10,-5,20"]) == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert (m.nq, m.nv, m.neq, m.nu, m.nkey) == (34, 27, 6, 3, 1)
    model, points, frames = pin.buildModelAndConstraintsFromMJCF(str(out))
    assert (model.nq, model.nv, len(points)) == (34, 27, 6)
    # the home keyframe at those readings is an assembly
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_fwdPosition(m, d)
    assert np.max(np.abs(d.efc_pos[d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY])) < 1e-13
    assert np.allclose(d.qpos[m.jnt_qposadr[[m.joint(f"arm{i}").id for i in (1, 2, 3)]]],
                       np.radians([10.0, -5.0, 20.0]), rtol=0, atol=1e-15)


def test_mujoco_drives_the_arms_to_compensated_readings():
    """A dynamic smoke test: the position servos take the arms to the readings, the loops stay closed.

    The servos are proportional only, so gravity leaves a small sag (a fraction of a millimetre).
    """
    geometry = load_nominal(BAI).geometry()
    m = mujoco.MjModel.from_xml_string(mjcf_model(geometry))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(HOME_KEY).id)
    target = np.array([100.0, -50.0, -850.0])
    q = compensate(geometry, target[None])[0]
    d.ctrl[:] = q
    for _ in range(1500):
        mujoco.mj_step(m, d)
    arms = m.jnt_qposadr[[m.joint(f"arm{i}").id for i in (1, 2, 3)]]
    assert np.max(np.abs(d.qpos[arms] - q)) < 2e-3
    assert np.max(np.abs(d.efc_pos[d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY])) < 1e-4  # [m]
    assert np.linalg.norm(d.site("tcp").xpos * 1000.0 - target) < 1.0
    assert np.max(np.abs(d.qvel)) < 1e-3


def test_odd_names_stay_well_formed_xml(tmp_path):
    geometry = load_nominal(BAI).geometry()
    odd = replace(geometry, points={'a "quoted" <point> & co': np.array([1.0, 2.0, 3.0])})
    text = mjcf_model(odd, name="robot <1> & 'two'", stations=["st--1"], source="my--file.toml")
    root = ET.fromstring(text)
    assert root.get("model") == "robot <1> & 'two'"
    m = mujoco.MjModel.from_xml_string(text)
    assert m.site('a "quoted" <point> & co').id >= 0


@pytest.mark.parametrize("station", ["a---b", "süd-", "ταυ", "-"])
def test_station_names_with_runs_of_dashes_stay_well_formed_xml(station):
    """'--' was replaced once: 'a---b' still left '--' in the comment (issue 21, item 3)."""
    text = mjcf_model(load_nominal(BAI).geometry(), stations=[station, "east"], source="x---y.toml")
    ET.fromstring(text)
    assert mujoco.MjModel.from_xml_string(text).nsite > 0



# --------------------------------------------------------------------- (d) a linear Delta printer
KOSSEL = str(MODELS / "kossel.toml")
CARRIAGES = ("carriage1", "carriage2", "carriage3")
#: Steps from the endstops (home) to the travels, each solved by Newton: at most about 40 mm each.
STAGES = 8


@pytest.fixture(scope="module")
def printers(tmp_path_factory):
    """{name: (geometry, MJCF path)}: the Kossel robot file and a perturbed printer's geometry file."""
    folder = tmp_path_factory.mktemp("printers")
    nominal = load_robot(KOSSEL).geometry()
    true = nominal.perturbed(Tolerances.printer_kit(), np.random.default_rng(24))
    true = replace(true, points={"probe": np.array([25.0, -10.0, -34.0])})
    save_geometry(true, folder / "true.toml")
    out = {}
    cases = (("kossel", KOSSEL, nominal), ("perturbed", str(folder / "true.toml"), true))
    for name, source, geometry in cases:
        xml = folder / f"{name}.xml"
        assert main(["export", source, "--mjcf", str(xml)]) == 0
        out[name] = (geometry, xml)
    return out


def printer_readings(geometry, seed: int) -> np.ndarray:
    """Carriage travels [mm] that put the nozzle on 8 random points of a Kossel's printable volume."""
    rng = np.random.default_rng(seed)
    r = 100.0 * np.sqrt(rng.uniform(0.0, 1.0, 8))
    a = rng.uniform(0.0, 2.0 * np.pi, 8)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, 200.0, 8)])
    return exact.inverse(geometry, targets)


def slide_values(geometry, q: np.ndarray) -> np.ndarray:
    """The carriages' slide values [m] at readings q [mm] (the module docstring: ``-joint_scale q``)."""
    return -geometry.joint_scale * q / 1000.0


@pytest.mark.parametrize("name", ["kossel", "perturbed"])
def test_printer_nozzle_in_mujoco_follows_the_exact_kinematics(printers, name):
    geometry, xml = printers[name]
    q = printer_readings(geometry, seed=len(name))
    names = geometry.point_names
    sites, residual = mujoco_sites(xml, slide_values(geometry, q), names, CARRIAGES, STAGES)
    error = np.max(np.abs(sites - exact_points(geometry, q, names)))
    print(f"MuJoCo nozzle vs exact FK, {name}: max {error:.3g} mm (closure residual {residual:.3g} m)")
    assert residual < 1e-13
    assert error < MUJOCO_TOL_MM


@pytest.mark.parametrize("name", ["kossel", "perturbed"])
def test_printer_in_pinocchio_agrees_with_the_exact_forward_kinematics(printers, name):
    geometry, xml = printers[name]
    q = printer_readings(geometry, seed=10 + len(name))
    names = geometry.point_names
    frames, residual = pinocchio_frames(xml, slide_values(geometry, q), names, CARRIAGES, STAGES)
    error = np.max(np.abs(frames - exact_points(geometry, q, names)))
    print(f"Pinocchio vs exact FK, {name}: max {error:.3g} mm (closure residual {residual:.3g} m)")
    assert residual < 1e-13
    assert error < PINOCCHIO_TOL_MM


def test_printer_model_mirrors_deltacal_multibody(printers):
    """Carriage placements as in DeltaMultibody (endstop error along the tower); prismatic joints along y."""
    geometry, xml = printers["perturbed"]
    model, _, _ = pin.buildModelAndConstraintsFromMJCF(str(xml))
    ours = DeltaMultibody(geometry).model
    for name in (*CARRIAGES, "rod11", "rod12", "rod21", "rod22", "rod31", "rod32"):
        a = model.jointPlacements[model.getJointId(name)]
        b = ours.jointPlacements[ours.getJointId(name)]
        assert np.max(np.abs(a.rotation - b.rotation)) < 1e-15
        assert np.max(np.abs(a.translation * 1000.0 - b.translation)) < 1e-12
        kind = model.joints[model.getJointId(name)].shortname()
        assert kind == ours.joints[ours.getJointId(name)].shortname()
    assert model.joints[model.getJointId("carriage1")].shortname() == "JointModelPY"


def test_printer_home_is_an_assembly_and_the_servo_controls_are_readings(printers, tmp_path):
    geometry, xml = printers["perturbed"]
    home = np.array([180.0, 240.0, 210.0])  # [mm] below the endstops
    out = tmp_path / "home.xml"
    assert main(["export", str(xml.parent / "true.toml"), "--mjcf", str(out), "--home", "180,240,210"]) == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert (m.nq, m.nv, m.neq, m.nu, m.nkey) == (34, 27, 6, 3, 1)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(HOME_KEY).id)
    mujoco.mj_fwdPosition(m, d)
    rows = d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert rows.sum() == 18 and np.max(np.abs(d.efc_pos[rows])) < 1e-13  # [m]
    nozzle = exact.forward(geometry, home[None]).point(geometry.tool)[0]
    assert np.max(np.abs(d.site("tcp").xpos * 1000.0 - nozzle)) < 1e-9
    # the geared servos' lengths are the readings [mm], and the keyframe's controls hold them
    np.testing.assert_allclose(d.actuator_length, home, rtol=0.0, atol=1e-9)
    assert np.array_equal(m.key(HOME_KEY).ctrl, home)
    np.testing.assert_array_equal(m.actuator_gear[:, 0], -1000.0 / geometry.joint_scale)


def test_printer_file_holds_slides_towers_and_the_bed(printers):
    geometry, xml = printers["perturbed"]
    root = ET.parse(xml).getroot()
    assert [b.get("name") for b in root.find("worldbody").findall("body")] == ["base"]
    for i in range(3):
        carriage = root.find(f".//body[@name='carriage{i + 1}_link']")
        pos = np.array([float(v) for v in carriage.get("pos").split()])
        w = geometry.axis_direction[i]
        np.testing.assert_allclose(pos, (geometry.axis_point[i] - geometry.encoder_offset[i] * w) / 1000.0,
                                   rtol=0.0, atol=1e-15)
        joint = carriage.find("joint")
        kind = (joint.get("name"), joint.get("type"), joint.get("axis"))
        assert kind == (f"carriage{i + 1}", "slide", "0 1 0")
        assert [r.find("joint").get("type") for r in carriage.findall("body")] == ["ball", "ball"]
    base = root.find(".//body[@name='base']")
    towers = [g for g in base.findall("geom") if g.get("type") == "capsule"]
    assert len(towers) == 3
    for i, tower in enumerate(towers):  # along the axis lines, from the bed up past the endstops
        ends = np.array([float(v) for v in tower.get("fromto").split()]).reshape(2, 3) * 1000.0
        assert abs(ends[0, 2]) < 1e-9 and ends[1, 2] > geometry.axis_point[i, 2]
        w = geometry.axis_direction[i]
        for end in ends:
            off = end - geometry.axis_point[i]
            assert np.linalg.norm(off - (off @ w) * w) < 1e-9
    text = xml.read_text()
    assert "linear Delta printer" in text and "control = reading [mm]" in text
    assert not root.findall(".//joint[@type='hinge']")


def test_masses_of_the_geometry_are_used_for_both_kinds():
    """Issue 23 left 'MJCF ignores [masses]': a geometry's masses are the model's, each part at its place."""
    given = Masses(arm=0.35, rod=0.04, plate=0.0)
    for robot, moving in ((BAI, "arm1_link"), (KOSSEL, "carriage1_link")):
        geometry = replace(load_robot(robot).geometry(), masses=given)
        text = mjcf_model(geometry)
        m = mujoco.MjModel.from_xml_string(text)
        assert m.body(moving).mass[0] == 0.35
        assert m.body("rod11_link").mass[0] == 0.04
        assert m.body("plate").mass[0] == 1e-6  # 0 kg given; MuJoCo needs some: said in the file
        assert "Masses: the geometry's" in text and "weighs 1e-06 kg" in text
        assert np.all(m.body_inertia[1:] > 0.0)
    # the conventions' arm: its centre of mass half-way from the axis to the elbow balls' midpoint
    geometry = replace(load_robot(BAI).geometry(), masses=given)
    m = mujoco.MjModel.from_xml_string(mjcf_model(geometry))
    np.testing.assert_allclose(m.body("arm1_link").ipos * 1000.0, 0.5 * geometry.arm_ball[0].mean(axis=0),
                               rtol=0.0, atol=1e-12)


def test_a_point_named_like_a_printer_element_is_refused():
    geometry = load_robot(KOSSEL).geometry()
    clash = replace(geometry, points={"carriage2_link": np.array([0.0, 0.0, -10.0])})
    with pytest.raises(GeometryError, match="carriage2_link"):
        mjcf_model(clash)
    # a rotary robot has no carriages: the name is free there
    rotary = load_nominal(BAI).geometry()
    assert mujoco.MjModel.from_xml_string(mjcf_model(replace(rotary, points=clash.points))).nsite > 0


def test_printer_masses_are_plausible():
    m = mujoco.MjModel.from_xml_string(mjcf_model(load_robot(KOSSEL).geometry()))
    assert 0.05 < m.body("carriage1_link").mass[0] < 0.5
    assert 0.001 < m.body("rod11_link").mass[0] < 0.02  # carbon tube of 269 mm
    assert 0.03 < m.body("plate").mass[0] < 0.5
    assert np.all(m.body_inertia[1:] > 0.0)


def test_mujoco_drives_the_carriages_to_their_readings():
    """A dynamic smoke test: the geared servos take the carriages to readings [mm], the loops stay closed.

    The servos are proportional only and the closures soft (their sag under gravity is about
    g τ² = 0.16 mm for the time constant τ = 4 ms), so the nozzle lands a fraction of a millimetre off.
    """
    geometry = load_robot(KOSSEL).geometry()
    m = mujoco.MjModel.from_xml_string(mjcf_model(geometry))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(HOME_KEY).id)
    target = np.array([40.0, -30.0, 50.0])
    q = exact.inverse(geometry, target[None])[0]
    d.ctrl[:] = q
    for _ in range(3000):
        mujoco.mj_step(m, d)
    assert np.max(np.abs(d.actuator_length - q)) < 0.05  # [mm]
    assert np.max(np.abs(d.efc_pos[d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY])) < 2e-4  # [m]
    assert np.linalg.norm(d.site("tcp").xpos * 1000.0 - target) < 0.5
    assert np.max(np.abs(d.qvel)) < 1e-3


def test_printer_home_must_not_rise_above_the_endstops(tmp_path, capsys):
    out = tmp_path / "x.xml"
    assert main(["export", KOSSEL, "--mjcf", str(out), "--home", "-1,100,100"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "below the endstops" in err[0] and not out.exists()
