"""``deltacal compensate``: joint readings (or a controller's corrected targets) that put the TCP on targets.

With ``--controller`` the output holds, after the targets, the targets to send a controller running
that model (:func:`~deltacal.controller.corrected_targets`), computed and refused chunk by chunk
as the joint readings are.

The targets file is streamed: read and checked whole first (a bad row fails at reading
speed, before anything is computed), each chunk screened on the way by the closed-form
virtual model (:func:`~deltacal.compensation.screen`: a target it doubts is refused only
if the exact computation refuses it), then read again chunk by chunk, compensated,
checked and written, so memory stays flat in the file's length. A bad value anywhere is
named first; an unreachable target the screen found, once the file is read. The joints
file replaces an earlier one only once complete.
"""

from __future__ import annotations

import argparse
import os
import warnings
from collections.abc import Callable

import numpy as np

from ..compensation import METHODS, screen
from ..controller import CommandModel, RefusedCommands
from ..exceptions import InputError, UnreachableError, UsageError
from ..gcode import (
    DEFAULT_SEGMENT_MM,
    MAX_COORDINATE_MM,
    MIN_SEGMENT_MM,
    filter_gcode,
    is_gcode_path,
    marker_line,
)
from ..gcode.dialect import Dialect
from ..holds import DEFAULT_BOUND
from ..io import (
    CommandsWriter,
    JointsWriter,
    TargetChunk,
    TargetFile,
    lines_text,
    load_calibration,
)
from ..printer.firmware import config_firmware
from ..printer.identification.where import holds_in_words
from ..robots import load_controller
from .common import check_input, check_output, non_negative_float, positive_float, three_numbers, warn
from .firmware import add_firmware_argument, check_config_printer, controller_firmware
from .progress import Progress
from .workers import Job, Refused, shared_values, solved_in_order


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal compensate``; returns the exit status."""
    if args.firmware is not None and args.controller is None:
        raise UsageError("--firmware applies with --controller (the firmware's configuration)")
    inputs = [p for p in (args.calibration, args.targets, args.controller) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    if args.controller is not None and args.method != "exact":
        raise UsageError("--method applies to joint readings: --controller's corrected targets come from the "
                         "exact compensation")
    _check_payload(args)
    if is_gcode_path(args.targets):
        return _program(args)
    if args.segment_mm is not None or args.start is not None:
        raise UsageError("--segment-mm and --start apply to a G-code program (.gcode, .gco, .g, .nc)")
    calibration = load_calibration(args.calibration)  # read and checked once
    _warn_rigid_route(args, calibration.geometry.compliance)
    controller = _controller(args, calibration.geometry) if args.controller is not None else None
    geometry, frames = calibration.geometry, calibration.instrument
    targets_file = TargetFile(args.targets)
    linear = None if args.method == "exact" else _linear(calibration, args.calibration)
    to_base = _to_base(args, frames)
    size = max(targets_file.size, 1)
    with Progress("compensate") as progress:
        refused: tuple[UnreachableError, TargetChunk] | None = None
        for chunk in targets_file.chunks():  # the whole file checked before anything is computed
            if refused is None:
                try:  # fail fast where the reading can tell: the virtual model's suspects, decided exactly
                    screen(geometry, chunk.targets if to_base is None else to_base(chunk.targets),
                           args.method, linear)
                except UnreachableError as exc:
                    if not exc.indices:
                        raise
                    refused = exc, chunk
            progress.update(0.1 * chunk.read / size, "reading")
        warn(targets_file.warnings)
        if refused is not None:  # a bad value anywhere came first; the file's rows are now known
            raise _unreachable(*refused, targets_file, _frame_hint(args, frames)) from refused[0]
        writer = JointsWriter if controller is None else CommandsWriter
        job = Job(geometry, controller, args.method, linear, args.payload, writer, calibration,
                  args.sigma_bound, args.refuse_unheld)
        limits = None if controller is None else controller.limits
        beyond = None if limits is None else RefusedCommands(limits)
        with writer(args.output) as out:
            for chunk, values in solved_in_order(job, targets_file.chunks(), to_base, targets_file.rows):
                if isinstance(values, UnreachableError):
                    if not values.indices:
                        raise values
                    raise _unreachable(values, chunk, targets_file, _frame_hint(args, frames)) from values
                if isinstance(values, Refused):  # gathered over the whole file, refused at its end
                    assert beyond is not None
                    beyond.check(values.commands, chunk.lines[values.indices],
                                 lambda k, c=chunk, v=values: c.where(int(v.indices[k])))
                elif beyond is None or not beyond.count:
                    out.write_encoded(values, len(chunk))
                progress.update(0.1 + 0.9 * chunk.read / size, f"{out.rows:,} targets")
            refusal = None if beyond is None else beyond.error(targets_file.source)
            if refusal is not None:
                raise refusal
    what = ("joint readings" if controller is None
            else f"corrected targets for the controller {args.controller}")
    print(f"wrote {out.rows} {what} to {args.output}")
    _where_it_holds(calibration if controller is not None else None, args.sigma_bound)
    return 0


def _where_it_holds(calibration, bound: float) -> None:
    """Say where a printer's corrections were applied, why not elsewhere, and what to measure."""
    if calibration is None or calibration.holds is None:
        return
    print(f"corrections applied where their σ is at most {0.5 * bound:g} mm, blended into the controller's "
          f"own commands up to {bound:g} mm (--sigma-bound): {holds_in_words(calibration.holds, bound)}")


