"""Klipper's own reading of a program's lines: ``gcode.py`` and ``gcode_move.py`` run on a stub printer.

``KLIPPER_DIR`` names a Klipper checkout; its two files are copied to a temporary folder and run
with a stand-in toolhead that records every move it is sent (no MCU, no kinematics). What the
tests compare is the G-code state Klipper keeps: its position and extruder position (G-code
coordinates: ``last_position - base_position``) after each line, and each move it makes.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from pathlib import Path

import pytest


def klipper_dir() -> Path:
    """The Klipper checkout named by ``KLIPPER_DIR``; the test is skipped without one."""
    source = os.environ.get("KLIPPER_DIR")
    if not source or not (Path(source) / "klippy" / "extras" / "gcode_move.py").is_file():
        pytest.skip("KLIPPER_DIR does not name a Klipper checkout")
    return Path(source)


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


class _Printer:
    """The few services ``GCodeDispatch`` and ``GCodeMove`` ask of Klipper's printer object."""

    config_error = RuntimeError

    def __init__(self) -> None:
        self.objects: dict = {}

    def get_start_args(self) -> dict:
        return {}

    def register_event_handler(self, *_) -> None:
        pass

    def send_event(self, *_) -> None:
        pass

    def get_reactor(self):
        return self

    def mutex(self):
        return None

    def lookup_object(self, name, default=None):
        return self.objects.get(name, default)

    def get_printer(self):
        return self


class _Toolhead:
    def __init__(self) -> None:
        self.position = [0.0, 0.0, 0.0, 0.0]
        self.moves: list[list[float]] = []

    def move(self, position, speed) -> None:
        self.position = list(position)
        self.moves.append(list(position))

    def get_position(self):
        return list(self.position)


class Klipper:
    """Klipper's G-code reading of lines, one at a time (:meth:`run`)."""

    def __init__(self, folder: Path) -> None:
        source = klipper_dir() / "klippy"
        copy = folder / "klippy"
        (copy / "extras").mkdir(parents=True, exist_ok=True)
        shutil.copy(source / "gcode.py", copy / "gcode.py")
        shutil.copy(source / "extras" / "gcode_move.py", copy / "extras" / "gcode_move.py")
        gcode = _load(copy / "gcode.py", "klipper_gcode_copy")
        gcode_move = _load(copy / "extras" / "gcode_move.py", "klipper_gcode_move_copy")
        printer = _Printer()
        self.toolhead = _Toolhead()
        self.dispatch = gcode.GCodeDispatch(printer)
        printer.objects.update(gcode=self.dispatch, toolhead=self.toolhead)
        self.move = gcode_move.GCodeMove(printer)
        self.dispatch._handle_ready()
        self.move._handle_ready()
        self.error = gcode.CommandError

    def run(self, line: str) -> None:
        """Run one line (raises Klipper's error where Klipper stops the print)."""
        self.dispatch._process_commands([line], need_ack=False)

    def position(self) -> list[float]:
        """X, Y, Z, E in G-code coordinates, as ``M114`` reports them."""
        return self.move._get_gcode_position()[:4]

    def absolute(self) -> tuple[bool, bool]:
        """Whether coordinates (G90) and extrusion (M82) are absolute."""
        return self.move.absolute_coord, self.move.absolute_extrude
