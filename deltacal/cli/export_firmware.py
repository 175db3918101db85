"""``deltacal export CAL --controller FIRMWARE --config SETTINGS -o OUT``: a firmware's values that fit best.

For a firmware other than Klipper (Marlin, RepRapFirmware; Klipper's route is :mod:`.export_klipper`):
through the firmware interface alone
(:class:`~deltacal.printer.firmware.base.Firmware`), its values that leave the least nozzle error
over the printable volume of the identified printer (its true bed as z = 0), judged in the printed
part's frame, with the first layer's height errors weighted as Klipper's export weighs them
(:data:`~deltacal.printer.firmware.klipper.fit.EXPORT_FIRST_LAYER_WEIGHT`). The fit starts from
``--config`` (the settings the printer runs, whose other values it keeps: RRF's print radius, its
microstepping), else from the calibration's nominal printer. What the values leave, in the whole
and of each error source alone (:func:`.export_klipper.source_budget`, Klipper's lines), is printed
and kept as comments in the file, then how to apply the file (:attr:`Firmware.apply_note
<deltacal.printer.firmware.base.Firmware.apply_note>`, also its header's second line).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from ..exceptions import ConvergenceError, GeometryError, InputError, UnreachableError, UsageError
from ..io import load_calibration
from ..printer.firmware.base import Firmware
from ..printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT
from .common import check_input, check_output
from .export_klipper import _step_distance, _text, _workspace, source_budget, summary
from .firmware import check_printer_values, refuse_deltacal_file


def run_firmware(args: argparse.Namespace, firmware: Firmware[Any]) -> int:
    """Run ``export --controller NAME`` for a firmware; returns the exit status."""
    if args.output is None:
        raise UsageError(f"--controller {firmware.name} needs -o OUT, the firmware's values to write")
    if args.home is not None:
        raise UsageError("--home applies to --mjcf")
    inputs = [p for p in (args.calibration, args.robot, args.config) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    if not calibration.geometry.chain.firmware:
        raise UsageError(f"--controller {firmware.name}: {args.calibration} is a rotary Delta's "
                         "calibration; a firmware's values are a printer's (--controller offsets|limbs "
                         "serve a rotary Delta)")
    if args.config is not None:
        refuse_deltacal_file(args.config, "--config")
    config = firmware.read_config(args.config) if args.config is not None else None
    step = _step_distance(calibration.geometry.step_distance, config, args,  # type: ignore[arg-type]
                          "geometry.step_distance_mm" if calibration.base else "step_distance_mm")
    geometry, nominal = calibration.geometry, calibration.nominal
    if config is not None:
        check_printer_values(firmware, replace(geometry, step_distance=step), config, args.calibration,
                             args.config)
    try:
        start = config if config is not None else firmware.start(replace(nominal, step_distance=step))
    except GeometryError as exc:
        raise InputError(str(exc), str(args.calibration), "key nominal") from None
    workspace, where = _workspace(args, nominal)
    try:
        fit = firmware.fit(geometry, start, step, workspace, hold_step_distance=args.keep_rotation_distance,
                           first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)
        budget = source_budget(firmware, geometry, nominal, start, step, workspace,
                               args.keep_rotation_distance)
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"a target of the printable volume ({_text(workspace)}{where}) is out of the "
                         f"firmware's reach (row {k + 1} of the fit's grid): give --robot with a "
                         "[workspace] it reaches",
                         str(args.robot or args.calibration), "key workspace") from None
    except ConvergenceError as exc:
        raise InputError(f"the firmware's values could not be fitted: {exc}", str(args.calibration)) from None
    lines = summary(firmware, fit.before, fit.after, budget, workspace, where, fit.held, config is not None)
    firmware.save_config(args.output, fit.values, args.config,
                         title=f"{firmware.title} values fitted by deltacal to {args.calibration}",
                         notes=lines)
    print(f"wrote the {firmware.title} values that best fit {args.calibration} to {args.output}")
    print("\n".join(lines))
    print(f"to apply: {firmware.apply_note}")
    return 0
