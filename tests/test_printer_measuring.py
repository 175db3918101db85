"""Measuring a printer without typing numbers: the probe program, the labelled object, the sheet."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import kossel_printer_cfg
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.exceptions import InputError
from deltacal.printer.files.measurements import (
    read_printed_distances,
    read_probe_heights,
    write_printed_distances,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.base import PROBE_CLEARANCE, Firmware
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.printed.labels import LABEL_GAP
from deltacal.printer.printed.lettering import RELIEF, TILE_THICKNESS, label_mesh, text_raster
from deltacal.printer.printed.object import BALL_DIAMETER, LOWEST_LEVEL, footprint_radius, probe_grid

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
MOVE = re.compile(r"^G1 X(-?\d+\.\d{3}) Y(-?\d+\.\d{3}) Z(\d+\.\d{3}) F\d+$")


def probed_points(program: str) -> np.ndarray:
    """The (x, y) of each ``PROBE``: where the last move before it left the nozzle, and its height."""
    position = None
    homed = False
    out = []
    for line in program.splitlines():
        command = line.split(";")[0].strip()
        if command == "G28":
            homed = True
        elif (m := MOVE.match(command)) is not None:
            position = tuple(float(v) for v in m.groups())
        elif command.startswith("G1 Z") and position is not None:
            position = (position[0], position[1], float(command.split()[1][1:]))
        elif command == "PROBE":
            assert homed, "PROBE before G28"
            assert position is not None
            out.append(position)
    return np.array(out)


# ------------------------------------------------------------------ the probe program
def test_klipper_probe_program_probes_each_point_in_order():
    grid = probe_grid(115.0, 7)
    program = KLIPPER.probe_program(grid, title="test")
    assert isinstance(KLIPPER, Firmware)
    assert program.splitlines()[0] == "; test"
    probed = probed_points(program)
    assert_allclose(probed[:, :2], grid[:, :2], rtol=0, atol=0)  # to the micrometre, as Klipper echoes
    assert np.all(probed[:, 2] == PROBE_CLEARANCE)  # each PROBE starts from the clearance
    assert program.count("PROBE\n") == len(grid)
    # after each probe the nozzle rises straight up before the next horizontal move
    lines = [line for line in program.splitlines() if not line.startswith(";")]
    after = [lines[k + 1] for k, line in enumerate(lines) if line == "PROBE"]
    assert all(line.startswith(f"G1 Z{PROBE_CLEARANCE:.3f} ") for line in after)
    with pytest.raises(ValueError, match="clearance"):
        KLIPPER.probe_program(grid, clearance=0.0)


# ------------------------------------------------------------------ the labelled object
@pytest.fixture(scope="module")
def plan(kossel_plan):
    return kossel_plan  # plan_object of the Kossel and Klipper's nominal values, planned once


def edge_uses(mesh) -> np.ndarray:
    """How many faces use each edge of a mesh (its vertices merged by position)."""
    merged = mesh.copy()
    merged.merge_vertices()
    _, counts = np.unique(merged.edges_sorted, axis=0, return_counts=True)
    return counts


def test_the_labelled_object_is_a_closed_mesh(plan):
    mesh = plan.labelled_mesh()
    assert np.all(edge_uses(mesh) == 2)  # every edge shared by exactly two faces
    assert mesh.is_watertight and mesh.is_winding_consistent
    parts = mesh.split(only_watertight=False)
    assert len(parts) == 2 * len(plan.features)  # a ball on its post and a label's tile for each
    assert all(part.volume > 0.0 for part in parts)
    assert len(plan.labels) == len(plan.features)
    assert sorted(plan.names, key=int) == [str(k) for k in range(1, len(plan.features) + 1)]


def test_each_label_lies_beside_its_ball_clear_of_every_feature(plan):
    sites, pads = plan.features[:, :2], np.array([footprint_radius(z) for z in plan.features[:, 2]])
    for label in plan.labels:
        tile = label.mesh()
        low, high = tile.bounds[0, :2], tile.bounds[1, :2]
        assert_allclose([low, high], label.corners, atol=1e-9)  # where the plan (and the sheet) says
        assert tile.bounds[1, 2] == TILE_THICKNESS + RELIEF < LOWEST_LEVEL - 0.5 * BALL_DIAMETER
        centre = 0.5 * (low + high)
        distance = np.linalg.norm(sites - centre, axis=1)
        assert int(np.argmin(distance)) == label.ball
        # no pad (nor the post and ball above it) within the gap of the tile
        outside = np.maximum(np.maximum(low - sites, sites - high), 0.0)
        assert np.all(np.hypot(*outside.T) >= pads + LABEL_GAP - 1e-9)
        assert np.max(np.hypot(*tile.vertices[:, :2].T)) <= load_printer(KOSSEL).workspace.radius


def test_labels_read_one_way_only():
    """No name of 1..19 turned half round is another's (6 and 9 are underlined); every digit is closed."""
    def raised(text, turn):
        r = np.rot90(text_raster(text), 2 * turn)
        rows, cols = np.flatnonzero(r.any(axis=1)), np.flatnonzero(r.any(axis=0))
        return r[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]

    names = [str(k) for k in range(1, 20)]
    for a in names:
        for b in names:
            if a != b:
                turned, other = raised(a, 1), raised(b, 0)
                assert turned.shape != other.shape or np.any(turned != other), (a, b)
    for digit in "0123456789":
        tile = label_mesh(digit, np.zeros(2))
        assert np.all(edge_uses(tile) == 2) and tile.volume > 0.0
    with pytest.raises(ValueError, match="digits only"):
        text_raster("A1")


