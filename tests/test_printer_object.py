"""The printed calibration object of a printer (issue 24): probe grid, STL, distance pairs, CSV files, CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.exceptions import InputError, PlanningError
from deltacal.geometry import Workspace
from deltacal.printer.files.measurements import (
    read_printed_distances,
    read_probe_heights,
    write_printed_distances,
    write_probe_heights,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.printed.object import (
    BALL_DIAMETER,
    CALIPER_RANGE,
    CLEARANCE,
    MAX_ELEVATION,
    feature_mesh,
    levels,
    probe_grid,
)
from deltacal.printer.printed.plan import geometric_rows, model_rows, plan_object

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
KOSSEL = MODELS / "kossel.toml"


@pytest.fixture(scope="module")
def printer():
    return load_printer(KOSSEL)


@pytest.fixture(scope="module")
def firmware(printer):
    return KlipperDelta.from_printer(printer)


@pytest.fixture(scope="module")
def plan(kossel_plan):
    return kossel_plan  # plan_object(printer, firmware), planned once for the session


def write_printer_cfg(path: Path, klipper: KlipperDelta) -> Path:
    """A minimal Klipper configuration of a delta printer with these values (a probe at the nozzle)."""
    lines = ["[printer]", "kinematics: delta", f"delta_radius: {klipper.delta_radius!r}"]
    for k, axis in enumerate("abc"):
        lines += [f"[stepper_{axis}]", "microsteps: 16", "rotation_distance: 40",
                  f"arm_length: {float(klipper.arm_length[k])!r}",
                  f"position_endstop: {float(klipper.position_endstop[k])!r}"]
    lines += ["[probe]", "pin: ^PA4", "z_offset: 0"]
    path.write_text("\n".join(lines) + "\n")
    return path


# ------------------------------------------------------------------ the probe grid
def test_probe_grid_is_klippers_round_mesh():
    """7 across a 115 mm radius: the 29 grid points within the circle (Klipper's round_probe_count 7)."""
    grid = probe_grid(115.0, 7)
    assert grid.shape == (29, 3)
    assert np.all(np.hypot(grid[:, 0], grid[:, 1]) <= 115.0 + 1e-9)
    assert np.all(grid[:, 2] == 0.0)
    assert [0.0, 0.0, 0.0] in grid.tolist() and [0.0, 115.0, 0.0] in grid.tolist()
    assert len(probe_grid(100.0, 5)) == 13  # the 5-point diagram of Klipper's Config_Reference
    with pytest.raises(PlanningError, match="odd number"):
        probe_grid(115.0, 6)


# ------------------------------------------------------------------ the object
def test_object_mesh_is_printable_in_the_printable_volume(plan, printer):
    """Every part watertight, on the bed (z >= 0, a pad at z = 0), within the printable cylinder."""
    mesh = plan.mesh()
    parts = mesh.split(only_watertight=False)
    assert len(parts) == len(plan.features)
    assert all(part.is_watertight and part.volume > 0.0 for part in parts)
    ws = printer.workspace
    assert mesh.bounds[0, 2] == 0.0
    assert mesh.bounds[1, 2] <= ws.height
    assert np.max(np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])) <= ws.radius + 1e-9


def test_each_ball_is_centred_on_its_commanded_position(plan):
    """A part's top is its ball's top: the feature's centre plus the ball's radius, on its axis."""
    for part, centre in zip(plan.mesh().split(only_watertight=False), _by_part(plan), strict=True):
        top = part.vertices[np.argmax(part.vertices[:, 2])]
        assert_allclose(top, centre + [0.0, 0.0, 0.5 * BALL_DIAMETER], atol=1e-9)
        # the equator of the ball: as far from the axis as the radius (the outline's polygon inscribed)
        ring = part.vertices[np.abs(part.vertices[:, 2] - centre[2]) < 0.3]
        spread = np.hypot(*(ring[:, :2] - centre[:2]).T)
        assert 0.5 * BALL_DIAMETER * np.cos(np.pi / 72) - 0.05 < spread.max() <= 0.5 * BALL_DIAMETER + 1e-9


def _by_part(plan):
    """The features in the order ``mesh.split`` returns the parts: matched by their top's (x, y)."""
    parts = plan.mesh().split(only_watertight=False)
    centres = []
    for part in parts:
        top = part.vertices[np.argmax(part.vertices[:, 2])]
        k = int(np.argmin(np.linalg.norm(plan.features[:, :2] - top[:2], axis=1)))
        centres.append(plan.features[k])
    return np.array(centres)


