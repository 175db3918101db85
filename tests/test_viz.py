"""3-D views (deltacal.viz): scene contents, server hygiene, and real renders in headless Chromium."""

from __future__ import annotations

import argparse
import base64
import math
import os
import re
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from deltacal import DeltaGeometry, NominalDelta, Tolerances, UnreachableError, Workspace
from deltacal.geometry import vector_from_rotation

meshcat = pytest.importorskip("meshcat")
umsgpack = pytest.importorskip("umsgpack")

from deltacal import viz  # noqa: E402
from deltacal.cli import view as view_cli  # noqa: E402
from deltacal.io import load_nominal, save_geometry  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "deltacal" / "models"
CHROMIUM = Path("/usr/bin/chromium")
SEED = 20150601


@pytest.fixture(scope="module")
def nominal() -> NominalDelta:
    return load_nominal(MODELS / "bai2015.toml")


@pytest.fixture(scope="module")
def robots(nominal: NominalDelta) -> tuple[DeltaGeometry, DeltaGeometry]:
    geometry = nominal.geometry()
    return geometry, geometry.perturbed(Tolerances.bai2015(), np.random.default_rng(SEED))


def decode_commands(html: str) -> list[dict]:
    """The meshcat commands replayed by a standalone page."""
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def child_pids() -> set[int]:
    """Children of this process (all threads)."""
    out: set[int] = set()
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():
        try:
            out |= {int(p) for p in (task / "children").read_text().split()}
        except OSError:
            pass
    return out


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return stat.exists() and stat.read_text().split(") ")[-1][0] != "Z"


# ----------------------------------------------------------------------------- numbers
def test_tilt_is_exaggerated_by_the_factor_and_positions_are_not(robots):
    nominal_geometry, true_geometry = robots
    q = np.radians([[10.0, 20.0, 30.0]])
    plain = viz.RobotState.compute(true_geometry, q, 1.0)
    shown = viz.RobotState.compute(true_geometry, q, 100.0)
    phi = vector_from_rotation(plain.plate.rotation)[0]
    np.testing.assert_allclose(vector_from_rotation(shown.shown_rotation)[0], 100.0 * phi, atol=1e-9)
    np.testing.assert_allclose(shown.plate.position, plain.plate.position, atol=0.0)
    np.testing.assert_allclose(
        plain.plate_balls,
        plain.plate.point(np.zeros(3))[:, None, None]
        + np.einsum("kl,ijl->ijk", plain.plate.rotation[0], true_geometry.plate_ball)[None],
        atol=1e-9,
    )
    # the rods of the unexaggerated drawing have their true lengths
    lengths = np.linalg.norm(plain.plate_balls - plain.arm_balls, axis=-1)[0]
    np.testing.assert_allclose(lengths, true_geometry.rod_length, atol=1e-8)


def test_error_field_is_zero_for_the_nominal_robot_and_not_for_a_real_one(nominal, robots):
    nominal_geometry, true_geometry = robots
    grid = viz.workspace_grid(nominal.workspace)
    assert grid.shape == (39, 3)
    perfect = viz.ErrorField.compute(nominal_geometry, nominal_geometry, grid)
    assert len(perfect.commanded) == 39
    np.testing.assert_allclose(perfect.magnitude, 0.0, atol=1e-8)
    real = viz.ErrorField.compute(nominal_geometry, true_geometry, grid)
    assert 0.5 < real.magnitude.max() < 100.0  # mm: a 1 deg encoder offset on a 375 mm arm


def test_nice_numbers_and_colours():
    assert [viz.nice_number(x) for x in (0.7, 1.0, 3.0, 7.5, 23.6)] == [0.5, 1.0, 2.0, 5.0, 20.0]
    c = viz.error_colours(np.array([0.0, 0.5, 1.0, 2.0]))
    assert c.shape == (4, 3) and np.all((0.0 <= c) & (c <= 1.0))
    np.testing.assert_allclose(c[2], c[3])
    assert not np.allclose(c[0], c[2])


