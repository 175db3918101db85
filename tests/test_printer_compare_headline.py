"""Issue 24's headline, as ``scripts/printer_compare.py`` measures it, held by a test.

The G-code route's mean 3-D max (less the bed motion) on the script's 10 fresh well-built printers at most a
third of Klipper's enhanced calibration's. No test ran the script's criteria: on 2026-11-29 it had drifted to
0.43 (0.032 against 0.076 mm, the correction along the bed of a calibration measured over the volume weighted
by its significance as a bed-level one is) while docs/results.md still said 0.30.
"""

from __future__ import annotations

import warnings

import pytest
from script_module import load_script

from deltacal.printer.comparison import (
    BASIC,
    CLASSES,
    DISTANCE_SIGMA,
    ENHANCED,
    GCODE,
    evaluate,
    exported_name,
    run_printer,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.printed.plan import plan_object


def _script():
    return load_script("printer_compare")


def test_the_headline_criterion_is_the_scripts():
    """The criterion this file holds is the script's own (its name and limit), on its seeds."""
    script = _script()
    assert script.SEEDS["well built"] == 24000 and script.HEADLINE == "less bed motion"
    figures = {ENHANCED: (0.09, 0.02), BASIC: (0.1, 0.02), GCODE: (0.031, 0.01),
               exported_name(30.0): (0.05, 0.01)}
    summary = {script.HEADLINE: {name: {"mean": {"max_3d_mm": m, "flatness_mm": f}}
                                 for name, (m, f) in figures.items()}}
    checks = script.criteria(summary, 30.0)
    third = checks["G-code route 3-D max <= 1/3 Klipper enhanced"]
    assert third["limit"] == pytest.approx(1 / 3) and third["holds"] is False  # 0.031 / 0.09 = 0.34


@pytest.mark.long
@pytest.mark.slow
def test_the_gcode_route_is_a_third_of_klippers_enhanced_on_well_built_printers():
    """Measured 2026-11-29: G-code route 0.023 mm against Klipper enhanced's 0.076 (0.30; docs/results.md)."""
    script = _script()
    printer = load_printer(script.REPO_ROOT / "deltacal" / "models" / "kossel.toml")
    plan = plan_object(printer, KlipperDelta.from_printer(printer), caliper=script.CALIPER_RANGE)
    tolerances, tilt = CLASSES["well built"]
    runs = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for k in range(10):
            run = run_printer(printer, plan, script.SEEDS["well built"] + k, tolerances, tilt, (30.0,),
                              DISTANCE_SIGMA)
            runs.append({view: {m: s.as_dict() for m, s in methods.items()}
                         for view, methods in evaluate(run).items()})
    checks = script.criteria(script.summarise(runs), 30.0)
    third = checks["G-code route 3-D max <= 1/3 Klipper enhanced"]
    assert third["holds"], third
