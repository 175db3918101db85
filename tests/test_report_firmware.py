"""A printer's report fits and names its own firmware's values (issue 37): Marlin's M665/M666 lines, RRF's
config.g and config-override.g, never Klipper's printer.cfg; a rotary Delta's report takes no firmware."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

from deltacal import Tolerances
from deltacal.cli import main
from deltacal.io import save_geometry
from deltacal.io.calibration import calibration_from_result, load_calibration, save_calibration
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import firmware_named
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
from deltacal.report import accuracy_map, controller_routes

KOSSEL = MODELS / "kossel.toml"


@pytest.fixture(scope="module")
def printer(tmp_path_factory):
    """A kit printer identified from its probe heights, its calibration file and true geometry."""
    folder = tmp_path_factory.mktemp("report_firmware")
    kossel = load_printer(KOSSEL)
    nominal = kossel.geometry()
    rng = np.random.default_rng(2406)
    truth = nominal.perturbed(Tolerances.printer_kit(), rng)
    u = np.linspace(-115.0, 115.0, 7)
    bed = np.stack(np.meshgrid(u, u), axis=-1).reshape(-1, 2)
    bed = bed[np.hypot(*bed.T) <= 115.0 + 1e-9]
    probe = exact.inverse(truth, np.column_stack([bed, np.zeros(len(bed))]))
    result = identify_printer(nominal, PrinterMeasurements(probe + rng.normal(size=probe.shape) * 0.01))
    save_calibration(calibration_from_result(result), folder / "cal.toml")
    save_geometry(truth, folder / "truth.toml")
    return folder, kossel, truth


@pytest.mark.slow
@pytest.mark.parametrize("name, words", [("marlin", ("Marlin", "--controller marlin", "M665, M666 and M92",
                                                     "--controller m503.txt")),
                                         ("rrf", ("RepRapFirmware", "--controller rrf", "config-override.g",
                                                  "--controller config.g"))])
@pytest.mark.long
def test_a_marlin_or_rrf_printers_report_fits_and_names_its_own_values(printer, name, words, capsys):
    folder, kossel, truth = printer
    out = folder / f"{name}.html"
    assert main(["report", str(folder / "cal.toml"), "-o", str(out), "--firmware", name, "--truth",
                 str(folder / "truth.toml"), "--robot", str(KOSSEL), "--no-view"]) == 0
    text = out.read_text(encoding="utf-8")
    for phrase in (f"controller is its firmware ({words[0]})", *words, "firmware values fitted"):
        assert phrase in text, phrase
    assert "printer.cfg" not in text and "Klipper" not in text and "--controller klipper" not in text
    # issue 39: the owner's part first, each tower's endstop in mm and lean in deg in the firmware's words
    # (Marlin's and RRF's towers are X, Y, Z; their endstops M666), before any parameter name
    owner = text.index("tower X: endstop")
    assert owner < text.index("<h2>Base parameters") and owner < text.index("b11x")
    assert "M666 X" in text and "tower Z: leans outwards" in text and " deg" in text
    # and where the calibration holds, in the owner's part too (issue 38)
    where = text.index("where it holds: the nozzle is known within")
    assert owner < where < text.index("<h2>Base parameters")
    # which of the firmware's values the measurements determine, in its words (M666 X, M92 X), not Klipper's
    values = text[text.index('<p id="holds-values">'):]
    values = values[:values.index("</p>")]
    assert "M666 X" in values and "M92 X" in values and "position_endstop" not in values, values
    # the fitted route is the firmware's own fit (its names held), and it holds a part of the error
    firmware = firmware_named(name)
    calibration = load_calibration(folder / "cal.toml")
    amap = accuracy_map(calibration, kossel.workspace, None, truth, 11)
    routes = controller_routes(calibration, amap, truth, firmware)
    nominal, fitted = routes.routes
    assert routes.firmware is firmware and fitted.name == name
    assert fitted.true_max_error < 0.5 * nominal.true_max_error
    klipper = controller_routes(calibration, amap, truth)
    assert klipper.firmware is firmware_named("klipper") and klipper.routes[1].name == "klipper"
    assert set(fitted.held).isdisjoint(klipper.routes[1].held)  # the firmware's own names, not Klipper's


def test_a_rotary_deltas_report_takes_no_firmware(tmp_path, capsys):
    from deltacal.io import load_nominal

    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), geometry)
    assert main(["report", str(geometry), "-o", str(tmp_path / "r.html"), "--firmware", "marlin"]) == 2
    err = capsys.readouterr().err
    expected = f"--firmware applies to a printer's calibration; {geometry} is a rotary Delta's"
    assert err.strip().endswith(expected)
    assert not (tmp_path / "r.html").exists()