# ------------------------------------------------------------------------- HTML, no server
def test_html_holds_every_element_and_starts_no_process(tmp_path, nominal, robots):
    nominal_geometry, true_geometry = robots
    before = child_pids()
    out = tmp_path / "scene.html"
    summary = viz.export_html(nominal_geometry, true_geometry, out, workspace=nominal.workspace, animate=True)
    assert child_pids() - before == set(), "static export must not start a server"
    html = out.read_text(encoding="utf-8")
    commands = decode_commands(html)
    paths = {c["path"] for c in commands}
    expected = []
    for robot in ("true", "nominal"):
        expected.append(f"{robot}/base")
        for i in (1, 2, 3):
            expected += [
                f"{robot}/limb{i}/actuator",
                f"{robot}/limb{i}/arm/link",
                f"{robot}/limb{i}/arm/elbow",
            ]
            expected += [f"{robot}/limb{i}/arm/ball{j}" for j in (1, 2)]
            expected += [f"{robot}/limb{i}/rod{j}" for j in (1, 2)]
            expected += [f"{robot}/plate/ball{i}{j}" for j in (1, 2)]
        expected += [f"{robot}/plate/body", f"{robot}/plate/axis", f"{robot}/plate/tcp"]
    expected += ["arrows", "workspace", "frame", "inset/true/body", "inset/nominal/body"]
    for path in expected:
        assert f"/meshcat/deltacal/{path}" in paths, path
        assert path in summary.paths
    objects = [c for c in commands if c["type"] == "set_object"]
    assert sum(p.startswith("/meshcat/deltacal/true/") for p in (c["path"] for c in objects)) == 1 + 3 * 7 + 9
    # the ghost is translucent, the true robot opaque
    ghost = next(c for c in objects if c["path"] == "/meshcat/deltacal/nominal/plate/body")
    solid = next(c for c in objects if c["path"] == "/meshcat/deltacal/true/plate/body")
    assert ghost["object"]["materials"][0]["transparent"] and ghost["object"]["materials"][0]["opacity"] < 0.5
    assert solid["object"]["materials"][0]["opacity"] == 1.0
    # the real tilt is written in the scene, and the exaggeration factor
    texts = [t["text"] for c in objects for t in c["object"].get("textures", []) if t.get("type") == "_text"]
    assert f"plate tilt {math.degrees(summary.tilt):.3f}\u00b0" in texts
    assert "(drawn \u00d7100)" in texts
    assert f"{summary.max_error:.1f} mm" in texts
    assert 0.01 < math.degrees(summary.tilt) < 1.0
    # 38 arrows: the grid of 39 points minus the one at the drawn TCP
    assert summary.arrows == 38 and summary.arrow_scale > 1.0
    # camera: the viewer's camera replaced, put at the computed place (metres, y up)
    camera = next(c for c in objects if c["path"] == "/Cameras/default/rotated")
    assert camera["object"]["object"]["type"] == "PerspectiveCamera"
    position = next(c for c in commands if c["path"] == "/Cameras/default/rotated/<object>")
    x, y, z = 1e-3 * summary.camera.distance * summary.camera.direction
    np.testing.assert_allclose(position["value"], [x, z, -y], atol=1e-9)
    # the animation moves both robots' arms, rods and plates along the path
    animation = [c for c in commands if c["type"] == "set_animation"]
    assert len(animation) == 1 and summary.animation_frames == 100
    animated = {a["path"] for a in animation[0]["animations"]}
    for robot in ("true", "nominal"):
        for path in (f"{robot}/limb1/arm", f"{robot}/limb3/rod2", f"{robot}/plate"):
            assert f"/meshcat/deltacal/{path}" in animated, path
    rod = next(a for a in animation[0]["animations"] if a["path"] == "/meshcat/deltacal/true/limb1/rod1")
    assert {t["name"] for t in rod["clip"]["tracks"]} == {".position", ".quaternion", ".scale"}
    assert len(rod["clip"]["tracks"][0]["keys"]) == 100


def test_html_is_written_atomically(tmp_path, robots):
    nominal_geometry, true_geometry = robots
    out = tmp_path / "scene.html"
    out.write_text("old page")
    far_away = Workspace(radius=100.0, height=10.0, top_z=-5000.0)
    with pytest.raises(UnreachableError, match="out of reach"):
        viz.export_html(nominal_geometry, true_geometry, out, workspace=far_away)
    assert out.read_text() == "old page"
    assert [p.name for p in tmp_path.iterdir()] == ["scene.html"]


