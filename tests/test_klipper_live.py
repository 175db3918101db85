"""The live module (issue 41): ``export --live`` and ``deltacal_geometry.py`` inside the real Klipper.

The module's arithmetic is checked without Klipper first (its interpolation against the library's,
its inverse, what it reads). Then the pinned Klipper (found through ``KLIPPER_DIR``, copied to a
temporary folder: it builds its C helper in place) runs programs in batch mode with the section
included: the MCU's step commands, decoded by ``klippy/parsedump.py`` and summed per stepper, are
each carriage's travel, which the simulated printer's exact kinematics (the true one, and the one
identified from the planned object) turn into the nozzle; compared with the program's points, and
with the same program corrected offline (``compensate``) and run through the same Klipper.
"""

from __future__ import annotations

import ast
import configparser
import contextlib
import functools
import io
import math
import re
import subprocess
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from deltacal.calibration import Calibration
from deltacal.cli import main
from deltacal.controller import corrected_targets, weighted_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.errormodels import get_model
from deltacal.exceptions import GeometryError
from deltacal.gcode.marker import MARKER
from deltacal.geometry import Tolerances
from deltacal.holds import DEFAULT_BOUND, SIGNIFICANT, WhereItHolds, correction_weight, significance_weight
from deltacal.io import load_calibration, save_calibration
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.live import deltacal_geometry as live
from deltacal.printer.firmware.klipper.live.export import (
    LIVE_FILES,
    SECTION_FILE,
    SPLIT_TOLERANCE_MM,
    module_text,
    section_text,
)
from deltacal.printer.firmware.klipper.live.field import (
    CorrectionField,
    LiveVolume,
    SamplingError,
    correction_field,
    curvature_bounds,
    exact_correction,
    sampling_error,
)
from deltacal.printer.firmware.klipper.model import KlipperController, KlipperDelta
from deltacal.printer.identification import PrinterMeasurements, identify_printer
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.simulation import printed_distances, probe_heights, random_printer, typical_kit

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
PRINTER = load_printer(KOSSEL)
STEP = PRINTER.step_distance
#: The MCU's clock (dict/atmega2560.dict) [Hz], and the dwell that separates a program's points [s].
CLOCK_HZ = 16_000_000
DWELL_S = 0.25
#: Each tower's step pin in the configurations written here, towers A, B, C.
STEP_PINS = ("PF0", "PF6", "PL3")


# ------------------------------------------------------------------ the module, without Klipper
def _holds(rng: np.random.Generator) -> WhereItHolds:
    """A made-up σ grid over the smooth field's volume whose weights go from 1 to 0 inside it.

    Its vertical σ crosses the bound (0.05 mm) between z = 20 and 50 mm; its horizontal σ is near the
    corrections' size there (0.05 to 0.4 mm), so that their significance weighs too.
    """
    radius, azimuth, height = WhereItHolds.grid(60.0, 80.0)
    r, _, z = np.meshgrid(radius, azimuth, height, indexing="ij")
    horizontal = (0.001 + 0.0015 * z + 0.0001 * r) * rng.uniform(0.8, 1.2, r.shape)
    vertical = (0.005 + 0.0012 * z) * rng.uniform(0.8, 1.2, r.shape)
    return WhereItHolds(radius, azimuth, height, horizontal, vertical)


def _smooth_field(step: float = 10.0, holds: WhereItHolds | None = None,
                  bound: float = DEFAULT_BOUND) -> CorrectionField:
    """A correction field of made-up smooth values (a few 0.1 mm), zero at the grid's border."""
    volume = LiveVolume(radius=60.0, min_z=0.0, max_z=80.0, limit_z=60.0, delta_radius=100.0, arm=200.0,
                        slow_radius=50.0)
    axes = [np.arange(-100.0, 100.1, step), np.arange(-100.0, 100.1, step), np.arange(-40.0, 120.1, step)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    fade = np.clip(1.0 - np.hypot(x, y) / 85.0, 0.0, 1.0) ** 2
    fade *= np.clip(1.0 - np.abs(z - 40.0) / 75.0, 0.0, 1.0) ** 2
    values = np.stack([0.3 * np.sin(x / 40.0) + 0.1 * z / 80.0, 0.2 * np.cos(y / 35.0) * x / 80.0,
                       0.4 + 0.1 * x * y / 5000.0], axis=-1) * fade[..., None]
    return CorrectionField(np.array([a[0] for a in axes]), step, values, volume, holds=holds, bound=bound)


def _grid(field: CorrectionField) -> live.CorrectionGrid:
    """The module's grid of a field, as the section gives it (its values in nm, its σ grid)."""
    values = live.decode_values("\n".join(_encoded(field)), ValueError)
    curvature = [[1e-4] * field.shape[2]]
    holds = live.read_holds(_Section(_section(field))) if field.holds is not None else None
    return live.CorrectionGrid(tuple(field.origin), field.step, field.shape, values, curvature, 1e-6, holds)


def _encoded(field: CorrectionField) -> list[str]:
    from deltacal.printer.firmware.klipper.live.export import encode_values

    return encode_values(field.values)


def test_the_module_interpolates_as_the_library_does():
    """The module's pure-Python Catmull-Rom is the field's (numpy), to the section's 1 nm rounding."""
    field = _smooth_field()
    grid = _grid(field)
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-90, 90, (400, 2)), rng.uniform(-30, 110, 400)])
    points[::7, 2] = 20.0  # points of one layer, through the module's contracted plane
    ours = np.array([grid.at(*p) or (0.0, 0.0, 0.0) for p in points])
    assert np.max(np.abs(ours - field(points))) < 2e-6
    assert np.max(np.abs(field(points))) > 0.1  # not a field of zeros
    # beyond the grid: no correction, and the command is the point itself
    assert grid.at(500.0, 0.0, 10.0) is None and grid.command(500.0, 0.0, 10.0) == (500.0, 0.0, 10.0)


def test_the_module_weights_the_correction_as_the_library_does():
    """σ (trilinear on the calibration's grid) and the weights, in pure Python, are the library's.

    At random points of a made-up σ grid whose weights go from 1 to 0 inside the volume: the
    module's σ is :meth:`WhereItHolds.sigma`, its weights :meth:`WhereItHolds.weights` of its own
    interpolated correction, and its correction the field's :meth:`CorrectionField.applied`.
    """
    assert live.SIGNIFICANT == SIGNIFICANT
    holds = _holds(np.random.default_rng(7))
    field = _smooth_field(holds=holds)
    grid = _grid(field)
    rng = np.random.default_rng(8)
    points = np.column_stack([rng.uniform(-75, 75, (3000, 2)), rng.uniform(-10, 100, 3000)])
    points[:40, :2] = 0.0  # the axis, where the azimuth is undefined
    points[40:80, 1] = 0.0  # the azimuth 0 from either side
    points[40:60, 0] = -np.abs(points[40:60, 0])
    assert np.max(np.abs(np.array([grid.holds.sigma(*p) for p in points]) - holds.sigma(points))) < 1e-12
    interpolated = np.array([grid.at(*p) or (0.0, 0.0, 0.0) for p in points])
    ours = np.array([grid.holds.weights(*p, *c[:2]) for p, c in zip(points, interpolated, strict=True)])
    theirs = holds.weights(points, DEFAULT_BOUND, interpolated)
    assert np.max(np.abs(ours - theirs)) < 1e-12
    applied = np.array([grid.correction(*p) or (0.0, 0.0, 0.0) for p in points])
    assert np.max(np.abs(applied - field.applied(points))) < 2e-6
    # the formulas, one by one, where they are strictly between their ends too
    sigma = np.concatenate([rng.uniform(0.0, 0.08, 200), [0.025, 0.05, np.inf, np.nan, 0.0]])
    size = rng.uniform(0.0, 0.3, sigma.size)
    for bound in (DEFAULT_BOUND, 0.03):
        assert np.allclose([live.correction_weight(v, bound) for v in sigma], correction_weight(sigma, bound),
                           rtol=0.0, atol=1e-15)
    assert np.allclose([live.significance_weight(a, b) for a, b in zip(size, sigma[:-2], strict=False)],
                       significance_weight(size[:-2], sigma[:-2]), rtol=0.0, atol=1e-15)
    # the weights are all three kinds here: the test is not of a constant (along the bed, what stands
    # out of the correction's σ is applied: its weight below 1, but most of a large correction's)
    inside = np.hypot(points[:, 0], points[:, 1]) < 60.0
    for w, most in ((theirs[inside, 0], 0.5), (theirs[inside, 1], 1.0)):
        assert np.any(w >= most) and np.any(w == 0.0) and np.mean((w > 0.0) & (w < 1.0)) > 0.05
    # measured over the volume (a printed object's levels): along the bed the correction is applied whole
    # where it holds, no significance weighting, in the module as in the library
    tall = replace(holds, measured_top=80.0)
    assert holds.bed_level and not tall.bed_level
    grid = _grid(_smooth_field(holds=tall))
    assert grid.holds.significance is False and _grid(field).holds.significance is True
    ours = np.array([grid.holds.weights(*p, *c[:2]) for p, c in zip(points, interpolated, strict=True)])
    whole_along = tall.weights(points, DEFAULT_BOUND, interpolated)
    assert np.max(np.abs(ours - whole_along)) < 1e-12
    assert np.all(whole_along[:, 0] >= theirs[:, 0]) and np.max(whole_along[:, 0] - theirs[:, 0]) > 0.5
    assert np.array_equal(whole_along[:, 0], correction_weight(tall.sigma(points)[:, 0], DEFAULT_BOUND))
    # an infinite bound applies every correction wholly, as corrected_targets(bound=inf) does
    whole = _grid(_smooth_field(holds=holds, bound=math.inf))
    assert whole.holds.weights(10.0, 5.0, 70.0, 0.0, 0.0) == (1.0, 1.0)
    assert whole.correction(10.0, 5.0, 70.0) == whole.at(10.0, 5.0, 70.0)


