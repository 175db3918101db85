"""The live module under bad moves and bad values (issue 49, items 1 to 3).

A move Klipper's limits refuse is refused whole, in Klipper's words, before any segment is made
(checked on the module's own arithmetic with a fake Klipper, then in the pinned Klipper in batch
mode: the same refusals with and without the module, no step of the towers); every number the
section holds is refused when it is not one (Klipper's ``getfloat`` passes ``nan``); a σ bound
below the correction's resolution is refused by the export and by the module.
"""

from __future__ import annotations

import base64
import functools
import math
import re
import time
import zlib
from array import array

import numpy as np
import pytest
from test_klipper_live import (
    PRINTER,
    SECTION_FILE,
    _Config,
    _Error,
    _holds,
    _Printer,
    _Section,
    _section,
    _smooth_field,
    _Toolhead,
    _transform,
    decode_steps,
    kossel,  # noqa: F401 (a fixture)
    printer_cfg,
    run_klippy,
)

from deltacal.cli import main
from deltacal.io import save_geometry
from deltacal.printer.firmware.klipper.live import deltacal_geometry as live
from deltacal.printer.firmware.klipper.live.export import VALUE_UNIT_MM
from deltacal.printer.firmware.klipper.model import KlipperDelta

#: Klipper's refusals of a move, as its toolhead says them (klippy/toolhead.py's ``move_error``).
REFUSAL = r"^(Must home first|Move out of range): (\S+) (\S+) (\S+) \[(\S+)\]$"
#: A number Klipper's G-code parser reads (digits only) as inf.
HUGE = "1" + "0" * 400


# ------------------------------------------------------------------ moves, with a fake Klipper
def _counting(module) -> list:
    """Record every call of the module's grid's ``segments`` (a list of segments is built after it)."""
    calls: list = []
    segments = module.grid.segments

    def counted(*args):
        calls.append(args)
        return segments(*args)

    module.grid.segments = counted
    return calls


def test_a_move_klipper_refuses_is_refused_whole_before_any_segment_is_made():
    module, toolhead, _ = _transform()
    module.grid.curvature = [[4e-4] * module.grid.nz] * len(module.grid.curvature)
    module.grid.cells = [4e-4] * len(module.grid.cells)  # the section's bound per cell, made even
    module.tolerance = 0.005  # segments of 10 mm at most: the moves below would be cut
    module.move([0.0, 0.0, 10.0, 0.0], 50.0)
    toolhead.moves.clear()
    calls = _counting(module)
    refused = {  # the program's point -> Klipper's words
        (0.0, 0.0, -20.0): "Move out of range: 0.000 0.000 -20.000 [0.000]",  # below the bed
        (1e9, 0.0, 10.0): "Move out of range: 1000000000.000 0.000 10.000 [0.000]",
        (100000.0, 0.0, 10.0): "Move out of range: 100000.000 0.000 10.000 [0.000]",
        (0.0, 0.0, 1000.0): "Move out of range: 0.000 0.000 1000.000 [0.000]",  # Klipper's taper: no radius
        (1e300, 0.0, 10.0): f"Move out of range: {1e300:.3f} 0.000 10.000 [0.000]",  # length inf, no overflow
        (math.inf, 0.0, 10.0): "Move out of range: inf 0.000 10.000 [0.000]",
        (math.nan, 0.0, 10.0): "Move out of range: nan 0.000 10.000 [0.000]",  # Klipper would pass it
        (0.0, -math.inf, math.nan): "Move out of range: 0.000 -inf nan [0.000]",
    }
    for point, words in refused.items():
        with pytest.raises(_Error) as error:
            module.move([*point, 0.0], 50.0)
        assert str(error.value) == words
    assert toolhead.moves == [] and calls == []  # nothing sent, no segment made
    assert module.last_position == [0.0, 0.0, 10.0, 0.0]
    module.move([30.0, 0.0, 10.0, 1.0], 50.0)  # a move inside: cut and sent
    assert len(toolhead.moves) == 3 and len(calls) == 1