def test_a_feature_is_watertight_on_its_own():
    part = feature_mesh(np.array([10.0, -20.0, 8.0]))
    assert part.is_watertight and part.is_winding_consistent and part.volume > 0.0


def test_pairs_can_be_measured_with_a_caliper(plan):
    """At most 40; each reading fits the caliper, rises at most 45°, joins two sites; nothing in the way."""
    assert 1 <= len(plan.pairs) <= 40
    a, b = plan.features[plan.pairs[:, 0]], plan.features[plan.pairs[:, 1]]
    d = b - a
    assert np.all(plan.lengths + BALL_DIAMETER <= CALIPER_RANGE)
    assert np.all(np.abs(d[:, 2]) <= np.tan(MAX_ELEVATION) * np.hypot(d[:, 0], d[:, 1]) + 1e-9)
    assert np.all(np.hypot(d[:, 0], d[:, 1]) > 0.0)
    assert len({tuple(p) for p in plan.features[:, :2].round(6)}) == len(plan.features)  # one ball per site
    blocks = _blocking_of_printed(plan.features, plan.pairs)
    assert not blocks.any(), f"{int(blocks.sum())} features within {CLEARANCE} mm of a measured line"


def _blocking_of_printed(features, pairs):
    """Printed features within the clearance of a pair's line (ball, cone and tapered post), by loops."""
    from deltacal.printer.printed import object as po

    r = 0.5 * BALL_DIAMETER
    out = np.zeros((len(pairs), len(features)), dtype=bool)
    for p, (i, j) in enumerate(pairs):
        a, b = features[i], features[j]
        u = (b - a) / np.linalg.norm(b - a)
        t = np.linspace(0.0, 1.0, 200)[:, None]
        line = (a - r * u) + t * ((b + r * u) - (a - r * u))
        for f, c in enumerate(features):
            if f in (i, j):
                continue
            dxy = np.hypot(line[:, 0] - c[0], line[:, 1] - c[1])
            ball = np.hypot(dxy, line[:, 2] - c[2]) - r
            foot, neck = po._foot_radius(float(c[2])), po._neck_height(float(c[2]))
            along = np.clip(line[:, 2] / neck, 0.0, 1.0)
            radius = np.where(line[:, 2] <= neck, foot + (po.NECK_RADIUS - foot) * along, r)
            post = np.where(line[:, 2] <= c[2], dxy - radius, np.inf)
            out[p, f] = min(ball.min(), post.min()) < CLEARANCE
    return out


def test_distances_add_what_probe_heights_cannot_identify(printer, firmware):
    """Probe heights alone (Klipper's round 7 x 7 mesh, 29 points): endstops, scales, leans; the distances
    add the rods (and more)."""
    plan = plan_object(printer, firmware, probe_count=7)
    alone, both = plan.probe_only, plan.with_distances
    assert alone is not None and both is not None
    assert both.rank > alone.rank
    assert {"l12", "l21", "l22", "l31", "l32"} <= set(plan.added_names())
    assert plan.log_det > plan.log_det_probe


@pytest.mark.slow
def test_greedy_selection_beats_random_measurable_sets(printer, firmware, plan):
    """The chosen pairs' D-criterion is above that of measurable sets chosen at random (same constraints)."""
    rows = model_rows(printer, firmware)

    def log_det(chosen):
        probe_rows, pair_rows = rows(chosen.probe, chosen.pair_positions.reshape(-1, 2, 3))
        information = np.eye(pair_rows.shape[1]) + probe_rows.T @ probe_rows
        return np.linalg.slogdet(information + pair_rows.T @ pair_rows)[1]

    assert_allclose(log_det(plan), plan.log_det, rtol=1e-12)
    for seed in range(4):
        rng = np.random.default_rng(seed)

        def random_rows(probe, pairs, rng=rng):
            return np.zeros((len(probe), 6)), rng.normal(size=(len(pairs), 6))

        other = plan_object(printer, firmware, rows=random_rows)
        assert len(other.pairs) == len(plan.pairs)
        assert log_det(other) < plan.log_det - 1.0


