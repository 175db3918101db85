"""A rotary Delta printer's identification: its probe heights and printed distances, through its firmware.

A rotary robot file imported from a firmware's configuration (``deltacal import rotary.cfg``: Klipper's
``rotary_delta``) is a printer when ``identify`` is given that configuration (``--controller``): its
measurements are ``plan --object``'s files, of commanded positions in the firmware's frame (its bed,
z = 0), turned into the arms' readings through the firmware's own rotary model; the complete rotary
model with each arm's step scale (``rotary_printer``) is identified on the true bed from the nominal
robot moved into that frame, with a rotary printer kit's tolerances
(:meth:`~deltacal.geometry.Tolerances.rotary_printer_kit`) scaled by the evidence, as a linear printer's
(:func:`~deltacal.wings.printer.identify.read_prints` and ``fit_prints``: the same files, checks
and refusals). A configuration whose SAVE_CONFIG block holds the measurements Klipper's rotary
calibration was fitted to (``deltacal import`` writes them as the measurements' files) is a start
calibrated from the same data: the values that calibration fits take wide priors
(:meth:`~deltacal.printer.identification.errormodels.RotaryPrinterModel.prior_factor`) and the
correction along the bed follows what the measurements determine (``[holds.along_bed]``), as a linear
printer's. The calibration is written in the robot file's frame {O}, as a rotary robot's; where it
holds stays in the firmware's frame, where ``compensate`` puts it again
(:class:`~deltacal.printer.firmware.config_file.RotaryFirmwareConfig`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ...calibration import Calibration
from ...errormodels import get_model
from ...geometry import NominalDelta, Workspace
from ...io import save_calibration
from ...printer.firmware.config_file import RotaryFirmwareConfig, out_of_firmware_frame, told_firmware
from ...printer.firmware.controller import RotaryFirmwareController
from ...printer.identification.anchor import measured_record
from ...printer.identification.errormodels import kit_tolerances
from ...printer.identification.fit import PrinterFitOptions
from ...printer.identification.where import holds_in_words
from ...printer.rotary_owner import rotary_owner_lines
from ..base import Done, check_files, warn
from ..printer.identify import Commanded, fit_prints, read_prints
from ..requests import IdentifyRequest
from .printed import rotary_controller_of


@dataclass(frozen=True)
class _Angles:
    """A rotary firmware's inverse as a printer's identification asks it (no step distance: angles)."""

    rotary: RotaryFirmwareController

    def inverse(self, targets: np.ndarray, step_distance: Any = None, check: bool = True) -> np.ndarray:
        """The arms' readings [rad] the firmware commands for nozzle targets in its frame, (N, 3)."""
        return self.rotary.inverse(targets, check=check)


def identify_rotary_printer(request: IdentifyRequest, nominal: NominalDelta) -> Done:
    """``deltacal identify`` of a rotary Delta printer: the calibration file written, the report said.

    Raises:
        UsageError: a linear Delta's configuration (:func:`.printed.rotary_controller_of`).
        InputError: another printer's configuration (naming the value), or the measurements' own
            refusals (by file and line).
    """
    model = request.printer_model("rotary_printer")
    assert request.controller is not None
    check_files([request.nominal, request.controller, *map(str, request.measurements)], request.output)
    firmware = told_firmware(request.controller, request.firmware)
    rotary = rotary_controller_of(firmware, request.controller, request.nominal, nominal)
    robot = nominal.geometry()
    lift = rotary.bed_height(robot)
    start = rotary.in_bed_frame(robot)
    ws = nominal.workspace
    volume = None if ws is None else Workspace(ws.radius, ws.height, ws.top_z + lift)
    data, files = read_prints(request, start, Commanded(_Angles(rotary)), nominal.name)
    options = PrinterFitOptions(method="linear" if request.linear else "iterated",
                                tolerances=kit_tolerances(get_model(model)),
                                tolerance_scale=request.tolerance_scale or "evidence", workspace=volume,
                                accept_poor_fit=request.accept_poor_fit,
                                calibrated_start=firmware.calibrated_from_saved(request.controller),
                                reach=rotary.reach_radius)  # σ out to where Klipper moves the nozzle
    result = fit_prints(request, start, model, options, data, files)
    calibration = replace(out_of_firmware_frame(Calibration.from_result(result), rotary),
                          controller=RotaryFirmwareConfig(firmware, rotary, str(request.controller)).record(),
                          measured=measured_record(data, options, result.tolerance_scale))
    save_calibration(calibration, request.output)
    if result.outliers:
        warn([f"{files.where(k)} does not fit the other measurements (see the report): check it, or "
              "remove it and identify again" for k in result.outliers])
    where = () if result.holds is None else (f"where it holds: {holds_in_words(result.holds)}",)
    step = (f"next: deltacal compensate {request.output} PART.gcode --controller {request.controller} "
            f"corrects every move through {firmware.title}'s rotary model, where the calibration holds; "
            f"deltacal export {request.output} --controller {firmware.name} --config {request.controller} -o "
            f"{firmware.export_file} writes its values")
    owner = rotary_owner_lines(calibration, firmware.title)
    return Done((f"{request.nominal}: a rotary Delta printer measured through {request.controller}'s "
                 f"{firmware.title} rotary model; identified in its frame (bed z = 0, {lift:g} mm below the "
                 "robot file's {O})", *owner, *where, step, "\nThe engineer's part:", result.report(),
                 f"\nwrote {request.output}"))
