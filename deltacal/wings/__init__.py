r"""The robot kinds' wings: each kind's robot file and jobs behind one interface, found once by kind.

A command of ``deltacal`` is a request (:mod:`.requests`: its options, checked once), the wing of the
robot's kind (:class:`~.base.Wing`: :data:`ROTARY`, :data:`PRINTER`), found once from the robot file's
``kind`` (parsed once: :func:`robot_wing`) or the calibration's chain (:func:`wing_for`), and the wing's
job, which returns what the command prints (:class:`~.base.Done`). The functions below are the jobs as
a program calls them::

    from deltacal import wings
    done = wings.identify(wings.IdentifyRequest("kossel.toml", ("probe.csv",), "cal.toml",
                                                controller="printer.cfg"))
    print("\\n".join(done.lines))

:func:`compensate` serves both kinds alike (:mod:`.compensate_job`, a large file on every core:
:mod:`.workers`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from ..chains import Chain
from ..geometry import DeltaGeometry
from ..io import load_calibration, read_toml
from ..io.paths import check_input, check_output_folder
from ..io.robot import robot_kind
from ..printer.firmware import config_files, firmware_named
from .base import Done, Robot, Wing, check_files
from .compensate_job import Progress, compensate_targets
from .printer import PRINTER, PrinterWing
from .printer.compare import compare_printer_calibrations
from .printer.importing import import_found as import_found_printer
from .requests import (
    CompareRequest,
    CompensateRequest,
    ExportRequest,
    IdentifyRequest,
    ImportRequest,
    PlanRequest,
    ReportRequest,
    SimulateRequest,
)
from .rotary import ROTARY, RotaryWing

#: Every robot kind's wing.
WINGS: tuple[Wing, ...] = (ROTARY, PRINTER)


def wing_for(chain: Chain) -> Wing:
    """The wing of a robot kind's chain (a calibration's, a geometry's)."""
    return next(wing for wing in WINGS if wing.chain == chain)


def robot_wing(path: str | Path) -> tuple[Wing, Robot]:
    """The wing of a robot file's ``kind``, and the file read by it (the file parsed once).

    Raises:
        UsageError: no such file.
        InputError: naming the file and the key of the first problem found.
    """
    check_input(path)
    data = read_toml(path)
    wing = _wing_of_file(data, path)
    return wing, wing.load(path, data)


def _wing_of_file(data: dict, path: str | Path) -> Wing:
    """The wing of a robot file's parsed TOML (its ``kind``, checked)."""
    kind = robot_kind(data, str(path))
    return next(wing for wing in WINGS if wing.chain.robot_kind == kind)


def plan(request: PlanRequest, notify: Callable[[str], None] | None = None) -> Done:
    """``deltacal plan``: the robot file's wing plans (poses, or a printer's object)."""
    wing, robot = robot_wing(request.nominal)
    return wing.plan(request, robot, notify)


def simulate(request: SimulateRequest) -> Done:
    """``deltacal simulate``: the robot file's wing simulates its measurements."""
    wing, robot = robot_wing(request.nominal)
    return wing.simulate(request, robot)


def identify(request: IdentifyRequest) -> Done:
    """``deltacal identify``: the robot file's wing identifies the geometry from its measurements."""
    wing, robot = robot_wing(request.nominal)
    return wing.identify(request, robot)


def export(request: ExportRequest) -> Done:
    """``deltacal export``: an MJCF model (either kind), or the calibration's wing's controller values.

    A firmware's values may not overwrite a file its configuration (``config``) reads; ``live``
    writes the firmware's files in a folder (:attr:`~deltacal.printer.firmware.base.Firmware.live_files`).
    Every file is checked before the calibration is read.
    """
    read = config_files(request.config, request.controller) if request.config is not None else ()
    inputs = (request.calibration, request.robot, request.config)
    output = request.mjcf if request.mjcf is not None else request.output
    check_files(inputs, None if request.live else output, read)
    live = firmware_named(str(request.controller)) if request.live else None
    if live is not None and request.output is not None:
        check_output_folder(request.output, live.live_files, (*inputs, *read), "export --live")
    if request.mjcf is not None:
        geometry, stations = _exported_geometry(request.calibration)
        return wing_for(geometry.chain).export_mjcf(request, geometry, stations)
    calibration = load_calibration(request.calibration)
    return wing_for(calibration.geometry.chain).export_controller(request, calibration)


def _exported_geometry(path: str | Path) -> tuple[DeltaGeometry, list[str]]:
    """The geometry of a calibration, geometry or robot file (either kind), and the calibration's stations.

    Raises:
        InputError: naming the file, key and value of the first problem found.
    """
    data = read_toml(path)
    geometry = data.get("geometry")
    if "format" not in data and (data.get("kind") is not None or (
            isinstance(geometry, Mapping) and "base_radius_mm" in geometry)):  # a robot file: no format key
        return _wing_of_file(data, path).load(path, data).geometry(), []
    calibration = load_calibration(path)  # a calibration or geometry file, checked as every command does
    return calibration.geometry, list(calibration.frames)


def report(request: ReportRequest) -> Done:
    """``deltacal report``: the calibration's HTML page, through its wing (a printer's: its firmware)."""
    check_files((request.calibration, *(request.measurements or ()), request.truth, request.robot,
                 request.controller, *(request.history or ())), request.output)
    calibration = load_calibration(request.calibration)
    return wing_for(calibration.geometry.chain).report(request, calibration)


def compare(request: CompareRequest) -> Done:
    """``deltacal compare OLD NEW [NEWER ...]``: what changed in a printer between its calibrations."""
    check_files(request.files, request.output)
    return compare_printer_calibrations(request)


def import_found(request: ImportRequest) -> Done:
    """``deltacal import``: a printer as its firmware's configuration finds it, or a log's probe results."""
    return import_found_printer(request)


def compensate(request: CompensateRequest, progress: Progress | None = None) -> Done:
    """``deltacal compensate``: joint readings, a controller's corrected targets or a corrected program."""
    return compensate_targets(request, progress)


__all__ = [
    "PRINTER",
    "ROTARY",
    "WINGS",
    "CompareRequest",
    "CompensateRequest",
    "Done",
    "ExportRequest",
    "IdentifyRequest",
    "ImportRequest",
    "PlanRequest",
    "PrinterWing",
    "ReportRequest",
    "RotaryWing",
    "SimulateRequest",
    "Wing",
    "compare",
    "compensate",
    "export",
    "identify",
    "import_found",
    "plan",
    "report",
    "robot_wing",
    "simulate",
    "wing_for",
]
