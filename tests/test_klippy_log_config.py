"""A ``klippy.log``'s own configuration (its dump at each start) gives the probe's offsets of its rows.

Klipper writes the configuration it runs at the top of ``klippy.log`` (``===== Config file =====``,
``configfile.py``): the probe's ``z_offset`` there is the trigger height of every probe after it,
with or without ``--config``; a ``--config`` that disagrees is warned of, naming both values
(issue 40, item 13).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import kossel_printer_cfg

from deltacal.cli import main
from deltacal.exceptions import InputWarning
from deltacal.printer.files.measurements import read_probe_heights
from deltacal.printer.firmware.klipper.log import ProbeOffsets, read_probe_log


def _start(z_offset: float, x_offset: float = 0.0) -> str:
    """Klipper's start of a log: its banner, then the configuration it runs, as configfile.py writes it."""
    return ("Start printer at Mon Aug 10 09:00:00 2026 (1786352400.0 8.1)\n===== Config file =====\n"
            "[printer]\nkinematics = delta\ndelta_radius = 134.4\n\n"
            f"[probe]\npin = ^PA4\nx_offset = {x_offset}\nz_offset = {z_offset}\nsamples = 1\n\n"
            "[delta_calibrate]\nradius = 100\n=======================\n")


PROBES = "probe at 0.000,0.000 is z=1.612500\nprobe at 50.000,0.000 is z=1.587500\n"


def _imported(tmp_path: Path, log: str, *config: str) -> tuple[int, str, str]:
    (tmp_path / "klippy.log").write_text(log)
    code = main(["import", str(tmp_path / "klippy.log"), *config, "-o", str(tmp_path / "probe.csv")])
    return code, str(tmp_path / "probe.csv"), str(tmp_path / "printer.cfg")


def test_the_logs_own_z_offset_is_each_rows_trigger_height(tmp_path, capsys):
    code, probe, _ = _imported(tmp_path, _start(1.5) + PROBES)
    assert code == 0
    assert read_probe_heights(probe).heights.tolist() == [1.5, 1.5]
    out = capsys.readouterr()
    assert "trigger height 1.5 mm ([probe] z_offset of the log's own configuration (line 2))" in out.out
    assert out.err == ""


def test_a_config_that_disagrees_is_warned_of_naming_both_values(tmp_path, capsys):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg", probe_z_offset=1.2)
    code, probe, _ = _imported(tmp_path, _start(1.5) + PROBES, "--config", str(cfg))
    assert code == 0
    assert read_probe_heights(probe).heights.tolist() == [1.5, 1.5]  # the one the printer probed with
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert ("klippy.log: line 2: the log's own configuration (Klipper's dump at its start) has [probe] "
            f"z_offset = 1.5 where {cfg} has 1.2: the log's is taken") in err
    kossel_printer_cfg(cfg, probe_z_offset=1.5)
    assert _imported(tmp_path, _start(1.5) + PROBES, "--config", str(cfg))[0] == 0
    assert capsys.readouterr().err == ""  # the same values: nothing to say


def test_each_start_gives_the_rows_after_it_their_trigger_height(tmp_path):
    (tmp_path / "klippy.log").write_text(_start(1.5) + PROBES + _start(1.75) + PROBES)
    log = read_probe_log(tmp_path / "klippy.log")
    assert log.trigger_height.tolist() == [1.5, 1.5, 1.75, 1.75]
    assert log.lines.tolist() == [16, 17, 33, 34]


def test_a_2026_probe_line_is_read_with_the_logs_own_offsets(tmp_path):
    line = "probe: at 10.000,0.000 bed will contact at z=0.112500\n"  # the probe's position, offsets applied
    (tmp_path / "klippy.log").write_text(_start(1.5, x_offset=-10.0) + line)
    log = read_probe_log(tmp_path / "klippy.log")
    assert log.commanded.tolist() == [[20.0, 0.0, 1.6125]] and log.trigger_height.tolist() == [1.5]
    with pytest.warns(InputWarning, match=r"x_offset = -10, z_offset = 1.5 where printer.cfg has 0, 1.2"):
        log = read_probe_log(tmp_path / "klippy.log", offsets=ProbeOffsets(0.0, 0.0, 1.2),
                             offsets_source="printer.cfg")
    assert log.commanded.tolist() == [[20.0, 0.0, 1.6125]]
