"""A rotary Delta's controller values that fit a calibration best (``export --controller offsets|limbs``).

The controller's joint offsets, or its per-limb values, fitted to the calibration over a grid of the
workspace (the report's accuracy-map grid of the robot file's ``[workspace]``, else of the report's
default cylinder), written as a controller file whose ``[fit]`` holds the TCP error these values leave
(:func:`deltacal.controller.fit_controller`).
"""

from __future__ import annotations

import numpy as np

from ...calibration import Calibration
from ...controller import Controller, fit_controller
from ...exceptions import AssemblyError, GeometryError, InputError, UnreachableError
from ...geometry import Workspace
from ...io import load_nominal, save_controller
from ...kinematics.workspace import default_workspace
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
