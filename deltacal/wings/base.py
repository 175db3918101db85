"""The interface each robot kind's wing implements: its robot file and its jobs, asked, never tested for.

A rotary Delta and a linear Delta printer are calibrated by the same engine, but read different robot
files and do each job their own way: a rotary Delta plans poses and is measured by a tracker, a printer
prints an object and is measured through its firmware. Each kind is one :class:`Wing` object
(:data:`~deltacal.wings.rotary.ROTARY`, :data:`~deltacal.wings.printer.PRINTER`), found once from the
robot file's kind or the calibration's chain (:func:`deltacal.wings.robot_wing`,
:func:`deltacal.wings.wing_for`), the way each firmware is one
:class:`~deltacal.printer.firmware.base.Firmware`. A job takes its request
(:mod:`deltacal.wings.requests`: the options, checked once), does the work, writes its files and returns
:class:`Done`: the lines the command prints. Warnings about the inputs go out as they arise, through
:mod:`warnings` (:class:`~deltacal.exceptions.InputWarning`; the command line prints each on one line).
"""

from __future__ import annotations

import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ..calibration import Calibration
from ..chains import Chain
from ..exceptions import InputError, InputWarning, UsageError
from ..export import write_mjcf
from ..geometry import DeltaGeometry, NominalDelta
from ..identification.quality import implausible_deviations
from ..io import load_geometry
from ..io.paths import check_input, check_inputs, check_output
from ..printer.firmware.base import Firmware, FirmwareModel
from ..printer.robot import NominalLinearDelta
from ..report import write_report
from ..robots import load_robot
from .requests import (
    ExportRequest,
    IdentifyRequest,
    PlanRequest,
    ReportRequest,
    SimulateRequest,
)

#: A robot file's nominal robot, of either kind.
Robot = NominalDelta | NominalLinearDelta


@dataclass(frozen=True)
class Done:
    """What a job did, as the command says it: the lines it prints on standard output.

    Attributes:
        lines: Each printed as given (a line may hold several, a report say).
    """

    lines: tuple[str, ...] = ()


def warn(lines: Iterable[str]) -> None:
    """Each line as an :class:`~deltacal.exceptions.InputWarning`, now (printed on one line each)."""
    for line in lines:
        warnings.warn(line, InputWarning, stacklevel=2)