def _check_payload(args: argparse.Namespace) -> None:
    """``--payload``: the exact method's (joint readings, or corrected targets for a controller)."""
    if not args.payload:
        return
    if args.method != "exact":
        raise UsageError(f"--payload: the {args.method} method cannot represent a payload (the linear "
                         "compensators know no gravity); use --method exact")


def _warn_rigid_route(args: argparse.Namespace, compliance: np.ndarray) -> None:
    """A compliant calibration through a linear method, which models no gravity: say what it leaves out.

    And a payload given for a calibration without compliances: it changes nothing.
    """
    if args.payload and not np.any(compliance):
        warn([f"{args.calibration}: --payload {args.payload:g} changes nothing: the calibration holds no "
              "actuator compliance (identify --compliance, from measurements at two payloads)"])
    if np.any(compliance) and args.method != "exact":
        warn([f"{args.calibration}: the actuators' compliances are identified, but --method {args.method} "
              "models no gravity: the robot's own deflection is not compensated (--method exact's is)"])


def _program(args: argparse.Namespace) -> int:
    """``compensate CAL PROGRAM.gcode --controller C -o OUT.gcode``: every move corrected, streamed."""
    if args.controller is None:
        raise UsageError(f"{args.targets}: a G-code program goes to a controller: give --controller (a "
                         "controller file, the robot file for its nominal controller, or a printer's "
                         "firmware configuration)")
    if args.frame != "base":
        raise UsageError("a G-code program is in the controller's frame, the robot base {O}: --frame "
                         "instrument applies to a targets CSV")
    segment = DEFAULT_SEGMENT_MM if args.segment_mm is None else args.segment_mm
    if segment < MIN_SEGMENT_MM:
        raise UsageError(f"--segment-mm {segment:g}: below {MIN_SEGMENT_MM:g} mm (100 times the output's 0.1 "
                         "µm resolution) the segments follow the rounding, not the path, and the program "
                         "grows without use")
    if args.start is not None and not all(abs(v) <= MAX_COORDINATE_MM for v in args.start):
        start = ",".join(f"{v:g}" for v in args.start)
        raise UsageError(f"--start {start}: beyond ±{MAX_COORDINATE_MM:g} mm, out of reach of any robot "
                         "(the TCP's position in mm)")
    calibration = load_calibration(args.calibration)
    _warn_rigid_route(args, calibration.geometry.compliance)
    controller = _controller(args, calibration.geometry)
    if controller.interpolation != "cartesian":  # what splitting moves into corrected segments assumes
        raise UsageError(f"--controller {args.controller}: a controller interpolating in "
                         f"{controller.interpolation} space cannot be sent a corrected G-code program")

    job = Job(calibration.geometry, controller, "exact", None, args.payload, None, calibration,
              args.sigma_bound, args.refuse_unheld)
    lines = os.path.getsize(args.targets) // 25  # about 25 bytes a line: sets whether workers share it
    dialect = _dialect(args.controller, args.firmware)
    marker = marker_line(args.controller, args.calibration)
    with Progress("compensate") as progress, shared_values(job, lines) as correct:
        filter_gcode(args.targets, args.output, correct, segment, args.start,
                     lambda fraction, _: progress.update(fraction, "program"), home=controller.home,
                     dialect=dialect, limits=controller.limits, marker=marker)
    print(f"wrote the program corrected for the controller {args.controller} to {args.output} "
          f"(moves split every {segment:g} mm at most)")
    _where_it_holds(calibration, args.sigma_bound)
    return 0


def _dialect(path: str, name: str | None = None) -> Dialect | None:
    """The controller's reading of G-code: its firmware's (``--firmware``, else the file's), or None."""
    firmware = config_firmware(path) if name is None else controller_firmware(path, name)
    if firmware is None:
        return None
    with warnings.catch_warnings():  # the configuration's warnings were said when it was read
        warnings.simplefilter("ignore")
        return firmware.dialect(path)