def test_the_modules_inverse_is_exact_and_never_raises():
    field = _smooth_field(holds=_holds(np.random.default_rng(7)))
    grid = _grid(field)
    rng = np.random.default_rng(4)
    applied = 0
    for p in np.column_stack([rng.uniform(-40, 40, 200), rng.uniform(-40, 40, 200), rng.uniform(0, 80, 200)]):
        command = grid.command(*p)
        applied += np.linalg.norm(np.subtract(command, p)) > 1e-3
        assert np.allclose(grid.program_point(*command), p, rtol=0.0, atol=1e-9)
    assert applied > 50  # a correction is applied (weighted: where the made-up σ holds)
    # positions Klipper makes up while homing, and worse: returned as they are
    for made_up in [(0.0, 0.0, -365.0), (1e9, 0.0, 0.0), (math.nan, 0.0, 0.0), (math.inf, -math.inf, 1.0)]:
        back = grid.program_point(*made_up)
        assert all((a == b) or (math.isnan(a) and math.isnan(b)) for a, b in zip(back, made_up, strict=True))


def test_long_moves_are_cut_to_keep_the_chord_within_tolerance():
    grid = _grid(_smooth_field())
    layers = grid.nz
    grid.curvature = [[1e-4] * layers] * 6 + [[1e-3] * layers]  # per ring of 10 mm
    grid.curvature[2] = [1e-4] * 12 + [0.1] * (layers - 12)  # high above z = 70 mm there
    # within radius 50: s^2 K / 8 <= 0.005 -> segments of 20 mm
    assert grid.segments([0, 0, 1, 0], [40.0, 0, 1, 0], 0.005) == 2
    assert grid.segments([0, 0, 1, 0], [5.0, 0, 1, 0], 0.005) == 1
    assert grid.segments([0, 0, 1, 0], [0, 0, 1, 5], 0.005) == 1  # extrusion alone
    # its larger radius sets the bound (K 1e-3 beyond 50 mm: segments of 6.3 mm)
    assert grid.segments([30.0, 0, 1, 0], [55.0, 0, 1, 0], 0.005) == 4
    # the layers of its heights set it too
    assert grid.segments([5.0, 0, 1, 0], [15.0, 0, 1, 0], 0.005) == 1
    assert grid.segments([5.0, 0, 100, 0], [15.0, 0, 100, 0], 0.005) == 16


def test_long_moves_are_cut_by_the_bound_of_the_cells_they_cross():
    """With the section's bound per cell, a move is cut by the cells its box crosses, not by its ring."""
    grid = _grid(_smooth_field())
    grid.curvature = [[1e-3] * grid.nz] * 8  # its rings' bound: segments of 6.3 mm
    cells = [1e-4] * ((grid.nx - 1) * (grid.ny - 1) * (grid.nz - 1))  # segments of 20 mm
    # one cell bends more: x 20 to 30, y -10 to 0, z 0 to 10 (K 0.1: segments of 0.63 mm)
    cells[(12 * (grid.ny - 1) + 9) * (grid.nz - 1) + 4] = 0.1
    assert grid.segments([0, 5.0, 1, 0], [40.0, 5.0, 1, 0], 0.005) == 7  # by its ring
    grid.cells = cells
    assert grid.segments([0, 5.0, 1, 0], [40.0, 5.0, 1, 0], 0.005) == 2  # y 0 to 10: away from it
    assert grid.segments([0, -5.0, 1, 0], [40.0, -5.0, 1, 0], 0.005) == 64  # through it
    assert grid.segments([0, -5.0, 11, 0], [40.0, -5.0, 11, 0], 0.005) == 2  # the layer above it
    assert grid.segments([25.0, -5.0, 20, 0], [25.0, -5.0, 5, 0], 0.005) == 24  # down into it
    assert grid.segments([0, 5.0, 1, 0], [4.0, 5.0, 1, 0], 0.005) == 1  # shorter than the cells allow
    assert grid.segments([-500.0, 5.0, 1, 0], [-460.0, 5.0, 1, 0], 0.005) == 2  # beyond: the edge's cells


class _Section:
    """Klipper's reading of a section (the calls of ``configfile.ConfigWrapper`` the module makes)."""

    error = configparser.Error

    def __init__(self, text: str) -> None:
        parser = configparser.RawConfigParser()
        parser.read_string(text)
        self.options = parser["deltacal_geometry"]
        self.read: set[str] = set()

    def get(self, key, default=None):
        if key not in self.options:
            if default is None:
                raise self.error(f"Option '{key}' in section 'deltacal_geometry' must be specified")
            return default
        self.read.add(key)
        return self.options[key]

    def getfloat(self, key, default=None, above=None):
        return float(self.get(key, default))

    def getboolean(self, key, default=None):
        """Klipper's (configparser's) words for a boolean."""
        if key not in self.options:
            return default
        return configparser.ConfigParser.BOOLEAN_STATES[self.get(key).lower()]

    def getfloatlist(self, key, count=None):
        return [float(v) for v in self.get(key).split(",")]

    def getintlist(self, key, count=None):
        return [int(v) for v in self.get(key).split(",")]


def _section(field: CorrectionField) -> str:
    klipper = KlipperDelta.from_printer(PRINTER)
    return section_text(field, SamplingError(0.002, 0.0005, 0.001, 100, 0), klipper, "my cal#1.toml",
                        ("a note",))


def test_the_section_reads_back_into_the_module():
    holds = _holds(np.random.default_rng(7))
    field = _smooth_field(holds=holds, bound=0.04)
    section = _Section(_section(field))
    grid, values, volume = live.read_section(section)
    assert section.read == set(section.options) - {"split_tolerance", "sampling_error", "calibration"}
    klipper = KlipperDelta.from_printer(PRINTER)
    assert values["arm_length_b"] == klipper.arm_length[1] and values["angle_c"] == pytest.approx(90.0)
    assert values["step_distance_a"] == klipper.step_distance[0]
    assert volume["build_radius"] == field.volume.radius and volume["coverage_margin"] == field.step
    assert section.get("calibration") == "my cal?1.toml"  # a '#' would start a comment in Klipper
    point = (12.5, -31.0, 44.0)
    assert np.allclose(grid.at(*point), field(np.array([point]))[0], rtol=0.0, atol=2e-6)
    # where the calibration holds: its σ grid, exact, and the bound
    assert grid.holds.bound == 0.04
    assert list(grid.holds.radius) == list(holds.radius) and list(grid.holds.height) == list(holds.height)
    assert list(grid.holds.azimuth) == list(holds.azimuth)
    assert list(grid.holds.sigma_values) == [*holds.horizontal.ravel(), *holds.vertical.ravel()]
    # the bound of the curvature per cell, exact
    assert list(grid.cells) == curvature_bounds(field)[1].ravel().tolist() and max(grid.cells) > 0.0
    assert len(grid.cells) == (grid.nx - 1) * (grid.ny - 1) * (grid.nz - 1)
    # a calibration without it (a geometry): the whole correction, no σ keys
    plain = _Section(_section(_smooth_field()))
    assert live.read_section(plain)[0].holds is None and "holds_sigma" not in plain.options
    assert plain.read == set(plain.options) - {"split_tolerance", "sampling_error", "calibration"}


@pytest.mark.parametrize(("change", "message"), [
    (("format: deltacal-klipper-live-2", "format: deltacal-klipper-live-9"), "this module reads"),
    (("grid_shape: 21, 21, 17", "grid_shape: 20, 21, 17"), "values, expected"),
    (("grid_shape: 21, 21, 17", "grid_shape: 21, 21, 16"), "key split_curvature"),
    (("correction:\n  eN", "correction:\n  #N"), "key correction"),
    (("holds_height: 0.0, 0.5", "holds_height: 0.5, 0.5"), "key holds_height: two increasing values"),
    (("50.0, 60.0\n", "50.0, 60.0, 70.0\n"), "key holds_sigma: 2016 values, expected 2304"),
    (("holds_sigma:\n  eN", "holds_sigma:\n  #N"), "key holds_sigma: not deltacal's"),
])
def test_a_broken_section_is_refused_naming_its_key(change, message):
    text = _section(_smooth_field(holds=_holds(np.random.default_rng(7))))
    assert change[0] in text
    with pytest.raises(configparser.Error, match=message):
        live.read_section(_Section(text.replace(*change, 1)))


