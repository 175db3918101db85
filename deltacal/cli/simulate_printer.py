"""``deltacal simulate`` for a printer: plan's templates filled by a true printer through its firmware.

``deltacal simulate PRINTER.toml PROBE.csv [DISTANCES.csv] --controller printer.cfg (--perturb SEED |
--truth TRUE.toml) -o OUT_PROBE.csv [--distances-output OUT_DISTANCES.csv]`` reads the templates
``plan --object`` wrote (the commanded x, y of each probe point; the commanded pairs of features;
the measured column empty or not: it is replaced in the output), runs them on a true printer
through the firmware (:mod:`deltacal.printer.simulation`) and writes the filled files. The
readings count steps in the robot file's nominal step distance, as ``identify`` reads them.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..exceptions import AssemblyError, InputError, UnreachableError, UsageError
from ..geometry import DeltaGeometry, Tolerances
from ..io import data_row, load_geometry, save_geometry
from ..printer.files.measurements import (
    read_printed_distances,
    read_probe_heights,
    write_printed_distances,
    write_probe_heights,
)
from ..printer.firmware.base import FirmwareModel
from ..printer.robot import NominalLinearDelta
from ..printer.simulation import (
    KIT_BED_TILT_DEG,
    WELL_BUILT_BED_TILT_DEG,
    printed_distances,
    probe_heights,
    random_true_printer,
    typical_kit,
    well_built,
)
from ..simulation import truth_path
from .common import check_input, check_output, non_negative_float, three_numbers
from .firmware import add_firmware_argument, controller_firmware

#: ``simulate`` options of a rotary Delta's measurements, which a printer's simulation does not take.
ROTARY_OPTIONS = ("points", "sigma_position", "sigma_angle", "no_orientation", "repeats", "payload",
                  "compliance", "station")
#: ``simulate`` options of a printer's simulation, which a rotary Delta's does not take.
PRINTER_OPTIONS = ("controller", "firmware", "distances_output", "sigma_height", "sigma_distance",
                   "probe_offset", "tolerances")
#: ``--tolerances``: the build tolerances of a perturbed printer and the σ of its bed's tilts [deg].
TOLERANCE_CLASSES = {
    "printer-kit": (Tolerances.printer_kit, KIT_BED_TILT_DEG),
    "typical-kit": (typical_kit, KIT_BED_TILT_DEG),
    "well-built": (well_built, WELL_BUILT_BED_TILT_DEG),
}
#: Default σ of a probe height and of a caliper distance [mm] (as ``identify`` assumes them).
SIGMA_HEIGHT = 0.01
SIGMA_DISTANCE = 0.02


def add_printer_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``simulate`` that serve printers (default None: given or not is known)."""
    p.add_argument("--controller", metavar="SETTINGS",
                   help="a printer: the firmware's settings (Klipper's printer.cfg, Marlin's M503 "
                        "capture, RepRapFirmware's config.g) the probing and the print are commanded with")
    add_firmware_argument(p)
    p.add_argument("--distances-output", metavar="OUT_DISTANCES.csv",
                   help="a printer: the filled distances file (with a DISTANCES.csv template)")
    p.add_argument("--sigma-height", type=non_negative_float, metavar="MM",
                   help=f"a printer: σ of a probe height [mm] (default {SIGMA_HEIGHT:g})")
    p.add_argument("--sigma-distance", type=non_negative_float, metavar="MM",
                   help=f"a printer: σ of a caliper distance [mm] (default {SIGMA_DISTANCE:g})")
    p.add_argument("--probe-offset", type=lambda t: np.asarray(three_numbers(t, "X,Y,Z in mm")),
                   metavar="X,Y,Z",
                   help="a printer: the probe's trigger point from the nozzle, in the effector frame [mm] "
                        "(default 0,0,0: the nozzle is the probe)")
    p.add_argument("--tolerances", choices=tuple(TOLERANCE_CLASSES),
                   help="a printer with --perturb: its build tolerances (default printer-kit: "
                        "Tolerances.printer_kit(); typical-kit and well-built: the anchor's classes)")


def refuse_printer_options(args: argparse.Namespace) -> None:
    """A rotary Delta's simulation: refuse the options of a printer's."""
    given = [name for name in PRINTER_OPTIONS if getattr(args, name) is not None]
    if given:
        option = given[0].replace("_", "-")
        raise UsageError(f"--{option} applies to a printer's simulation (kind = 'linear')")


