"""A printer.cfg that includes deltacal's live correction (issue 49 item 5): measured with it off, never
corrected offline.

``export --live`` writes ``deltacal_geometry.cfg`` (its ``[deltacal_geometry]`` section), which the
owner includes in printer.cfg: that printer corrects every move itself. ``compensate`` refuses to
correct a program for it (corrected twice), ``identify`` refuses measurements made through it unless
told they were made with it off (``--live-correction-off``), and ``plan``'s probe program turns it
off while it probes. An include of that file that does not exist here (a configuration copied off
the printer) is taken as the section by its name.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli.main import main
from deltacal.io import save_geometry
from deltacal.printer.files.measurements import write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.live.export import SECTION_FILE

KOSSEL = MODELS / "kossel.toml"
#: A stub of export --live's section file (its first keys: only its section matters here).
SECTION = ("# deltacal's live correction\n[deltacal_geometry]\nformat: deltacal-klipper-live-2\n"
           "calibration: cal.toml\n")


def _printer(folder: Path, include: str = f"[include {SECTION_FILE}]", section: bool = True) -> Path:
    """printer.cfg of the Kossel with ``include`` added, and the section's file beside it (``section``)."""
    cfg = kossel_printer_cfg(folder / "printer.cfg")
    cfg.write_text(cfg.read_text() + f"\n{include}\n")
    if section:
        (folder / SECTION_FILE).write_text(SECTION)
    return cfg


@pytest.mark.filterwarnings("ignore:.*include file not found")
@pytest.mark.parametrize("include, section, where", [
    ("[include deltacal_geometry.cfg]", True, "[deltacal_geometry] from {folder}/deltacal_geometry.cfg"),
    ("[include deltacal_*.cfg]", True, "[deltacal_geometry] from {folder}/deltacal_geometry.cfg"),
    ("[include deltacal_geometry.cfg]", False,
     "[include deltacal_geometry.cfg] at line 41 of {folder}/printer.cfg: not found here, taken as the "
     "section's file by its name"),
    ("#[include deltacal_geometry.cfg]", True, ""),
    ("[include other.cfg]", False, ""),
])
def test_the_reader_finds_the_live_section_where_klipper_would_load_it(tmp_path, include, section, where):
    cfg = _printer(tmp_path, include, section)
    assert read_klipper_config(cfg).live == where.format(folder=tmp_path)
    live = KLIPPER.live_correction(cfg)
    assert (live is None) == (not where)
    if live is not None:
        assert (live.off, live.on) == ("DELTACAL_GEOMETRY ENABLE=0", "DELTACAL_GEOMETRY ENABLE=1")


