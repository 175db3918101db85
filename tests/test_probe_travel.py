"""The probe program travels above the probe's trigger height, as each firmware's configuration sets it.

A probe that hangs 16 to 24 mm below the nozzle (FLSUN's and Anycubic's deltas: Klipper's
``z_offset``, Marlin's ``-M851 Z``, RRF's ``G31 Z``) is driven into the bed by a program that moves
between points at a fixed ``G1 Z5``: every move of ``probe.gcode`` must be above the trigger
height, by the firmware's own travel height or a margin, and a configuration that does not say the
trigger height is refused.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.printer.firmware.base import PROBE_CLEARANCE
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.probing import MIN_TRAVEL_MARGIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).resolve().parent / "data"
Q5 = DATA / "klipper" / "real" / "flsun-q5-razorcopter.cfg"
KOSSEL = MODELS / "kossel.toml"
_Z = re.compile(r"^G1 .*\bZ(-?[\d.]+)", re.MULTILINE)


def _heights(program: str) -> list[float]:
    """The Z of every move of a probe program (each travel and each rise)."""
    return [float(z) for z in _Z.findall(program)]


def _planned(tmp_path: Path, robot: Path, config: Path, *extra: str) -> str:
    out = tmp_path / "plan"
    assert main(["plan", str(robot), "--object", "--controller", str(config), "-o", str(out), *extra]) == 0
    return (out / "probe.gcode").read_text()


def _imported(tmp_path: Path, config: Path) -> Path:
    assert main(["import", str(config), "-o", str(tmp_path / "imported")]) == 0
    return tmp_path / "imported" / "printer.toml"


def test_a_flsun_q5s_program_travels_above_its_24_mm_probe(tmp_path, capsys):
    """The real Q5 printer.cfg: z_offset 24.374 (saved), horizontal_move_z 10 and 25: none 2 mm above it."""
    program = _planned(tmp_path, _imported(tmp_path, Q5), Q5)
    heights = _heights(program)
    assert len(heights) == 1 + 2 * 49
    assert set(heights) == {24.374 + PROBE_CLEARANCE}
    assert "[delta_calibrate] horizontal_move_z = 10 mm is below it: Klipper refuses to probe" in program


def test_klippers_own_horizontal_move_z_is_taken_when_above_the_z_offset(tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=18.0)
    cfg.write_text(cfg.read_text() + "\n[delta_calibrate]\nradius: 100\nhorizontal_move_z: 10\n"
                   "\n[bed_mesh]\nhorizontal_move_z: 25\n")
    travel = KLIPPER.probe_travel(cfg)
    assert travel.height == 25.0
    assert travel.reason.startswith("[bed_mesh] horizontal_move_z = 25 mm; the probe triggers with the")
    assert set(_heights(KLIPPER.probe_program([[0.0, 0.0], [10.0, 5.0]], clearance=travel))) == {25.0}
    # Klipper's default (5) when the section does not set it: below the probe, z_offset + 5 instead
    cfg.write_text(cfg.read_text().replace("horizontal_move_z: 25\n", ""))
    travel = KLIPPER.probe_travel(cfg)
    assert travel.height == 18.0 + PROBE_CLEARANCE
    assert "[bed_mesh] horizontal_move_z (Klipper's default) = 5 mm is below it" in travel.reason
    # a nozzle probe: Klipper's default of 5 mm is the firmware's own travel height
    assert KLIPPER.probe_travel(kossel_printer_cfg(tmp_path / "nozzle.cfg")).height == PROBE_CLEARANCE


def test_a_klipper_config_without_a_probe_plans_no_probe_program(tmp_path, capsys):
    """Issue 47 (was refused, issue 39): no probe section, no probe.gcode, the paper test said instead;
    the travel height above a probe that is not there is still not known."""
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=None)
    out = tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "--probe-grid", "3",
                 "-o", str(out)]) == 0
    assert "MANUAL_PROBE" in capsys.readouterr().out and not (out / "probe.gcode").exists()
    with pytest.raises(InputError, match=r"printer.cfg: no probe section \(\[probe\]"):
        KLIPPER.probe_travel(cfg)


def _m503(tmp_path: Path, m851: str | None) -> Path:
    """The real-shaped capture of tests/data with its M851 line replaced (or removed)."""
    lines = (DATA / "marlin_m503.txt").read_text().splitlines(keepends=True)
    kept = [line for line in lines if "M851" not in line]
    if m851 is not None:
        kept = [line if "M851" not in line else f"Recv: echo:  {m851} ; (mm)\n" for line in lines]
    path = tmp_path / "m503.txt"
    path.write_text("".join(kept))
    return path


def test_a_marlin_program_travels_above_m851s_19_mm_probe(tmp_path):
    capture = _m503(tmp_path, "M851 X0.00 Y0.00 Z-19.32")
    program = _planned(tmp_path, _imported(tmp_path, capture), capture)
    assert set(_heights(program)) == {19.32 + PROBE_CLEARANCE}
    assert "the probe triggers with the nozzle 19.32 mm above the bed (-M851 Z, line 15 of" in program


def test_a_marlin_capture_without_m851_plans_no_probe_program(tmp_path, capsys):
    """Issue 47 (was refused, issue 39): no M851 (no probe), no probe.gcode, the paper test said; an
    M851 without Z (a capture cut short) is still refused by its key."""
    capture = _m503(tmp_path, None)
    out = tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(capture), "--probe-grid", "3",
                 "-o", str(out)]) == 0
    assert "M114" in capsys.readouterr().out and not (out / "probe.gcode").exists()
    capture = _m503(tmp_path, "M851 X0.00 Y0.00")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(capture),
                 "-o", str(tmp_path / "p2")]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "m503.txt: M851 Z: no M851 Z" in err
    assert not (tmp_path / "p2").exists()
    with pytest.raises(InputError, match="capture M503's whole report"):
        MARLIN.probe_travel(capture)


def _config_g(tmp_path: Path, g31: str, m558: str) -> Path:
    """tests/data's config.g (and its config-override.g) with its G31 and M558 lines replaced."""
    for name in ("config.g", "config-override.g"):
        shutil.copy(DATA / "rrf" / name, tmp_path / name)
    path = tmp_path / "config.g"
    text = re.sub(r"^G31 .*$", g31, path.read_text(), flags=re.MULTILINE)
    path.write_text(re.sub(r"^M558 .*$", m558, text, flags=re.MULTILINE))
    return path


