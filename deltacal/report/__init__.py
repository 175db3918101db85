"""Calibration reports: one self-contained HTML page per calibration file.

* :mod:`.data`: the calibration file as the report reads it;
* :mod:`.accuracy`: the predicted σ of the TCP over the workspace (covariance propagation);
* :mod:`.residuals`: each measurement's residual before and after;
* :mod:`.controllers`: what each route to a Cartesian controller leaves over the same slices;
* :mod:`.figures`: matplotlib figures as inline SVG;
* :mod:`.html`: the page.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..calibration import Calibration
from ..exceptions import DeltacalError, InputError
from ..geometry import DeltaGeometry, Workspace
from ..io import atomic_write_text, load_calibration
from ..printer.firmware import firmwares
from ..printer.firmware.base import Firmware, FirmwareModel
from ..printer.identification.where import holds_in_words
from ..printer.owner import owner_lines, printer_errors
from ..printer.rotary_owner import rotary_owner_lines
from ..viz import DEFAULT_EXAGGERATION, build_scene, default_workspace, recording_visualizer, words
from . import figures
from .accuracy import (
    AccuracyMap,
    accuracy_map,
    actual_tcp_error,
    predicted_tcp_covariance,
    predicted_tcp_sigma,
    sigma_3d,
    tcp_jacobian,
)
from .controllers import ControllerRoutes, controller_routes
from .deflection import deflection_map
from .html import Page, render_page
from .residuals import MeasurementResiduals, measurement_residuals


@dataclass(frozen=True)
class ReportSummary:
    """What :func:`write_report` wrote.

    Attributes:
        path: The HTML file.
        worst_sigma: Largest predicted 3-D σ of the TCP over the slices [mm].
        worst_point: Where [mm].
        figures: Names of the figures drawn.
        warnings: What the page warns about.
    """

    path: Path
    worst_sigma: float
    worst_point: np.ndarray
    figures: tuple[str, ...]
    warnings: tuple[str, ...] = field(default_factory=tuple)


def _scene(calibration: Calibration, workspace: Workspace) -> tuple[str | None, str]:
    """Meshcat's standalone page of the identified robot over its nominal ghost, or None and why."""
    try:
        vis = recording_visualizer(f"deltacal: {calibration.robot}")
        summary = build_scene(vis, calibration.nominal, calibration.geometry, workspace=workspace,
                              arrows=True, animate=False, title=f"{calibration.robot} (identified)")
    except (DeltacalError, ImportError) as exc:
        return None, f"No 3-D view: {exc}"
    plate, tcp = words(calibration.geometry)
    robot = calibration.geometry.chain.words.robot
    bed = " above the bed (the plane z = 0)" if calibration.geometry.chain.on_bed else ""
    note = (f"The identified {robot} (solid) over the nominal one (ghost){bed}, {plate} tilt exaggerated "
            f"{DEFAULT_EXAGGERATION:g} times (real tilt {np.degrees(summary.tilt):.4f}° at the drawn pose); "
            f"arrows: where the identified {robot}'s {tcp} goes when commanded with the nominal model (the "
            "correction the calibration makes). Drag to turn, scroll to zoom.")
    return vis.static_html(), note