def test_before_homing_every_move_of_the_nozzle_is_refused_and_extrusion_is_not():
    module, toolhead, _ = _transform()
    status = toolhead.get_status
    toolhead.get_status = lambda eventtime: {**status(eventtime), "homed_axes": ""}
    start = list(module.last_position)
    calls = _counting(module)
    for point in ([10.0, 0.0, 20.0, 0.0], [1e9, 0.0, 0.0, 0.0]):
        words = rf"^Must home first: {point[0]:.3f} 0\.000 {point[2]:.3f} \[0\.000\]$"
        with pytest.raises(_Error, match=words):
            module.move(point, 50.0)
    assert toolhead.moves == [] and calls == []
    module.move([*start[:3], 2.0], 5.0)  # extrusion alone: Klipper does not check it
    assert len(toolhead.moves) == 1 and toolhead.moves[0][3] == 2.0


def test_klippers_refusal_is_its_check_move():
    """Klipper's limits as klippy/kinematics/delta.py's ``check_move`` has them, at chosen points.

    The Kossel's values: build radius 133.68 mm (print_radius), z 0 to 295.60 mm, its taper above
    259.21 mm; Klipper's home (0, 0, 295.60): the move down from above its top there is let through.
    """
    firmware = KlipperDelta.from_printer(PRINTER)
    toolhead = _Toolhead(firmware)
    home = (0.0, 0.0, firmware.max_z + 0.5)  # asymmetric endstops put it above the top
    limits = live.Limits(toolhead.get_calibration(), toolhead.get_status(None), home)
    r, top, cone = firmware.max_radius, firmware.max_z, firmware.limit_z
    taper = firmware.delta_radius - math.sqrt(max(firmware.arm_length) ** 2 - (max(firmware.arm_length)
                                                                               - (top - 1.0 - cone)) ** 2)
    inside = [(r - 0.01, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 0.0, top), (taper - 0.01, 0.0, top - 1.0),
              (0.0, 0.0, top + 0.4)]  # the last: Klipper's home, from above its top
    outside = [(r + 0.01, 0.0, 5.0), (0.0, 0.0, -0.01), (0.1, 0.0, top + 0.4), (0.0, 0.0, top + 0.6),
               (taper + 0.01, 0.0, top - 1.0), (0.0, 0.0, 1e6), (math.nan, 0.0, 5.0)]
    assert [limits.refusal([*p, 0.0], True) for p in inside] == [""] * len(inside)
    assert all(limits.refusal([*p, 0.0], True).startswith("Move out of range: ") for p in outside)
    assert limits.refusal([0.0, 0.0, 5.0, 1.5], False) == "Must home first: 0.000 0.000 5.000 [1.500]"
    # no home known: the move down from above the top is refused too
    homeless = live.Limits(toolhead.get_calibration(), toolhead.get_status(None))
    assert homeless.refusal([0.0, 0.0, top + 0.4], True).startswith("Move out of range: ")


def test_the_segments_of_a_move_are_few_whatever_its_points():
    grid = _transform()[0].grid
    grid.curvature = [[4e-4] * grid.nz] * len(grid.curvature)
    grid.cells = [4e-4] * len(grid.cells)  # the section's bound per cell, made even
    start = [0.0, 0.0, 10.0, 0.0]
    for end in ([math.inf, 0.0, 10.0, 0.0], [math.nan, 0.0, 10.0, 0.0], [1e300, 1e300, 10.0, 0.0],
                [-1e308, 0.0, 1e308, 0.0]):
        assert 1 <= grid.segments(start, end, 0.005) <= live.MOST_SEGMENTS
    assert grid.segments(start, [1e9, 0.0, 10.0, 0.0], 0.005) == live.MOST_SEGMENTS
    assert grid.segments(start, [60.0, 0.0, 10.0, 0.0], 0.005) == 6  # as before: the bound's cut


# ------------------------------------------------------------------ the section's numbers
@functools.cache
def _text() -> str:
    """The section of a made-up field with a σ grid."""
    return _section(_smooth_field(holds=_holds(np.random.default_rng(7))))


def _with(text: str, key: str, value: str) -> str:
    """The section with ``key``'s value replaced (its first value, for a list)."""
    line = re.search(rf"^{key}: (.*)$", text, flags=re.M)
    assert line, key
    values = line[1].split(", ")
    return text.replace(line[0], f"{key}: {', '.join([value, *values[1:]])}", 1)