def test_changed_klipper_values_are_refused_naming_the_key_and_both_values():
    field = _smooth_field()
    _, ours, _ = live.read_section(_Section(_section(field)))
    klipper = dict(ours)
    live.check_values(ours, klipper, ValueError)  # the same: accepted
    klipper["arm_length_b"] = ours["arm_length_b"] + 0.1
    with pytest.raises(ValueError, match=r"\[stepper_b\] arm_length is 269\.1 in Klipper, but the correction "
                                         r"was computed for 269"):
        live.check_values(ours, klipper, ValueError)
    klipper = dict(ours, step_distance_c=0.00625)
    with pytest.raises(ValueError, match=r"\[stepper_c\] rotation_distance \(its step distance\) is 0\.006"):
        live.check_values(ours, klipper, ValueError)


def test_the_module_is_standard_library_python_and_knows_deltacals_marker():
    tree = ast.parse(module_text())
    imported = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                for alias in node.names}
    imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                 if isinstance(node, ast.ImportFrom) and node.module}
    assert imported and imported <= set(sys.stdlib_module_names)
    assert live.MARKER == MARKER


class _Error(Exception):
    """Klipper's command error."""


class _Toolhead:
    """What the module sees of Klipper under it: the moves it is sent, its position, its kinematics."""

    def __init__(self, firmware: KlipperDelta) -> None:
        self.moves: list[list[float]] = []
        self.position = [0.0, 0.0, 150.0, 0.0]
        self.firmware = firmware

    def move(self, newpos, speed):
        self.moves.append(list(newpos))
        self.position = list(newpos)

    def get_position(self):
        return list(self.position)

    def get_kinematics(self):
        return self

    def get_calibration(self):  # Klipper's DeltaCalibration's attributes
        f = self.firmware
        return type("DeltaCalibration", (), {
            "radius": f.delta_radius, "angles": np.degrees(f.angle).tolist(), "arms": f.arm_length.tolist(),
            "endstops": f.position_endstop.tolist(), "stepdists": f.step_distance.tolist()})()

    def get_status(self, eventtime):
        f = self.firmware
        return {"homed_axes": "xyz", "axis_minimum": (-f.max_radius, -f.max_radius, f.minimum_z_position),
                "axis_maximum": (f.max_radius, f.max_radius, f.max_z), "cone_start_z": f.limit_z}


class _Printer:
    """Klipper's printer object as the module uses it (objects, events, errors)."""

    config_error = configparser.Error

    def __init__(self, toolhead: _Toolhead) -> None:
        self.handlers: dict[str, list] = {}
        self.commands: dict[str, object] = {}
        self.toolhead = toolhead
        self.gcode = type("GCode", (), {"error": _Error, "cmd_default": staticmethod(lambda gcmd: "default"),
                                        "register_command": lambda _, name, f, desc=None:
                                        self.commands.__setitem__(name, f)})()
        self.gcode_move = type("GCodeMove", (), {"move_transform": None, "resets": 0})()
        self.gcode_move.set_move_transform = self._set_transform
        self.gcode_move.reset_last_position = self._reset

    def _set_transform(self, transform, force=False):
        self.gcode_move.move_transform = transform
        return None

    def _reset(self):
        self.gcode_move.resets += 1

    def load_object(self, config, name):
        return self.gcode_move

    def lookup_object(self, name):
        return {"gcode": self.gcode, "toolhead": self.toolhead}[name]

    def register_event_handler(self, event, handler):
        self.handlers.setdefault(event, []).append(handler)

    def get_reactor(self):
        return type("Reactor", (), {"monotonic": staticmethod(lambda: 0.0)})()


class _Config(_Section):
    def __init__(self, text: str, printer: _Printer) -> None:
        super().__init__(text)
        self.printer = printer

    def get_printer(self):
        return self.printer

    def get_name(self):
        return "deltacal_geometry"

    def has_section(self, name):
        return False


class _Command:
    def __init__(self, line: str, **params) -> None:
        self.line, self.params, self.said = line, params, []

    def get_commandline(self):
        return line if (line := self.line) else ""

    def get_int(self, key, default=None, minval=None, maxval=None):
        return int(self.params[key]) if key in self.params else default

    def respond_info(self, text):
        self.said.append(text)

    def error(self, text):
        return _Error(text)


def _transform():
    """The module's transform of a made-up field over a fake Klipper of the Kossel's values, connected."""
    firmware = KlipperDelta.from_printer(PRINTER)
    toolhead = _Toolhead(firmware)
    printer = _Printer(toolhead)
    section = section_text(_smooth_field(), SamplingError(0.002, 0.0005, 0.001, 100, 0), firmware, "c")
    for key, value in (("maximum_z: 80.0", firmware.max_z), ("build_radius: 60.0", firmware.max_radius),
                       ("coverage_margin: 10.0", 400.0)):  # Klipper's volume within the section's
        section = section.replace(key, f"{key.split(':')[0]}: {value!r}")
    module = live.DeltacalGeometry(_Config(section, printer))
    for handler in printer.handlers["klippy:connect"]:
        handler()
    module.get_position()
    return module, toolhead, printer


def test_a_long_move_is_cut_into_corrected_segments_on_its_line():
    module, toolhead, _ = _transform()
    module.grid.curvature = [[4e-4] * module.grid.nz] * len(module.grid.curvature)
    module.grid.cells = [4e-4] * len(module.grid.cells)  # the section's bound per cell, made even
    module.tolerance = 0.005  # segments of 10 mm at most
    toolhead.position = [-20.0, 5.0, 40.0, 0.0]
    start = module.get_position()
    assert np.linalg.norm(np.subtract(start[:3], toolhead.position[:3])) > 0.1  # inside the field
    module.move([start[0] + 60.0, start[1], start[2], 3.0], 50.0)
    sent = np.array(toolhead.moves)
    assert len(sent) == 6
    program = np.array(start[:3]) + np.outer(np.arange(1, 7) / 6, [60.0, 0.0, 0.0])
    assert np.allclose(sent[:, :3], program + _smooth_field()(program), rtol=0.0, atol=2e-6)
    assert np.allclose(sent[:, 3], np.arange(1, 7) / 6 * 3.0)  # the extrusion shared out along it
    assert module.last_position == [start[0] + 60.0, start[1], start[2], 3.0]
    # the position read back is the program's
    assert np.allclose(module.get_position()[:3], module.last_position[:3], rtol=0.0, atol=1e-9)


def test_a_move_out_of_klippers_limits_once_corrected_is_refused_whole():
    module, toolhead, _ = _transform()
    module.limits.max_xy = 40.0  # a tight print_radius
    module.grid.curvature = [[4e-4] * module.grid.nz] * len(module.grid.curvature)
    start = module.last_position
    # its end at radius 39.97 mm is inside, its corrected end beyond 40 mm
    end = [39.97, 0.0, 40.0, 0.0]
    assert math.hypot(*module.grid.command(*end[:3])[:2]) > 40.0
    refusal = r"radius 4\d\.\d+ beyond Klipper's 40\.0000: set \[printer\] print_radius"
    with pytest.raises(_Error, match=refusal):
        module.move(end, 50.0)
    assert toolhead.moves == [] and module.last_position == start


def test_turned_off_it_sends_moves_as_they_are_and_reports_its_state():
    module, toolhead, printer = _transform()
    command = _Command("DELTACAL_GEOMETRY ENABLE=0", ENABLE="0")
    printer.commands["DELTACAL_GEOMETRY"](command)
    assert not module.enabled and printer.gcode_move.resets == 1
    assert "deltacal_geometry: off" in command.said[0]
    module.move([10.0, 5.0, 20.0, 0.0], 50.0)
    assert toolhead.moves == [[10.0, 5.0, 20.0, 0.0]]
    assert module.get_position() == [10.0, 5.0, 20.0, 0.0]
    command = _Command("DELTACAL_GEOMETRY ENABLE=1", ENABLE="1")
    printer.commands["DELTACAL_GEOMETRY"](command)
    assert module.enabled and "on: every move corrected" in command.said[0]
    assert "move transforms: deltacal_geometry > _Toolhead" in command.said[0]
    assert module.get_status()["enabled"] is True


def test_the_marker_line_is_refused_and_other_lines_go_to_klippers_handler():
    module, _, printer = _transform()
    handler = printer.gcode.cmd_default
    assert handler(_Command("; sliced by someone")) == "default"
    assert handler(_Command("M999")) == "default"
    for line in (MARKER + "0.9 for printer.cfg with cal.toml", "\ufeff" + MARKER + "0.9"):
        with pytest.raises(_Error, match="already corrected by deltacal"):
            handler(_Command(line))
    module.enabled = False
    assert handler(_Command(MARKER + "0.9")) == "default"


def test_get_position_never_raises():
    module, toolhead, _ = _transform()
    for made_up in ([0.0, 0.0, -365.0, 0.0], [math.nan, 0.0, 0.0, 0.0], [1e300, 1e300, 1e300, 0.0]):
        toolhead.position = made_up
        assert module.get_position()[2] == made_up[2] or math.isnan(made_up[0])


def _made_up_calibration(geometry, holds: WhereItHolds) -> Calibration:
    """A calibration of this geometry that knows where it holds (the made-up σ grid)."""
    return Calibration(geometry, PRINTER.geometry(), get_model("printer"), [], np.zeros((0, 0)), holds=holds)