@pytest.mark.filterwarnings("ignore:.*include file not found")
@pytest.mark.parametrize("section", [True, False])
@pytest.mark.parametrize("targets", ["p.gcode", "t.csv"])
def test_compensate_refuses_a_printer_that_corrects_every_move_itself(tmp_path, capsys, section, targets):
    cfg = _printer(tmp_path, section=section)
    cal, out = tmp_path / "cal.toml", tmp_path / ("o" + Path(targets).suffix)
    save_geometry(load_printer(KOSSEL).geometry(), cal)
    (tmp_path / "p.gcode").write_text("G28\nG1 X0 Y0 Z10\n")
    (tmp_path / "t.csv").write_text("x_mm,y_mm,z_mm\n0,0,10\n")
    code = main(["compensate", str(cal), str(tmp_path / targets), "--controller", str(cfg), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert f"error: {cfg}: includes deltacal's live correction (" in err
    assert "every move is already corrected; print the program as sliced, or remove the [include " \
           "deltacal_geometry.cfg] to correct offline; nothing written" in err


def _probe(folder: Path) -> Path:
    """A probe file of the Kossel's nominal heights at a few points (what identify reads first)."""
    probe = folder / "probe.csv"
    xy = np.array([[0.0, 0.0], [0.0, -100.0], [100.0, 0.0], [-70.0, 70.0], [50.0, 50.0]])
    write_probe_heights(probe, xy, np.zeros(len(xy)))
    return probe


def test_identify_refuses_measurements_made_through_the_live_correction(tmp_path, capsys):
    cfg, probe, out = _printer(tmp_path), _probe(tmp_path), tmp_path / "c.toml"
    code = main(["identify", str(KOSSEL), str(probe), "--controller", str(cfg), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and len(err.strip().splitlines()) == 1 and not out.exists()
    assert f"error: {cfg}: includes deltacal's live correction ([deltacal_geometry] from " in err
    assert "measure the corrected printer, and the new calibration would undo the old; measure with it off " \
           "(DELTACAL_GEOMETRY ENABLE=0 before probing and printing the object, or remove the [include " \
           "deltacal_geometry.cfg]), then give --live-correction-off; nothing written" in err


def test_identify_told_the_correction_was_off_identifies_and_says_so(tmp_path, capsys):
    cfg, probe, out = _printer(tmp_path), _probe(tmp_path), tmp_path / "c.toml"
    assert main(["identify", str(KOSSEL), str(probe), "--controller", str(cfg), "-o", str(out),
                 "--live-correction-off"]) == 0
    said = capsys.readouterr().out.splitlines()
    assert said[0] == (f"{cfg} includes deltacal's live correction ([deltacal_geometry] from {tmp_path}/"
                       "deltacal_geometry.cfg): the measurements are taken as made with it off "
                       "(--live-correction-off)")
    assert out.exists()
    rotary = main(["identify", str(MODELS / "flexpicker.toml"), str(probe), "-o", str(tmp_path / "r.toml"),
                   "--live-correction-off"])
    assert rotary == 2 and "--live-correction-off applies to a printer's measurements" in \
        capsys.readouterr().err


def test_plans_probe_program_turns_the_live_correction_off_while_probing(tmp_path, capsys):
    cfg, plan = _printer(tmp_path), tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(plan),
                 "--probe-grid", "3", "--distances", "1"]) == 0
    said = capsys.readouterr().out
    commands = [line.split(";")[0].strip() for line in (plan / "probe.gcode").read_text().splitlines()]
    commands = [c for c in commands if c]
    assert commands[0] == "DELTACAL_GEOMETRY ENABLE=0" and commands[1] == "G28"
    assert commands[-1] == "DELTACAL_GEOMETRY ENABLE=1" and commands.count("PROBE") == 5
    line = next(x for x in said.splitlines() if "live correction" in x)
    assert line == (f"{cfg} includes deltacal's live correction ([deltacal_geometry] from {tmp_path}/"
                    "deltacal_geometry.cfg): probe.gcode turns it off first (DELTACAL_GEOMETRY ENABLE=0) and "
                    "on again at its end (DELTACAL_GEOMETRY ENABLE=1): the probe heights measure the printer "
                    "itself")
    plain = kossel_printer_cfg(tmp_path / "plain.cfg")  # without the include: the program as before
    program = KLIPPER.probe_program(np.zeros((1, 2)), clearance=5.0, live=KLIPPER.live_correction(plain))
    assert "DELTACAL_GEOMETRY" not in program and "G28 ; home\nG90" in program



def test_a_printer_without_a_probe_is_told_to_turn_it_off_while_measuring_by_hand(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=None)
    cfg.write_text(cfg.read_text() + "\n[include deltacal_geometry.cfg]\n")
    (tmp_path / SECTION_FILE).write_text(SECTION)
    plan = tmp_path / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(plan),
                 "--probe-grid", "3", "--distances", "1"]) == 0
    said = capsys.readouterr().out
    assert not (plan / "probe.gcode").exists()
    line = next(x for x in said.splitlines() if "live correction" in x)
    assert line.endswith("turn it off (DELTACAL_GEOMETRY ENABLE=0) before measuring the heights and "
                         "printing the object, and on again after (DELTACAL_GEOMETRY ENABLE=1): they measure "
                         "the printer itself"), line