# ------------------------------------------------------------------ distances.csv with the balls' labels
def test_distances_carry_the_balls_labels_and_read_back(tmp_path, plan):
    path = tmp_path / "distances.csv"
    names = plan.names
    balls = [(names[i], names[j]) for i, j in plan.pairs.tolist()]
    write_printed_distances(path, plan.pair_positions, balls=balls)
    assert path.read_text().splitlines()[0] == "x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,ball1,ball2,distance_mm"
    template = read_printed_distances(path, filled=False)
    assert template.balls == balls and np.all(np.isnan(template.distance))
    write_printed_distances(path, plan.pair_positions, plan.lengths + 0.01, balls=balls)
    read = read_printed_distances(path)
    assert read.balls == balls
    assert_allclose(read.pairs, plan.pair_positions, rtol=0, atol=0)
    assert_allclose(read.distance, plan.lengths + 0.01, rtol=0, atol=0)
    write_printed_distances(path, plan.pair_positions, plan.lengths)  # a file without them still reads
    assert read_printed_distances(path).balls == []


HEADER = "x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,ball1,ball2,distance_mm\n0,0,8,50,0,30,1,2,54.6\n"


@pytest.mark.parametrize(("text", "message"), [
    (HEADER + "0,0,8,0,50,8,3,4,50.1\n",
     r"line 3 \(data row 2\), column ball1: the ball at \[0.0, 0.0, 8.0\] mm is 1 on an earlier row "
     r"and 3 here"),
    (HEADER + "0,0,8,0,50,8,1,1,50.1\n",
     r"line 3 \(data row 2\), column ball2: ball 1 is at \[0.0, 0.0, 8.0\] mm on an earlier row and at "
     r"\[0.0, 50.0, 8.0\] mm here"),
    (HEADER + "0,0,8,0,50,8,1,,50.1\n", r"line 3 \(data row 2\), column ball2: empty ball label"),
    ("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,ball1,distance_mm\n0,0,8,50,0,30,1,54.6\n",
     r"distances.csv: line 1: columns ball1, ball2 go together; missing ball2"),
])
def test_labels_that_contradict_the_positions_are_refused(tmp_path, text, message):
    path = tmp_path / "distances.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_printed_distances(path)


# ------------------------------------------------------------------ the sheet
LABEL_TEXT = re.compile(r'<text class="label" data-ball="(\d+)" x="(-?[\d.]+)" y="(-?[\d.]+)"[^>]*>'
                        r'([^<]+)</text>')
BALL = re.compile(r'<circle class="ball" data-ball="(\d+)" cx="(-?[\d.]+)" cy="(-?[\d.]+)"')
PAIR_ROW = re.compile(r'<tr class="pair"><td>(\d+)</td><td>([^<]+)</td><td>([^<]+)</td><td>([\d.]+)</td>')


@pytest.mark.slow
def test_plan_writes_the_probe_program_and_the_sheet_of_its_files(tmp_path, capsys):
    """probe.gcode probes probe.csv's points; sheet.html shows the labels where object.stl has them and
    lists the pairs of distances.csv."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    out = tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "probe.gcode" in printed and "sheet.html" in printed
    probe = read_probe_heights(out / "probe.csv", filled=False)
    probed = probed_points((out / "probe.gcode").read_text())
    assert len(probed) == len(probe.commanded) == 49
    assert_allclose(probed[:, :2], probe.commanded[:, :2], rtol=0, atol=5e-4)
    page = (out / "sheet.html").read_text()
    assert "<script" not in page and not re.search(r'(src|href)="', page)  # self-contained, nothing fetched
    assert re.findall(r"https?://[^\"]+", page) == ["http://www.w3.org/2000/svg"]
    balls = {int(k): np.array([float(x), -float(y)]) for k, x, y in BALL.findall(page)}
    labels = [(int(k), np.array([float(x), -float(y)]), name) for k, x, y, name in LABEL_TEXT.findall(page)]
    # the STL's tiles: every part no higher than a tile, centred where the sheet writes its name
    mesh = trimesh.load(out / "object.stl", force="mesh")
    tiles = [part for part in mesh.split(only_watertight=False)
             if part.bounds[1, 2] <= TILE_THICKNESS + RELIEF + 1e-5]
    assert np.all(edge_uses(mesh) == 2)  # the STL as written: closed
    assert len(tiles) == len(labels) == len(balls)
    tile_centres = np.array([0.5 * (t.bounds[0, :2] + t.bounds[1, :2]) for t in tiles])
    for ball, centre, _ in labels:
        assert np.min(np.linalg.norm(tile_centres - centre, axis=1)) < 1e-3  # float32 STL
        nearest = min(balls, key=lambda k: np.linalg.norm(balls[k] - centre))
        assert nearest == ball
    # the table: the pairs of distances.csv, in its order, with the same labels and positions
    read = read_printed_distances(out / "distances.csv", filled=False)
    rows = PAIR_ROW.findall(page)
    assert [int(r[0]) for r in rows] == list(range(1, len(read.pairs) + 1))
    assert [(r[1], r[2]) for r in rows] == read.balls
    names = {name: balls[ball] for ball, _, name in labels}
    for (_, one, two, nominal), pair in zip(rows, read.pairs, strict=True):
        assert_allclose(names[one], pair[:2], atol=1e-3)
        assert_allclose(names[two], pair[3:5], atol=1e-3)
        assert abs(float(nominal) - np.linalg.norm(pair[:3] - pair[3:])) <= 0.005