def test_an_rrf_program_travels_at_the_dive_height_above_g31_z(tmp_path):
    config = _config_g(tmp_path, "G31 P500 X0 Y25 Z16.695", 'M558 P5 C"zprobe.in" H8 F120 T6000')
    program = _planned(tmp_path, _imported(tmp_path, config), config)
    assert set(_heights(program)) == {24.695}  # 16.695 + 8, written to the micrometre
    assert "G31 Z + M558 H8 (line 14 of" in program


@pytest.mark.parametrize(("m558", "height"), [
    ('M558 P5 C"zprobe.in" H1 F120', 16.695 + PROBE_CLEARANCE),  # a dive under 2 mm: the margin instead
    ('M558 P5 C"zprobe.in" H5:2 F120', 16.695 + 5.0),  # RRF 3.5.1's two dive heights: the first
    ('M558 K1 P5 C"zprobe2.in" H30 F120', 16.695 + 5.0),  # another probe's: RRF's default dive of probe 0
])
def test_rrf_dive_heights(tmp_path, m558, height):
    travel = RRF_FIRMWARE.probe_travel(_config_g(tmp_path, "G31 P500 X0 Y25 Z16.695", m558))
    assert travel.height == pytest.approx(height, abs=1e-9)
    assert travel.height >= 16.695 + MIN_TRAVEL_MARGIN


def test_an_rrf_dive_height_rrf_computes_is_refused_for_the_program_alone(tmp_path):
    config = _config_g(tmp_path, "G31 P500 X0 Y25 Z16.695", 'M558 P5 C"zprobe.in" H{global.dive} F120')
    assert RRF_FIRMWARE.read_config(config).radius == 134.5  # the configuration reads as before
    with pytest.raises(InputError, match=r"config.g: line 14, M558 H: the dive height is not a number"):
        RRF_FIRMWARE.probe_travel(config)