def test_the_field_is_the_whole_correction_and_the_module_weights_it_as_the_offline_route():
    """At its nodes in the volume the field is the exact whole correction; applied, the offline route's.

    A calibration without a σ grid (a geometry): the library's correction, everywhere. One with it:
    the grid holds the correction of the identified printer in Klipper's frame (``corrected_targets``
    with ``bound = inf``); weighted, it is the offline route's with the bound (to the sampling error),
    where the weights go from 1 to 0 inside the volume.
    """
    truth = random_printer(PRINTER, np.random.default_rng(5), typical_kit())
    firmware = KlipperDelta.from_printer(PRINTER)
    controller = KlipperController(firmware, STEP)
    volume = LiveVolume(30.0, 0.0, 30.0, firmware.limit_z, firmware.delta_radius, 269.0, 25.0)
    field = correction_field(truth, controller, volume, step=10.0)
    nx, ny, nz = field.shape
    axes = [field.origin[k] + 10.0 * np.arange(n) for k, n in enumerate((nx, ny, nz))]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = volume.distance(nodes) == 0.0
    exact_values = exact_correction(truth, controller, nodes[inside])
    assert np.allclose(field.values.reshape(-1, 3)[inside], exact_values, rtol=0.0, atol=1e-12)
    assert np.max(np.abs(field.values)) > 0.1 and not np.any(field.values[[0, -1]])  # 0 at the border
    error = sampling_error(field, truth, controller, count=300)
    assert error.points == 300 and error.max < 0.002
    assert field.holds is None and np.array_equal(field.applied(nodes), field(nodes))

    radius, azimuth, height = WhereItHolds.grid(150.0, 300.0)
    r, _, z = np.meshgrid(radius, azimuth, height, indexing="ij")  # the vertical part held up to z 10-20 mm
    holds = WhereItHolds(radius, azimuth, height, 0.01 + 0.002 * z + 0.0001 * r, 0.005 + 0.002 * z)
    calibration = _made_up_calibration(truth, holds)
    held = correction_field(calibration, controller, volume, step=10.0)
    whole = corrected_targets(calibration, controller, nodes[inside], bound=math.inf).commands - nodes[inside]
    assert np.allclose(held.values.reshape(-1, 3)[inside], whole, rtol=0.0, atol=1e-12)
    aligned = aligned_to_controller(truth, controller, 150.0)
    assert np.max(np.abs(exact_correction(aligned, controller, nodes[inside]) - whole)) < 1e-9
    assert np.max(np.abs(whole - exact_values)) > 0.01  # not the unaligned printer's
    points = volume.sample(300, np.random.default_rng(6))
    offline = weighted_targets(calibration, controller, points)
    assert np.any(offline.weights == 1.0) and np.any(offline.weights == 0.0)
    assert np.mean((offline.weights > 0.0) & (offline.weights < 1.0)) > 0.05
    assert np.max(np.abs(held.applied(points) - (offline.commands - points))) < 0.002
    error = sampling_error(held, calibration, controller, count=300)
    assert error.points == 300 and error.max < 0.002
    with pytest.raises(GeometryError, match="must be positive"):
        correction_field(calibration, controller, volume, step=10.0, bound=0.0)


@pytest.mark.long
@pytest.mark.parametrize("per", ["ring", "cell"])
def test_long_moves_cut_by_the_bound_stay_within_the_tolerance_of_the_applied_correction(per):
    """The module's cut keeps each segment's chord within the tolerance of the applied correction.

    The applied correction (weighted: its weights turn from 1 to 0 inside the volume, bent where
    the σ grid's trilinear interpolation bends) at 200 points along each segment of random long
    moves, cut as the module cuts them by :func:`curvature_bounds` (per ring and layer; per cell of
    the grid, as the section's ``split_cells`` gives it), against the segment's chord.
    """
    truth = random_printer(PRINTER, np.random.default_rng(5), typical_kit())
    firmware = KlipperDelta.from_printer(PRINTER)
    controller = KlipperController(firmware, STEP)
    volume = LiveVolume(60.0, 0.0, 60.0, firmware.limit_z, firmware.delta_radius, 269.0, 50.0)
    radius, azimuth, height = WhereItHolds.grid(150.0, 300.0)
    r, _, z = np.meshgrid(radius, azimuth, height, indexing="ij")
    holds = WhereItHolds(radius, azimuth, height, 0.003 + 0.0015 * z + 0.0001 * r, 0.004 + 0.003 * z)
    field = correction_field(_made_up_calibration(truth, holds), controller, volume, step=10.0)
    bound, cells = curvature_bounds(field)
    grid = live.CorrectionGrid(tuple(field.origin), field.step, field.shape, [], bound.tolist(),
                               cells=cells.ravel().tolist() if per == "cell" else None)
    rng = np.random.default_rng(9)
    ends = volume.sample(120, rng).reshape(60, 2, 3)
    ends[:30, :, 2] = rng.uniform(0.0, 25.0, (30, 1))  # moves along a layer through the transition
    worst, weighted, cuts = 0.0, [], 0
    for start, end in ends:
        count = grid.segments(list(start), list(end), SPLIT_TOLERANCE_MM)
        cuts += count
        knots = start + np.outer(np.arange(count + 1) / count, end - start)
        t = np.linspace(0.0, 1.0, 201)[:, None]
        for a, b in zip(knots[:-1], knots[1:], strict=True):
            along = a + t * (b - a)
            values = field.applied(along)
            chord = values[:1] + t * (values[-1:] - values[:1])
            worst = max(worst, _max(values - chord))
            weighted.append(field.weights(along, field(along)))
    weights = np.concatenate(weighted)
    print(f"\nlargest chord error {worst:.5f} mm, {cuts} segments of 60 moves")
    assert np.any(weights == 1.0) and np.any(weights == 0.0) and np.mean((weights > 0) & (weights < 1)) > 0.05
    assert worst <= SPLIT_TOLERANCE_MM
    assert cuts > 120  # long moves were cut


