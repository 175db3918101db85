"""``deltacal compare``: what changed in a printer between its calibrations, in its owner's words.

Each file is checked as a printer's calibration of the complete model; all are brought to the
newest's controller (:func:`~deltacal.printer.history.under_one_prior`: identified again under one
prior when their robot files or tolerances' scales differ, a rotary printer's readings through other
rotary values counted again first), each step's changes computed
(:func:`~deltacal.printer.history.calibration_history`) and said one per line, with the HTML page
(:mod:`deltacal.report.history`) when asked.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...calibration import Calibration
from ...exceptions import InputError
from ...io import load_calibration
from ...printer.firmware import firmwares
from ...printer.firmware.base import Firmware
from ...printer.history import SIGNIFICANT_SIGMAS, calibration_history, significant_in_words, under_one_prior
from ...printer.identification.errormodels import PrinterModel, RotaryPrinterModel
from ...report.history import history_html, write_comparison, write_history
from ..base import Done
from ..requests import CompareRequest, ReportRequest


def printer_calibration(path: str | Path) -> Calibration:
    """A printer's calibration file of the complete model, or one line saying what the file is instead.

    Raises:
        InputError: a geometry file, a rotary Delta's calibration, or another model than ``printer``.
    """
    return checked_printer_calibration(load_calibration(path), path)


def checked_printer_calibration(calibration: Calibration, path: str | Path) -> Calibration:
    """``calibration`` (read from ``path``) if a printer's of the complete model, else one line.

    Raises:
        InputError: a geometry file, a rotary Delta's calibration, or another model than ``printer``.
    """
    if not calibration.base:
        raise InputError("not a calibration file: a geometry file has no measurements to compare (give the "
                         "calibration file written by 'deltacal identify')", str(path), "key format")
    if not isinstance(calibration.model, PrinterModel | RotaryPrinterModel):
        if not calibration.geometry.chain.firmware:
            raise InputError(f"{calibration.geometry.chain.words.a_robot} robot's calibration (model "
                             f"{calibration.model.name!r}): compare tells what changed in a printer (a "
                             "linear or rotary Delta printer's calibrations)", str(path), "key model")
        raise InputError(f"model {calibration.model.name!r}: compare needs the complete printer model "
                         "('printer', identify's default for a printer; 'rotary_printer' for a rotary one)",
                         str(path), "key model")
    return calibration


def compare_printer_calibrations(request: CompareRequest) -> Done:
    """``deltacal compare OLD NEW [NEWER ...] [-o PAGE]``: the changes in the owner's words, the page written.

    Two files: their changes; more: each step between consecutive ones, all under the newest's prior.
    """
    files = request.files
    cals, firmware, said = under_one_prior([printer_calibration(f) for f in files], files)
    firmware = firmware or firmwares()[0]
    history = calibration_history(cals, names=firmware.owner_keys.towers)
    if request.output is not None and len(files) == 2:
        write_comparison(request.output, [q.steps[0] for q in history], str(files[0]), str(files[1]),
                         firmware.title, said)
    elif request.output is not None:
        write_history(request.output, history, [str(f) for f in files], firmware.title, said)
    lines = list(said)
    for k, (old, new) in enumerate(zip(files, files[1:], strict=False)):
        changes = [q.steps[k] for q in history]
        lines.append(f"What changed in the printer from {old} to {new}, in {firmware.title}'s words (new - "
                     f"old ± its σ; significant: measured by both and beyond {SIGNIFICANT_SIGMAS:g} σ):")
        lines += [f"  {c.words()}" for c in changes if c.measured]
        unmeasured = [c.what for c in changes if not c.measured]
        if unmeasured:
            lines.append(f"  not measured by both calibrations: {', '.join(unmeasured)}")
        lines.append(significant_in_words(changes))
    if request.output is not None:
        lines.append(f"wrote {request.output}")
    return Done(tuple(lines))


def history_section(request: ReportRequest, calibration: Calibration, firmware: Firmware[Any]
                    ) -> tuple[str, tuple[str, ...]]:
    """``report --history OLDER ...``: the printer's history up to ``calibration`` (the report's, as read).

    Each file checked as compare checks it, all brought under the report's calibration's prior
    (:func:`~deltacal.printer.history.under_one_prior`), every step compared.

    Returns:
        The report's section (:func:`~deltacal.report.history.history_html`) and what to say: the
        re-anchoring, then each step's significant changes.

    Raises:
        InputError: a file that is not a printer's calibration, of another firmware or printer (one line).
    """
    assert request.history
    files = (*request.history, request.calibration)
    older = [printer_calibration(f) for f in request.history]
    newest = checked_printer_calibration(calibration, request.calibration)
    cals, found, said = under_one_prior([*older, newest], files)
    if found is not None and found is not firmware:
        raise InputError(f"identified with {found.title} but the report speaks {firmware.title}: a printer's "
                         "history compares only through one firmware", str(request.history[0]))
    history = calibration_history(cals, names=firmware.owner_keys.towers)
    steps = tuple(f"history, {a} -> {b}: {significant_in_words([q.steps[k] for q in history])}"
                  for k, (a, b) in enumerate(zip(files, files[1:], strict=False)))
    return history_html(history, [str(f) for f in files]), (*said, *steps)


__all__ = ["checked_printer_calibration", "compare_printer_calibrations", "history_section",
           "printer_calibration"]
