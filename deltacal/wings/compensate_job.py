"""The compensate job, either kind: joint readings (or a controller's targets) that put the TCP on targets.

With a controller (``request.controller``) the output holds, after the targets, the targets to send a
controller running that model (:func:`~deltacal.controller.corrected_targets`), computed and refused
chunk by chunk as the joint readings are. A printer's firmware configuration is told and read once
(:func:`~deltacal.printer.firmware.config_file.controller_firmware`): its values give the controller,
the same-printer check and the reading of G-code.

The targets file is streamed: read and checked whole first (a bad row fails at reading
speed, before anything is computed), each chunk screened on the way by the closed-form
virtual model (:func:`~deltacal.compensation.screen`: a target it doubts is refused only
if the exact computation refuses it), then read again chunk by chunk, compensated,
checked and written, so memory stays flat in the file's length (a large file on every core:
:mod:`.workers`). A bad value anywhere is named first; an unreachable target the screen found,
once the file is read. The joints file replaces an earlier one only once complete. A G-code program
is rewritten move by move (:func:`~deltacal.gcode.filter_gcode`).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..calibration import Calibration
from ..compensation import screen
from ..controller import CommandModel, RefusedCommands
from ..exceptions import InputError, UnreachableError, UsageError
from ..gcode import DEFAULT_SEGMENT_MM, filter_gcode, marker_line
from ..io import CommandsWriter, JointsWriter, TargetChunk, TargetFile, lines_text, load_calibration
from ..io.controller_file import load_controller_file
from ..io.paths import check_output
from ..printer.firmware import config_files
from ..printer.firmware.base import Firmware
from ..printer.firmware.config_file import (
    FirmwareConfig,
    RotaryFirmwareConfig,
    controller_firmware,
    settings_read,
)
from ..printer.identification.where import holds_in_words
from .base import Done, check_files, warn
from .requests import CompensateRequest
from .workers import Job, Refused, shared_values, solved_in_order

#: A firmware's configuration read once: a linear Delta printer's or a rotary one's.
Settings = FirmwareConfig | RotaryFirmwareConfig

#: ``progress(fraction, detail)``: how far the job is (0..1), and what it is at.
Progress = Callable[[float, str], None]


def compensate_targets(request: CompensateRequest, progress: Progress | None = None) -> Done:
    """``deltacal compensate``: the joints (or corrected targets, or corrected program) file written."""
    inputs = (request.calibration, request.targets, request.controller)
    check_files(inputs, None)  # before any is opened
    # the firmware whose configuration --controller is (told once), or None; no output over a file it reads
    kind = None if request.controller is None else controller_firmware(request.controller, request.firmware)
    read = () if kind is None else config_files(str(request.controller), kind)
    live = None if kind is None else kind.live_correction(str(request.controller))
    if live is not None:  # a printer that corrects every move itself: corrected offline, twice
        raise live.refuse_compensate()
    check_output(request.output, [*inputs, *read])
    report: Progress = progress or (lambda fraction, detail: None)
    if request.program:
        return _program(request, report, kind)
    calibration = load_calibration(request.calibration)  # read and checked once
    if request.controller is not None:
        calibration.where_held()  # a printer's correction for a controller reads it: refused without
    elif calibration.geometry.chain.firmware:
        raise UsageError(f"{request.calibration} is a printer's calibration: give --controller, its "
                         "firmware's settings (printer.cfg, an M503 capture or config.g), to write the "
                         "corrected targets its commands go through (a joints file holds a rotary Delta's "
                         "readings, in degrees)")
    _warn_rigid_route(request, calibration.geometry.compliance)
    controller, said = None, cast(tuple[str, ...], ())
    if request.controller is not None:
        controller, _, said, calibration = _controller(request, calibration, kind)
    geometry, frames = calibration.geometry, calibration.instrument
    targets_file = TargetFile(request.targets)
    linear = None if request.method == "exact" else _linear(calibration, str(request.calibration))
    to_base = _to_base(request, frames)
    size = max(targets_file.size, 1)
    refused: tuple[UnreachableError, TargetChunk] | None = None
    for chunk in targets_file.chunks():  # the whole file checked before anything is computed
        if refused is None:
            try:  # fail fast where the reading can tell: the virtual model's suspects, decided exactly
                screen(geometry, chunk.targets if to_base is None else to_base(chunk.targets), request.method,
                       linear)
            except UnreachableError as exc:
                if not exc.indices:
                    raise
                refused = exc, chunk
        report(0.1 * chunk.read / size, "reading")
    warn(targets_file.warnings)
    if refused is not None:  # a bad value anywhere came first; the file's rows are now known
        raise _unreachable(*refused, targets_file, _frame_hint(request, frames)) from refused[0]
    writer = JointsWriter if controller is None else CommandsWriter
    job = Job(geometry, controller, request.method, linear, request.payload, writer, calibration,
              request.sigma_bound, request.refuse_unheld)
    beyond = None if controller is None or controller.limits is None else RefusedCommands(controller.limits)
    with writer(request.output) as out:
        for chunk, values in solved_in_order(job, targets_file.chunks(), to_base, targets_file.rows):
            if isinstance(values, UnreachableError):
                if not values.indices:
                    raise values
                raise _unreachable(values, chunk, targets_file, _frame_hint(request, frames)) from values
            if isinstance(values, Refused):  # gathered over the whole file, refused at its end
                assert beyond is not None
                beyond.check(values.commands, chunk.lines[values.indices],
                             lambda k, c=chunk, v=values: c.where(int(v.indices[k])))
            elif beyond is None or not beyond.count:
                out.write_encoded(values, len(chunk))
            report(0.1 + 0.9 * chunk.read / size, f"{out.rows:,} targets")
        refusal = None if beyond is None else beyond.error(targets_file.source)
        if refusal is not None:
            raise refusal
    what = ("joint readings" if controller is None
            else f"corrected targets for the controller {request.controller}")
    held = () if controller is None else where_it_holds(calibration, request.sigma_bound)
    return Done((*said, f"wrote {out.rows} {what} to {request.output}", *held))


def _warn_rigid_route(request: CompensateRequest, compliance: np.ndarray) -> None:
    """A compliant calibration through a linear method, which models no gravity: say what it leaves out.

    And a payload given for a calibration without compliances: it changes nothing.
    """
    if request.payload and not np.any(compliance):
        warn([f"{request.calibration}: --payload {request.payload:g} changes nothing: the calibration holds "
              "no actuator compliance (identify --compliance, from measurements at two payloads)"])
    if np.any(compliance) and request.method != "exact":
        warn([f"{request.calibration}: the actuators' compliances are identified, but --method "
              f"{request.method} models no gravity: the robot's own deflection is not compensated (--method "
              "exact's is)"])


def _program(request: CompensateRequest, report: Progress, kind: Firmware[Any] | None) -> Done:
    """A G-code program for ``--controller``: every move corrected, streamed."""
    assert request.controller is not None
    segment = DEFAULT_SEGMENT_MM if request.segment_mm is None else request.segment_mm
    calibration = load_calibration(request.calibration)
    calibration.where_held()  # each move's correction reads it: refused without
    _warn_rigid_route(request, calibration.geometry.compliance)
    controller, config, said, calibration = _controller(request, calibration, kind)
    if controller.interpolation != "cartesian":  # what splitting moves into corrected segments assumes
        raise UsageError(f"--controller {request.controller}: a controller interpolating in "
                         f"{controller.interpolation} space cannot be sent a corrected G-code program")
    job = Job(calibration.geometry, controller, "exact", None, request.payload, None, calibration,
              request.sigma_bound, request.refuse_unheld)
    lines = os.path.getsize(request.targets) // 25  # about 25 bytes a line: sets whether workers share it
    dialect = None
    if config is not None:
        with warnings.catch_warnings():  # the configuration's warnings were said when it was read
            warnings.simplefilter("ignore")
            dialect = config.dialect()
    marker = marker_line(str(request.controller), str(request.calibration))
    start = None if request.start is None else list(request.start)
    with shared_values(job, lines) as correct:
        filter_gcode(request.targets, request.output, correct, segment, start,
                     lambda fraction, _: report(fraction, "program"), home=controller.home,
                     dialect=dialect, limits=controller.limits, marker=marker)
    return Done((*said, f"wrote the program corrected for the controller {request.controller} to "
                 f"{request.output} (moves split every {segment:g} mm at most)",
                 *where_it_holds(calibration, request.sigma_bound)))


def _controller(request: CompensateRequest, calibration: Calibration, kind: Firmware[Any] | None
                ) -> tuple[CommandModel, Settings | None, tuple[str, ...], Calibration]:
    """``--controller``'s model (and its firmware ``kind``'s configuration, read once, or None), checked.

    Refused if not of the robot's kind (rotary, printer), of another firmware than the calibration
    recorded, or of another printer; what to say of its values against the recorded ones, and the
    calibration re-anchored to them where they changed
    (:meth:`~deltacal.printer.firmware.config_file.FirmwareConfig.anchor`). A printer's readings
    count steps in its nominal step distance, the calibration's (a Klipper configuration's own
    ``rotation_distance`` may have been refitted per tower since).
    """
    geometry = calibration.geometry
    assert request.controller is not None
    config = None if kind is None else settings_read(kind, request.controller)
    if config is None:
        controller: CommandModel = load_controller_file(request.controller)
    else:
        controller = config.controller(geometry.step_distance)
    chain = controller.virtual.chain
    if chain != geometry.chain:
        raise UsageError(f"--controller {request.controller} is {chain.words.a_kind}'s, but the calibration "
                         f"{request.calibration} is of {geometry.chain.words.a_kind}")
    said: tuple[str, ...] = ()
    if config is not None:  # a printer's calibration re-anchored; a rotary one's put in the firmware's frame
        calibration, said = config.anchor(calibration, request.calibration)
    return controller, config, said, calibration


def _to_base(request: CompensateRequest, frames: dict) -> Callable[[np.ndarray], np.ndarray] | None:
    """The map of the targets to the base frame {O} (None: they are in it), from --frame and --station."""
    if request.frame != "instrument":
        return None
    if not frames:
        raise UsageError(f"{request.calibration}: no [instrument] table: --frame instrument needs a "
                         "calibration identified with --frame free")
    station = request.station
    if station is None:
        if len(frames) > 1:
            raise UsageError(f"--station is needed: the calibration has stations {', '.join(frames)}")
        station = next(iter(frames))
    if station not in frames:
        raise UsageError(f"--station {station!r}: the calibration's stations are {', '.join(frames)}")
    return frames[station].to_base


def _linear(calibration: Calibration, path: str) -> Any:
    """The linear compensators' view of a calibration (a geometry file has none)."""
    if not calibration.base:
        raise InputError("not a calibration file (format 'deltacal-geometry-1'): a geometry file has no "
                         "base parameters for savoure or bai; use --method exact",
                         path, "key format")
    try:
        return calibration.linear()
    except InputError as exc:  # a free-frame calibration: the method asked for cannot serve it
        raise UsageError(str(exc)) from None


