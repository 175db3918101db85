"""``deltacal compare``: what changed in a printer between two of its calibrations, in its owner's words.

Both files are checked as a printer's calibrations of the complete model; OLD is brought to NEW's
controller (:func:`~deltacal.printer.history.old_against_new_controller`: both identified again under
one prior when their robot files or tolerances' scales differ), the changes computed
(:func:`~deltacal.printer.history.compare_calibrations`) and said one per line, with the HTML page
(:mod:`deltacal.report.history`) when asked.
"""

from __future__ import annotations

from pathlib import Path

from ...calibration import Calibration
from ...exceptions import InputError
from ...io import load_calibration
from ...printer.firmware import firmwares
from ...printer.history import SIGNIFICANT_SIGMAS, Change, compare_calibrations, old_against_new_controller
from ...report.history import write_comparison
from ..base import Done
from ..requests import CompareRequest


def printer_calibration(path: str | Path) -> Calibration:
    """A printer's calibration file of the complete model, or one line saying what the file is instead.

    Raises:
        InputError: a geometry file, a rotary Delta's calibration, or another model than ``printer``.
    """
    calibration = load_calibration(path)
    if not calibration.base:
        raise InputError("not a calibration file: a geometry file has no measurements to compare (give the "
                         "calibration file written by 'deltacal identify')", str(path), "key format")
    if not calibration.geometry.chain.firmware:
        raise InputError(f"{calibration.geometry.chain.words.a_robot}'s calibration: compare tells what "
                         "changed in a printer (a linear Delta's calibrations)", str(path))
    if calibration.model.name != "printer":
        raise InputError(f"model {calibration.model.name!r}: compare needs the complete printer model "
                         "('printer', identify's default for a printer)", str(path), "key model")
    return calibration


def compare_printer_calibrations(request: CompareRequest) -> Done:
    """``deltacal compare OLD NEW [-o PAGE]``: the changes in the owner's words, the page written."""
    old, new = printer_calibration(request.old), printer_calibration(request.new)
    old, new, firmware, said = old_against_new_controller(old, new, request.old, request.new)
    firmware = firmware or firmwares()[0]
    changes = compare_calibrations(old, new, names=firmware.owner_keys.towers)
    if request.output is not None:
        write_comparison(request.output, changes, str(request.old), str(request.new), firmware.title, said)
    lines = [*said, f"What changed in the printer from {request.old} to {request.new}, in {firmware.title}'s "
             f"words (new - old ± its σ; significant: measured by both and beyond {SIGNIFICANT_SIGMAS:g} σ):"]
    lines += [f"  {c.words()}" for c in changes if c.measured]
    unmeasured = [c.what for c in changes if not c.measured]
    if unmeasured:
        lines.append(f"  not measured by both calibrations: {', '.join(unmeasured)}")
    lines.append(_summary(changes))
    if request.output is not None:
        lines.append(f"wrote {request.output}")
    return Done(tuple(lines))


def _summary(changes: list[Change]) -> str:
    found = [c.what for c in changes if c.significant]
    return f"significant: {', '.join(found)}" if found else "no significant change between them"


__all__ = ["compare_printer_calibrations", "printer_calibration"]