def test_export_live_refusals(tmp_path, capsys):
    from deltacal.io import load_nominal, save_geometry

    config = tmp_path / "printer.cfg"
    config.write_text(printer_cfg(KlipperDelta.from_printer(PRINTER)))
    cal = str(KOSSEL)  # any file: each refusal comes before the calibration is read
    out = str(tmp_path / "o")
    cases = [
        (["--controller", "marlin", "--live", "-o", out], "--live applies to --controller klipper"),
        (["--controller", "klipper", "--live", "-o", out], "--live needs --config printer.cfg"),
        (["--controller", "klipper", "--config", str(config), "--live"], "--live needs --config printer.cfg"),
        (["--controller", "klipper", "--config", str(config), "--live", "--home", "0,0,0", "-o", out],
         "leave out --keep-rotation-distance, --robot and --home"),
        (["--controller", "klipper", "--config", str(config), "--live", "-o", str(config)],
         "writes 2 files in a folder; this is a file"),
    ]
    for options, message in cases:
        assert main(["export", cal, *options]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
    rotary = tmp_path / "rotary.toml"
    save_geometry(load_nominal(KOSSEL.parent / "bai2015.toml").geometry(), rotary)
    assert main(["export", str(rotary), "--controller", "klipper", "--config", str(config), "--live", "-o",
                 str(tmp_path / "o")]) == 2
    assert "is a rotary Delta's calibration" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ the real Klipper
#: What a printer.cfg of these tests holds besides the delta's values (pins of example-delta.cfg).
CONFIG_REST = """[extruder]
step_pin: PA4
dir_pin: PA6
enable_pin: !PA2
microsteps: 16
rotation_distance: 33.5
nozzle_diameter: 0.4
filament_diameter: 1.75
heater_pin: PB4
sensor_type: ATC Semitec 104GT-2
sensor_pin: PK5
control: pid
pid_Kp: 22.2
pid_Ki: 1.08
pid_Kd: 114
min_temp: 0
max_temp: 250
min_extrude_temp: 0

[mcu]
serial: /dev/ttyACM0

[force_move]
enable_force_move: True

[gcode_arcs]
resolution: 1.0

[printer]
kinematics: delta
max_velocity: 300
max_accel: 3000
max_z_velocity: 150
"""


def printer_cfg(firmware: KlipperDelta, extra: str = "") -> str:
    """A whole printer.cfg of Klipper's delta with these values (16 microsteps), and more."""
    pins = [("PF0", "PF1", "!PD7", "^PE4"), ("PF6", "PF7", "!PF2", "^PJ0"), ("PL3", "PL1", "!PK0", "^PD2")]
    text = ""
    for k, tower in enumerate("abc"):
        step, direction, enable, endstop = pins[k]
        text += (f"[stepper_{tower}]\nstep_pin: {step}\ndir_pin: {direction}\nenable_pin: {enable}\n"
                 f"microsteps: 16\nrotation_distance: {float(firmware.step_distance[k]) * 3200!r}\n"
                 f"endstop_pin: {endstop}\nhoming_speed: 50\n"
                 f"position_endstop: {float(firmware.position_endstop[k])!r}\n"
                 f"arm_length: {float(firmware.arm_length[k])!r}\n"
                 f"angle: {math.degrees(firmware.angle[k])!r}\n\n")
    return text + CONFIG_REST + f"delta_radius: {float(firmware.delta_radius)!r}\n" + extra


@dataclass
class Run:
    """A batch run of klippy: its exit status, log and MCU output."""

    status: int
    log: str
    serial: Path


#: Batch runs of one program at most, while Klipper's output misses its tail (:func:`output_complete`).
KLIPPY_ATTEMPTS = 3


def run_klippy(klipper: Path, config: Path, program: str, name: str, timeout: float = 600.0,
               steps: bool = False) -> Run:
    """``klippy.py config -i program -o out.serial -d dict/atmega2560.dict -l log`` in config's folder.

    A run over ``timeout`` seconds fails the test (a module that hangs). ``steps``: its MCU output is
    decoded (:func:`decode_steps`), so a run whose output misses its tail (:func:`output_complete`) is
    run again, at most :data:`KLIPPY_ATTEMPTS` times in all (a test of the log alone takes any: a
    program ending in a flush, ``SET_KINEMATIC_POSITION``, lost its tail in three runs running in CI).
    """
    folder = config.parent
    gcode, serial, log = folder / f"{name}.gcode", folder / f"{name}.serial", folder / f"{name}.log"
    gcode.write_text(program, encoding="utf-8")
    for _ in range(KLIPPY_ATTEMPTS):
        log.unlink(missing_ok=True)
        done = subprocess.run([sys.executable, str(klipper / "klippy" / "klippy.py"), str(config), "-i",
                               str(gcode), "-o", str(serial), "-d", str(klipper / "dict" / "atmega2560.dict"),
                               "-l", str(log)], cwd=folder, timeout=timeout, capture_output=True, text=True)
        text = log.read_text(encoding="utf-8", errors="replace") if log.exists() else ""
        if done.returncode != 0 or not steps or output_complete(dumped(klipper, serial)):
            return Run(done.returncode, text, serial)
    raise AssertionError(f"{name}: Klipper's MCU output missed its tail in {KLIPPY_ATTEMPTS} runs")


def dumped(klipper: Path, serial: Path) -> str:
    """``klippy/parsedump.py``'s decoding of a run's MCU output (one decoding per written file)."""
    stat = serial.stat()
    return _dumped(klipper, serial, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)
def _dumped(klipper: Path, serial: Path, mtime_ns: int, size: int) -> str:
    return subprocess.run([sys.executable, str(klipper / "klippy" / "parsedump.py"),
                           str(klipper / "dict" / "atmega2560.dict"), str(serial)],
                          check=True, capture_output=True, text=True, timeout=600).stdout


def output_complete(text: str) -> bool:
    """Whether a batch run's decoded MCU output holds every step it generated.

    At the end of its input Klipper turns the motors off (``gcode:request_restart``): the enable
    pins' ``queue_digital_out``, timed after the last step, are the last messages its serial writer
    sends, in clock order. That writer is a thread stopped at exit without draining its queue: on a
    loaded machine the last move's steps were seen cut (930 of 17,347 step events written) or lost
    whole. A run that stepped is complete when a ``queue_digital_out`` follows its last ``queue_step``.
    """
    last_step = text.rfind("\nqueue_step ")
    return last_step < 0 or text.find("\nqueue_digital_out ", last_step) > 0


def toolhead_positions(log: str) -> np.ndarray:
    """The toolhead position of each GET_POSITION, as Klipper reported it (its commands, exact), (N, 3)."""
    return np.array(re.findall(r"^toolhead: X:(\S+) Y:(\S+) Z:(\S+)", log, flags=re.M), dtype=float)


def gcode_positions(log: str) -> np.ndarray:
    """The G-code position of each GET_POSITION (the program's coordinates), (N, 3)."""
    return np.array(re.findall(r"^gcode: X:(\S+) Y:(\S+) Z:(\S+)", log, flags=re.M), dtype=float)


@dataclass
class Steps:
    """The steps of the three towers decoded from a run's MCU output.

    Attributes:
        time: Each step event's MCU clock, in order, (M,).
        count: Each tower's steps from its start after the event, (M, 3) (up: positive).
        own: Per tower, the clock of each of its steps and its exact commanded travel there [steps]
            (half way between the levels before and after: a step is taken where the commanded
            position crosses the half step).
    """

    time: np.ndarray
    count: np.ndarray
    own: list[tuple[np.ndarray, np.ndarray]]


def decode_steps(klipper: Path, serial: Path) -> Steps:
    """The towers' steps, from ``klippy/parsedump.py``'s decoding of the MCU commands."""
    text = dumped(klipper, serial)
    tower = {int(oid): STEP_PINS.index(pin)
             for oid, pin in re.findall(r"config_stepper oid=(\d+) step_pin=(\w+)", text) if pin in STEP_PINS}
    clock = dict.fromkeys(tower, 0)
    sign = dict.fromkeys(tower, 1)
    times: list[list[int]] = [[], [], []]
    signs: list[list[int]] = [[], [], []]
    commands = r"^(queue_step|set_next_step_dir|reset_step_clock) oid=(\d+) (.*)$"
    for kind, oid_text, rest in re.findall(commands, text, flags=re.M):
        oid = int(oid_text)
        if oid not in tower:
            continue
        fields = dict(item.split("=") for item in rest.split())
        if kind == "set_next_step_dir":
            sign[oid] = 1 if fields["dir"] == "1" else -1
        elif kind == "reset_step_clock":
            clock[oid] += (int(fields["clock"]) - clock[oid]) % 2**32
        else:
            interval, count, add = int(fields["interval"]), int(fields["count"]), int(fields["add"])
            k = np.arange(1, count + 1, dtype=np.int64)
            step_times = clock[oid] + k * interval + add * k * (k - 1) // 2
            times[tower[oid]].extend(step_times.tolist())
            signs[tower[oid]].extend([sign[oid]] * count)
            clock[oid] = int(step_times[-1])
    every = np.unique(np.concatenate([np.array(t, dtype=np.int64) for t in times]))
    count = np.zeros((every.size, 3))
    own = []
    for i in range(3):
        t, s = np.array(times[i], dtype=np.int64), np.array(signs[i])
        level = np.concatenate([[0], np.cumsum(s)])
        count[:, i] = level[np.searchsorted(t, every, side="right")]
        own.append((t, level[1:] - 0.5 * s))
    return Steps(every, count, own)


def moves(steps: Steps) -> np.ndarray:
    """Each step event's move: the program's points are separated by dwells, (M,) integers from 0."""
    return np.concatenate([[0], np.cumsum(np.diff(steps.time) > 0.5 * DWELL_S * CLOCK_HZ)])


def exact_travel(steps: Steps, longest: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """The towers' exact commanded travels at the step events where all three are known, and which those are.

    A tower's travel between two of its steps is interpolated (its steps are taken where the commanded
    travel crosses the half steps), where they are at most ``longest`` seconds apart within one move.
    """
    move = moves(steps)
    known = np.ones(steps.time.size, dtype=bool)
    travel = np.zeros((steps.time.size, 3))
    for i, (t, v) in enumerate(steps.own):
        after = np.searchsorted(t, steps.time, side="left")
        before = np.searchsorted(t, steps.time, side="right") - 1
        ok = (before >= 0) & (after < t.size)
        b, a = np.clip(before, 0, t.size - 1), np.clip(after, 0, t.size - 1)
        ok &= (t[a] - t[b] <= longest * CLOCK_HZ) & (move[np.searchsorted(steps.time, t[b])] == move) & \
            (move[np.searchsorted(steps.time, t[a])] == move)
        known &= ok
        travel[:, i] = np.interp(steps.time, t, v)
    return travel, known


def at_dwells(steps: Steps) -> np.ndarray:
    """The towers' step counts where the program dwells (after each of its points), (K, 3)."""
    gaps = np.flatnonzero(np.diff(steps.time) > 0.5 * DWELL_S * CLOCK_HZ)
    return np.vstack([steps.count[gaps], steps.count[-1:]])


def nozzle(geometry, klipper: KlipperDelta, heights: np.ndarray) -> np.ndarray:
    """Where the printer's nozzle is with its carriages at Klipper's carriage heights [mm], (N, 3)."""
    readings = (klipper.carriage_top - heights) / klipper.step_distance * STEP
    return exact.forward(geometry, readings).point(geometry.tool)


def _kossel(folder: Path, bed_only: bool = False, bound: float = DEFAULT_BOUND) -> dict:
    """A kit printer identified from the planned object, its printer.cfg, and ``export --live``'s output.

    ``bed_only``: from the probe heights and the object's distances at the bed alone (its first balls,
    8 mm up), as Klipper's own calibration measures: its calibration holds near the bed and not
    far above it, where the weights of its correction turn from 1 to 0 inside the volume.
    """
    firmware = KlipperDelta.from_printer(PRINTER)
    rng = np.random.default_rng(4101)
    truth = random_printer(PRINTER, rng, typical_kit())
    plan = plan_object(PRINTER, firmware)
    probe = probe_heights(truth, firmware, STEP, plan.probe[:, :2], 0.01, rng)
    pairs = plan.features[plan.pairs].reshape(-1, 6)
    if bed_only:
        pairs = pairs[np.maximum(pairs[:, 2], pairs[:, 5]) < 10.0]
    distance = printed_distances(truth, firmware, STEP, pairs, 0.02, rng)
    data = PrinterMeasurements(firmware.inverse(probe, STEP), firmware.inverse(pairs.reshape(-1, 3), STEP)
                               .reshape(-1, 2, 3), distance)
    result = identify_printer(PRINTER.geometry(), data, "printer", method="iterated",
                              tolerances=Tolerances.printer_kit())
    calibration = folder / "cal.toml"
    save_calibration(result, calibration)
    config = folder / "printer.cfg"
    config.write_text(printer_cfg(firmware))
    out = folder / "live"
    said = io.StringIO()
    with contextlib.redirect_stdout(said):
        status = main(["export", str(calibration), "--controller", "klipper", "--config", str(config),
                       "--live", "-o", str(out), "--sigma-bound", repr(bound)])
    assert status == 0
    live_config = folder / "printer_live.cfg"
    live_config.write_text(printer_cfg(firmware, f"\n[include {out / SECTION_FILE}]\n"))
    loaded = load_calibration(calibration)
    assert loaded.holds is not None
    controller = KlipperController(firmware, STEP)
    return {"folder": folder, "firmware": load_klipper(config), "truth": truth, "calibration": calibration,
            "geometry": loaded.geometry, "config": config, "live_config": live_config, "out": out,
            "said": said.getvalue(), "loaded": loaded, "controller": controller, "bound": bound,
            "aligned": aligned_to_controller(loaded.geometry, controller, float(loaded.holds.radius[-1]))}


@pytest.fixture(scope="module")
def kossel(tmp_path_factory):
    """The Kossel kit identified from the planned object (its calibration holds almost everywhere)."""
    return _kossel(tmp_path_factory.mktemp("live"))


@pytest.fixture(scope="module")
def kossel_bed(tmp_path_factory):
    """The Kossel kit identified from bed-level data, exported and compensated with --sigma-bound 0.04."""
    return _kossel(tmp_path_factory.mktemp("live_bed"), bed_only=True, bound=0.04)


@pytest.mark.long
@pytest.mark.parametrize("printer", ["kossel", "kossel_bed"])
def test_export_live_writes_the_module_and_its_section_and_says_the_sampling_error(printer, request):
    kossel = request.getfixturevalue(printer)
    out, said = kossel["out"], kossel["said"]
    assert sorted(p.name for p in out.iterdir()) == sorted(LIVE_FILES)
    assert (out / "deltacal_geometry.py").read_text(encoding="utf-8") == module_text()
    bound = kossel["bound"]
    error = re.search(r"sampling error against the exact correction at (\d+) points of the volume \(weighted "
                      rf"where the calibration holds within σ {bound:g} mm, as compensate --sigma-bound "
                      rf"{bound:g} does: its σ grid goes with the section\): max ([\d.]+) mm within radius "
                      r"([\d.]+) mm \(where Klipper moves at full speed\), ([\d.]+) mm out to the rim", said)
    assert error, said
    # far below the calibration's sigma where Klipper prints at full speed, and stated
    assert int(error[1]) > 3000 and float(error[2]) < 0.002 and float(error[4]) < 0.05
    assert "to install: copy deltacal_geometry.py into klippy/extras/" in said
    print("\n" + said)
    text = (out / SECTION_FILE).read_text(encoding="utf-8")
    assert f"sampling_error: max {error[2]} mm within radius {error[3]} mm" in text
    # the σ grid and the bound the module weights the correction with, as the library holds them
    section = _Section(text)
    grid = live.read_section(section)[0]
    holds = kossel["loaded"].holds
    assert grid.holds.bound == bound and list(grid.holds.height) == list(holds.height)
    assert list(grid.holds.sigma_values) == [*holds.horizontal.ravel(), *holds.vertical.ravel()]
    print(f"section: {len(text.encode())} bytes, grid {section.get('grid_shape')} nodes, σ grid "
          f"{holds.horizontal.shape}")


def _volume_points(rng: np.random.Generator, count: int) -> np.ndarray:
    """Points of the planned object's volume (radius 115 mm, z 0.2 to 200 mm) [mm], (count, 3)."""
    r = 115.0 * np.sqrt(rng.random(count))
    a = 2.0 * np.pi * rng.random(count)
    return np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.2, 200.0, count)])


