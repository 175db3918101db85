"""``deltacal export CAL --controller klipper -o CALIBRATED.cfg``: the firmware values that fit best.

Klipper's model (vertical towers, one rod per tower, a point effector) cannot hold a real printer:
:func:`~deltacal.printer.firmware.klipper.fit.fit_klipper` finds its ``delta_radius``, tower ``angle``,
``arm_length``, ``position_endstop`` and ``rotation_distance`` that leave the least nozzle error
over the printable volume of the identified printer (its true bed as z = 0), judged in the printed
part's frame, with the first layer's height errors weighted
(:data:`~deltacal.printer.firmware.klipper.fit.EXPORT_FIRST_LAYER_WEIGHT`) so that its flatness is not
traded for the volume's. The file written holds only the keys Klipper knows, ready to replace those in
``printer.cfg``; what the values leave is printed (and kept as comments in the file), with what
each error source alone would leave (:func:`~deltacal.printer.firmware.budget.error_budget`):
what ``compensate`` corrects through the firmware.
"""

from __future__ import annotations

import argparse

from ..printer.firmware.klipper.firmware import KLIPPER
from ..printer.firmware.klipper.fit import EXPORT_FIRST_LAYER_WEIGHT
from .export_firmware import export_start, fit_refusals, source_budget, summary


def run_klipper(args: argparse.Namespace) -> int:
    """Run ``export --controller klipper``; returns the exit status."""
    begun = export_start(
        args, KLIPPER, "CALIBRATED.cfg, the Klipper values to write", "Klipper's values",
        needs_config="--controller klipper: rotation_distance is the step distance times each tower's "
                     "full_steps_per_rotation x microsteps, which the calibration does not hold: give "
                     "--config printer.cfg (the configuration the printer runs), or "
                     "--keep-rotation-distance to keep the printer's own rotation_distance")
    geometry, start, step = begun.geometry, begun.start, begun.step
    workspace = begun.workspace
    with fit_refusals(args, begun, "Klipper's"):
        fit = KLIPPER.fit(geometry, start, step, workspace, hold_step_distance=args.keep_rotation_distance,
                          first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, hold=begun.kept)
        budget = source_budget(KLIPPER, begun, args.keep_rotation_distance)
    lines = summary(KLIPPER, fit.before, fit.after, budget, begun, fit.held, args.config is not None)
    values = KLIPPER.admit_bed(fit.klipper, geometry, step, workspace.radius)
    if values is not fit.klipper:
        lines.append(f"minimum_z_position {values.minimum_z_position:g} mm: the true bed is below these "
                     f"values' z 0 over radius {workspace.radius:g} mm; a corrected first layer goes there "
                     "(compensate --controller)")
    KLIPPER.save_config(args.output, values, args.config,
                        title=f"Klipper delta values fitted by deltacal to {args.calibration}",
                        notes=lines)
    print(f"wrote the Klipper values that best fit {args.calibration} to {args.output}")
    print("\n".join(lines))
    return 0