def test_geometric_default_plans_without_a_model(printer, firmware):
    plan = plan_object(printer, firmware, count=12, rows=geometric_rows)
    assert len(plan.pairs) == 12 and plan.probe_only is None and plan.added_names() == []
    assert len(np.unique(plan.features[:, 2])) >= 2  # several heights


def test_too_many_distances_are_refused(printer, firmware):
    with pytest.raises(PlanningError, match="1 to 40"):
        plan_object(printer, firmware, count=41)


# ------------------------------------------------------------------ the CSV files
def test_templates_round_trip(tmp_path, plan):
    probe, pairs = tmp_path / "probe.csv", tmp_path / "distances.csv"
    write_probe_heights(probe, plan.probe)
    write_printed_distances(pairs, plan.pair_positions)
    with pytest.raises(InputError, match=r"probe.csv: line 2 \(data row 1\), column z_mm: fill in z_mm: .* "
                                         r"empty on 49 of 49 rows \(a template"):
        read_probe_heights(probe)
    with pytest.raises(InputError, match=r"distances.csv: line 2 \(data row 1\), column distance_mm: fill in "
                                         r"distance_mm"):
        read_printed_distances(pairs)
    heights = np.linspace(-0.1, 0.1, len(plan.probe))
    write_probe_heights(probe, plan.probe, heights)
    read = read_probe_heights(probe)
    assert_allclose(read.commanded, np.column_stack([plan.probe[:, :2], heights]), rtol=0, atol=0)
    assert read.lines.tolist() == list(range(2, len(plan.probe) + 2))
    write_printed_distances(pairs, plan.pair_positions, plan.lengths + 0.01)
    got = read_printed_distances(pairs)
    assert_allclose(got.pairs, plan.pair_positions, rtol=0, atol=0)
    assert_allclose(got.distance, plan.lengths + 0.01, rtol=0, atol=0)


@pytest.mark.parametrize(("text", "message"), [
    ("x_mm,y_mm,z_mm\n0,0,0.1\n10,abc,0.2\n",
     r"line 3 \(data row 2\), column y_mm: value 'abc' is not a number"),
    ("x_mm,y_mm,z_mm\n0,0,0.1\n10,0,\n20,0,\n",
     r"line 3 \(data row 2\), column z_mm: fill in z_mm: .* empty on 2 of 3 rows$"),
    ("x_mm,y_mm\n0,0\n", r"line 1: missing required column z_mm"),
    ("x_mm,y_mm,z_mm\n0,0,0,1\n", r"line 2 \(data row 1\): 4 fields where the header has 3"),
    ("x_mm,y_mm,z_mm\n0,0,nan\n", r"column z_mm: value 'nan' is not a finite number"),
])
def test_bad_probe_files_name_the_row(tmp_path, text, message):
    path = tmp_path / "probe.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_probe_heights(path)


@pytest.mark.parametrize(("row", "message"), [
    ("0,0,8,50,0,8,-1", r"line 3 \(data row 2\), column distance_mm: a distance must be above 0 mm, got -1$"),
    ("0,0,8,0,0,8,5", r"line 3 \(data row 2\), columns x1_mm..z2_mm: both features of the pair are at"),
    ("0,0,8,50,0,8,50,3", r"line 3 \(data row 2\): 8 fields where the header has 7"),
    ("0,0,8,50,0,8,5O.1", r"line 3 \(data row 2\), column distance_mm: value '5O.1' is not a number"),
])
def test_bad_distance_files_name_the_row(tmp_path, row, message):
    path = tmp_path / "distances.csv"
    path.write_text("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm\n0,0,8,50,0,30,54.6\n" + row + "\n")
    with pytest.raises(InputError, match=message):
        read_printed_distances(path)


