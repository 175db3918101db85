"""A printer's plan: the printed calibration object, its probe grid and the sheet to measure it with.

Writes ``DIR/object.stl`` (the object, in the printer's coordinates), ``DIR/probe.csv`` (the probe grid,
``z_mm`` to fill in), ``DIR/probe.gcode`` (the firmware's program that probes that grid, its results on
the console, travelling above the probe's trigger height:
:meth:`~deltacal.printer.firmware.base.Firmware.probe_travel`; a configuration without a probe gets none,
its ``probe.csv`` a ``trigger_height_mm`` of :data:`~deltacal.printer.firmware.probing.PAPER_MM` and the
firmware's paper test said instead: :meth:`~deltacal.printer.firmware.base.Firmware.manual_heights`;
RepRapFirmware's ``M558 P0`` keeps the program, whose ``G30`` asks for each height by hand:
:attr:`~deltacal.printer.firmware.base.Firmware.probes_by_hand`),
``DIR/distances.csv`` (the pairs of features to measure, the labels of their balls, ``distance_mm`` to
fill in) and ``DIR/sheet.html`` (the measuring sheet: a top view with the labels and the pairs in the
order of distances.csv), and says what was planned: what the probe heights alone identify of the
complete model and what the object's distances add.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...exceptions import UsageError
from ...geometry import Workspace
from ...io import write_stl
from ...io.atomic import atomic_write_text
from ...io.paths import check_input, check_output_folder
from ...printer.files.measurements import write_printed_distances, write_probe_heights
from ...printer.firmware import config_files
from ...printer.firmware.base import Firmware
from ...printer.firmware.config_file import FirmwareConfig, told_firmware
from ...printer.firmware.probing import PAPER_MM
from ...printer.printed.object import BALL_DIAMETER, CALIPER_RANGE, MAX_DISTANCES, levels
from ...printer.printed.plan import ObjectPlan, plan_object
from ...printer.printed.sheet import sheet_html
from ...printer.printed.target import LinearPrinterToPlan, PrinterToPlan
from ...printer.robot import NominalLinearDelta
from ..base import Done
from ..requests import PlanRequest

#: The files ``plan --object`` writes in its folder.
OBJECT_FILES = ("object.stl", "probe.csv", "distances.csv", "probe.gcode", "sheet.html")
#: Largest probe grid: 9 across the bed, whose round mesh keeps 49 points (the budget: at most 49 heights).
MAX_PROBE_GRID = 9


def plan_printed_object(request: PlanRequest, printer: NominalLinearDelta) -> Done:
    """``deltacal plan --object``: the object's files written in the folder, what was planned said.

    Raises:
        UsageError: a rotary Delta printer's configuration (``--controller``) for this linear printer.
    """
    firmware = object_firmware(request)
    assert request.controller is not None
    if firmware.rotary_controller(request.controller) is not None:
        raise UsageError(f"--controller {request.controller}: a rotary Delta printer's configuration, but "
                         f"{request.nominal} is a linear Delta printer's robot file: give the printer's own "
                         "configuration (or the rotary printer's robot file, deltacal import)")
    config = FirmwareConfig.read(firmware, request.controller)
    firmware.check_same_printer(firmware.nominal(printer), config.values, str(request.nominal),
                                str(request.controller))
    return write_object_plan(request, firmware, LinearPrinterToPlan(printer, config.values))


def object_firmware(request: PlanRequest) -> Firmware[Any]:
    """The firmware of ``plan --object``'s ``--controller`` (told once), its folder's outputs checked first.

    Raises:
        UsageError: as :func:`~deltacal.printer.firmware.config_file.told_firmware`; an output that would
            overwrite an input (:func:`~deltacal.io.paths.check_output_folder`).
    """
    assert request.controller is not None
    check_input(request.controller)
    firmware = told_firmware(request.controller, request.firmware)  # told once
    read = config_files(request.controller, firmware)  # none overwritten
    check_output_folder(Path(request.output), OBJECT_FILES, (request.nominal, *read), "plan --object")
    return firmware


def write_object_plan(request: PlanRequest, firmware: Firmware[Any], printer: PrinterToPlan) -> Done:
    """The object planned for ``printer`` (in the bed's frame), its five files written, what was planned said.

    The firmware's configuration (``--controller``) tells the probe (its travel, or the paper test by
    hand) and its live correction (turned off while probing).
    """
    assert request.controller is not None
    folder = Path(request.output)
    outputs = [folder / name for name in OBJECT_FILES]
    manual = firmware.manual_heights(request.controller)  # no probe: its heights by hand, or none
    # RRF's G30 with M558 P0 asks for each height by hand: its program kept
    travel = firmware.probe_travel(request.controller) if not manual or firmware.probes_by_hand else None
    live = firmware.live_correction(request.controller)  # turned off while the heights are measured
    caliper = request.caliper or CALIPER_RANGE
    plan = plan_object(printer, count=request.distances,
                       probe_count=request.probe_grid or MAX_PROBE_GRID, caliper=caliper)
    mesh = plan.labelled_mesh()
    if not folder.exists():
        folder.mkdir()
    write_stl(outputs[0], mesh)
    write_probe_heights(outputs[1], plan.probe,
                        trigger_height=None if not manual else np.full(len(plan.probe), PAPER_MM))
    names = plan.names
    write_printed_distances(outputs[2], plan.pair_positions,
                            balls=[(names[i], names[j]) for i, j in plan.pairs.tolist()])
    if travel is not None:
        atomic_write_text(outputs[3], firmware.probe_program(
            plan.probe, title=f"deltacal plan --object: the probe grid of {printer.name} ({outputs[1].name})",
            clearance=travel, live=live))
    assert printer.workspace is not None  # plan_object refused a printer without one
    atomic_write_text(outputs[4], sheet_html(plan, printer.workspace.radius, f"{printer.name}: the printed "
                                             "object's distances", printer.tower_azimuth))
    lines = [_report(plan, printer, mesh, caliper, not manual)]
    if request.distances is None and len(plan.pairs) < MAX_DISTANCES:
        lines.append(f"note: with a caliper of {caliper:g} mm the object offers {len(plan.pairs)} distances "
                     f"that can be measured together ({MAX_DISTANCES} with a longer one): planned the "
                     f"{len(plan.pairs)}")
    lines.extend(_lowered(plan, printer.workspace, caliper))
    if live is not None:
        lines.append(live.plan_note(outputs[3].name) if travel is not None else live.manual_note())
    probed = ("heights by hand, below" if travel is None else f"{outputs[3]} asks for each by hand, below"
              if manual else f"{outputs[3]} probes them")
    lines.append(f"wrote {outputs[0]}, {outputs[1]} ({len(plan.probe)} probe points; {probed}), {outputs[2]} "
                 f"({len(plan.pairs)} distances) and {outputs[4]} (the sheet to measure them with)")
    if manual:
        lines.append(manual)
    return Done(tuple(lines))


def _lowered(plan: ObjectPlan, workspace: Workspace, caliper: float) -> tuple[str, ...]:
    """The note when the object stands lower than the caliper allows: its pads need a wider bed."""
    top, allowed = plan.top_level, float(levels(workspace, caliper)[-1])
    if not top < allowed:  # the layout's top, whether or not a feature chosen stands on it
        return ()
    return (f"note: the printable radius {workspace.radius:g} mm holds the pads and labels of balls up to "
            f"{top:g} mm, "
            f"not the {allowed:g} mm the caliper reaches: the object stands lower and the calibration holds "
            "below it; if the printer prints wider, a wider [workspace] radius_mm in the robot file gives a "
            "taller object",)


def _report(plan: ObjectPlan, printer: PrinterToPlan, mesh, caliper: float, probe: bool) -> str:
    radius = float(abs(plan.probe[:, :2]).max())
    how = ("run probe.gcode (it homes, then probes at each) and read its console back (deltacal import LOG), "
           "or write the commanded z at which the probe triggered in probe.csv" if probe else
           "no probe: the heights by hand (the paper test), or none (the last line)")
    heights = sorted({float(z) for z in plan.features[:, 2]})
    lengths = plan.lengths
    lines = [
        f"probe grid: {len(plan.probe)} points (Klipper's round mesh, radius {radius:g} mm); {how}",
        f"object: {len(plan.features)} balls of {BALL_DIAMETER:g} mm on posts, centres at heights "
        f"{', '.join(f'{z:g}' for z in heights)} mm, each labelled 1 to {len(plan.features)} on a tile "
        "beside it; "
        f"{len(mesh.faces)} facets, "
        f"height {mesh.bounds[1, 2]:g} mm; print object.stl where it stands (printer coordinates, origin at "
        "the bed's centre: the slicer must not move it)",
        f"distances: {len(plan.pairs)} pairs of ball centres, {lengths.min():.1f} to {lengths.max():.1f} mm "
        f"(readings up to {lengths.max() + BALL_DIAMETER:.1f} mm: a {caliper:g} mm caliper, --caliper): "
        "outside jaws across both balls, rocked to the largest reading, minus the balls' mean diameter; "
        "write each in distances.csv",
        f"D-optimal (complete model, in units of the build tolerances): log det {plan.log_det_probe:.4g} "
        f"with the probe heights alone, {plan.log_det:.4g} with the distances",
    ]
    if plan.probe_only is not None and plan.with_distances is not None:
        alone, both = plan.probe_only, plan.with_distances
        lines.append(f"probe heights alone identify {alone.rank} of the {len(alone.names)} complete-model "
                     f"combinations better than the build tolerances: {', '.join(alone.base_names)}")
        added = ", ".join(plan.added_names()) or "none"
        lines.append(f"the distances add {both.rank - alone.rank}: {added}; "
                     f"{len(both.names) - both.rank} stay within their tolerances only")
    return "\n".join(lines)