def _program(points: np.ndarray, start=(0.0, 0.0, 150.0), after: str = "") -> str:
    """From a position set without homing, each point in turn, a dwell and GET_POSITION after each."""
    lines = [f"SET_KINEMATIC_POSITION X={start[0]} Y={start[1]} Z={start[2]}", "G90", "G1 F6000"]
    for x, y, z in points:
        lines += [f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f}", f"G4 P{DWELL_S * 1000:g}", "GET_POSITION"]
    return "\n".join(lines + [after, ""])


@dataclass
class Landed:
    """Where a run's moves put the nozzle, at the program's points and along its moves."""

    commands: np.ndarray  # Klipper's toolhead at each point (the commands), (N, 3)
    exact: dict[str, np.ndarray]  # printer -> its nozzle at each point, exact carriages, (N, 3)
    # (the identified printer: in Klipper's frame, as the correction puts it, aligned_to_controller)
    rounded: dict[str, np.ndarray]  # printer -> its nozzle at each point, carriages as stepped, (N, 3)
    path: np.ndarray  # the identified printer's nozzle along the moves (exact carriages), (M, 3)
    path_move: np.ndarray  # each path sample's move (0: the first point's), (M,)


def _landed(kossel, klipper: Path, run: Run, start=(0.0, 0.0, 150.0), path: bool = True) -> Landed:
    assert run.status == 0, run.log[-3000:]
    firmware = kossel["firmware"]
    commands = toolhead_positions(run.log)
    steps = decode_steps(klipper, run.serial)
    start_heights = firmware.carriage_heights(np.array([start]))[0]
    stepped = start_heights + at_dwells(steps) * firmware.step_distance
    exact_heights = firmware.carriage_heights(commands)
    # the decoded steps are Klipper's commands, rounded to a step
    assert stepped.shape == exact_heights.shape
    assert np.max(np.abs(stepped - exact_heights)) <= 0.5 * float(np.max(firmware.step_distance)) + 1e-6
    printers = {"identified": kossel["aligned"], "true": kossel["truth"]}
    travel, known = exact_travel(steps) if path else (np.zeros((0, 3)), np.zeros(0, dtype=bool))
    path_heights = start_heights + travel[known] * firmware.step_distance
    return Landed(commands, {k: nozzle(g, firmware, exact_heights) for k, g in printers.items()},
                  {k: nozzle(g, firmware, stepped) for k, g in printers.items()},
                  nozzle(kossel["aligned"], firmware, path_heights) if path else np.zeros((0, 3)),
                  moves(steps)[known] if path else np.zeros(0, dtype=int))


def _offline(kossel, program: str, name: str) -> str:
    """The program corrected by ``compensate`` for the printer's configuration (the offline route)."""
    folder, bound = kossel["folder"], repr(kossel["bound"])
    source, corrected = folder / f"{name}.gcode", folder / f"{name}_corrected.gcode"
    source.write_text(program, encoding="utf-8")
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["compensate", str(kossel["calibration"]), str(source), "--controller",
                     str(kossel["config"]), "-o", str(corrected), "--sigma-bound", bound]) == 0
    return corrected.read_text(encoding="utf-8")


def _max(errors: np.ndarray) -> float:
    return float(np.max(np.linalg.norm(errors, axis=1)))


@pytest.mark.long
@pytest.mark.parametrize("printer", ["kossel", "kossel_bed"])
def test_klipper_with_the_module_lands_the_nozzle_as_the_offline_route_does(printer, request, klipper):
    """Done when (issue 41): within 1.2x the offline route's 3-D max + 0.005 mm; the offline route's commands.

    The offline route: ``compensate`` with the same ``--sigma-bound`` (the correction weighted where
    the calibration holds). Before step rounding (the carriages at Klipper's commands); on the
    identified printer (in Klipper's frame, where the correction puts it), and on the true one as
    the printed part sees it (less the shift along the bed and the turn about its normal, which no
    measurement of the planned object sees: both routes leave them alike). Where the height's whole
    correction is applied (its weight 1) the identified nozzle is at the point's height (along the bed
    the correction is eased in: its weight stays below 1).
    """
    kossel = request.getfixturevalue(printer)
    points = _volume_points(np.random.default_rng(41), 30)
    weights = weighted_targets(kossel["loaded"], kossel["controller"], points, bound=kossel["bound"]).weights
    whole = weights[:, 1] == 1.0
    if printer == "kossel_bed":  # its held region ends inside the volume: weights of every kind
        assert np.any(whole) and np.any(weights == 0.0) and np.any((weights > 0.0) & (weights < 1.0))
    program = _program(points)
    run = run_klippy(klipper, kossel["live_config"], program, "points_live", steps=True)
    module = _landed(kossel, klipper, run, path=False)
    corrected = _offline(kossel, program, "points")
    run = run_klippy(klipper, kossel["config"], corrected, "points_offline", steps=True)
    offline = _landed(kossel, klipper, run, path=False)
    figures = {}
    for name in ("identified", "true"):
        errors = [landed.exact[name] - points for landed in (module, offline)]
        errors += [landed.rounded[name] - points for landed in (module, offline)]
        if name == "true":
            errors = [less_bed_motion(points, e)[0] for e in errors]
        figures[name] = [round(_max(e), 5) for e in errors]
        ours, theirs = figures[name][:2]
        assert ours <= 1.2 * theirs + 0.005, figures
    held = float(np.max(np.abs(module.exact["identified"][whole, 2] - points[whole, 2])))
    assert held <= 0.005, held
    apart = _max(module.commands - offline.commands)
    print(f"\n{printer}: 3-D max [mm] (module, offline; the same with step rounding): {figures}; where "
          f"the height wholly corrected ({int(whole.sum())} of {len(points)} points), the identified "
          f"nozzle's height within {held:.5f} mm; weights {np.round(weights.T, 3).tolist()}; commands "
          f"apart {apart:.5f} mm")
    # the module's commands are the offline route's, to the field's sampling error
    assert apart < 0.005


