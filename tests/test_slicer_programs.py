"""Slicers' programs corrected through Klipper on the command line, as a printer's owner runs them.

Each program of tests/data/slicers/ (Cura, PrusaSlicer, SuperSlicer, OrcaSlicer, Bambu Studio,
ideaMaker; each file's header says what it is) goes through ``deltacal compensate`` for a simulated
kit printer built on Klipper's example delta (tests/data/klipper/printer.cfg, with its START_PRINT and
END_PRINT), its calibration the true printer itself. The output is read here by rules of this file
alone (Klipper's own: G90/G91, M82/M83, G91 making E relative, G92 E, arcs' ends meeting making a full
turn) and judged: every line that is not a positioning move kept byte for byte and in order; the
extrusion between any two kept lines the program's exactly; every command inside Klipper's limits of
that printer.cfg and none an arc (the example configuration has no [gcode_arcs]); the true nozzle,
driven through Klipper's model by the commands written, on the program's points.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.gcode.homing import HOME_BLEND_MM, HOME_ZONE_MM
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.simulation import nozzle_positions, random_printer

DATA = Path(__file__).parent / "data"
CONFIG = DATA / "klipper" / "printer.cfg"
PROGRAMS = sorted((DATA / "slicers").glob("*.gcode"))
#: The programs that take a second or more (spiral lifts cut into many chords); the others stay fast.
SLOW = ("bambustudio-1.9", "orcaslicer-2.1")
#: Those of them over the suite's budget of a test (tests/budget.py): run by ``pytest --all``.
LONG = ("bambustudio-1.9",)
#: The true nozzle's distance from the program's points [mm]: exact compensation (1e-6 mm) and the
#: output's 0.1 µm rounding leave 0.1-0.2 µm (measured); 1 µm allowed.
POINT_TOLERANCE = 1e-3
#: Arcs of the program are sampled here in chords at most this far from the arc [mm].
ARC_SAGITTA_MM = 2e-5
WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
COMMAND = re.compile(r"^\s*([GM])0*(\d+)(?:\.(\d+))?(?![\d.])")
MACRO = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)")


def code_of(line: str) -> str:
    return line.split(";", 1)[0].strip().upper()


def is_positioning(line: str) -> bool:
    """A G0-G3 line with an axis or arc word: what the rewriter may rewrite."""
    code = code_of(line)
    head = COMMAND.match(code)
    if not head or head.group(1) != "G" or head.group(3) is not None or int(head.group(2)) > 3:
        return False
    return any(letter in "XYZIJR" for letter, _ in WORD.findall(code[head.end():]))


@dataclass
class Reading:
    """A program read as Klipper reads it: extrusion, points, commands."""

    home: np.ndarray
    macros: frozenset[str]
    absolute: bool = True
    absolute_e: bool = True
    e: Decimal = Decimal(0)
    extruded: Decimal = Decimal(0)
    position: list[float | None] = field(default_factory=lambda: [None, None, None])
    kept_extrusion: list[Decimal] = field(default_factory=list)
    ends: list[tuple[float, float, float]] = field(default_factory=list)  # each move's end, if known
    restarts: list[int] = field(default_factory=list)  # index in ends where a macro was called
    path: list[np.ndarray] = field(default_factory=list)  # (2, 3) segments between known points
    arcs: int = 0

    def line(self, text: str) -> None:
        code = code_of(text)
        head = COMMAND.match(code)
        if not is_positioning(text):
            self.kept_extrusion.append(self.extruded)
        if head is None:
            name = MACRO.match(code)
            if name and name.group(1) in self.macros:
                self.position = [None, None, None]
                self.restarts.append(len(self.ends))
            return
        kind, number = head.group(1) + head.group(2), head.group(3)
        words = {k: Decimal(v) for k, v in WORD.findall(code[head.end():])}
        if number is not None:
            return
        if kind == "M82":
            self.absolute_e = True
        elif kind == "M83":
            self.absolute_e = False
        elif kind == "G90":
            self.absolute = True
        elif kind == "G91":
            self.absolute = False
        elif kind == "G92" and "E" in words:
            self.e = words["E"]
        elif kind == "G28":
            self.position = [float(v) for v in self.home]
        elif kind in ("G0", "G1", "G2", "G3"):
            self.move(kind, words)

    def move(self, kind: str, words: dict[str, Decimal]) -> None:
        if "E" in words:
            relative_e = not self.absolute or not self.absolute_e  # Klipper: G91 makes E relative too
            step = words["E"] if relative_e else words["E"] - self.e
            self.e += step
            self.extruded += step
        start = list(self.position)
        end: list[float | None] = list(start)
        for k, axis in enumerate("XYZ"):
            if axis in words:
                value = float(words[axis])
                if self.absolute:
                    end[k] = value
                else:
                    end[k] = None if start[k] is None else start[k] + value  # type: ignore[operator]
        if not any(a in words for a in "XYZIJR"):
            return
        self.position = end
        if None in end:
            return
        self.ends.append(tuple(end))  # type: ignore[arg-type]
        if None in start:
            return
        a, b = np.array(start, dtype=float), np.array(end, dtype=float)
        if kind in ("G2", "G3"):
            self.arcs += 1
            i, j = float(words.get("I", 0)), float(words.get("J", 0))
            self.path.extend(arc_segments(a, b, i, j, kind == "G3"))
        elif np.any(a != b):
            self.path.append(np.stack([a, b]))


def arc_segments(start: np.ndarray, end: np.ndarray, i: float, j: float, ccw: bool) -> list[np.ndarray]:
    """An XY arc in chords within ARC_SAGITTA_MM of it; ends that meet make a full turn.

    Z and the radius go linearly from the start's to the end's (the end, rounded by the slicer, is not
    exactly at the start's radius: up to 1 µm apart in these programs).
    """
    centre = start[:2] + [i, j]
    r0, r1 = math.hypot(i, j), math.hypot(end[0] - centre[0], end[1] - centre[1])
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    sweep = ((a1 - a0) if ccw else (a0 - a1)) % (2.0 * math.pi)
    if sweep == 0.0:
        sweep = 2.0 * math.pi
    n = max(2, math.ceil(sweep / math.sqrt(8.0 * ARC_SAGITTA_MM / max(r0, r1))))
    t = np.linspace(0.0, 1.0, n + 1)
    angle = a0 + (1.0 if ccw else -1.0) * sweep * t
    radius = r0 + t * (r1 - r0)
    points = np.column_stack([centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle),
                              start[2] + t * (end[2] - start[2])])
    return [points[k:k + 2] for k in range(n)]


def read_program(lines: list[str], home: np.ndarray, macros: frozenset[str]) -> Reading:
    reading = Reading(home, macros)
    for text in lines:
        reading.line(text)
    reading.kept_extrusion.append(reading.extruded)
    return reading


def distance_to_path(points: np.ndarray, path: list[np.ndarray]) -> np.ndarray:
    """Each point's distance [mm] to the nearest segment of the path."""
    a = np.array([s[0] for s in path])
    ab = np.array([s[1] - s[0] for s in path])
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30)
    best = np.full(len(points), np.inf)
    for k in range(0, len(points), 64):
        p = points[k:k + 64, None, :]
        t = np.clip(np.einsum("nmi,mi->nm", p - a, ab) / length2, 0.0, 1.0)
        d = np.linalg.norm(p - a - t[..., None] * ab, axis=2)
        best[k:k + 64] = d.min(axis=1)
    return best


