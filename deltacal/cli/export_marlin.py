"""``deltacal export CAL --controller marlin --config SETTINGS -o OUT.gcode``: Marlin's best values.

:func:`~deltacal.printer.firmware.marlin.fit.fit_marlin` finds the ``M665`` (``L R H`` and the
tower angle and rod trims), ``M666`` and ``M92`` values that leave the least nozzle error over the
printable volume of the identified printer (its true bed as z = 0, the printed part's frame, the
first layer's height errors weighted as Klipper's export weighs them), written by Marlin's rules
(``M666`` <= 0, the angle trims' sum 0). ``--config`` is the printer's ``M503`` capture: its values
start the fit and its ``M851`` (which ``M665 H`` depends on), soft endstops, ``M665 S`` and ``M92
E`` are kept. The file holds ``M665``, ``M666``, ``M92`` and ``M500``, to send to the printer.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from ..exceptions import ConvergenceError, GeometryError, InputError, UnreachableError, UsageError
from ..io import load_calibration
from ..printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT
from ..printer.firmware.marlin.firmware import MARLIN
from .common import check_input, check_output
from .export_klipper import _step_distance, _text, _workspace
from .firmware import check_printer_values, refuse_deltacal_file


def run_marlin(args: argparse.Namespace) -> int:
    """Run ``export --controller marlin``; returns the exit status."""
    if args.output is None:
        raise UsageError("--controller marlin needs -o CALIBRATED.gcode, the Marlin values to write")
    if args.home is not None:
        raise UsageError("--home applies to --mjcf")
    inputs = [p for p in (args.calibration, args.robot, args.config) if p is not None]
    for path in inputs:
        check_input(path)
    check_output(args.output, inputs)
    calibration = load_calibration(args.calibration)
    if not calibration.geometry.chain.firmware:
        raise UsageError(f"--controller marlin: {args.calibration} is a rotary Delta's calibration; Marlin's "
                         "values are a printer's (--controller offsets|limbs serve a rotary Delta)")
    if args.config is not None:
        refuse_deltacal_file(args.config, "--config")
    config = MARLIN.read_config(args.config) if args.config is not None else None
    step = _step_distance(calibration.geometry.step_distance, config, args,
                          "geometry.step_distance_mm" if calibration.base else "step_distance_mm")
    geometry, nominal = calibration.geometry, calibration.nominal
    if config is not None:
        check_printer_values(MARLIN, replace(geometry, step_distance=step), config, args.calibration,
                             args.config)
    try:
        start = config if config is not None else MARLIN.start(replace(nominal, step_distance=step))
    except GeometryError as exc:
        raise InputError(str(exc), str(args.calibration), "key nominal") from None
    workspace, where = _workspace(args, nominal)
    try:
        fit = MARLIN.fit(geometry, start, step, workspace, hold_step_distance=args.keep_rotation_distance,
                         first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        raise InputError(f"a target of the printable volume ({_text(workspace)}{where}) is out of Marlin's "
                         f"reach (row {k + 1} of the fit's grid): give --robot with a [workspace] it reaches",
                         str(args.robot or args.calibration), "key workspace") from None
    except ConvergenceError as exc:
        raise InputError(f"Marlin's values could not be fitted: {exc}", str(args.calibration)) from None
    before, after = fit.before, fit.after
    origin = "the --config values" if config is not None else "the nominal values"
    lines = [f"nozzle error over the printable volume ({_text(workspace)}{where}), of the printed part:",
             f"  these values: 3-D max {after.max_3d:.3f} mm, RMS {after.rms_3d:.3f} mm; first layer "
             f"(z 0.2 mm) max |dz| {after.flatness:.3f} mm",
             f"  {origin}: 3-D max {before.max_3d:.3f} mm, RMS {before.rms_3d:.3f} mm; first layer "
             f"max |dz| {before.flatness:.3f} mm",
             f"  held (not fitted): {', '.join(fit.held)}"]
    MARLIN.save_config(args.output, fit.values, title=f"Marlin delta values fitted by deltacal to "
                       f"{args.calibration}", notes=lines)
    print(f"wrote the Marlin values that best fit {args.calibration} to {args.output}")
    print("\n".join(lines))
    return 0
