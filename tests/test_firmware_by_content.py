"""Issue 47, items 2 and 4: firmware files told apart by the commands they run, and refusals that name a file.

A Duet ``config.g`` whose comments say "; Delta Settings" or "; endstop adjustments" was taken for a
Marlin ``M503`` capture (Marlin's report prints "echo:; Delta settings:" headings), so that
``export --controller rrf --config config.g`` refused it as Marlin's. Each test failed on the code
before the change.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from deltacal.cli import main
from deltacal.controller_record import ControllerRecord
from deltacal.exceptions import UsageError
from deltacal.io import load_calibration
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import config_firmware, firmwares, input_firmware
from deltacal.wings.printer import PrinterWing
from deltacal.wings.requests import ReportRequest

DATA = Path(__file__).resolve().parent / "data"
#: Duet3D's Mini Kossel config.g with "; Delta Settings" and "; endstop adjustments" comments (its header).
DELTA_SETTINGS = DATA / "rrf" / "duet3d-minikossel-delta-settings" / "config.g"
MARLIN_110 = DATA / "marlin" / "marlin-1.1.0-m503.txt"


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    return err


def expected_firmware(path: Path) -> str | None:
    """Whose file a test file is, by where it is kept and its name (never by its content)."""
    parts = path.relative_to(DATA).parts
    if path.suffix == ".cfg":
        return "klipper"
    if "rrf" in parts:
        return "rrf" if path.name in ("config.g", "config-override.g") else None  # homedelta.g, bed.g...
    if "marlin" in parts or path.name.startswith("marlin"):
        return "marlin"
    return None  # a slicer's G-code


def test_every_firmware_file_of_the_tests_is_told_by_its_content():
    """Every real configuration and capture under tests/data, comments as found: one firmware claims it."""
    files = sorted(p for p in DATA.rglob("*") if p.is_file())
    rrf = [p for p in files if expected_firmware(p) == "rrf"]
    marlin = [p for p in files if expected_firmware(p) == "marlin"]
    assert len(rrf) >= 9 and len(marlin) >= 6  # config.g, config-override.g; captures, a log, Configuration.h
    claims = {p: [f.name for f in firmwares() if f.is_config(p)] for p in files}
    wrong = {p.relative_to(DATA).as_posix(): claimed for p, claimed in claims.items()
             if claimed != [name for name in [expected_firmware(p)] if name is not None]}
    assert wrong == {}  # before: rrf/config.g ("; endstop adjustments, tilt") claimed by RRF and Marlin


def test_an_rrf_config_g_with_delta_settings_comments_is_rrfs():
    assert [f.name for f in firmwares() if f.is_config(DELTA_SETTINGS)] == ["rrf"]
    text = DELTA_SETTINGS.read_text()
    assert "; Delta Settings\nM665" in text and "; endstop adjustments" in text


def test_an_rrf_config_g_with_delta_settings_comments_exports(tmp_path, capsys):
    """deltacal export CAL --controller rrf --config config.g: refused before as "Marlin's configuration"."""
    assert main(["import", str(DELTA_SETTINGS), "-o", str(tmp_path / "imported")]) == 0
    cal = tmp_path / "cal.toml"
    save_geometry(load_printer(tmp_path / "imported" / "printer.toml").geometry(), cal)
    capsys.readouterr()
    out = tmp_path / "values.g"
    assert main(["export", str(cal), "--controller", "rrf", "--config", str(DELTA_SETTINGS),
                 "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "Marlin" not in err
    written = out.read_text()
    assert re.search(r"^M665 L215\.0+:215\.0+:215\.0+ R105\.60+ H240\.0+ B85\.0+ ", written, re.MULTILINE)
    assert "the M665 line of config.g (line 30)" in written  # its own line, below the "; Delta Settings" one


def test_a_marlin_capture_without_echo_saved_as_g_is_marlins(tmp_path):
    """Marlin 1.1.0's report with its echo: prefixes left out by the host, in a *.g file: Marlin's.

    It runs M851 (Marlin's report) and none of RRF's commands; before, a *.g with an M665 line was
    RepRapFirmware's whatever else it ran, and the capture was read as RRF's config.g.
    """
    capture = tmp_path / "settings.g"
    capture.write_text(MARLIN_110.read_text().replace("echo:", ""))
    assert [f.name for f in firmwares() if f.is_config(capture)] == ["marlin"]
    assert config_firmware(capture).name == "marlin"
    assert input_firmware(capture, capture.read_text()) == (config_firmware(capture), False)
    assert config_firmware(MARLIN_110).name == "marlin"


def test_comments_never_make_a_file_marlins(tmp_path):
    """Marlin's headings and commands in an RRF config.g's comments, anywhere in a line: still RRF's."""
    config = tmp_path / "config.g"
    config.write_text("; Delta settings: L=diagonal rod\n; Endstop adjustment (mm):\n"
                      "M665 L215 R105.6 B85 H240 ; echo: M851 Z-1 M211 S1\n"
                      "M666 X0 Y0 Z0 ; Steps per unit: M503\n"
                      "; M851 Z-4.8\n;M211 S1\n")
    assert [f.name for f in firmwares() if f.is_config(config)] == ["rrf"]


# ------------------------------------------------------------------ item 4: refusals that name a file
KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"


@pytest.fixture
def printer_calibration(tmp_path) -> Path:
    """A printer's calibration: the nominal kossel's geometry (no controller recorded)."""
    path = tmp_path / "cal.toml"
    save_geometry(load_printer(KOSSEL).geometry(), path)
    return path


def test_report_without_controller_names_the_measurements(printer_calibration, tmp_path, capsys):
    """Before: "cal.toml: ... give --controller printer.cfg|config.g|M503.txt": no measurements file named."""
    probe, distances = tmp_path / "probe.csv", tmp_path / "distances.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n")
    distances.write_text("ball1,ball2,distance_mm\na,b,10\n")
    assert main(["report", str(printer_calibration), "-o", str(tmp_path / "r.html"), "--measurements",
                 str(probe), str(distances)]) == 2
    err = one_line_error(capsys)
    assert (f": {probe}, {distances}: a printer's measurements are of commanded positions: give --controller "
            "printer.cfg|config.g|m503.txt (the firmware's settings they were made with, for their residuals)"
            ) in err
    assert not (tmp_path / "r.html").exists()


