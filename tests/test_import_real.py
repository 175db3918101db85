"""``deltacal import`` on real delta printers' ``printer.cfg`` files, as found in public repositories.

Each file in ``tests/data/klipper/real/`` names its source in its header (kept unchanged where the
source's licence allows, else written in its shape with its numbers). Each was copied without the
files it includes: they are named in one warning, and the configuration imports whenever the keys
of Klipper's delta kinematics are in it; one that lacks a key is refused in one line.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from deltacal.cli.main import main
from deltacal.exceptions import InputWarning
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import read_printed_distances, read_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import klipper_from_config, read_klipper_config
from deltacal.printer.firmware.klipper.model import KlipperController

REAL = Path(__file__).resolve().parent / "data" / "klipper" / "real"

#: Complete configurations: file -> the includes missing beside it, and the saved heights and distances.
COMPLETE = {
    "flsun-q5-razorcopter.cfg": (("fluidd.cfg",), 7, 12),
    "flsun-sr-official.cfg": (("backend.cfg", "timelapse.cfg"), 0, 0),
    "flsun-sr-guilouz.cfg": (("macros.cfg",), 0, 0),
    "flsun-t1-mnemonic3d.cfg": (("timelapse.cfg",), 7, 0),
    "flsun-qqs-pro-susisstrolch.cfg": (("shell_command.cfg", "tmc2209-stepper.cfg", "Macros.cfg"), 7, 0),
    "flsun-v400-official.cfg": (("backend.cfg", "timelapse.cfg"), 0, 0),
    "flsun-v400-fzechert.cfg": (("macros.cfg", "timelapse.cfg"), 7, 0),
    "flsun-v400-phnxdrgn536.cfg": (("macros.cfg", "timelapse.cfg", "neopixels.cfg"), 7, 12),
    "flsun-v400-aieie78.cfg": (("macros.cfg", "shutdown.cfg", "config_backup.cfg", "timelapse.cfg",
                                "moonraker_obico_macros.cfg"), 7, 12),
    "velleman-k8800-susisstrolch.cfg": (("kiauh_macros.cfg",), 0, 0),
}


def test_every_real_file_is_listed():
    listed = set(COMPLETE) | {"flsun-q5-razorcopter-incomplete.cfg"}
    # the V400 A's and B's saved runs: test_real_printer, test_where_it_holds; the rotary Delta printers':
    # test_klipper_rotary_real
    found = {p.name for p in REAL.glob("*.cfg")
             if "-run" not in p.name and "-heights-" not in p.name and not p.name.startswith("rotary-")}
    assert found == listed


@pytest.mark.parametrize("name", sorted(COMPLETE))
def test_a_real_configuration_imports_and_commands_the_nozzle_exactly(tmp_path, capsys, name):
    missing, heights, distances = COMPLETE[name]
    out = tmp_path / "out"
    assert main(["import", str(REAL / name), "-o", str(out)]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "not found, skipped" in line]
    assert len(warned) == 1
    for include in missing:
        assert f" {include} (line " in warned[0]
    # the saved measurements come out, one row each, or no file
    probe, pairs = out / "probe.csv", out / "distances.csv"
    assert (len(read_probe_heights(probe).commanded) if probe.exists() else 0) == heights
    assert (len(read_printed_distances(pairs).distance) if pairs.exists() else 0) == distances
    with warnings.catch_warnings():  # the missing includes, said above
        warnings.simplefilter("ignore", InputWarning)
        config = read_klipper_config(REAL / name)
    klipper = klipper_from_config(config)
    if heights:  # probe.csv's commanded positions are the saved steps through printer.cfg (saved to 1e-3)
        saved = config.sections["delta_calibrate"]
        steps = [[float(v) for v in saved[f"height{i}_pos"].split(",")] for i in range(heights)]
        assert np.max(np.abs(klipper.steps(read_probe_heights(probe).commanded) - steps)) < 1e-6
    # the robot file's nominal printer, commanded through printer.cfg, puts the nozzle where commanded
    printer = load_printer(out / "printer.toml")
    ws = printer.workspace
    assert ws is not None and ws.radius > 0.0 and ws.height > 0.0
    rng = np.random.default_rng(5)
    r, a = ws.radius * np.sqrt(rng.random(200)), rng.uniform(0.0, 2.0 * np.pi, 200)
    targets = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, ws.height, 200)])
    readings = KlipperController(klipper, printer.step_distance).inverse(targets)
    nozzle = exact.forward(printer.geometry(), readings).point(printer.tool)
    assert np.max(np.abs(nozzle - targets)) < 1e-9


def test_a_real_incomplete_configuration_is_refused_in_one_line(tmp_path, capsys):
    """The Q5's file before calibration: ``delta_radius`` commented out, ``fluidd.cfg`` not beside it."""
    out = tmp_path / "out"
    assert main(["import", str(REAL / "flsun-q5-razorcopter-incomplete.cfg"), "-o", str(out)]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if "not found, skipped" not in line]
    assert len(err) == 1
    assert "section [printer]: missing required key 'delta_radius'" in err[0]
    assert "it may be in the missing include fluidd.cfg" in err[0]
    assert not out.exists()  # nothing written, no folder left behind