def run_printer(args: argparse.Namespace, printer: NominalLinearDelta) -> int:
    """Run ``deltacal simulate`` for a printer robot file: write the filled templates, return 0."""
    probe_file, distance_file = _check_usage(args)
    inputs = [args.nominal, args.controller, *args.poses, args.truth]
    for path in inputs:
        if path is not None:
            check_input(path)
    outputs = [Path(args.output)]
    if args.distances_output is not None:
        outputs.append(Path(args.distances_output))
    if args.truth is None:
        outputs.append(truth_path(args.output))
    for path in outputs:
        check_output(path, inputs)
    if len({p.resolve() for p in outputs}) != len(outputs):
        raise UsageError(f"the outputs {', '.join(map(str, outputs))} must be different files")
    kind = controller_firmware(args.controller, args.firmware)
    firmware = kind.read_config(args.controller)
    kind.check_same_printer(kind.nominal(printer), firmware, args.nominal, args.controller)
    truth = _truth(args, printer)
    step = printer.step_distance
    offset = np.zeros(3) if args.probe_offset is None else args.probe_offset
    rng = np.random.default_rng(args.seed)
    template = read_probe_heights(probe_file, filled=False)
    xy = template.commanded[:, :2]
    noise = SIGMA_HEIGHT if args.sigma_height is None else args.sigma_height
    robot = f"the true printer ({args.truth})" if args.truth is not None else "the perturbed printer"
    with _rows_named(probe_file, template.lines, xy, robot):
        probe = probe_heights(truth, firmware, step, xy, noise, rng, offset, trigger_height=template.heights)
    _check_travel(firmware, step, probe, probe_file, template.lines)
    pairs, measured, balls = None, None, None
    if distance_file is not None:
        printed = read_printed_distances(distance_file, filled=False)
        pairs, balls = printed.pairs, printed.balls or None
        noise = SIGMA_DISTANCE if args.sigma_distance is None else args.sigma_distance
        _check_travel(firmware, step, pairs, distance_file, printed.lines)
        with _rows_named(distance_file, printed.lines, pairs, robot):
            measured = printed_distances(truth, firmware, step, pairs, noise, rng)
    if args.truth is None:
        save_geometry(truth, truth_path(args.output))
    write_probe_heights(args.output, probe[:, :2], probe[:, 2],
                        trigger_height=template.trigger_height if template.trigger_height.size else None)
    if pairs is not None and measured is not None:
        write_printed_distances(args.distances_output, pairs, measured, balls)  # the template's labels kept
    _report(args, len(probe), None if measured is None else len(measured))
    return 0


def _check_usage(args: argparse.Namespace) -> tuple[str, str | None]:
    """The probe template and the distances template (or None), the options checked."""
    given = [name for name in ROTARY_OPTIONS if getattr(args, name) not in (None, False)]
    if given:
        raise UsageError(f"--{given[0].replace('_', '-')} applies to a rotary Delta's simulation, not to a "
                         "printer's")
    if args.controller is None:
        raise UsageError(f"{args.nominal}: a printer's measurements are of commanded positions: give "
                         "--controller printer.cfg (the Klipper configuration they are made with)")
    if len(args.poses) > 2:
        raise UsageError(f"a printer's templates are PROBE.csv and at most one DISTANCES.csv, got "
                         f"{len(args.poses)} files")
    distance_file = args.poses[1] if len(args.poses) == 2 else None
    if distance_file is not None and args.distances_output is None:
        raise UsageError(f"{distance_file}: give --distances-output OUT.csv for the filled distances")
    if distance_file is None and args.distances_output is not None:
        raise UsageError("--distances-output needs a DISTANCES.csv template after PROBE.csv")
    if args.tolerances is not None and args.truth is not None:
        raise UsageError("--tolerances applies to --perturb (the true printer of --truth is given)")
    return args.poses[0], distance_file


def _truth(args: argparse.Namespace, printer: NominalLinearDelta) -> DeltaGeometry:
    """The true printer: the geometry file of ``--truth``, or the nominal one perturbed (``--perturb``)."""
    if args.truth is not None:
        truth = load_geometry(args.truth)
        if truth.chain != printer.geometry().chain:
            raise InputError(f"a printer's true geometry has prismatic chains, got joint = {truth.joint!r} "
                             "(a rotary Delta's geometry?)", args.truth, "key joint")
        return truth
    tolerances, tilt = TOLERANCE_CLASSES[args.tolerances or "printer-kit"]
    return random_true_printer(printer, np.random.default_rng(args.perturb), tolerances(), tilt).geometry


def _check_travel(firmware: FirmwareModel, step_distance: np.ndarray | float, commanded: np.ndarray,
                  source: str, lines: np.ndarray) -> None:
    """Refuse, by its row, a commanded position (or pair of them) the firmware cannot reach.

    Out of the rods' reach, or a carriage above its endstop (a negative travel).
    """
    readings = firmware.inverse(commanded.reshape(-1, 3), step_distance, check=False)
    readings = readings.reshape(len(commanded), -1)
    bad = np.flatnonzero(~np.all(np.nan_to_num(readings, nan=-1.0) >= 0.0, axis=1))
    if bad.size:
        k = int(bad[0])
        why = "out of the rods' reach" if np.isnan(readings[k]).any() else "a carriage above its endstop"
        more = f" ({bad.size} rows in all)" if bad.size > 1 else ""
        raise InputError(f"the firmware cannot reach the commanded position {commanded[k].tolist()} mm "
                         f"({why}){more}", source, data_row(lines[k], k + 1))


@contextmanager
def _rows_named(source: str, lines: np.ndarray, rows: np.ndarray, robot: str) -> Iterator[None]:
    """A position the firmware or the true printer cannot reach becomes one line naming its row."""
    try:
        yield
    except (UnreachableError, AssemblyError) as exc:
        if not exc.indices:
            raise
        k = int(exc.indices[0])
        who = "the firmware" if isinstance(exc, UnreachableError) else robot
        more = f" ({len(exc.indices)} rows in all)" if len(exc.indices) > 1 else ""
        raise InputError(f"{who} cannot reach the commanded position {rows[k].tolist()} mm{more}",
                         source, data_row(lines[k], k + 1)) from exc


def _report(args: argparse.Namespace, probes: int, distances: int | None) -> None:
    """What was written, on stdout."""
    line = f"simulated {probes} probe heights -> {args.output}"
    if distances is not None:
        line += f"; {distances} distances -> {args.distances_output}"
    print(line)
    if args.truth is None:
        tolerances = args.tolerances or "printer-kit"
        print(f"true printer (seed {args.perturb}, {tolerances} tolerances, on its true bed) -> "
              f"{truth_path(args.output)}")

