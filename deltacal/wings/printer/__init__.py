"""The printer's wing: a linear Delta printer's robot file and its jobs, each through the printer's firmware.

Each job in a module of its own: :mod:`.plan` (the printed object, its probe grid and sheet),
:mod:`.simulate` (the templates filled by a true printer), :mod:`.identify` (probe heights and printed
distances); its export is the firmware's values (:mod:`deltacal.printer.firmware.export`, one route for
every firmware) and its report fits and names them. The printer's own parts (its model, identification,
object, firmwares) are :mod:`deltacal.printer`. :data:`PRINTER` is the one wing object.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from ...calibration import Calibration
from ...chains import PRISMATIC, Chain
from ...controller import FIT_KINDS
from ...exceptions import UsageError
from ...geometry import DeltaGeometry, Workspace
from ...kinematics.workspace import default_workspace
from ...printer.files.robot_file import load_printer
from ...printer.firmware import firmware_named, firmwares
from ...printer.firmware.base import Firmware, FirmwareModel
from ...printer.firmware.config_file import (
    firmware_names,
    read_firmware_config,
    recorded_firmware,
    refuse_deltacal_file,
    settings_files,
    settings_needed,
)
from ...printer.firmware.export import export_firmware_values
from ...printer.robot import NominalLinearDelta
from ...robots import load_robot
from ..base import Done, Robot, Wing
from ..requests import ExportRequest, IdentifyRequest, PlanRequest, ReportRequest, SimulateRequest
from .compare import history_section
from .identify import identify_from_prints
from .plan import plan_printed_object
from .simulate import simulate_prints


class PrinterWing(Wing):
    """A linear Delta printer (three carriages on towers): a robot file with ``kind = "linear"``."""

    name: ClassVar[str] = "printer"
    chain: ClassVar[Chain] = PRISMATIC

    def load(self, path: str | Path, data: dict | None = None) -> NominalLinearDelta:
        """:func:`~deltacal.printer.files.robot_file.load_printer`."""
        return load_printer(path, data)

    def _robot(self, path: str | Path, robot: Robot | None) -> NominalLinearDelta:
        robot = self.load(path) if robot is None else robot
        assert isinstance(robot, NominalLinearDelta)
        return robot

    def plan(self, request: PlanRequest, robot: Robot | None = None,
             notify: Callable[[str], None] | None = None) -> Done:
        """The printed object (:func:`.plan.plan_printed_object`); a printer's plan is ``--object``."""
        if not request.object:
            raise UsageError(f"{request.nominal}: a printer's plan is the object it prints and measures: use "
                             f"--object --controller {settings_files()} -o DIR")
        return plan_printed_object(request, self._robot(request.nominal, robot))

    def simulate(self, request: SimulateRequest, robot: Robot | None = None) -> Done:
        """Probe heights and printed distances through the firmware (:func:`.simulate.simulate_prints`)."""
        return simulate_prints(request, self._robot(request.nominal, robot))

    def identify(self, request: IdentifyRequest, robot: Robot | None = None) -> Done:
        """The geometry from probe heights and distances (:func:`.identify.identify_from_prints`)."""
        return identify_from_prints(request, self._robot(request.nominal, robot))

    def export_controller(self, request: ExportRequest, calibration: Calibration) -> Done:
        """The firmware's values that fit best (:mod:`deltacal.printer.firmware.export`).

        One route for every firmware; ``offsets`` and ``limbs`` are a rotary Delta's.
        """
        firmware = firmware_named(str(request.controller))
        if firmware is None or request.controller in FIT_KINDS:
            raise UsageError(f"--controller {request.controller}: {request.calibration} is a printer's "
                             f"calibration; its firmware's values: --controller {'|'.join(firmware_names())}")
        assert request.output is not None
        if request.config is None:  # with one: checked against the geometry first, then the record
            recorded_firmware(calibration, request.calibration, firmware, f"--controller {firmware.name}")
        if request.live:
            return _export_live(firmware, request, calibration)
        said: tuple[str, ...] = ()
        if request.config is not None:
            refuse_deltacal_file(request.config, "--config")
            calibration, said = read_firmware_config(request.config, firmware.name).anchor(calibration,
                                                                                          request.calibration)
        workspace, where = printable_volume(request.robot, calibration.nominal)
        export = export_firmware_values(firmware, calibration, request.calibration, workspace, where,
                                        request.config, request.keep_rotation_distance, request.robot,
                                        request.sigma_bound)
        export.save(request.output, request.config)
        wrote = f"wrote the {firmware.title} values that best fit {request.calibration} to {request.output}"
        return Done((*said, wrote, *export.lines, f"to apply: {firmware.apply_note_for(request.config)}"))

    def report_firmware(self, request: ReportRequest, calibration: Calibration
                        ) -> tuple[Firmware[Any], FirmwareModel | None, tuple[str, ...], Calibration]:
        """``--controller``'s firmware (its values read once, checked of this printer), or the recorded one.

        With ``--controller``, the calibration re-anchored to its values where they changed
        (:meth:`~deltacal.printer.firmware.config_file.FirmwareConfig.anchor`).

        Without ``--controller``: the firmware the calibration was identified with (``[controller]``),
        else ``--firmware``'s, else Klipper; ``--controller`` or ``--firmware`` of another firmware
        than the recorded one is refused. A printer's measurements are of commanded positions: their
        residuals need the settings they were made with (``--controller``).
        """
        if request.measurements and request.controller is None:
            raise settings_needed(request.measurements, "measurements", "the firmware's settings they were "
                                  "made with, for their residuals", calibration, request.calibration)
        if request.controller is None:
            named = firmware_named(request.firmware) if request.firmware is not None else None
            recorded = recorded_firmware(calibration, request.calibration, named,
                                         f"--firmware {request.firmware}")
            return (recorded or named or firmwares()[0]), None, (), calibration
        config = read_firmware_config(request.controller, request.firmware)
        calibration, said = config.anchor(calibration, request.calibration)
        return config.firmware, config.values, said, calibration

    def report_history(self, request: ReportRequest, calibration: Calibration, firmware: Firmware[Any] | None
                       ) -> tuple[str | None, tuple[str, ...]]:
        """``--history``: the calibrations under the report's prior (:func:`.compare.history_section`)."""
        if not request.history:
            return None, ()
        assert firmware is not None
        return history_section(request, calibration, firmware)