@pytest.mark.slow
def test_live_server_is_always_stopped():
    with viz.meshcat_server() as vis:
        proc = vis.window.server_proc
        assert proc.poll() is None and vis.url().startswith("http://")
    assert proc.poll() is not None and not pid_alive(proc.pid)
    with pytest.raises(RuntimeError, match="boom"), viz.meshcat_server() as vis:
        proc = vis.window.server_proc
        raise RuntimeError("boom")
    assert proc.poll() is not None and not pid_alive(proc.pid)


def view_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="deltacal")
    view_cli.add_parser(parser.add_subparsers(dest="command", required=True))
    return parser


def test_view_command_writes_html(tmp_path, capsys):
    out = tmp_path / "view.html"
    args = view_parser().parse_args(
        ["view", str(MODELS / "bai2015.toml"), "--perturb", "7", "--exaggerate", "50", "--html", str(out)]
    )
    assert args.func(args) == 0
    html = out.read_text(encoding="utf-8")
    assert "MeshCat.Viewer" in html and "(drawn \u00d750)" in str(decode_commands(html))
    assert "wrote" in capsys.readouterr().out


def test_view_command_reads_a_truth_file_and_rejects_bad_input(tmp_path, robots, capsys):
    nominal_geometry, true_geometry = robots
    truth = tmp_path / "truth.toml"
    save_geometry(true_geometry, truth)
    out = tmp_path / "view.html"
    args = view_parser().parse_args(
        ["view", str(MODELS / "bai2015.toml"), "--truth", str(truth), "--html", str(out)]
    )
    assert view_cli.run(args) == 0 and out.exists()
    with pytest.raises(SystemExit):
        view_parser().parse_args(["view", "x.toml", "--truth", "a.toml", "--perturb", "1"])
    capsys.readouterr()
    missing = tmp_path / "none.html"
    # a missing input is a usage error (exit 2), as for every command
    from deltacal.cli import main

    assert main(["view", str(tmp_path / "nope.toml"), "--html", str(missing)]) == 2
    err = capsys.readouterr().err
    assert "nope.toml" in err and len(err.strip().splitlines()) == 1
    assert not missing.exists()
    assert main(["view", str(MODELS / "bai2015.toml"), "--exaggerate", "-1", "--html", str(missing)]) == 2
    assert "--exaggerate" in capsys.readouterr().err and not missing.exists()


@pytest.mark.long
def test_view_command_serves_until_ctrl_c_and_stops_the_server(tmp_path):
    script = (
        "import sys\n"
        "from deltacal.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script, "view", str(MODELS / "bai2015.toml"), "--perturb", "3"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
    )
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 60.0)
        assert ready, "the view command printed no URL within 60 s"
        url = proc.stdout.readline().strip()  # type: ignore[union-attr]
        assert url.startswith("http://127.0.0.1:"), url
        servers: set[int] = set()
        deadline = time.monotonic() + 30.0
        while not servers and time.monotonic() < deadline:
            for task in Path(f"/proc/{proc.pid}/task").iterdir():
                servers |= {int(p) for p in (task / "children").read_text().split()}
            time.sleep(0.1)
        assert servers, "the view command should run a meshcat server"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)
    for pid in servers:
        assert not pid_alive(pid), f"meshcat server {pid} left running"


# ------------------------------------------------------------------------ real renders
needs_chromium = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="/usr/bin/chromium is missing (apt-get install -y chromium)"
)


def render(vis, tmp_path: Path, name: str) -> np.ndarray:
    html = viz.write_html(vis, tmp_path / f"{name}.html")
    png = viz.render_png(html, tmp_path / f"{name}.png", timeout=180.0, chromium=str(CHROMIUM))
    from PIL import Image

    with Image.open(png) as image:
        return np.asarray(image.convert("RGB"), dtype=np.int16)


def isolate(vis, summary: viz.SceneSummary, keep: str) -> None:
    """Hide every object of the scene but one, and paint that one opaque red."""
    for path in summary.paths:
        if path != keep:
            vis["deltacal"][path].set_property("visible", False)
    vis["deltacal"][keep].set_property("color", [1.0, 0.0, 0.0, 1.0])


def red_mask(image: np.ndarray) -> np.ndarray:
    return (image[..., 0] - np.maximum(image[..., 1], image[..., 2])) > 50