def test_report_without_controller_names_the_recorded_settings(printer_calibration, tmp_path):
    """A calibration that records Marlin's m503.txt: that file is the one to give, and why."""
    record = ControllerRecord("marlin", "/home/owner/m503.txt", "0" * 64, {"M665.L": 250.0})
    calibration = replace(load_calibration(printer_calibration), controller=record)
    probe = tmp_path / "probe.csv"
    request = ReportRequest(printer_calibration, tmp_path / "r.html", measurements=probe)
    with pytest.raises(UsageError) as refused:
        PrinterWing().report_firmware(request, calibration)
    assert str(refused.value) == (
        f"{probe}: a printer's measurements are of commanded positions: give --controller m503.txt (the "
        f"firmware's settings they were made with, for their residuals: {printer_calibration} was identified "
        "with Marlin's /home/owner/m503.txt)")


def test_identify_and_simulate_without_controller_name_their_files(tmp_path, capsys):
    probe = tmp_path / "probe.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n")
    assert main(["identify", str(KOSSEL), str(probe), "-o", str(tmp_path / "c.toml")]) == 2
    err = one_line_error(capsys)  # before: "kossel.toml: ... give --controller printer.cfg|config.g (...)"
    assert f"{probe}: a printer's measurements are of commanded positions" in err
    assert "give --controller printer.cfg|config.g|m503.txt (" in err
    assert main(["simulate", str(KOSSEL), str(probe), "--perturb", "1", "-o", str(tmp_path / "s.csv")]) == 2
    err = one_line_error(capsys)  # before: "kossel.toml: ... --controller printer.cfg (the Klipper ...)"
    assert f"{probe}: a printer's templates are of commanded positions" in err
    assert "give --controller printer.cfg|config.g|m503.txt (" in err and "Klipper" not in err


def test_plan_and_export_refusals_name_the_file_and_every_firmware(printer_calibration, tmp_path, capsys):
    assert main(["plan", str(KOSSEL), "--object", "-o", str(tmp_path / "p")]) == 2
    err = one_line_error(capsys)  # before: "--object needs --controller printer.cfg: ...", no file
    assert f"{KOSSEL}: --object needs --controller printer.cfg|config.g|m503.txt" in err
    assert main(["plan", str(KOSSEL), "-o", str(tmp_path / "p")]) == 2
    assert "use --object --controller printer.cfg|config.g|m503.txt -o DIR" in one_line_error(capsys)
    assert main(["export", str(printer_calibration), "--controller", "offsets", "-o",
                 str(tmp_path / "e")]) == 2
    err = one_line_error(capsys)  # before: "... its firmware's values: --controller klipper"
    assert f"{printer_calibration} is a printer's calibration" in err
    assert err.rstrip().endswith("--controller klipper|rrf|marlin")
