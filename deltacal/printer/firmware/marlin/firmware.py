"""Marlin behind the firmware interface (:class:`~..base.Firmware`): a thin layer over its modules.

Each method delegates: the settings to :mod:`.settings`, the model and the controller to
:mod:`.model`, nominal and start values to :mod:`.values`, the fit to :mod:`.fit`, the probe
program to :mod:`.probing` and its results to :mod:`.log`. :data:`MARLIN` is
the one instance. Units: mm, trims in degrees.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ....gcode.dialect import Dialect
from ....geometry import DeltaGeometry, Workspace
from ....towers import per_tower
from ...files.importer import PrinterImport
from ..base import PROBE_CLEARANCE, Firmware, FirmwareFit, Flatness, Measuring
from ..live_correction import LiveCorrection
from ..owner_keys import OwnerKeys
from ..probe_log import ProbeLog
from ..value_keys import ValueKey
from .calibrate import DEFAULT_POINTS, marlin_g33
from .dialect import marlin_dialect
from .fit import fit_marlin
from .importer import import_marlin
from .log import is_marlin_probe_log, read_marlin_probe_log
from .model import MarlinController, MarlinDelta
from .probing import marlin_manual_heights, marlin_probe_program, marlin_probe_travel
from .settings import APPLY_NOTE, is_marlin_settings, load_marlin, marlin_settings_text, read_marlin_settings
from .values import marlin_from_geometry, marlin_from_printer

if TYPE_CHECKING:
    from ...robot import NominalLinearDelta
    from ..probing import ProbeTravel


#: Where the firmware keeps each value an owner adjusts (:class:`~..owner_keys.OwnerKeys`).
OWNER_KEYS = OwnerKeys(
    towers=("X", "Y", "Z"), rod_names=("A", "B", "C"), endstop="M666 {tower}", travel="M92 {tower}",
    rods="M665 {rod} (diagonal rod trim)", angle="M665 {tower} (tower angle trim)", bed_tilt="",
    where="the M503 settings (send them, then M500)",
)


class Marlin(Firmware[MarlinDelta]):
    """Marlin 2.x: an ``M503`` capture, :class:`~.model.MarlinDelta`, :class:`~.model.MarlinController`."""

    name: ClassVar[str] = "marlin"
    title: ClassVar[str] = "Marlin"
    step_distance_keys: ClassVar[str] = "M92 X Y Z (steps per mm)"
    classical_keys: ClassVar[tuple[str, str, str]] = ("M665 R", "M665 L + A/B/C",
                                                      "homed height M665 H - M851 Z - M666")
    config_file: ClassVar[str] = "m503.txt"
    calibrated_file: ClassVar[str] = "printer_calibrated.gcode"
    minimum_z_key: ClassVar[str] = "M211 Min Z"
    apply_note: ClassVar[str] = APPLY_NOTE
    owner_keys: ClassVar[OwnerKeys] = OWNER_KEYS
    export_file: ClassVar[str] = "CALIBRATED.gcode"
    values_words: ClassVar[str] = "M665, M666 and M92 lines, saved by M500"
    value_names: ClassVar[Mapping[str, str]] = MappingProxyType({
        "delta_radius": "M665 R",
        "angle_a": "M665 X",
        "angle_b": "M665 Y",
        "angle_c": "M665 Z",
        "arm_length_a": "M665 L+A",
        "arm_length_b": "M665 L+B",
        "arm_length_c": "M665 L+C",
        "position_endstop_a": "M666 X",
        "position_endstop_b": "M666 Y",
        "position_endstop_c": "M666 Z",
        "step_distance_a": "M92 X",
        "step_distance_b": "M92 Y",
        "step_distance_c": "M92 Z",
    })

    value_keys: ClassVar[Mapping[str, ValueKey]] = MappingProxyType({
        "M665.R": ValueKey("radius"), "M665.L": ValueKey("rod"), "M665.H": ValueKey("height"),
        "M665.S": ValueKey("segments_per_second"),
        **{f"M665.{axis}": ValueKey("angle_trim", k) for k, axis in enumerate("XYZ")},
        **{f"M665.{axis}": ValueKey("rod_trim", k) for k, axis in enumerate("ABC")},
        **{f"M666.{axis}": ValueKey("endstop_adj", k) for k, axis in enumerate("XYZ")},
        **{f"M92.{axis}": ValueKey("steps_per_mm", k) for k, axis in enumerate("XYZ")},
        "M92.E": ValueKey("extruder_steps_per_mm"),
        **{f"M851.{axis}": ValueKey("probe_offset", k) for k, axis in enumerate("XYZ")},
    })

    def is_config(self, path: str | Path) -> bool:
        """An ``M503`` capture, or a ``Configuration.h`` (:func:`~.settings.is_marlin_settings`)."""
        return is_marlin_settings(path)

    def read_config(self, path: str | Path) -> MarlinDelta:
        """An ``M503`` capture read as Marlin's values (:func:`~.settings.load_marlin`)."""
        return load_marlin(path)

    def nominal(self, printer: NominalLinearDelta) -> MarlinDelta:
        """:func:`~.values.marlin_from_printer`."""
        return marlin_from_printer(printer)

    def start(self, geometry: DeltaGeometry) -> MarlinDelta:
        """:func:`~.values.marlin_from_geometry`."""
        return marlin_from_geometry(geometry)

    def controller(self, model: MarlinDelta, step_distance: np.ndarray | float) -> MarlinController:
        """:class:`~.model.MarlinController` of the values, readings counted in ``step_distance`` [mm]."""
        return MarlinController(model, per_tower("step_distance", step_distance))

    def config_text(self, model: MarlinDelta, source: str | Path | None = None, title: str = "",
                    notes: list[str] | tuple[str, ...] = (), complete: bool = False) -> str:
        """:func:`~.settings.marlin_settings_text` (``source`` is not needed: the values hold ``M851``)."""
        return marlin_settings_text(model, title, notes, complete)

    def fit(self, geometry: DeltaGeometry, start: MarlinDelta, step_distance: np.ndarray | float,
            workspace: Workspace, hold_step_distance: bool = False,
            first_layer_weight: float = 0.0, minimax: bool = False,
            grid: np.ndarray | None = None, flatness: Flatness = None,
            hold: Sequence[str] = ()) -> FirmwareFit[MarlinDelta]:
        """:func:`~.fit.fit_marlin` (the printed part's frame, Marlin's rules)."""
        return fit_marlin(geometry, start, step_distance, workspace, hold_step_distance, first_layer_weight,
                          minimax, grid, flatness, hold)

    def own_calibrations(self, model: MarlinDelta, measuring: Measuring,
                         radius: float) -> dict[str, MarlinDelta]:
        """``G33`` with its default points (:func:`~.calibrate.marlin_g33`) at printable radius ``radius``."""
        result = marlin_g33(model, measuring.heights, radius, DEFAULT_POINTS)
        return {f"{self.title} G33 (P{DEFAULT_POINTS})": result.values}

    def probe_program(self, points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
        """:func:`~.probing.marlin_probe_program` (``G28``, then ``G30`` with the nozzle above each point)."""
        return marlin_probe_program(points, title, clearance, live)

    def probe_travel(self, path: str | Path) -> ProbeTravel:
        """:func:`~.probing.marlin_probe_travel`: above ``-M851 Z`` of the ``M503`` capture."""
        return marlin_probe_travel(read_marlin_settings(path))

    def manual_heights(self, path: str | Path) -> str | None:
        """:func:`~.probing.marlin_manual_heights`: the paper test and ``M114``, without ``M851``."""
        return marlin_manual_heights(read_marlin_settings(path))

    def is_probe_log(self, text: str) -> bool:
        """Marlin's ``Bed X:`` results, or G33's (:func:`~.log.is_marlin_probe_log`)."""
        return is_marlin_probe_log(text)

    def read_probe_log(self, path: str | Path, config: str | Path | None = None,
                       text: str | None = None) -> ProbeLog:
        """:func:`~.log.read_marlin_probe_log`, ``M851`` from the ``M503`` capture ``config``."""
        if config is None:
            return read_marlin_probe_log(path, text)
        log = read_marlin_probe_log(path, text, load_marlin(config).probe_offset)
        return replace(log, trigger_source=f"-M851 Z of {config}")

    def import_config(self, path: str | Path, folder: str | Path, effector_radius: float | None = None,
                      rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
        """:func:`~.importer.import_marlin`: ``printer.toml`` of Marlin's model of an ``M503`` capture."""
        return import_marlin(path, folder, effector_radius, rod_spacing, nozzle_drop)

    def dialect(self, path: str | Path, model: MarlinDelta | None = None) -> Dialect:
        """Marlin 2's reading of G-code with an ``M503`` capture (:func:`~.dialect.marlin_dialect`).

        G90 and G91 set E's mode too and M82/M83 override it until the next G90/G91
        (``gcode.h``, ``set_relative_mode``: the last of the four decides); a ``P`` on an arc is
        that many full circles before it, Z and E spread over the whole sweep (``G2_G3.cpp`` with
        ``ARC_P_CIRCLES``); G28 leaves the nozzle at ``(0, 0, H - M851 Z)`` (a delta homes its three
        towers on any G28: :attr:`MarlinController.home <.model.MarlinController.home>`); G33, and
        the commands that set the values the program is corrected for (``M665``, ``M666``, ``M92 X
        Y Z``, ``M851 Z``, ``M501``, ``M502``), are refused (:func:`~.dialect.marlin_rules`); ``M211 S0``
        switches the soft endstops off for the lines after it (``M211.cpp``), ``S1`` on; no macros; a
        line's command is its first letter after spaces (:data:`~.dialect.MARLIN_LINES`).
        """
        return marlin_dialect(load_marlin(path) if model is None else model)


#: Marlin, the firmware.
MARLIN = Marlin()