@needs_chromium
@pytest.mark.long
@pytest.mark.browser
def test_render_shows_the_robot_and_its_plate_apart_from_the_ghost(tmp_path, nominal, robots):
    nominal_geometry, true_geometry = robots
    from PIL import Image

    # the demo views: an animated page and a still screenshot of the robot
    views = viz.export_views(
        nominal_geometry, true_geometry, tmp_path / "demo.html", tmp_path / "demo.png", nominal.workspace
    )
    assert views["html"].exists() and views["png"].exists()
    with Image.open(views["png"]) as image:
        assert image.size == viz.DEFAULT_WINDOW
        full = np.asarray(image.convert("RGB"), dtype=np.int16)

    options = {"workspace": nominal.workspace}
    vis = viz.recording_visualizer()
    summary = viz.build_scene(vis, nominal_geometry, true_geometry, **options)
    vis["deltacal"].set_property("visible", False)
    empty = render(vis, tmp_path, "empty")
    changed = np.max(np.abs(full - empty), axis=2) > 24
    fraction = changed.mean()
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    width, height = np.ptp(cols) / full.shape[1], np.ptp(rows) / full.shape[0]
    print(f"robot pixels {fraction:.1%}, spanning {width:.0%} x {height:.0%} of the window")
    assert fraction > 0.05, f"only {fraction:.1%} of the view shows the robot"
    # framed: the drawing spans most of the window, not a speck
    assert width > 0.6 and height > 0.6

    # the true plate (tilt drawn x100) and the ghost plate, alone, in the same camera
    masks = {}
    for name, truth, keep in (
        ("true", true_geometry, "true/plate/body"),
        ("ghost", true_geometry, "nominal/plate/body"),
        ("control", nominal_geometry, "true/plate/body"),  # a perfect robot: its plate is the ghost's
    ):
        vis = viz.recording_visualizer()
        s = viz.build_scene(vis, nominal_geometry, truth, camera_view=summary.camera, **options)
        isolate(vis, s, keep)
        masks[name] = red_mask(render(vis, tmp_path, name))
    for name, mask in masks.items():
        assert mask.sum() > 500, f"{name} plate not visible ({mask.sum()} px)"
    apart = (
        np.logical_xor(masks["true"], masks["ghost"]).sum()
        / np.logical_or(masks["true"], masks["ghost"]).sum()
    )
    same = (
        np.logical_xor(masks["control"], masks["ghost"]).sum()
        / np.logical_or(masks["control"], masks["ghost"]).sum()
    )
    print(f"plate pixels {masks['true'].sum()}, true vs ghost differ on {apart:.0%}, control on {same:.1%}")
    assert apart > 0.25, f"true and ghost plates differ on only {apart:.0%} of their pixels"
    assert same < 0.05, f"a perfect robot's plate should cover the ghost's ({same:.1%} differ)"


# ------------------------------------------------------------------ a linear Delta printer
@pytest.fixture(scope="module")
def printer():
    """The Kossel printer file and a true printer around it (a typical kit's errors)."""
    from deltacal.robots import load_robot

    kossel = load_robot(MODELS / "kossel.toml")
    geometry = kossel.geometry()
    return kossel, geometry, geometry.perturbed(Tolerances.printer_kit(), np.random.default_rng(SEED))