def _with_sigma(text: str, value: float | None, key: str = "holds_sigma") -> str:
    """The section with the σ grid's first value replaced (holds_sigma, encoded; None: removed)."""
    lines = text.split("\n")
    first = lines.index(f"{key}:") + 1
    last = next(k for k in range(first, len(lines)) if not lines[k].startswith("  "))
    sigma = array("d", zlib.decompress(base64.b64decode("".join(lines[first:last]))))
    if value is None:
        sigma.pop()
    else:
        sigma[0] = value
    encoded = base64.b64encode(zlib.compress(sigma.tobytes())).decode("ascii")
    return "\n".join([*lines[:first], "  " + encoded, *lines[last:]])


FLOAT_KEYS = (*live.VALUE_KEYS, *live.VOLUME_KEYS, "grid_origin", "grid_step", "correction_unit",
              "sigma_bound", "holds_radius", "holds_azimuth", "holds_height")


NOT_NUMBERS = [(key, value) for key in FLOAT_KEYS for value in ("nan", "inf", "-inf")
               if (key, value) != ("sigma_bound", "inf")]  # the infinite bound is one


@pytest.mark.parametrize(("key", "value"), NOT_NUMBERS)
def test_a_number_of_the_section_that_is_not_one_is_refused_naming_its_key(key, value):
    """Every float the module reads: nan (Klipper's getfloat passes it), and inf but for the bound."""
    text = _with(_text(), key, value)
    with pytest.raises(_Section.error, match=rf"^deltacal_geometry: key {key}: {value} is not a"):
        live.read_section(_Section(text))


def test_split_curvature_split_tolerance_and_holds_sigma_that_are_not_numbers_are_refused():
    text = _text()
    curvature = re.search(r"^split_curvature:\n  (\S+),", text, flags=re.M)
    assert curvature
    for value in ("nan", "inf"):
        broken = text.replace(curvature[0], f"split_curvature:\n  {value},", 1)
        with pytest.raises(_Section.error, match=rf"key split_curvature: {value} is not a finite number"):
            live.read_section(_Section(broken))
    for value in (math.nan, math.inf):
        with pytest.raises(_Section.error, match="key holds_sigma: .* non-negative finite ones"):
            live.read_section(_Section(_with_sigma(text, value)))
    live.read_section(_Section(_with_sigma(text, 0.5)))  # a finite σ: read
    firmware = KlipperDelta.from_printer(PRINTER)
    for value in ("nan", "inf"):
        broken = text.replace("split_tolerance: 0.01", f"split_tolerance: {value}", 1)
        with pytest.raises(_Section.error, match=rf"key split_tolerance: {value} is not a finite number"):
            live.DeltacalGeometry(_Config(broken, _Printer(_Toolhead(firmware))))


def test_split_cells_that_are_not_deltacals_bounds_are_refused_naming_the_key():
    text = _text()
    for value in (math.nan, math.inf, -1e-3, None):  # None: one value short
        with pytest.raises(_Section.error, match=r"^deltacal_geometry: key split_cells: \d+ values, expected "
                                                 r"\d+ non-negative finite ones"):
            live.read_section(_Section(_with_sigma(text, value, "split_cells")))
    with pytest.raises(_Section.error, match="key split_cells: not deltacal's encoded values"):
        live.read_section(_Section(text.replace("split_cells:\n  eN", "split_cells:\n  #N", 1)))
    assert live.read_section(_Section(_with_sigma(text, 0.5, "split_cells")))[0].cells[0] == 0.5


def test_a_sigma_bound_below_the_correction_unit_is_refused_by_the_module():
    text = _text()
    assert "correction_unit: 1e-06" in text
    for value in ("5e-324", "9e-07"):
        with pytest.raises(_Section.error, match=rf"^deltacal_geometry: key sigma_bound: {value} is below "
                                                 r"correction_unit 1e-06"):
            live.read_section(_Section(_with(text, "sigma_bound", value)))
    grid = live.read_section(_Section(_with(text, "sigma_bound", "2e-06")))[0]
    assert grid.holds.bound == 2e-6 and grid.correction(10.0, 5.0, 20.0) is not None
    # the infinite bound stays one: the whole correction everywhere
    grid = live.read_section(_Section(_with(text, "sigma_bound", "inf")))[0]
    assert grid.correction(10.0, 5.0, 20.0) == grid.at(10.0, 5.0, 20.0)