@pytest.fixture(scope="module")
def printer(tmp_path_factory):
    """A kit printer built on the example configuration; its calibration; the printer.cfg it runs.

    The printer.cfg is the example with ``minimum_z_position`` lowered as ``deltacal export`` writes
    it where the true bed is below Klipper's z 0 (without it the corrected first layer is refused).
    """
    folder = tmp_path_factory.mktemp("slicers")
    assert main(["import", str(CONFIG), "-o", str(folder)]) == 0
    nominal = load_printer(folder / "printer.toml")
    truth = random_printer(nominal, np.random.default_rng(2))
    calibration = folder / "true.toml"
    save_geometry(truth, calibration)
    model = KLIPPER.admit_bed(KLIPPER.read_config(CONFIG), truth, nominal.step_distance,
                              nominal.workspace.radius)
    assert model.minimum_z_position < 0.0  # the true bed is below Klipper's z 0 here
    cfg = folder / "printer.cfg"
    cfg.write_text(CONFIG.read_text().replace(
        "[printer]\n", f"[printer]\nminimum_z_position: {model.minimum_z_position}\n", 1))
    assert KLIPPER.read_config(cfg).minimum_z_position == model.minimum_z_position
    return truth, model, nominal.step_distance, calibration, cfg


@pytest.mark.parametrize("program", [
    pytest.param(p, id=p.stem,
                 marks=[pytest.mark.long] if p.stem in LONG else [pytest.mark.slow] if p.stem in SLOW else [])
    for p in PROGRAMS])
