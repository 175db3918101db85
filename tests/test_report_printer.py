"""``report CAL --measurements probe.csv distances.csv --controller printer.cfg``: a printer's residuals.

A printer's measurement files are of commanded positions: the report turns them into the readings the
firmware commanded (as ``identify`` does) and shows each file's residuals before and after, which
must agree with what the calibration file recorded (issue 39, item 6).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli import main
from deltacal.io import load_calibration

KOSSEL = MODELS / "kossel.toml"
RECOMPUTED = re.compile(r"Recomputed from ([^<]*)")


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """A printer planned, simulated (seed 3) and identified from its probe heights and distances."""
    folder = tmp_path_factory.mktemp("report_printer")
    cfg = kossel_printer_cfg(folder / "printer.cfg")
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(cfg), "-o", str(folder / "plan")]) == 0
    plan = folder / "plan"
    assert main(["simulate", str(KOSSEL), str(plan / "probe.csv"), str(plan / "distances.csv"),
                 "--controller", str(cfg), "--perturb", "3", "--seed", "5", "-o", str(folder / "probe.csv"),
                 "--distances-output", str(folder / "distances.csv")]) == 0
    assert main(["identify", str(KOSSEL), str(folder / "probe.csv"), str(folder / "distances.csv"),
                 "--controller", str(cfg), "-o", str(folder / "cal.toml")]) == 0
    return folder, cfg


def _report(folder: Path, *argv: str) -> int:
    return main(["report", str(folder / "cal.toml"), "--no-view", "-o", str(folder / "report.html"), *argv])


@pytest.mark.parametrize("order", [("probe.csv", "distances.csv"), ("distances.csv", "probe.csv")])
@pytest.mark.long
def test_the_report_shows_each_printer_files_residuals(identified, capsys, order):
    folder, cfg = identified
    capsys.readouterr()
    assert _report(folder, "--measurements", *(str(folder / name) for name in order),
                   "--controller", str(cfg)) == 0
    assert capsys.readouterr().err == ""  # no warning: the residuals are those the calibration recorded
    text = RECOMPUTED.search((folder / "report.html").read_text()).group(1)
    recorded = load_calibration(folder / "cal.toml").residuals_after
    probe, distances = re.findall(r"(\S+\.csv) \((\d+) (probe height|distance)s: RMS ([\d.e-]+) mm before, "
                                  r"([\d.e-]+) mm after\)", text)
    assert probe[0].endswith("probe.csv") and probe[1:3] == ("49", "probe height")  # the heights first
    assert distances[0].endswith("distances.csv") and distances[1:3] == ("40", "distance")
    assert float(probe[4]) == pytest.approx(recorded.height_rms, rel=1e-3)
    assert float(distances[4]) == pytest.approx(recorded.distance_rms, rel=1e-3)
    assert float(probe[3]) > 10 * float(probe[4])  # the uncalibrated printer's heights are far off
    assert "(89 measurements, probe height and distance residuals)" in text


@pytest.mark.long
def test_a_printers_probe_heights_alone(identified, capsys):
    folder, cfg = identified
    assert _report(folder, "--measurements", str(folder / "probe.csv"), "--controller", str(cfg)) == 0
    text = RECOMPUTED.search((folder / "report.html").read_text()).group(1)
    assert "(49 measurements, probe height residuals)" in text


def test_a_printers_measurements_need_the_firmware_settings(identified, capsys):
    folder, cfg = identified
    capsys.readouterr()
    assert _report(folder, "--measurements", str(folder / "probe.csv")) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "give --controller printer.cfg" in err
    other = folder / "other.cfg"
    other.write_text(cfg.read_text().replace("delta_radius: 13", "delta_radius: 10", 1))  # another printer
    assert _report(folder, "--measurements", str(folder / "probe.csv"), "--controller", str(other)) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "delta_radius" in err and "other.cfg" in err
