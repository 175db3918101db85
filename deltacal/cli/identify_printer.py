"""``deltacal identify`` for a printer: its probe heights and printed distances, through its firmware.

The measurements are of commanded positions: each is turned into the readings the firmware
commanded (steps below the endstops, counted in the printer's nominal step distance) through
the firmware's own inverse model (the Klipper configuration they were made with), then
:func:`~deltacal.printer.identification.identify_printer` finds the full geometry on the true bed.
"""

from __future__ import annotations

import argparse

import numpy as np

from ..exceptions import InputError, UsageError
from ..geometry import Tolerances
from ..io import save_calibration
from ..printer.firmware.base import FirmwareModel
from ..printer.identification import PrinterMeasurements, identify_printer
from ..printer.measurement_files import read_printed_distances, read_probe_heights
from ..printer.robot import NominalLinearDelta
from .common import check_input, check_output, positive_float, sigma, three_numbers
from .firmware_option import add_firmware_option, controller_firmware

#: The error models of a printer.
PRINTER_MODELS = ("printer", "klipper")


def run_printer(args: argparse.Namespace, printer: NominalLinearDelta) -> int:
    """Run ``deltacal identify`` for a printer robot file; returns the exit status."""
    if args.controller is None:
        raise UsageError(f"{args.nominal}: a printer's measurements are of commanded positions: give "
                         "--controller printer.cfg|config.g (the firmware configuration they were made with)")
    model = args.model or "printer"
    if model not in PRINTER_MODELS:
        raise UsageError(f"--model {model}: a printer's models are {', '.join(PRINTER_MODELS)}")
    for flag in ("distances", "compliance", "free_points", "pairs"):
        if getattr(args, flag):
            raise UsageError(f"--{flag.replace('_', '-')} applies to a rotary Delta's measurements")
    files = list(args.measurements)
    inputs = [args.nominal, args.controller, *files]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    firmware = controller_firmware(args).read_config(args.controller)
    heights = read_probe_heights(files[0])
    probe = _readings(firmware, heights.commanded, printer.step_distance, files[0])
    pairs, distance = _read_distances(files[1:], firmware, printer.step_distance)
    data = PrinterMeasurements(probe, pairs, distance, probe_offset=args.probe_offset,
                               height_sigma=args.sigma_height, distance_sigma=args.sigma_distance,
                               trigger_height=heights.heights)
    result = identify_printer(printer.geometry(), data, model, method="linear" if args.linear else "iterated",
                              tolerances=Tolerances.printer_kit(),
                              tolerance_scale=args.tolerance_scale or "evidence")
    save_calibration(result, args.output)
    print(result.report())
    print(f"\nwrote {args.output}")
    return 0


def _read_distances(distance_files: list[str], firmware: FirmwareModel,
                    step_distance: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Readings of the printed pairs, and the distances measured."""
    pairs, distance = [np.zeros((0, 2, 3))], [np.zeros(0)]
    for path in distance_files:
        printed = read_printed_distances(path)
        both = _readings(firmware, printed.pairs.reshape(-1, 3), step_distance, path)
        pairs.append(both.reshape(-1, 2, 3))
        distance.append(printed.distance)
    return np.concatenate(pairs), np.concatenate(distance)


def _readings(firmware: FirmwareModel, commanded: np.ndarray, step_distance: np.ndarray | float,
              source: str) -> np.ndarray:
    """The readings the firmware commanded for positions; a position it cannot reach is named by row."""
    readings = firmware.inverse(commanded, step_distance, check=False)
    bad = np.flatnonzero(~np.all(np.isfinite(readings), axis=1))
    if bad.size:
        row = int(bad[0])
        raise InputError(f"row {row + 1}: the firmware cannot reach the commanded position "
                         f"{commanded[row].tolist()} mm (another printer's file?)", source)
    return readings


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``identify`` that serve printers."""
    p.add_argument("--controller", metavar="CONFIG",
                   help="a printer: the firmware configuration the measurements were made with (Klipper's "
                        "printer.cfg, RepRapFirmware's config.g)")
    add_firmware_option(p)
    p.add_argument("--probe-offset", type=lambda t: np.asarray(three_numbers(t, "X,Y,Z in mm")),
                   default=np.zeros(3), metavar="X,Y,Z",
                   help="a printer: the probe's trigger point from the nozzle, in the effector frame [mm] "
                        "(default 0,0,0: the nozzle is the probe; a probe file's trigger_height_mm is that "
                        "point's height above the bed at the trigger)")
    p.add_argument("--sigma-height", type=sigma, default=0.01, metavar="MM",
                   help="a printer: σ of a probe height [mm] (default 0.01)")
    p.add_argument("--sigma-distance", type=sigma, default=0.02, metavar="MM",
                   help="a printer: σ of a caliper distance [mm] (default 0.02)")
    p.add_argument("--tolerance-scale", type=positive_float, default=None, metavar="S",
                   help="a printer: the factor of the kit's build tolerances the priors take (default: the "
                        "one the measurements make most probable)")