def _frame_hint(request: CompensateRequest, frames: dict) -> str:
    """What to try when targets are out of reach and the calibration has instrument stations."""
    if not frames:
        return ""
    if request.frame == "instrument":
        return "; are the targets in the robot base frame {O}? then leave out --frame instrument"
    station = " --station " + "|".join(frames) if len(frames) > 1 else ""
    return (f"; are the targets in the tracker's frame? the calibration has stations ({', '.join(frames)}): "
            f"use --frame instrument{station}")


def _unreachable(exc: UnreachableError, chunk: TargetChunk, targets_file: TargetFile,
                 hint: str = "") -> InputError:
    """The error naming the first unreachable target's line (and the others of its chunk), and a hint."""
    k = exc.indices[0]
    lines = chunk.lines[exc.indices].tolist()
    whole = len(chunk) == targets_file.rows
    scope = "in all" if whole else f"in lines {int(chunk.lines[0])}-{int(chunk.lines[-1])}"
    more = f"; {len(lines)} targets {scope}, lines {lines_text(lines)}" if len(lines) > 1 else ""
    return InputError(
        f"target {np.round(chunk.targets[k], 6).tolist()} mm is {UnreachableError.WORDS[exc.reason]}{more}"
        + (hint if exc.reason == UnreachableError.OUT_OF_REACH and len(lines) * 2 > len(chunk) else ""),
        targets_file.source, f"{chunk.where(k)}, columns x_mm..z_mm",
    )


def where_it_holds(calibration, bound: float) -> tuple[str, ...]:
    """Where a printer's corrections were applied, why not elsewhere, what to measure (none if unknown)."""
    if calibration is None or getattr(calibration, "holds", None) is None:
        return ()
    return (f"corrections applied where their σ is at most {0.5 * bound:g} mm, blended into the controller's "
            f"own commands up to {bound:g} mm (--sigma-bound): {holds_in_words(calibration.holds, bound)}",)
