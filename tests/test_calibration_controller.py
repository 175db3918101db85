"""A printer's calibration records the controller it was identified with, and every route reads it.

``identify`` writes ``[controller]`` (firmware, source, digest) and ``[controller.values]``; ``report``
speaks the recorded firmware without ``--controller``; another firmware's configuration is refused;
a configuration whose values changed is said by its keys; a calibration written before loads.
"""

from __future__ import annotations

import hashlib
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, copy_object_plan

from deltacal.cli.main import main
from deltacal.io import load_calibration, save_calibration
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.files.same_printer import ENDSTOP_MM
from deltacal.printer.firmware.base import classical_values
from deltacal.printer.firmware.config_file import read_firmware_config
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

KOSSEL = MODELS / "kossel.toml"


@pytest.fixture(scope="module")
def calibrations(tmp_path_factory, kossel_object_plan) -> dict[str, tuple[Path, Path]]:
    """A Klipper, a Marlin and an RRF calibration of one simulated kossel (seed 46).

    Returns: firmware -> (calibration, configuration)."""
    folder = tmp_path_factory.mktemp("calibration_controller")
    printer = load_printer(KOSSEL)
    configs = {"klipper": copy_object_plan(kossel_object_plan, folder),
               "marlin": MARLIN.save_config(folder / "m503.gcode", MARLIN.nominal(printer), complete=True),
               "rrf": RRF_FIRMWARE.save_config(folder / "config.g", RRF_FIRMWARE.nominal(printer),
                                               complete=True)}
    plan = folder / "plan"
    out = {}
    for name, config in configs.items():
        probe, distances, cal = (folder / f"{name}-{what}"
                                 for what in ("probe.csv", "distances.csv", "cal.toml"))
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


@pytest.mark.long  # a report: 2.2 s of CPU each
@pytest.mark.parametrize("name", ["marlin", "rrf"])
def test_report_speaks_the_recorded_firmware_without_controller(calibrations, name, tmp_path, capsys):
    cal, _ = calibrations[name]
    assert main(["report", str(cal), "-o", str(tmp_path / "r.html"), "--no-view"]) == 0
    page = (tmp_path / "r.html").read_text()
    text = re.sub(r"<[^>]+>", " ", page)
    assert "printer.cfg" not in text and "stepper_a" not in text and "Klipper" not in text
    assert "M666" in text


def _refused(capsys, *words: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, err
    return err


def test_another_firmwares_controller_is_refused(calibrations, tmp_path, capsys):
    cal, _ = calibrations["klipper"]
    _, m503 = calibrations["marlin"]
    np.savetxt(tmp_path / "t.csv", [[0.0, 0.0, 5.0]], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    out = tmp_path / "c.csv"
    assert main(["compensate", str(cal), str(tmp_path / "t.csv"), "--controller", str(m503),
                 "-o", str(out)]) == 1
    _refused(capsys, "Klipper", "Marlin", str(cal))
    assert not out.exists()
    assert main(["report", str(cal), "--controller", str(m503), "-o", str(tmp_path / "r.html")]) == 1
    _refused(capsys, "Klipper", "Marlin")
    assert not (tmp_path / "r.html").exists()
    assert main(["export", str(cal), "--controller", "marlin", "--keep-rotation-distance",
                 "-o", str(tmp_path / "v.gcode")]) == 1
    _refused(capsys, "Klipper", "Marlin")
    assert not (tmp_path / "v.gcode").exists()
    assert main(["report", str(cal), "--firmware", "rrf", "-o", str(tmp_path / "r.html")]) == 1
    _refused(capsys, "Klipper", "RepRapFirmware")


def test_changed_values_are_named(calibrations, tmp_path, capsys):
    cal, m503 = calibrations["marlin"]
    text = m503.read_text()
    assert re.search(r"^M666 X0(\.0+)? ", text, re.M), text
    changed = tmp_path / "m503.gcode"
    changed.write_text(re.sub(r"^M666 X0(\.0+)? ", "M666 X-0.3 ", text, flags=re.M))
    np.savetxt(tmp_path / "t.csv", [[0.0, 0.0, 5.0]], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    for config, said in ((m503, False), (changed, True)):
        out = tmp_path / f"c-{said}.csv"
        assert main(["compensate", str(cal), str(tmp_path / "t.csv"), "--controller", str(config),
                     "-o", str(out)]) == 0
        lines = [line for line in capsys.readouterr().out.splitlines() if "values changed" in line]
        assert out.exists()
        if said:
            assert len(lines) == 1 and "M666.X 0 -> -0.3" in lines[0], lines
            assert "measure it again" in lines[0] and "rods, probe, effector" in lines[0]
            assert "M666.Y" not in lines[0]
        else:
            assert lines == []


def test_values_beyond_a_build_from_the_recorded_ones_are_refused_naming_the_key(calibrations, tmp_path,
                                                                                  capsys):
    # an endstop within the same-printer bound of the calibration's geometry (checked before, as ever)
    # but beyond it from the value the calibration was identified with: refused by the record alone
    cal, cfg = calibrations["klipper"]
    recorded = load_calibration(cal).controller
    assert recorded is not None
    config = read_firmware_config(cfg)
    geometry = classical_values(KLIPPER.start(load_calibration(cal).geometry))[2][0]
    d = geometry - classical_values(config.values)[2][0]
    assert abs(d) > 0.01  # the identified endstop moved: a window of |d| / 2 either side (0.027 mm)
    value = recorded.values["stepper_a.position_endstop"] + np.sign(d) * (ENDSTOP_MM + abs(d) / 2.0)
    far = tmp_path / "printer.cfg"
    far.write_text(re.sub(r"^(\[stepper_a\][^\[]*?position_endstop:\s*)\S+", rf"\g<1>{value:.4f}",
                          cfg.read_text(), count=1, flags=re.M))
    assert read_firmware_config(far).values.position_endstop[0] == pytest.approx(value, abs=1e-4)
    np.savetxt(tmp_path / "t.csv", [[0.0, 0.0, 5.0]], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    out = tmp_path / "c.csv"
    assert main(["compensate", str(cal), str(tmp_path / "t.csv"), "--controller", str(far),
                 "-o", str(out)]) == 1
    _refused(capsys, "position_endstop (tower A)", "recorded controller", "different printers")
    assert not out.exists()


def test_an_older_calibration_loads_and_says_none_is_recorded(calibrations, tmp_path, capsys):
    cal, cfg = calibrations["klipper"]
    text = cal.read_text()
    old = tmp_path / "old.toml"
    old.write_text(text[:text.index("\n[controller]")] + "\n")
    assert "[controller" not in old.read_text()
    calibration = load_calibration(old)
    assert calibration.controller is None
    assert calibration.geometry.name == load_calibration(cal).geometry.name
    np.savetxt(tmp_path / "t.csv", [[0.0, 0.0, 5.0]], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    assert main(["compensate", str(old), str(tmp_path / "t.csv"), "--controller", str(cfg),
                 "-o", str(tmp_path / "c.csv")]) == 0
    out = capsys.readouterr().out
    assert out.count("records no controller") == 1
