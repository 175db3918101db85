"""A rotary Delta's controller values that fit a calibration best (``export --controller offsets|limbs``).

The controller's joint offsets, or its per-limb values, fitted to the calibration over a grid of the
workspace (the report's accuracy-map grid of the robot file's ``[workspace]``, else of the report's
default cylinder), written as a controller file whose ``[fit]`` holds the TCP error these values leave
(:func:`deltacal.controller.fit_controller`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...calibration import Calibration
from ...controller import Controller, fit_controller
from ...exceptions import AssemblyError, GeometryError, InputError, UnreachableError, UsageError
from ...geometry import Workspace
from ...io import load_nominal, save_controller
from ...kinematics.workspace import default_workspace
from ...printer.firmware.base import Firmware
from ...printer.firmware.config_file import RotaryFirmwareConfig, refuse_deltacal_file
from ...report.accuracy import GRID, workspace_slices
from ..base import Done
from ..requests import ExportRequest


def export_controller_values(request: ExportRequest, calibration: Calibration) -> Done:
    """``export --controller offsets|limbs``: the controller file written, the error its values leave said."""
    kind = request.controller
    assert kind is not None and request.output is not None
    start, workspace, shift, sized = _start(calibration, request)
    points = np.concatenate([s.points.reshape(-1, 3) for s in workspace_slices(workspace, GRID)]) + shift
    points = points[np.all(np.isfinite(points), axis=1)]
    try:
        fit = fit_controller(calibration, start, points, kind)
    except (UnreachableError, AssemblyError) as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"the workspace point {np.round(points[k], 3).tolist()} mm is out of reach of the "
                         f"{'controller model' if isinstance(exc, UnreachableError) else 'identified robot'}"
                         f" (workspace: {_text(workspace)}{sized}): give --robot with a [workspace] it "
                         "reaches",
                         str(request.robot or request.calibration), "key workspace") from None
    notes = {"calibration": str(request.calibration), "workspace": _text(workspace) + sized}
    name = request.name or start.name or calibration.robot
    save_controller(request.output, fit.controller.replace(name=name), fit, notes)
    what = {"offsets": "joint offsets", "limbs": "per-limb values"}[kind]
    lines = [f"wrote the {what} that best fit {request.calibration} to {request.output}",
             f"TCP error left over the workspace ({fit.points} points; {_text(workspace)}{sized}): "
             f"max {fit.max_error:.4f} mm, RMS {fit.rms_error:.4f} mm (the nominal controller leaves max "
             f"{fit.max_error_before:.4f} mm, RMS {fit.rms_error_before:.4f} mm)"]
    if fit.held:
        lines.append("held at nominal (not identifiable from the TCP error; b_i and a_i enter only as b_i - "
                     f"a_i): {', '.join(fit.held)}")
    return Done(tuple(lines))


def export_firmware_rotary(firmware: Firmware[Any], request: ExportRequest, calibration: Calibration) -> Done:
    """``export --controller FIRMWARE --config printer.cfg``: the firmware's values of a rotary printer.

    Fitted to the calibration from the configuration's values
    (:meth:`~deltacal.printer.firmware.base.Firmware.rotary_export`), the calibration re-anchored first
    where the values changed since it was identified, as ``compensate`` and ``--live`` re-anchor it
    (:meth:`~deltacal.printer.firmware.config_file.RotaryFirmwareConfig.anchor_in_own_frame`: in {O},
    where the export takes it), over ``--robot``'s
    ``[workspace]``, else the configuration's own printable volume; written to ``-o``, what they leave said.

    Raises:
        UsageError: no ``--config``, ``--keep-rotation-distance``, or a configuration that is
            not of a rotary Delta printer (a linear Delta's).
        InputError: a file's first problem, a target out of the firmware's reach; values of another
            printer or firmware than the calibration recorded, or a re-anchoring that failed.
    """
    given = f"--controller {firmware.name}"
    if request.keep_rotation_distance:
        raise UsageError("--keep-rotation-distance applies to a linear Delta printer's calibration; "
                         f"{request.calibration} is a rotary Delta's calibration")
    if request.config is None:
        raise UsageError(f"{given}: {request.calibration} is a rotary Delta's calibration; "
                         f"{firmware.title}'s values are fitted from the configuration the printer runs: "
                         f"give --config {firmware.config_file} (or --controller offsets|limbs)")
    assert request.output is not None
    refuse_deltacal_file(request.config, "--config")
    if request.live:
        return _export_rotary_live(firmware, request, calibration)
    rotary = firmware.rotary_controller(request.config)
    if rotary is None:
        raise _not_rotary(firmware, request)
    calibration, said = RotaryFirmwareConfig(firmware, rotary, str(request.config)).anchor_in_own_frame(
        calibration, request.calibration)
    volume, where = None, ""
    if request.robot is not None:
        volume = load_nominal(request.robot).workspace
        where = "" if volume is None else f" of {request.robot}"
    values = firmware.rotary_export(request.config, calibration, request.calibration, volume, where)
    if values is None:
        raise _not_rotary(firmware, request)
    values.save(request.output)
    return Done((*said, f"wrote the {firmware.title} rotary values that best fit {request.calibration} to "
                 f"{request.output}", *values.lines, f"to apply: {firmware.apply_note_for(request.config)}"))


def _not_rotary(firmware: Firmware[Any], request: ExportRequest) -> UsageError:
    """The refusal of a ``--config`` that is not the firmware's configuration of a rotary Delta printer."""
    return UsageError(f"--config {request.config} is not {firmware.title}'s configuration of a rotary Delta "
                      f"printer, but {request.calibration} is a rotary Delta's calibration: give the rotary "
                      "printer's")


def _export_rotary_live(firmware: Firmware[Any], request: ExportRequest, calibration: Calibration) -> Done:
    """``export --live`` of a rotary printer: the correction the firmware runs itself, through ``--config``.

    The calibration moved into the firmware's frame (the bed's) as ``compensate`` moves it
    (:meth:`~deltacal.printer.firmware.config_file.RotaryFirmwareConfig.anchor`), then
    :meth:`~deltacal.printer.firmware.base.Firmware.export_live` with the configuration's rotary values.
    """
    assert request.config is not None and request.output is not None
    rotary = firmware.rotary_controller(request.config)
    if rotary is None:
        raise _not_rotary(firmware, request)
    anchored, said = RotaryFirmwareConfig(firmware, rotary, str(request.config)).anchor(calibration,
                                                                                        request.calibration)
    lines = firmware.export_live(anchored, request.config, request.output, str(request.calibration),
                                 request.sigma_bound)
    return Done((*said, *lines))


def _start(calibration: Calibration, request: ExportRequest) -> tuple[Controller, Workspace, np.ndarray, str]:
    """The nominal controller, the workspace, its shift [mm] and a note on where it came from.

    The controller's tool is the calibration's (the TCP identified); a robot file's workspace is
    for its own tool, so it is shifted by the difference (the convention of the robot file).
    """
    tool = calibration.nominal.tool
    if request.robot is not None:
        nominal = load_nominal(request.robot)
        start = Controller.from_geometry(nominal).replace(tool=tool)
        if nominal.workspace is not None:
            return start, nominal.workspace, tool - nominal.tool, ""
        return start, default_workspace(nominal.geometry().with_tool(tool)), np.zeros(3), " (the default)"
    try:
        start = Controller.from_geometry(calibration.nominal)
    except GeometryError:
        raise InputError("the calibration's nominal geometry is not a classical Delta (a geometry file?): "
                         "give the robot file with --robot", str(request.calibration),
                         "key nominal") from None
    return (start, default_workspace(calibration.nominal), np.zeros(3),
            " (the default; --robot gives the robot's own)")


def _text(workspace: Workspace) -> str:
    return f"radius {workspace.radius:g} mm, z from {workspace.bottom_z:g} to {workspace.top_z:g} mm"