# ------------------------------------------------------------------ the command line
def test_cli_writes_the_object_probe_grid_and_distances(tmp_path, firmware, capsys):
    cfg = write_printer_cfg(tmp_path / "printer.cfg", firmware)
    out = tmp_path / "object"
    code = main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(out),
                      "--distances", "30"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "probe heights alone identify" in captured.out and "the distances add" in captured.out
    mesh = trimesh.load(out / "object.stl", force="mesh")
    probe = np.loadtxt(out / "probe.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    pairs = np.loadtxt(out / "distances.csv", delimiter=",", skiprows=1, usecols=range(6))
    assert probe.shape == (49, 2) and pairs.shape == (30, 6)
    assert mesh.bounds[0, 2] >= -1e-6  # STL stores float32
    # every distance's feature is a ball of the STL: its top within float32 precision
    tops = {tuple(np.round(part.vertices[np.argmax(part.vertices[:, 2])], 3))
            for part in mesh.split(only_watertight=False)}
    for centre in pairs.reshape(-1, 3):
        assert tuple(np.round(centre + [0.0, 0.0, 0.5 * BALL_DIAMETER], 3)) in tops
    for name in ("probe.csv", "distances.csv"):
        text = (out / name).read_text().splitlines()
        assert all(line.endswith(",") for line in text[1:])  # the measured column left to fill in


@pytest.mark.parametrize(("extra", "message"), [
    ([], "--object needs --controller"),
    (["--controller", "CFG", "--n", "3"], "--n applies to pose planning"),
    (["--controller", "CFG", "--distances", "41"], "must be at most 40"),
    (["--controller", "CFG", "--probe-grid", "6"], "must be odd, 3 to 9"),
    (["--controller", "CFG", "--probe-grid", "11"], "must be odd, 3 to 9"),
    (["--controller", "missing.cfg"], "missing.cfg: file not found"),
])
def test_cli_refuses_bad_object_options(tmp_path, firmware, capsys, extra, message):
    cfg = write_printer_cfg(tmp_path / "printer.cfg", firmware)
    argv = ["plan", str(KOSSEL), "--object", "-o", str(tmp_path / "out")]
    argv += [str(cfg) if a == "CFG" else str(tmp_path / a) if a == "missing.cfg" else a for a in extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_cli_refuses_a_printer_without_object_and_a_rotary_robot_with_it(tmp_path, firmware, capsys):
    cfg = write_printer_cfg(tmp_path / "printer.cfg", firmware)
    assert main(["plan", str(KOSSEL), "-o", str(tmp_path / "poses.csv")]) == 2
    assert "use --object --controller printer.cfg" in capsys.readouterr().err
    assert main(["plan", str(MODELS / "bai2015.toml"), "--object", "--controller", str(cfg),
                      "-o", str(tmp_path / "out")]) == 2
    assert "is a rotary Delta's" in capsys.readouterr().err
    assert main(["plan", str(MODELS / "bai2015.toml"), "--controller", str(cfg), "-o",
                      str(tmp_path / "poses.csv")]) == 2
    assert "--controller applies to --object" in capsys.readouterr().err
    (tmp_path / "file").write_text("")
    argv = ["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(tmp_path / "file")]
    assert main(argv) == 2
    assert "this is a file" in capsys.readouterr().err


def test_cli_names_a_bad_printer_cfg(tmp_path, capsys):
    cfg = tmp_path / "printer.cfg"
    cfg.write_text("[printer]\nkinematics: delta\ndelta_radius: abc\n")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "section [printer], key delta_radius: value 'abc' is not a number" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "out").exists()


def test_feature_levels_follow_the_caliper_and_the_printable_height():
    """Four levels from 8 mm to 0.55 × the caliper above it, lower where the printable height ends."""
    tall = Workspace(radius=115.0, height=200.0, top_z=200.0)
    assert np.array_equal(levels(tall, 200.0), [8.0, 44.7, 81.3, 118.0])
    assert np.array_equal(levels(tall, 150.0), [8.0, 35.5, 63.0, 90.5])
    low = levels(Workspace(radius=115.0, height=60.0, top_z=60.0), 200.0)  # the top ball 2 mm under 60 mm
    assert low[-1] == 53.0 and len(low) == 4 and np.all(np.diff(low) > 0.0)
    with pytest.raises(PlanningError, match="printable height 24 mm holds no two feature levels"):
        levels(Workspace(radius=115.0, height=24.0, top_z=24.0), 200.0)


@pytest.mark.slow
def test_a_shorter_caliper_gets_a_lower_object_it_can_measure(printer, firmware, plan):
    short = plan_object(printer, firmware, caliper=150.0)
    assert set(np.unique(short.features[:, 2])) <= set(levels(printer.workspace, 150.0))
    assert np.all(short.lengths + BALL_DIAMETER <= 150.0)
    long = plan  # plan_object(printer, firmware): the default caliper's
    assert long.features[:, 2].max() > short.features[:, 2].max()
    assert (long.lengths + BALL_DIAMETER).max() > 150.0  # the default caliper reaches further
