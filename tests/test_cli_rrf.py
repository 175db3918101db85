"""The commands with RepRapFirmware's config.g: plan, simulate, identify, export, compensate."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.rrf.config import load_rrf, rrf_config_text
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.firmware.rrf.fit import values_of
from deltacal.printer.firmware.rrf.model import RRFDelta

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"


def kossel_config_g(path: Path) -> Path:
    """A config.g of the nominal kossel (RRF's values of the perfect printer)."""
    rrf = RRFDelta.from_printer(load_printer(KOSSEL))
    path.write_text(rrf_config_text(rrf, complete=True, title="kossel"))
    return path


@pytest.mark.long
def test_plan_simulate_identify_export_compensate_with_config_g(tmp_path, capsys):
    config = kossel_config_g(tmp_path / "config.g")
    assert (
        main(["plan", str(KOSSEL), "--object", "--controller", str(config), "-o", str(tmp_path / "plan")])
        == 0
    )
    assert "G30 S-1" in (tmp_path / "plan" / "probe.gcode").read_text()
    plan = tmp_path / "plan"
    assert (
        main(
            [
                "simulate",
                str(KOSSEL),
                str(plan / "probe.csv"),
                str(plan / "distances.csv"),
                "--controller",
                str(config),
                "--firmware",
                "rrf",
                "--perturb",
                "7",
                "-o",
                str(tmp_path / "probe.csv"),
                "--distances-output",
                str(tmp_path / "d.csv"),
            ]
        )
        == 0
    )
    cal = tmp_path / "cal.toml"
    assert (
        main(
            [
                "identify",
                str(KOSSEL),
                str(tmp_path / "probe.csv"),
                str(tmp_path / "d.csv"),
                "--controller",
                str(config),
                "-o",
                str(cal),
            ]
        )
        == 0
    )
    out = tmp_path / "CALIBRATED.g"
    capsys.readouterr()
    assert main(["export", str(cal), "--controller", "rrf", "--config", str(config), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "these values: 3-D max" in printed
    assert "what RepRapFirmware's values cannot hold of each error source alone" in printed
    note = printed.split("to apply: ")[1].splitlines()[0]
    # config.g holds M665 and M666 and runs no M501: its own lines, named, are replaced
    assert note.startswith("Replace the M665 line of config.g (line 3), the M666 line of config.g (line 4)")
    assert "config.g runs no M501, so M500 (config-override.g) would be lost" in note
    assert out.read_text().splitlines()[1] == f"; {note}"
    assert note == RRF_FIRMWARE.apply_note_for(config)
    fitted = load_rrf(out)
    assert not np.array_equal(values_of(fitted), values_of(load_rrf(config)))
    assert_allclose(fitted.print_radius, load_rrf(config).print_radius)  # the --config's kept
    program = tmp_path / "part.gcode"
    program.write_text("G28\nG90\nM82\nG92 E0\nG1 X0 Y0 Z10 F3000\nG91\nG1 X40 E2\nG1 Y30 E1.5\nG90\n")
    corrected = tmp_path / "out.gcode"
    assert (
        main(
            [
                "compensate",
                str(cal),
                str(program),
                "--controller",
                str(config),
                "--firmware",
                "rrf",
                "-o",
                str(corrected),
            ]
        )
        == 0
    )
    text = corrected.read_text()
    assert "G91" in text and text.count("\n") > program.read_text().count("\n")


def test_firmware_flag_refused_without_a_printer_or_controller(tmp_path, capsys):
    cal = tmp_path / "cal.toml"
    assert (
        main(["compensate", str(KOSSEL), str(tmp_path / "t.csv"), "--firmware", "rrf", "-o", str(cal)]) != 0
    )
    err = capsys.readouterr().err
    assert "--firmware" in err or "t.csv" in err


def test_an_unrecognised_controller_asks_for_firmware(tmp_path, capsys):
    odd = tmp_path / "settings.txt"
    odd.write_text("M665 L269 R134.4\n")
    probe = tmp_path / "probe.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n")
    assert (
        main(["identify", str(KOSSEL), str(probe), "--controller", str(odd), "-o", str(tmp_path / "c.toml")])
        == 2
    )
    assert "give --firmware klipper|rrf|marlin" in capsys.readouterr().err
    assert (
        main(
            [
                "identify",
                str(KOSSEL),
                str(probe),
                "--controller",
                str(odd),
                "--firmware",
                "rrf",
                "-o",
                str(tmp_path / "c.toml"),
            ]
        )
        != 0
    )
    assert "no M92 X" in capsys.readouterr().err  # read as RRF's: its first problem named