class Wing(ABC):
    """A robot kind's jobs: its robot file read, poses or an object planned, simulated, identified, exported.

    Attributes:
        name: The kind's name (``"rotary"``, ``"printer"``).
        chain: The kind's actuated chain (:data:`~deltacal.chains.REVOLUTE`,
            :data:`~deltacal.chains.PRISMATIC`): a robot file's ``kind`` and a calibration's
            geometry find the wing by it.
    """

    name: ClassVar[str]
    chain: ClassVar[Chain]

    @abstractmethod
    def load(self, path: str | Path, data: dict | None = None) -> Robot:
        """The kind's robot file (``data``: its TOML already parsed, so that it is read once).

        Raises:
            InputError: naming the file and the key of the first problem found.
        """

    @abstractmethod
    def plan(self, request: PlanRequest, robot: Robot | None = None,
             notify: Callable[[str], None] | None = None) -> Done:
        """``deltacal plan``: where to measure (poses, or a printer's printed object), written to ``output``.

        Args:
            request: The options.
            robot: The robot file's robot, if already read (else read from ``request.nominal``).
            notify: Told what a long selection will cost, before it starts (one line).
        """

    @abstractmethod
    def simulate(self, request: SimulateRequest, robot: Robot | None = None) -> Done:
        """``deltacal simulate``: a true robot's measurements at the planned poses or object, written."""

    @abstractmethod
    def identify(self, request: IdentifyRequest, robot: Robot | None = None) -> Done:
        """``deltacal identify``: the geometry from measurements, the calibration file written."""

    @abstractmethod
    def export_controller(self, request: ExportRequest, calibration: Calibration) -> Done:
        """``deltacal export --controller KIND``: the controller's values that fit best, written."""

    def report_firmware(self, request: ReportRequest, calibration: Calibration
                        ) -> tuple[Firmware[Any] | None, FirmwareModel | None, tuple[str, ...], Calibration]:
        """The firmware whose values a report fits (a printer's), or None (a rotary Delta's controller).

        And the firmware's values the measurements were commanded with (``--controller``), or None;
        what to say of them (values changed since the calibration: none by default); and the
        calibration to report (re-anchored to changed values: a printer's).

        Raises:
            UsageError: an option of the other kind.
        """
        return None, None, (), calibration

    def report_history(self, request: ReportRequest, calibration: Calibration, firmware: Firmware[Any] | None
                       ) -> tuple[str | None, tuple[str, ...]]:
        """The report's history of the calibrations (``--history``), an HTML fragment, and what to say.

        A printer's (its wing's); ``calibration``: as read from its file.

        Raises:
            UsageError: ``--history`` of a robot that is not a printer.
        """
        if request.history:
            robot = calibration.geometry.chain.words.a_robot
            raise UsageError(f"--history: {request.calibration} is {robot}'s calibration; the history is of "
                             "a printer's calibrations")
        return None, ()

    def export_mjcf(self, request: ExportRequest, geometry: DeltaGeometry, stations: Sequence[str]) -> Done:
        """``deltacal export --mjcf``: the robot as an MJCF model, of either kind (:func:`write_mjcf`).

        Raises:
            UsageError: ``home`` out of the kind's range.
        """
        assert request.mjcf is not None
        home = home_readings(request.home, geometry.chain)
        write_mjcf(request.mjcf, geometry, name=request.name, home=home, stations=stations,
                   source=str(request.calibration))
        frame = " (robot base frame {O}; the instrument frames are not exported)" if stations else ""
        return Done((f"wrote the MJCF model of {request.name or geometry.name or 'delta'} to {request.mjcf}"
                     f"{frame}",))

    def report(self, request: ReportRequest, calibration: Calibration) -> Done:
        """``deltacal report``: one self-contained HTML page of the calibration (:func:`write_report`)."""
        read = calibration
        firmware, controller, said, calibration = self.report_firmware(request, calibration)
        history, told = self.report_history(request, read, firmware)
        said += told
        nominal = calibration.nominal
        truth = load_geometry(request.truth) if request.truth is not None else None
        robot = load_robot(request.robot) if request.robot is not None else None
        for path, geometry, what in ((request.truth, truth, "true robot"),
                                     (request.robot, robot.geometry() if robot else None, "robot file")):
            odd = implausible_deviations(nominal, geometry) if geometry is not None else []
            if odd:
                name = nominal.name or "robot"
                raise InputError(f"this {what} is not the calibration's robot ({'; '.join(odd)} from the "
                                 f"calibration's nominal {name!r}): the file of another robot?", str(path))
        summary = write_report(calibration, request.output, measurements=request.measurements, truth=truth,
                               truth_source=None if request.truth is None else str(request.truth),
                               tool=request.tool, payload=request.payload,
                               workspace=robot.workspace if robot is not None else None,
                               view=not request.no_view, firmware=firmware, controller=controller,
                               history=history)
        warn(summary.warnings)
        w = summary.worst_point
        return Done((*said, f"largest predicted σ of the TCP: {summary.worst_sigma * 1000.0:.4g} µm at "
                     f"({w[0]:.1f}, {w[1]:.1f}, {w[2]:.1f}) mm", f"wrote {request.output}"))


def home_readings(text: str | None, chain: Chain) -> np.ndarray | None:
    """``--home`` (``Q1,Q2,Q3``) as readings, checked for the robot's kind.

    Arm angles in degrees within ±180 (one turn) -> [rad]; carriage travels below the endstops [mm],
    not negative (a carriage does not rise above its endstop).

    Raises:
        UsageError: three numbers out of the kind's range.
    """
    if text is None:
        return None
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise UsageError(f"argument --home: expected three numbers Q1,Q2,Q3, got {text!r}") from None
    low, high = chain.option_range
    if values.shape != (3,) or np.any((values < low) | (values > high)) or not np.all(np.isfinite(values)):
        raise UsageError(f"argument --home: {chain.words.reading_rule}, got {text!r}")
    return chain.reading_from_file(values)


def check_files(inputs: Sequence[str | Path | None], output: str | Path | None,
                read: Sequence[str | Path] = ()) -> None:
    """Each input an existing file, the output one deltacal may write and none of the inputs (status 2).

    ``read``: the files a firmware's configuration reads besides itself (Klipper's includes,
    :func:`~deltacal.printer.firmware.config_files`), which the output may not overwrite either.
    """
    check_inputs(inputs)
    if output is not None:
        check_output(output, [*inputs, *read])


__all__ = ["Done", "Robot", "Wing", "check_files", "check_input", "home_readings", "warn"]