def _intended(kossel, a: np.ndarray, b: np.ndarray, count: int = 4000) -> np.ndarray:
    """Where the offline route's exact commands put the identified nozzle along the move a -> b, (count, 3).

    The straight line where the whole correction is applied; where it is weighted down, the
    identified printer's nozzle under the weighted commands (as far off the line as the correction
    not applied).
    """
    x = a + np.linspace(0.0, 1.0, count)[:, None] * (b - a)
    commands = weighted_targets(kossel["loaded"], kossel["controller"], x, bound=kossel["bound"]).commands
    return nozzle(kossel["aligned"], kossel["firmware"], kossel["firmware"].carriage_heights(commands))


def _path_deviation(kossel, landed: Landed, points: np.ndarray) -> tuple[float, float]:
    """The largest distance of the path from its move's intended path, and from its straight line.

    Moves 2 on (from a point); the intended path (:func:`_intended`) as a polyline, each path sample
    against its pieces near the sample's place along the move.
    """
    worst = line = 0.0
    for k in range(1, len(points)):
        on = landed.path[landed.path_move == k]
        a, b = points[k - 1], points[k]
        length = float(np.linalg.norm(b - a))
        u = (b - a) / length
        rel = on - a
        line = max(line, float(np.max(np.linalg.norm(rel - np.outer(rel @ u, u), axis=1), initial=0.0)))
        curve = _intended(kossel, a, b)
        near = np.rint(np.clip(rel @ u / length, 0.0, 1.0) * (len(curve) - 2)).astype(int)
        best = np.full(len(on), np.inf)
        for shift in range(-40, 41):  # the pieces within 2.4 mm along the move or more
            i = np.clip(near + shift, 0, len(curve) - 2)
            p, q = curve[i], curve[i + 1]
            t = np.clip(np.sum((on - p) * (q - p), axis=1) / np.sum((q - p) ** 2, axis=1), 0.0, 1.0)
            best = np.minimum(best, np.linalg.norm(on - p - t[:, None] * (q - p), axis=1))
        worst = max(worst, float(np.max(best, initial=0.0)))
    return worst, line


@pytest.mark.long
@pytest.mark.parametrize("printer", ["kossel", "kossel_bed"])
def test_long_moves_stay_on_their_straight_line(printer, request, klipper):
    """Done when: the path within max(0.02, 1.2x the offline route's + 0.005 mm) of its intended path.

    The intended path: where the offline route's exact commands along the move put the identified
    nozzle (the straight line where the whole correction is applied: the planned object's
    calibration). On the bed-level one the moves cross where its weights turn from 1 to 0.
    """
    kossel = request.getfixturevalue(printer)
    points = np.array([[-100.0, -40.0, 0.3], [100.0, 40.0, 0.3], [-60.0, 90.0, 0.3], [70.0, -80.0, 120.0],
                       [-110.0, 10.0, 60.0], [0.0, 112.0, 5.0]])
    program = _program(points)
    module = _landed(kossel, klipper, run_klippy(klipper, kossel["live_config"], program, "lines_live",
                                                 steps=True))
    corrected = _offline(kossel, program, "lines")
    offline = _landed(kossel, klipper, run_klippy(klipper, kossel["config"], corrected, "lines_offline",
                                                  steps=True))
    (ours, our_line), (theirs, their_line) = _path_deviation(kossel, module, points), \
        _path_deviation(kossel, offline, points)
    print(f"\n{printer}: largest distance from the intended path [mm]: module {ours:.4f}, offline "
          f"{theirs:.4f}; from the straight line: module {our_line:.4f}, offline {their_line:.4f}; "
          f"{len(module.path)} path samples")
    assert len(module.path) > 1000
    assert ours <= max(0.02, 1.2 * theirs + 0.005)
    if printer == "kossel":  # wholly corrected: the intended path is the straight line
        assert our_line <= max(0.02, 1.2 * their_line + 0.005)
    else:
        weights = weighted_targets(kossel["loaded"], kossel["controller"], _intended_points(points),
                                   bound=kossel["bound"]).weights
        assert np.any(weights == 1.0) and np.any(weights == 0.0) and np.any((weights > 0.0) & (weights < 1.0))
        assert our_line > 0.1  # the correction is not applied all along: the path is not the line


def _intended_points(points: np.ndarray, count: int = 400) -> np.ndarray:
    """Points along each move of a program, (count x moves, 3)."""
    t = np.linspace(0.0, 1.0, count)[:, None, None]
    return (points[:-1] + t * (points[1:] - points[:-1])).reshape(-1, 3)


@pytest.mark.long
def test_arcs_are_corrected_as_klippers_gcode_arcs_cuts_them(kossel, klipper):
    """G2 reaches the module as ``[gcode_arcs]``'s 1 mm moves: the nozzle follows the arc."""
    centre, radius, z = np.array([10.0, -5.0]), 45.0, 0.3
    start = f"X{centre[0] + radius} Y{centre[1]}"
    program = (f"SET_KINEMATIC_POSITION X=0 Y=0 Z=150\nG90\nG1 {start} Z{z} F6000\n"
               f"G4 P{DWELL_S * 1000:g}\nG2 {start} I{-radius} J0\n"
               f"G4 P{DWELL_S * 1000:g}\nGET_POSITION\n")
    deviation = {}
    for route, config, text in (("module", kossel["live_config"], program),
                                ("offline", kossel["config"], _offline(kossel, program, "arc"))):
        run = run_klippy(klipper, config, text, f"arc_{route}", steps=True)
        assert run.status == 0, run.log[-3000:]
        steps = decode_steps(klipper, run.serial)
        travel, known = exact_travel(steps)
        heights = kossel["firmware"].carriage_heights(np.array([[0.0, 0.0, 150.0]]))[0] + \
            travel[known] * kossel["firmware"].step_distance
        on_arc = moves(steps)[known] == 1
        path = nozzle(kossel["aligned"], kossel["firmware"], heights[on_arc])
        assert len(path) > 500
        off = np.hypot(np.hypot(*(path[:, :2] - centre).T) - radius, path[:, 2] - z)
        deviation[route] = float(np.max(off))
    print(f"\nlargest distance from the arc [mm]: {deviation}")
    assert deviation["module"] <= max(0.02, 1.2 * deviation["offline"] + 0.005)


@pytest.mark.slow
def test_get_position_after_set_kinematic_position_is_the_programs_last_point(kossel, klipper):
    points = np.array([[-80.0, 30.0, 20.0], [90.0, -50.0, 2.0]])
    program = _program(points, after="SET_KINEMATIC_POSITION\nGET_POSITION")
    run = run_klippy(klipper, kossel["live_config"], program, "position_live")
    assert run.status == 0, run.log[-3000:]
    reported = gcode_positions(run.log)
    assert len(reported) == 3
    assert np.max(np.abs(reported[-1] - points[-1])) <= 0.001
    assert np.max(np.abs(reported[:2] - points)) <= 1e-6  # as gcode_move keeps it
    # the position read back is through the module: the toolhead is at the corrected command
    toolhead = toolhead_positions(run.log)
    assert np.linalg.norm(toolhead[-1] - points[-1]) > 0.05


@pytest.mark.slow
def test_after_homing_the_position_is_the_point_whose_command_is_klippers_home(kossel, klipper):
    """After G28 the position reported is the program point the offline route sends to Klipper's home.

    Where the correction is wholly applied there, the identified nozzle at its endstops.
    """
    program = "G28\nGET_POSITION\nG1 X10 Y-20 Z100 F6000\nGET_POSITION\n"
    run = run_klippy(klipper, kossel["live_config"], program, "home_live")
    assert run.status == 0, run.log[-3000:]
    reported = gcode_positions(run.log)
    home = kossel["firmware"].home_position
    geometry = kossel["aligned"]  # every carriage at its endstop: the identified nozzle there
    endstops = exact.forward(geometry, np.zeros((1, 3))).point(geometry.tool)[0]
    # the program point whose command is Klipper's home: the identified nozzle there, less the part of
    # the correction along the bed not applied (its weight below 1: what stands out of its σ, eased in).
    # That point and the nozzle's are at the top of the identified printer's reach, which the library
    # refuses to correct: the weight and the correction are read 0.5 mm below (the field is smooth there)
    below = endstops - np.array([0.0, 0.0, 0.5])
    there = weighted_targets(kossel["loaded"], kossel["controller"], below[None], bound=kossel["bound"])
    w = there.weights[0, 0]
    applied = (there.commands[0] - below) * np.array([1.0, 1.0, 0.0])  # w times the whole along the bed
    expected = endstops + (applied * (1.0 - w) / w if w > 0.0 else 0.0)
    print(f"\nafter G28: reported {reported[0]}, expected {expected}, Klipper's home {home}, weights 0.5 mm "
          f"below the identified nozzle's endstop point {there.weights[0]}")
    assert np.linalg.norm(reported[0] - home) > 0.05  # not Klipper's own home: a correction there
    assert np.linalg.norm(reported[0] - expected) < 0.001
    assert np.allclose(reported[1], [10.0, -20.0, 100.0], atol=1e-6)