def _controller(args: argparse.Namespace, geometry) -> CommandModel:
    """``--controller``'s model, refused if not of the robot's kind (rotary, printer) or of another printer.

    A printer's readings count steps in its nominal step distance, the calibration's (a Klipper
    configuration's own ``rotation_distance`` may have been refitted per tower since).
    """
    if args.firmware is not None:
        firmware = controller_firmware(args.controller, args.firmware)
        controller = firmware.load_controller(args.controller, step_distance=geometry.step_distance)
    else:
        controller = load_controller(args.controller, step_distance=geometry.step_distance)
    chain = controller.virtual.chain
    if chain != geometry.chain:
        raise UsageError(f"--controller {args.controller} is {chain.words.a_kind}'s, but the calibration "
                         f"{args.calibration} is of {geometry.chain.words.a_kind}")
    check_config_printer(args.controller, args.firmware, geometry, args.calibration)
    return controller


def _to_base(args: argparse.Namespace, frames: dict) -> Callable[[np.ndarray], np.ndarray] | None:
    """The map of the targets to the base frame {O} (None: they are in it), from --frame and --station."""
    if args.frame != "instrument":
        if args.station is not None:
            raise UsageError("--station applies to --frame instrument only")
        return None
    if not frames:
        raise UsageError(f"{args.calibration}: no [instrument] table: --frame instrument needs a "
                         "calibration identified with --frame free")
    station = args.station
    if station is None:
        if len(frames) > 1:
            raise UsageError(f"--station is needed: the calibration has stations {', '.join(frames)}")
        station = next(iter(frames))
    if station not in frames:
        raise UsageError(f"--station {station!r}: the calibration's stations are {', '.join(frames)}")
    return frames[station].to_base


def _linear(calibration, path: str):
    """The linear compensators' view of a calibration (a geometry file has none)."""
    if not calibration.base:
        raise InputError("not a calibration file (format 'deltacal-geometry-1'): a geometry file has no "
                         "base parameters for savoure or bai; use --method exact",
                         path, "key format")
    try:
        return calibration.linear()
    except InputError as exc:  # a free-frame calibration: the method asked for cannot serve it
        raise UsageError(str(exc)) from None


def _frame_hint(args: argparse.Namespace, frames: dict) -> str:
    """What to try when targets are out of reach and the calibration has instrument stations."""
    if not frames:
        return ""
    if args.frame == "instrument":
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


def add_parser(sub) -> None:
    """Register ``compensate``."""
    p = sub.add_parser("compensate", help="joint readings that put the TCP at target positions")
    p.add_argument("calibration", help="calibration file written by identify (TOML)")
    p.add_argument("targets", help="targets (CSV: x_mm,y_mm,z_mm)")
    p.add_argument("-o", "--output", required=True, help="joints (or, with --controller, corrected targets) "
                                                          "file to write (CSV)")
    p.add_argument("--method", choices=METHODS, default="exact",
                   help="exact (default), or a linear compensator: savoure (Eq. 29-33), bai (Eq. 22-25)")
    p.add_argument("--frame", choices=("base", "instrument"), default="base",
                   help="targets in the robot base frame {O} (default), or in the instrument frame {T} of a "
                        "calibration identified with --frame free")
    p.add_argument("--station", help="with --frame instrument: the station whose frame the targets are in")
    p.add_argument("--controller", metavar="CONTROLLER",
                   help="write corrected targets (x_cmd_mm,y_cmd_mm,z_cmd_mm, in the base frame {O}) to "
                        "send a controller running this model (a controller file, a robot file: its "
                        "nominal controller, or a printer's firmware settings: Klipper's printer.cfg, "
                        "Marlin's M503 capture, RepRapFirmware's config.g) instead of joint readings")
    add_firmware_argument(p)
    p.add_argument("--payload", type=non_negative_float, default=0.0, metavar="KG",
                   help="mass carried at the TCP [kg] (default 0): with a calibration that identified the "
                        "actuators' compliances, the readings (or a controller's corrected targets) put "
                        "the loaded TCP on the targets (exact method)")
    p.add_argument("--sigma-bound", type=positive_float, default=DEFAULT_BOUND, metavar="MM",
                   help=f"a printer: the σ of a correction accepted [mm] (default {DEFAULT_BOUND:g}): where "
                        "the calibration's correction has a larger σ (the measurements do not determine it) "
                        "the controller's own command is sent, blended in from half of it")
    p.add_argument("--refuse-unheld", action="store_true",
                   help="a printer: refuse a target where the correction is not wholly applied (its σ above "
                        "half --sigma-bound) instead of sending the controller's own command there")
    p.add_argument("--segment-mm", type=positive_float, metavar="S",
                   help=f"G-code: longest move sent [mm] (default {DEFAULT_SEGMENT_MM:g}); longer moves are "
                        "split so the real path follows the intended straight line")
    p.add_argument("--start", type=lambda t: three_numbers(t, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="G-code: the TCP position at the program's start [mm], if its first move does "
                        "not give X, Y and Z")
    p.set_defaults(func=run)