def test_export_live_refuses_a_sigma_bound_below_the_correction_unit(tmp_path, capsys):
    calibration = tmp_path / "cal.toml"
    save_geometry(PRINTER.geometry(), calibration)
    config = tmp_path / "printer.cfg"
    config.write_text(printer_cfg(KlipperDelta.from_printer(PRINTER)))
    out = tmp_path / "live"
    for bound in ("5e-324", "9e-07"):
        assert main(["export", str(calibration), "--controller", "klipper", "--config", str(config), "--live",
                     "-o", str(out), "--sigma-bound", bound]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"--sigma-bound {bound}: below 1e-06 mm" in err, err
        assert not out.exists()
    assert VALUE_UNIT_MM == 1e-6


# ------------------------------------------------------------------ the real Klipper
#: Moves Klipper refuses, before homing and after, each followed by the next (in batch mode Klipper
#: goes on with the lines it has read after an error, then exits); the last line makes Klipper
#: turn every move it accepted into steps.
REFUSED = f"""G1 X0 Y0 Z-20 F6000
G1 X1000000000 Y0 Z10
G1 E1
SET_KINEMATIC_POSITION X=0 Y=0 Z=10
G1 X0 Y0 Z-20
G1 X1000000000 Y0 Z10
G1 X100000 Y0 Z10
G1 X{HUGE} Y0 Z10
SET_KINEMATIC_POSITION X=0 Y=0 Z=10
"""


@pytest.mark.slow
def test_moves_klipper_refuses_are_refused_whole_with_and_without_the_module(kossel, klipper):  # noqa: F811 (kossel: the fixture imported)
    """With the module, each is refused in Klipper's words, at once, and no tower steps: as without it.

    Before, ``G1 X0 Y0 Z-20`` from Z10 was cut into segments and Klipper ran those above its
    minimum (765-766 steps of each tower down, onto the bed), ``G1 X1000000000`` made 10^8 segments.
    """
    refusals, elapsed = {}, {}
    for name in ("live_config", "config"):
        began = time.monotonic()
        run = run_klippy(klipper, kossel[name], REFUSED, f"refused_{name}", timeout=60.0)
        elapsed[name] = time.monotonic() - began
        assert run.status != 0 and "Internal error" not in run.log, run.log[-3000:]
        assert run.log.count("SET_KINEMATIC_POSITION pos=0.000,0.000,10.000") == 2, run.log[-3000:]
        refusals[name] = re.findall(REFUSAL, run.log, flags=re.M)
        assert decode_steps(klipper, run.serial).time.size == 0  # no tower stepped
    print(f"\nrefusals {refusals['live_config']}, klippy ran {elapsed}")
    assert refusals["live_config"] == refusals["config"]
    home, out = "Must home first", "Move out of range"
    assert [(what, float(x), float(z)) for what, x, _, z, _ in refusals["live_config"]] == [
        (home, 0.0, -20.0), (home, 1e9, 10.0), (out, 0.0, -20.0), (out, 1e9, 10.0), (out, 1e5, 10.0),
        (out, math.inf, 10.0)]
    assert elapsed["live_config"] < 10.0


@pytest.mark.slow
def test_the_section_s_bad_numbers_are_refused_by_klipper_naming_the_key(kossel, klipper):  # noqa: F811 (kossel: the fixture imported)
    """A NaN sigma_bound (read as the infinite bound before) and one below the correction unit."""
    text = (kossel["out"] / SECTION_FILE).read_text(encoding="utf-8")
    for value, words in (("nan", "nan is not a bound"), ("5e-324", "5e-324 is below correction_unit 1e-06")):
        folder = kossel["folder"] / f"bound_{value}"
        folder.mkdir(exist_ok=True)
        (folder / SECTION_FILE).write_text(_with(text, "sigma_bound", value), encoding="utf-8")
        config = folder / "printer.cfg"
        config.write_text(printer_cfg(kossel["firmware"], f"\n[include {folder / SECTION_FILE}]\n"))
        run = run_klippy(klipper, config, "G28\n", "bound", timeout=60.0)
        assert run.status != 0
        assert "Config error" in run.log and f"deltacal_geometry: key sigma_bound: {words}" in run.log, \
            run.log[-3000:]