def test_a_slicers_program_is_corrected_through_klipper(printer, program, tmp_path, capsys):
    truth, model, step, calibration, cfg = printer
    out = tmp_path / "corrected.gcode"
    assert main(["compensate", str(calibration), str(program), "--controller", str(cfg), "-o", str(out)]) == 0
    assert "wrote the program corrected" in capsys.readouterr().out
    source = program.read_bytes().splitlines(keepends=True)
    written = out.read_bytes().splitlines(keepends=True)
    assert written[0].startswith(b"; corrected by deltacal ")
    written = written[1:]

    # every line that is not a positioning move, byte for byte, in order
    def kept(lines: list[bytes]) -> list[bytes]:
        return [x for x in lines if not is_positioning(x.decode())]

    assert kept(written) == kept(source)
    heads = [COMMAND.match(code_of(x.decode())) for x in written]
    assert not any(h and h.group(1, 2) in (("G", "2"), ("G", "3")) for h in heads)  # chords: no [gcode_arcs]

    home = np.asarray(KLIPPER.controller(model, step).home)
    macros = frozenset(KLIPPER.dialect(cfg).macros)
    intended = read_program([x.decode() for x in source], home, macros)
    sent = read_program([x.decode() for x in written], home, macros)
    # the extrusion between any two kept lines is the program's, exactly (Decimal sums)
    assert sent.kept_extrusion == intended.kept_extrusion and intended.extruded > 10
    assert len(intended.ends) > 200 and len(sent.ends) >= len(intended.ends)
    if "orca" in program.stem or "bambu" in program.stem or "prusa" in program.stem:
        assert intended.arcs >= 8

    # every command inside Klipper's limits of that printer.cfg
    commands = np.array(sent.ends)
    assert not np.any(model.outside(commands)), model.refusal(commands)

    # the true nozzle at the commands written: on the program's path, and on each of its points,
    # but near the home after a homing (the correction blended in) and on a macro's first move
    real = nozzle_positions(truth, model, step, commands)
    judged = np.linalg.norm(real - home, axis=1) > HOME_ZONE_MM + HOME_BLEND_MM + 1.0
    targets = np.array(intended.ends)
    to_path = distance_to_path(real, intended.path)
    nearest = np.min(np.linalg.norm(targets[:, None, :] - real[None, :, :], axis=2), axis=1)
    after_macro = first_moves_after_macros(sent, targets, real)
    on_path = judged & ~after_macro
    assert on_path.mean() > 0.95  # a few points are left out
    assert np.max(to_path[on_path]) < POINT_TOLERANCE, np.max(to_path[on_path])
    far = np.linalg.norm(targets - home, axis=1) > HOME_ZONE_MM + HOME_BLEND_MM + 1.0
    assert np.max(nearest[far]) < POINT_TOLERANCE, np.max(nearest[far])
    # the check sees: the program sent as it is leaves the true nozzle far from its points
    as_is = nozzle_positions(truth, model, step, targets[far])
    assert np.max(np.linalg.norm(as_is - targets[far], axis=1)) > 0.1


def first_moves_after_macros(sent: Reading, targets: np.ndarray, real: np.ndarray) -> np.ndarray:
    """Which written points belong to a move that starts where a macro left the nozzle.

    The macro's own moves run uncorrected, so such a move starts off the program's path; its points
    are judged from the first one that lands on a program's point.
    """
    mask = np.zeros(len(real), dtype=bool)
    for k in sent.restarts:
        for n in range(k, len(real)):
            if np.min(np.linalg.norm(targets - real[n], axis=1)) < POINT_TOLERANCE:
                break
            mask[n] = True
    return mask