def _export_live(firmware: Firmware[Any], request: ExportRequest, calibration: Calibration) -> Done:
    """``export --live``: the correction the firmware runs itself, through the values of ``--config``."""
    assert request.config is not None and request.output is not None
    refuse_deltacal_file(request.config, "--config")  # its output folder checked by the job (wings.export)
    config = read_firmware_config(request.config, firmware.name)  # another firmware's refused, naming it
    calibration, said = config.anchor(calibration, request.calibration)
    return Done((*said, *firmware.export_live(calibration, request.config, request.output,
                                              str(request.calibration), request.sigma_bound)))


def printable_volume(robot: str | Path | None, nominal: DeltaGeometry) -> tuple[Workspace, str]:
    """The printable volume: the robot file's ``[workspace]``, else the default for the nominal printer.

    Returns:
        The volume and where it comes from, for the messages (``" of kossel.toml"``).

    Raises:
        UsageError: a rotary Delta's robot file.
    """
    if robot is not None:
        read = load_robot(robot)
        if read.geometry().chain != nominal.chain:
            raise UsageError(f"--robot {robot}: a rotary Delta's robot file; give the printer's")
        if read.workspace is not None:
            return read.workspace, f" of {robot}"
    return default_workspace(nominal), " (the default; --robot gives the printer's own)"


#: The linear Delta printer's wing.
PRINTER = PrinterWing()

__all__ = ["PRINTER", "PrinterWing", "printable_volume"]
