"""Benchmarks of a printer's calibration (issue 24), run by ``scripts/bench.py --only printer``.

On ``models/kossel.toml`` with Klipper's model of the nominal printer as its firmware: a kit
printer (:meth:`Tolerances.printer_kit`, seeded) measured on plan's object (49 probe heights and
40 caliper distances, trigger σ 0.01 mm, caliper σ 0.02 mm) through the firmware, then

* ``identify_printer`` with the complete ``"printer"`` model, iterated (the time, and the
  Gauss-Newton steps it took);
* ``fit_klipper``: the Klipper values that fit the identified printer best over the printable
  volume (radius 92 mm, z 0.2 to 100 mm), in the part's frame with the first layer weighted as
  ``export --controller klipper`` computes them.

Kept apart from ``bench.py`` so that neither module passes 700 lines; the rows are returned as
``(name, value, unit, target, spread)`` and made into ``bench.Row`` there.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from deltacal.geometry import Workspace
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from deltacal.printer.firmware.klipper.fit import fit_klipper
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.simulation import printed_distances, probe_heights, random_printer

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
#: The printable volume of the export's fit.
WORKSPACE = Workspace(radius=92.0, height=100.0, top_z=100.0)

Timer = Callable[[Callable[[], object], int], list[float]]
RowTuple = tuple[str, float, str, str | None, tuple[float, float] | None]


def _ms(name: str, times: list[float]) -> RowTuple:
    """The median of wall times [s] in ms, with the fastest and slowest runs."""
    ms = [1e3 * t for t in times]
    return name, float(np.median(ms)), "ms", None, (min(ms), max(ms))


def printer_rows(repeat: int, run_times: Timer, seed: int) -> list[RowTuple]:
    """The printer's rows: identification and Klipper's fit, timed by ``run_times`` (wall times [s])."""
    printer = load_printer(KOSSEL)
    firmware = KlipperDelta.from_printer(printer)
    step = printer.step_distance
    plan = plan_object(printer, firmware)
    rng = np.random.default_rng(seed)
    truth = random_printer(printer, rng)
    probe = probe_heights(truth, firmware, step, plan.probe[:, :2], 0.01, rng)
    pairs = plan.pair_positions.reshape(-1, 6)
    distance = printed_distances(truth, firmware, step, pairs, 0.02, rng)
    data = PrinterMeasurements(firmware.inverse(probe, step),
                               firmware.inverse(pairs.reshape(-1, 3), step).reshape(-1, 2, 3), distance)
    start = printer.geometry()
    result = identify_printer(start, data, "printer")
    t_identify = run_times(lambda: identify_printer(start, data, "printer"), repeat)
    def fit():
        return fit_klipper(result.geometry, firmware, step, WORKSPACE,
                           first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)

    t_fit = run_times(fit, repeat)
    fitted = fit()
    return [
        _ms(f"identify_printer_{len(probe)}_heights_{len(distance)}_distances", t_identify),
        ("identify_printer_iterations", float(result.iterations), "Gauss-Newton steps", None, None),
        _ms("fit_klipper_kossel", t_fit),
        ("fit_klipper_kossel_points", float(fitted.points), "targets", None, None),
    ]
