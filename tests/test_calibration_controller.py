"""A printer's calibration records the controller it was identified with, and every route reads it.

``identify`` writes ``[controller]`` (firmware, source, digest) and ``[controller.values]``; ``report``
speaks the recorded firmware without ``--controller``; another firmware's configuration is refused;
a configuration whose values changed is said by its keys; a calibration written before loads.
"""

from __future__ import annotations

import hashlib
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from conftest import MODELS, copy_object_plan
from deltacal.cli.main import main
from deltacal.io import load_calibration, save_calibration
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.config_file import read_firmware_config
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

KOSSEL = MODELS / "kossel.toml"


@pytest.fixture(scope="module")
def calibrations(tmp_path_factory, kossel_object_plan) -> dict[str, tuple[Path, Path]]:
    """A Klipper, a Marlin and an RRF calibration of one simulated kossel (seed 46): firmware -> (cal, config)."""
    folder = tmp_path_factory.mktemp("calibration_controller")
    printer = load_printer(KOSSEL)
    configs = {"klipper": copy_object_plan(kossel_object_plan, folder),
               "marlin": MARLIN.save_config(folder / "m503.gcode", MARLIN.nominal(printer), complete=True),
               "rrf": RRF_FIRMWARE.save_config(folder / "config.g", RRF_FIRMWARE.nominal(printer), complete=True)}
    plan = folder / "plan"
    out = {}
    for name, config in configs.items():
        probe, distances, cal = (folder / f"{name}-{what}" for what in ("probe.csv", "distances.csv", "cal.toml"))
        assert main(["simulate", str(KOSSEL), str(plan / "probe.csv"), str(plan / "distances.csv"),
                     "--controller", str(config), "--firmware", name, "--perturb", "46", "-o", str(probe),
                     "--distances-output", str(distances)]) == 0
        assert main(["identify", str(KOSSEL), str(probe), str(distances), "--controller", str(config),
                     "-o", str(cal)]) == 0
        out[name] = cal, config
    return out


@pytest.mark.parametrize("name", ["klipper", "marlin", "rrf"])
def test_the_calibration_records_its_controller(calibrations, name):
    cal, config = calibrations[name]
    record = load_calibration(cal).controller
    assert record is not None
    read = read_firmware_config(config)
    assert record.firmware == name == read.firmware.name
    assert record.source == str(config)
    assert record.digest == hashlib.sha256(config.read_bytes()).hexdigest()
    assert dict(record.values) == read.firmware.values_read(read.values)
    key = {"klipper": "stepper_a.position_endstop", "marlin": "M666.X", "rrf": "M665.L.a"}[name]
    assert key in record.values
    # written, read and written again: the same file
    again = cal.with_name(f"{name}-again.toml")
    save_calibration(load_calibration(cal), again)
    assert again.read_text() == cal.read_text()
    assert tomllib.loads(cal.read_text())["controller"]["values"][key] == record.values[key]