@pytest.mark.slow
def test_a_program_corrected_offline_is_refused(kossel, klipper):
    """Its marker line reaches Klipper's dispatcher as a comment: the module refuses it there.

    Printed from Klipper's virtual SD card (as Mainsail and Fluidd print), the print stops at it.
    """
    points = np.array([[10.0, 10.0, 20.0], [-30.0, 5.0, 10.0]])
    corrected = _offline(kossel, _program(points), "marked")
    assert corrected.startswith(MARKER)
    folder = kossel["folder"]
    config = folder / "printer_sdcard.cfg"
    config.write_text(kossel["live_config"].read_text() + f"\n[virtual_sdcard]\npath: {folder}\n")
    run = run_klippy(klipper, config, "SDCARD_PRINT_FILE FILENAME=marked_corrected.gcode\n", "marked_live")
    assert run.status != 0
    assert "deltacal_geometry: this program is already corrected by deltacal" in run.log
    assert not toolhead_positions(run.log).size  # the print stopped at its first line, before any move
    # with the module turned off first, it runs (corrected once, offline)
    run = run_klippy(klipper, kossel["live_config"], "DELTACAL_GEOMETRY ENABLE=0\n" + corrected, "marked_off")
    assert run.status == 0, run.log[-3000:]
    assert "deltacal_geometry: off" in run.log
    assert len(toolhead_positions(run.log)) == 2


@pytest.mark.slow
def test_klipper_values_other_than_the_corrections_are_refused_at_start(kossel, klipper):
    changed = kossel["folder"] / "printer_changed.cfg"
    text = kossel["live_config"].read_text()
    arm = f"arm_length: {float(kossel['firmware'].arm_length[1])!r}"
    assert arm in text
    head, tail = text.split("[stepper_b]", 1)
    changed.write_text(head + "[stepper_b]" + tail.replace(arm, "arm_length: 269.2", 1))
    run = run_klippy(klipper, changed, "G28\n", "changed")
    assert run.status != 0
    refusal = r"deltacal_geometry: \[stepper_b\] arm_length is 269\.2 in Klipper, but the correction was "
    assert re.search(refusal + r"computed for 269", run.log), run.log[-3000:]


def _beyond_the_rim(kossel) -> np.ndarray:
    """A point of Klipper's volume at its rim whose corrected command Klipper's radius refuses [mm]."""
    firmware = kossel["firmware"]
    angle = np.linspace(0.0, 2.0 * np.pi, 360, endpoint=False)
    rim = firmware.max_radius - 0.05
    points = np.column_stack([rim * np.cos(angle), rim * np.sin(angle), np.full(angle.size, 20.0)])
    commands = points + exact_correction(kossel["loaded"], kossel["controller"], points, kossel["bound"])
    beyond = np.hypot(commands[:, 0], commands[:, 1]) > firmware.max_radius + 0.01
    assert np.any(beyond)
    return points[np.flatnonzero(beyond)[0]]


@pytest.mark.slow
def test_a_move_whose_correction_leaves_klippers_limits_is_refused_whole(kossel, klipper):
    point = _beyond_the_rim(kossel)
    program = (f"SET_KINEMATIC_POSITION X=0 Y=0 Z=150\nG1 X0 Y0 Z20 F6000\nG4 P{DWELL_S * 1000:g}\n"
               f"G1 X{point[0]:.4f} Y{point[1]:.4f} Z20\n")
    run = run_klippy(klipper, kossel["live_config"], program, "rim_live")
    assert run.status != 0
    assert re.search(r"deltacal_geometry: the program's point X\S+ Y\S+ Z20\.0000, corrected, is .*: radius "
                     r"\S+ beyond Klipper's \S+: set \[printer\] print_radius", run.log), run.log[-3000:]
    assert "Move out of range" not in run.log  # refused before Klipper's own check
    run = run_klippy(klipper, kossel["live_config"], "DELTACAL_GEOMETRY ENABLE=0\n" + program, "rim_off")
    assert run.status == 0, run.log[-3000:]  # the point itself is inside Klipper's limits


@pytest.mark.slow
def test_it_sits_under_skew_correction_and_exclude_object_and_over_bed_mesh(kossel, klipper):
    mesh = ("\n[probe]\npin: PA1\nz_offset: 1\n\n[bed_mesh]\nmesh_radius: 80\nround_probe_count: 5\n\n"
            "[skew_correction]\n\n[exclude_object]\n")
    config = kossel["folder"] / "printer_chain.cfg"
    config.write_text(printer_cfg(kossel["firmware"], f"\n[include {kossel['out'] / SECTION_FILE}]\n" + mesh))
    program = ("G28\nBED_MESH_CALIBRATE\nSET_SKEW XY=141.42,141.42,100\nDELTACAL_GEOMETRY\n"
               "EXCLUDE_OBJECT_DEFINE NAME=a CENTER=0,0\nEXCLUDE_OBJECT_DEFINE NAME=b CENTER=50,0\n"
               "EXCLUDE_OBJECT_START NAME=a\nG1 X10 Y10 Z5 F6000\nEXCLUDE_OBJECT_END NAME=a\n"
               "EXCLUDE_OBJECT NAME=b\nDELTACAL_GEOMETRY\nG1 X-10 Y20 Z5\nGET_POSITION\n")
    run = run_klippy(klipper, config, program, "chain")
    assert run.status == 0, run.log[-3000:]
    chains = re.findall(r"move transforms: (.*)$", run.log, flags=re.M)
    assert chains == ["PrinterSkew > deltacal_geometry > BedMesh",
                      "ExcludeObject > PrinterSkew > deltacal_geometry > BedMesh"]
    assert np.allclose(gcode_positions(run.log)[-1], [-10.0, 20.0, 5.0], atol=1e-6)


def _example_delta_test(klipper: Path, folder: Path, name: str, config: str, commands: str) -> None:
    """One of Klipper's own test cases run by its harness, ``scripts/test_klippy.py``, with this config."""
    (folder / f"{name}.cfg").write_text(config)
    (folder / f"{name}.test").write_text(f"CONFIG {name}.cfg\nDICTIONARY atmega2560.dict\n{commands}")
    done = subprocess.run([sys.executable, "scripts/test_klippy.py", "-d", "dict", "-t", str(folder),
                           str(folder / f"{name}.test")], cwd=klipper, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-4000:]
    assert "All 1 test cases passed" in done.stderr


@pytest.mark.long
def test_klippers_own_delta_bed_mesh_and_skew_cases_pass_with_the_module(klipper, tmp_path):
    """Klipper's delta.test on its example-delta.cfg; bed_mesh.test's commands and a skew case on it too.

    The printer behind the correction: a kit printer built to example-delta.cfg's values (its
    geometry standing for the calibration).
    """
    from dataclasses import replace

    from deltacal.io import save_geometry

    example = (klipper / "config" / "example-delta.cfg").read_text()
    (tmp_path / "example-delta.cfg").write_text(example)
    firmware = load_klipper(tmp_path / "example-delta.cfg")
    nominal = replace(PRINTER, name="example-delta", rod_length=np.array(firmware.arm_length),
                      tower_radius=firmware.delta_radius + PRINTER.effector_radius,
                      endstop_height=firmware.carriage_top - PRINTER.tool[2])
    truth = random_printer(nominal, np.random.default_rng(4102), typical_kit())
    save_geometry(truth, tmp_path / "truth.toml")
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["export", str(tmp_path / "truth.toml"), "--controller", "klipper", "--config",
                     str(tmp_path / "example-delta.cfg"), "--live", "-o", str(tmp_path / "live")]) == 0
    live_config = example + "\n[include live/deltacal_geometry.cfg]\n"
    own = {name: (klipper / "test" / "klippy" / f"{name}.test").read_text() for name in ("delta", "bed_mesh")}
    commands = {name: re.sub(r"^(CONFIG|DICTIONARY) .*$", "", text, flags=re.M) for name, text in own.items()}
    _example_delta_test(klipper, tmp_path, "delta_live", live_config, commands["delta"])
    mesh = "\n[probe]\npin: PA1\nz_offset: 1\n\n[bed_mesh]\nmesh_radius: 80\nround_probe_count: 5\n"
    _example_delta_test(klipper, tmp_path, "bed_mesh_live", live_config + mesh, commands["bed_mesh"])
    skew = ("G28\nG1 X10 Y10 Z10 F6000\nSET_SKEW XY=141.42,141.42,100 XZ=141.42,141.42,100\n"
            "GET_CURRENT_SKEW\n"
            "G1 X-40 Y30 Z20\nSKEW_PROFILE SAVE=live\nSET_SKEW CLEAR=1\nG1 X0 Y0 Z5\nSKEW_PROFILE LOAD=live\n"
            "G1 X20 Y-20 Z5\n")
    _example_delta_test(klipper, tmp_path, "skew_live", live_config + "\n[skew_correction]\n", skew)
