"""Module paths of an earlier release that still import, with a :class:`DeprecationWarning`.

The linear Delta printer's parts moved into :mod:`deltacal.printer` and the G-code rewriter into
:mod:`deltacal.gcode`. A program that imports an old path (``deltacal.printer_simulation``,
``deltacal.io.gcode``, ...) gets the module at its new path, and a warning that names it; the old
paths go in the next release.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType

#: Old module path -> the module's path now.
MOVED = {
    "deltacal.printer_simulation": "deltacal.printer.simulation",
    "deltacal.printer_comparison": "deltacal.printer.comparison",
    "deltacal.printer_demo": "deltacal.printer.demo",
    "deltacal.identification.printer": "deltacal.printer.identification.fit",
    "deltacal.identification.evidence": "deltacal.printer.identification.evidence",
    "deltacal.errormodels.printer": "deltacal.printer.identification.errormodels",
    "deltacal.planning.printer_object": "deltacal.printer.printed.object",
    "deltacal.planning.printer_plan": "deltacal.printer.printed.plan",
    "deltacal.io.printer_measurements": "deltacal.printer.files.measurements",
    "deltacal.controller.klipper": "deltacal.printer.firmware.klipper.model",
    "deltacal.controller.klipper_fit": "deltacal.printer.firmware.klipper.fit",
    "deltacal.controller.klipper_calibrate": "deltacal.printer.firmware.klipper.calibrate",
    "deltacal.io.klipper": "deltacal.printer.firmware.klipper.config",
    "deltacal.io.gcode": "deltacal.gcode.rewriter",
    "deltacal.io.gcode_batch": "deltacal.gcode.batch",
    "deltacal.io.gcode_path": "deltacal.gcode.path",
    "deltacal.printer.object": "deltacal.printer.printed.object",
    "deltacal.printer.labels": "deltacal.printer.printed.labels",
    "deltacal.printer.lettering": "deltacal.printer.printed.lettering",
    "deltacal.printer.sheet": "deltacal.printer.printed.sheet",
    "deltacal.printer.plan": "deltacal.printer.printed.plan",
    "deltacal.printer.evidence": "deltacal.printer.identification.evidence",
    "deltacal.printer.outliers": "deltacal.printer.identification.outliers",
    "deltacal.printer.errormodels": "deltacal.printer.identification.errormodels",
    "deltacal.printer.importer": "deltacal.printer.files.importer",
    "deltacal.printer.measurement_files": "deltacal.printer.files.measurements",
    "deltacal.printer.robot_file": "deltacal.printer.files.robot_file",
    "deltacal.printer.same_printer": "deltacal.printer.files.same_printer",
}


class _MovedLoader(importlib.abc.Loader):
    """Loads an old path as the module at its new path (the same module object)."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(f"{spec.name} is now {self.new}; the old path goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the module was loaded at its new path."""


class _MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old paths of :data:`MOVED` (consulted after the ordinary finders)."""

    def find_spec(self, fullname: str, path=None, target=None) -> importlib.machinery.ModuleSpec | None:
        new = MOVED.get(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, _MovedLoader(new))


def install() -> None:
    """Put the finder of old paths on :data:`sys.meta_path` (once)."""
    if not any(isinstance(finder, _MovedFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedFinder())