def write_report(
    calibration: Calibration | str | Path,
    output: str | Path,
    measurements: str | Path | Sequence[str | Path] | None = None,
    truth: DeltaGeometry | None = None,
    truth_source: str | None = None,
    tool: np.ndarray | None = None,
    workspace: Workspace | None = None,
    view: bool = True,
    grid: int = 41,
    payload: float = 0.0,
    firmware: Firmware[Any] | None = None,
    controller: FirmwareModel | None = None,
    history: str | None = None,
) -> ReportSummary:
    """Write the HTML report of a calibration, atomically.

    Args:
        calibration: The calibration, or its file (written by ``deltacal identify``; read first).
        output: The HTML file to write.
        measurements: The measurement CSV the calibration was identified from (residual plots); a
            printer's: its probe heights and distances files.
        truth: The true geometry (simulations): actual TCP errors beside the predicted σ.
        truth_source: Where the truth came from (shown).
        tool: TCP in the plate frame for the accuracy map [mm] (default: the calibration's).
        workspace: Cylinder of the accuracy map (default: one sized from the robot).
        view: Embed the meshcat 3-D view.
        grid: Points along each side of a slice.
        payload: For a calibration that identified compliances: the payload [kg] whose TCP
            deflection the report maps (beside the robot's own weight).
        firmware: A printer's firmware, whose values the page fits and names (default: the first of
            :func:`~deltacal.printer.firmware.firmwares`, Klipper).
        controller: A printer's firmware values its measurements were commanded with (its
            ``--controller`` settings), for their residuals.
        history: A printer's history of its calibrations, its section's HTML
            (:func:`~deltacal.report.history.history_html`), after the owner's part.

    Returns:
        A summary of what was written.

    Raises:
        InputError: a calibration without base parameters (read from a geometry file), or a bad file.
    """
    cal = calibration if isinstance(calibration, Calibration) else load_calibration(calibration)
    if not cal.base:
        raise InputError("not a calibration file: a geometry file has no identification to report "
                         "(give the calibration file written by 'deltacal identify')", cal.source,
                         "key format")
    ws = workspace if workspace is not None else default_workspace(cal.nominal)
    ws_text = (f"Workspace cylinder: radius {ws.radius:.0f} mm, z from {ws.bottom_z:.0f} to {ws.top_z:.0f} mm"
               + ("" if workspace is not None else " (sized from the robot; give a robot file for its own)"))
    warnings: list[str] = []
    res: MeasurementResiduals | None = None
    if measurements is not None:
        res = measurement_residuals(cal, measurements, controller)
        warnings += list(res.warnings)
    amap = accuracy_map(cal, ws, tool, truth, grid)
    svg = {
        "correlation": figures.correlation_heatmap([p.name for p in cal.base], cal.correlation),
        "accuracy": figures.accuracy_slices(amap, res.position if res is not None else None),
    }
    if res is not None:
        svg["residuals_index"] = figures.residuals_by_pose(res)
        svg["residuals_workspace"] = figures.residuals_over_workspace(res)
    if truth is not None:
        svg["error"] = figures.error_slices(amap)
        svg["error_vs_sigma"] = figures.error_vs_sigma(amap)
    scene, note = _scene(cal, ws) if view else (None, "3-D view left out.")
    page = Page(
        calibration=cal, accuracy=amap, figures=svg, residuals=res, truth_source=truth_source,
        measurements_source=_file_names(measurements), workspace_text=ws_text,
        scene_html=scene, scene_note=note, warnings=warnings,
        controllers=controller_routes(cal, amap, truth, firmware),
        deflection=None if cal.compliance is None else deflection_map(cal.geometry, ws, payload),
        owner=_owner(cal, firmware), history=history,
    )
    path = Path(output)
    atomic_write_text(path, render_page(page))
    return ReportSummary(path, amap.worst, amap.worst_point, tuple(svg), tuple(warnings))


def _owner(cal: Calibration, firmware: Firmware[Any] | None) -> list[str] | None:
    """A printer's errors in its owner's words, its firmware's (:mod:`deltacal.printer.owner`), or None.

    Then where the calibration holds (:func:`~deltacal.printer.identification.where.holds_in_words`),
    when it knows.
    """
    where = [] if cal.holds is None else [f"  where it holds: {holds_in_words(cal.holds)}"]
    if cal.model.name == "rotary_printer":  # a rotary printer's: arm by arm (Klipper's rotary_delta)
        return [*rotary_owner_lines(cal, "Klipper" if firmware is None else firmware.title), *where]
    if not cal.geometry.chain.firmware or cal.model.name != "printer":
        return None
    if firmware is None:
        firmware = firmwares()[0]
    keys = firmware.owner_keys
    try:
        errors = printer_errors(cal, names=keys.towers)
    except ValueError:  # a calibration that regrouped the model's parameters: the engineer's part alone
        return None
    return [*owner_lines(errors, keys, firmware.title), *where]


def _file_names(paths: str | Path | Sequence[str | Path] | None) -> str | None:
    """The measurement files as the page names them (one, or several separated by commas)."""
    if paths is None:
        return None
    return str(paths) if isinstance(paths, str | Path) else ", ".join(str(p) for p in paths)


__all__ = [
    "AccuracyMap",
    "ControllerRoutes",
    "MeasurementResiduals",
    "ReportSummary",
    "accuracy_map",
    "actual_tcp_error",
    "controller_routes",
    "measurement_residuals",
    "predicted_tcp_covariance",
    "predicted_tcp_sigma",
    "sigma_3d",
    "tcp_jacobian",
    "write_report",
]