def test_printer_state_slides_the_carriages_down_their_towers(printer):
    kossel, nominal_geometry, true_geometry = printer
    q = np.array([[150.0, 210.0, 180.0]])  # travels below the endstops [mm]
    state = viz.RobotState.compute(true_geometry, q, 1.0)
    travel = true_geometry.joint_scale * q[0] + true_geometry.encoder_offset
    expected = true_geometry.axis_point - travel[:, None] * true_geometry.axis_direction
    np.testing.assert_allclose(state.arm_origin[0], expected, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(state.arm_rotation[0], true_geometry.actuator_rotation(), atol=0.0)
    np.testing.assert_allclose(state.arm_balls, true_geometry.arm_balls_in_base(q), atol=1e-12)
    lengths = np.linalg.norm(state.plate_balls - state.arm_balls, axis=-1)[0]
    np.testing.assert_allclose(lengths, true_geometry.rod_length, atol=1e-8)
    # a rotary robot's arm frames stay on their axes
    rotary = load_nominal(MODELS / "bai2015.toml").geometry()
    arms = viz.RobotState.compute(rotary, np.radians([[10.0, 20.0, 30.0]]))
    assert np.array_equal(arms.arm_origin[0], rotary.axis_point) and arms.joint == "revolute"
    # a scene draws two robots of one kind
    from deltacal.exceptions import GeometryError

    with pytest.raises(GeometryError, match="prismatic chain and the nominal one a revolute chain"):
        viz.build_scene(viz.recording_visualizer(), rotary, true_geometry)


def test_printer_html_holds_towers_carriages_effector_and_bed(tmp_path, printer):
    kossel, nominal_geometry, true_geometry = printer
    out = tmp_path / "printer.html"
    summary = viz.export_html(nominal_geometry, true_geometry, out, workspace=kossel.workspace, animate=True)
    commands = decode_commands(out.read_text(encoding="utf-8"))
    paths = {c["path"] for c in commands}
    expected = ["bed", "frame", "workspace", "arrows", "inset/true/body", "inset/nominal/body"]
    for robot in ("true", "nominal"):
        expected.append(f"{robot}/top")
        for i in (1, 2, 3):
            expected += [f"{robot}/limb{i}/tower", f"{robot}/limb{i}/carriage/body"]
            expected += [f"{robot}/limb{i}/carriage/ball{j}" for j in (1, 2)]
            expected += [f"{robot}/limb{i}/rod{j}" for j in (1, 2)]
            expected += [f"{robot}/plate/ball{i}{j}" for j in (1, 2)]
        expected += [f"{robot}/plate/{part}" for part in ("body", "axis", "tool", "tcp")]
    for path in expected:
        assert f"/meshcat/deltacal/{path}" in paths, path
        assert path in summary.paths
    assert not [p for p in summary.paths if "/arm/" in p or p.endswith("/base") or "actuator" in p]
    objects = [c for c in commands if c["type"] == "set_object"]
    assert sum(c["path"].startswith("/meshcat/deltacal/true/") for c in objects) == 1 + 3 * 6 + 10
    # the printer's words, the real tilt and the largest error
    texts = [t["text"] for c in objects for t in c["object"].get("textures", []) if t.get("type") == "_text"]
    assert f"effector tilt {math.degrees(summary.tilt):.3f}\u00b0" in texts
    assert "nozzle error arrows" in texts and "effectors \u00d73, tilt side-on" in texts
    assert not [t for t in texts if "plate" in t or "TCP" in t]
    assert 0.01 < math.degrees(summary.tilt) < 1.0 and 0.5 < summary.max_error < 20.0
    assert summary.arrows > 30
    # each carriage sits on its tower where the true travel puts it
    transform = {c["path"]: np.array(c["matrix"]).reshape(4, 4).T
                 for c in commands if c["type"] == "set_transform"}
    state = viz.RobotState.compute(true_geometry, summary_readings(nominal_geometry, kossel))
    for i in range(3):
        carriage = transform[f"/meshcat/deltacal/true/limb{i + 1}/carriage"]
        np.testing.assert_allclose(carriage[:3, 3], state.arm_origin[0, i], atol=1e-9)
    # the towers run along the axis lines from the bed up past the endstops
    for i in range(3):
        T = transform[f"/meshcat/deltacal/true/limb{i + 1}/tower"]
        axis = T[:3, 1]  # the unit cylinder along y, scaled to the tower's length
        w = true_geometry.axis_direction[i]
        np.testing.assert_allclose(axis / np.linalg.norm(axis), w, atol=1e-9)
        foot, top = T[:3, 3] - 0.5 * axis, T[:3, 3] + 0.5 * axis
        assert abs(foot[2]) < 1e-6 and top[2] > true_geometry.axis_point[i, 2]
        off = foot - true_geometry.axis_point[i]
        assert np.linalg.norm(off - (off @ w) * w) < 1e-6
    # the animation slides both printers' carriages
    animation = next(c for c in commands if c["type"] == "set_animation")
    animated = {a["path"] for a in animation["animations"]}
    for robot in ("true", "nominal"):
        for path in (f"{robot}/limb1/carriage", f"{robot}/limb3/rod2", f"{robot}/plate"):
            assert f"/meshcat/deltacal/{path}" in animated, path
    assert summary.animation_frames == 100


def summary_readings(nominal_geometry, kossel) -> np.ndarray:
    """The readings a scene draws by default: the nominal inverse kinematics of the workspace centre."""
    from deltacal.kinematics import exact

    return exact.inverse(nominal_geometry, kossel.workspace.centre[None])


def test_view_command_shows_a_printer_file(tmp_path, capsys):
    from deltacal.cli import main

    out = tmp_path / "printer.html"
    assert main(["view", str(MODELS / "kossel.toml"), "--perturb", "4", "--html", str(out)]) == 0
    assert "effector tilt" in capsys.readouterr().out
    paths = {c["path"] for c in decode_commands(out.read_text(encoding="utf-8"))}
    assert "/meshcat/deltacal/true/limb2/carriage/body" in paths and "/meshcat/deltacal/bed" in paths
    # a true printer from a geometry file
    from deltacal.robots import load_robot

    printer_truth = tmp_path / "printer_truth.toml"
    kossel = load_robot(MODELS / "kossel.toml").geometry()
    save_geometry(kossel.perturbed(Tolerances.printer_kit(), np.random.default_rng(5)), printer_truth)
    out = tmp_path / "printer_truth.html"
    assert main(["view", str(MODELS / "kossel.toml"), "--truth", str(printer_truth), "--html", str(out)]) == 0
    assert "largest nozzle error" in capsys.readouterr().out and out.exists()
    # a true robot of the other kind is refused in one line, nothing written
    truth = tmp_path / "rotary.toml"
    save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), truth)
    refused = tmp_path / "refused.html"
    assert main(["view", str(MODELS / "kossel.toml"), "--truth", str(truth), "--html", str(refused)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rotary.toml" in err[0] and "printer" in err[0] and not refused.exists()


@needs_chromium
@pytest.mark.long
@pytest.mark.browser
def test_render_shows_the_printer_and_its_effector_apart_from_the_ghost(tmp_path, printer):
    kossel, nominal_geometry, true_geometry = printer
    from PIL import Image

    views = viz.export_views(
        nominal_geometry, true_geometry, tmp_path / "printer.html", tmp_path / "printer.png", kossel.workspace
    )
    with Image.open(views["png"]) as image:
        full = np.asarray(image.convert("RGB"), dtype=np.int16)
    options = {"workspace": kossel.workspace}
    vis = viz.recording_visualizer()
    summary = viz.build_scene(vis, nominal_geometry, true_geometry, **options)
    vis["deltacal"].set_property("visible", False)
    changed = np.max(np.abs(full - render(vis, tmp_path, "empty")), axis=2) > 24
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    width, height = np.ptp(cols) / full.shape[1], np.ptp(rows) / full.shape[0]
    print(f"printer pixels {changed.mean():.1%}, spanning {width:.0%} x {height:.0%} of the window")
    assert changed.mean() > 0.05 and width > 0.6 and height > 0.6

    masks = {}
    for name, truth, keep in (
        ("true", true_geometry, "true/plate/body"),
        ("ghost", true_geometry, "nominal/plate/body"),
        ("control", nominal_geometry, "true/plate/body"),  # a perfect printer: its effector is the ghost's
        ("bed", true_geometry, "bed"),
    ):
        vis = viz.recording_visualizer()
        s = viz.build_scene(vis, nominal_geometry, truth, camera_view=summary.camera, **options)
        isolate(vis, s, keep)
        masks[name] = red_mask(render(vis, tmp_path, name))
    for name, mask in masks.items():
        assert mask.sum() > 300, f"{name} not visible ({mask.sum()} px)"
    assert masks["bed"].sum() > 20 * masks["true"].sum()  # the bed is the largest part in view

    def differ(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.logical_xor(a, b).sum() / np.logical_or(a, b).sum())

    apart, same = differ(masks["true"], masks["ghost"]), differ(masks["control"], masks["ghost"])
    print(f"effector pixels {masks['true'].sum()}, true vs ghost differ on {apart:.0%}, control {same:.1%}")
    assert apart > 0.25, f"true and ghost effectors differ on only {apart:.0%} of their pixels"
    assert same < 0.05, f"a perfect printer's effector should cover the ghost's ({same:.1%} differ)"
