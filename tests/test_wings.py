"""The commands as library calls (issue 37): a request per command, checked once in the value, the robot
kind's wing found once, a robot file parsed once, a firmware's configuration told and read once."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal import wings
from deltacal.chains import PRISMATIC, REVOLUTE
from deltacal.exceptions import UsageError
from deltacal.io import load_nominal, save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.robot import NominalLinearDelta
from deltacal.wings import (
    CompensateRequest,
    ExportRequest,
    IdentifyRequest,
    PlanRequest,
    ReportRequest,
    SimulateRequest,
)

ROBOT = MODELS / "bai2015.toml"
KOSSEL = MODELS / "kossel.toml"


def test_each_kind_has_its_wing_found_by_the_file_or_the_chain():
    assert wings.wing_for(REVOLUTE) is wings.ROTARY and wings.wing_for(PRISMATIC) is wings.PRINTER
    wing, robot = wings.robot_wing(KOSSEL)
    assert wing is wings.PRINTER and isinstance(robot, NominalLinearDelta)
    assert wings.robot_wing(ROBOT)[0] is wings.ROTARY


def test_a_robot_file_is_parsed_once(monkeypatch):
    import deltacal.io.robot
    import deltacal.io.toml
    import deltacal.printer.files.robot_file

    reads = []
    original = deltacal.io.toml.read_toml

    def counted(path):
        reads.append(str(path))
        return original(path)

    for module in (deltacal.wings, deltacal.io.robot, deltacal.printer.files.robot_file):
        monkeypatch.setattr(module, "read_toml", counted)
    for path in (KOSSEL, ROBOT):
        wings.robot_wing(path)
    assert reads == [str(KOSSEL), str(ROBOT)]


@pytest.mark.parametrize("make, message", [
    (lambda: PlanRequest(ROBOT, "o", object=True, model="complete"),
     "--model applies to pose planning, not to --object"),
    (lambda: PlanRequest(ROBOT, "o", object=True), f"{ROBOT}: --object needs --controller printer.cfg"),
    (lambda: PlanRequest(ROBOT, "o", probe_grid=5), "--probe-grid applies to --object"),
    (lambda: PlanRequest(ROBOT, "o", strategy="doptimal", n=4), "--n and --epsilon apply to --strategy bai"),
    (lambda: ExportRequest("c.toml", controller="klipper"), "--controller klipper needs -o CALIBRATED.cfg"),
    (lambda: ExportRequest("c.toml", mjcf="r.xml", config="p.cfg"), "--config and --keep-rotation-distance"),
    (lambda: ExportRequest("c.toml", controller="marlin", config="m.txt", output="o", live=True),
     "--live applies to --controller klipper "),
    (lambda: ExportRequest("c.toml", mjcf="r.xml", live=True), "--live applies to --controller klipper"),
    (lambda: ExportRequest("c.toml", controller="klipper", output="o", live=True),
     "--live needs --config printer.cfg"),
    (lambda: ExportRequest("c.toml", controller="klipper", config="p.cfg", output="o", robot="k.toml",
                           live=True),
     "--live takes Klipper's values and volume from --config alone"),
    (lambda: ReportRequest("c.toml", "r.html", firmware="grbl"), "--firmware grbl: one of klipper"),
    (lambda: CompensateRequest("c.toml", "t.csv", "o.csv", firmware="marlin"),
     "--firmware applies with --controller"),
    (lambda: CompensateRequest("c.toml", "p.gcode", "o.gcode"),
     "p.gcode: a G-code program goes to a controller"),
    (lambda: SimulateRequest(ROBOT, ("p.csv",), "m.csv", perturb=1, compliance="x"), "--compliance: numbers"),
])
def test_a_request_refuses_what_the_command_line_refuses(make, message):
    with pytest.raises(UsageError, match="^" + message.replace("(", r"\(").replace(".", r"\.")):
        make()


def test_the_kinds_own_refusals_come_from_its_wing(tmp_path):
    rotary = IdentifyRequest(ROBOT, ("m.csv",), tmp_path / "c.toml", rigid=True, compliance=True)
    with pytest.raises(UsageError, match="--rigid and --compliance: choose one"):
        wings.identify(rotary)
    printer = IdentifyRequest(KOSSEL, ("probe.csv",), tmp_path / "c.toml", distances=True, controller="x.cfg")
    with pytest.raises(UsageError, match="^--distances applies to a rotary Delta's measurements$"):
        wings.identify(printer)
    with pytest.raises(UsageError, match="a printer's plan is the object it prints"):
        wings.plan(PlanRequest(KOSSEL, tmp_path / "poses.csv"))
    with pytest.raises(UsageError, match="--sigma-height applies to a printer's simulation"):
        wings.simulate(SimulateRequest(ROBOT, ("p.csv",), tmp_path / "m.csv", perturb=1, sigma_height=0.1))
    linear = kossel_printer_cfg(tmp_path / "printer.cfg")  # a rotary robot's --controller: a rotary printer's
    probe = tmp_path / "p.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,\n")
    with pytest.raises(UsageError, match="not Klipper's configuration of a rotary Delta printer"):
        wings.simulate(SimulateRequest(ROBOT, (probe,), tmp_path / "m.csv", perturb=1, controller=linear))


def test_a_firmware_configuration_is_told_and_read_once(tmp_path, monkeypatch):
    """compensate --controller printer.cfg: the firmware told once, its values read once."""
    import deltacal.printer.firmware as firmware_package
    import deltacal.printer.firmware.config_file as config_file
    import deltacal.robots as robots

    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    geometry = load_printer(KOSSEL).geometry()
    save_geometry(geometry, tmp_path / "g.toml")
    (tmp_path / "t.csv").write_text("x_mm,y_mm,z_mm\n0,0,5\n10,-20,30\n")
    told, read = [], []
    config_firmware, read_config = firmware_package.config_firmware, type(KLIPPER).read_config
    for module in (firmware_package, config_file, robots):  # wherever a firmware is told from a file
        monkeypatch.setattr(module, "config_firmware",
                            lambda path: told.append(path) or config_firmware(path))
    monkeypatch.setattr(type(KLIPPER), "read_config",
                        lambda self, path: read.append(path) or read_config(self, path))
    done = wings.compensate(CompensateRequest(tmp_path / "g.toml", tmp_path / "t.csv", tmp_path / "o.csv",
                                              controller=cfg))
    wrote = f"wrote 2 corrected targets for the controller {cfg} to {tmp_path / 'o.csv'}"
    assert done.lines == (wrote,)
    assert len(told) == 1 and len(read) == 1
    program = tmp_path / "p.gcode"
    program.write_text("G28\nG1 X0 Y0 Z5 F3000\nG1 X10 Y-20 Z30\n")
    told.clear(), read.clear()
    wings.compensate(CompensateRequest(tmp_path / "g.toml", program, tmp_path / "o.gcode", controller=cfg))
    assert len(told) == 1 and len(read) == 1  # the controller, the same-printer check and the dialect
    rotary = tmp_path / "r.toml"
    save_geometry(load_nominal(ROBOT).geometry(), rotary)
    with pytest.raises(UsageError, match="is a linear Delta printer's, but the calibration"):
        wings.compensate(CompensateRequest(rotary, tmp_path / "t.csv", tmp_path / "o2.csv", controller=cfg))
    assert np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1).shape == (2, 6)


def test_a_printers_report_refuses_measurements_without_their_controller_and_a_rotarys_a_controller(tmp_path):
    """report: a printer's measurements need --controller (commanded positions); a rotary Delta takes none."""
    printer = tmp_path / "printer.toml"
    save_geometry(load_printer(KOSSEL).geometry(), printer)
    (tmp_path / "probe.csv").write_text("x_mm,y_mm,z_mm\n0,0,1\n")
    with pytest.raises(UsageError, match="a printer's measurements are of commanded positions: give "):
        wings.report(ReportRequest(printer, tmp_path / "r.html", measurements=tmp_path / "probe.csv"))
    rotary = tmp_path / "rotary.toml"
    save_geometry(load_nominal(ROBOT).geometry(), rotary)
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    with pytest.raises(UsageError, match=r"^--controller applies to a printer's calibration"):
        wings.report(ReportRequest(rotary, tmp_path / "r.html", controller=cfg))
    assert not (tmp_path / "r.html").exists()
