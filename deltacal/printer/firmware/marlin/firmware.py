"""Marlin behind the firmware interface (:class:`~..base.Firmware`): a thin layer over its modules.

Each method delegates: the settings to :mod:`.settings`, the model and the controller to
:mod:`.model`, nominal and start values to :mod:`.values`, the fit to :mod:`.fit`. :data:`MARLIN` is
the one instance. Units: mm, trims in degrees.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ....geometry import DeltaGeometry, Workspace
from ....towers import per_tower
from ..base import PROBE_CLEARANCE, Firmware, Measuring
from .calibrate import DEFAULT_POINTS, marlin_g33
from .fit import MarlinFit, fit_marlin
from .model import MarlinController, MarlinDelta
from .probing import marlin_probe_program
from .settings import is_marlin_settings, load_marlin, marlin_settings_text
from .values import marlin_from_geometry, marlin_from_printer

if TYPE_CHECKING:
    from ...robot import NominalLinearDelta


class Marlin(Firmware[MarlinDelta]):
    """Marlin 2.x: an ``M503`` capture, :class:`~.model.MarlinDelta`, :class:`~.model.MarlinController`."""

    name: ClassVar[str] = "marlin"
    title: ClassVar[str] = "Marlin"
    step_distance_keys: ClassVar[str] = "M92 X Y Z (steps per mm)"
    config_file: ClassVar[str] = "m503.txt"
    calibrated_file: ClassVar[str] = "printer_calibrated.gcode"
    minimum_z_key: ClassVar[str] = "M211 Min Z"

    def is_config(self, path: str | Path) -> bool:
        """An ``M503`` capture (:func:`~.settings.is_marlin_settings`)."""
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
            first_layer_weight: float = 0.0) -> MarlinFit:
        """:func:`~.fit.fit_marlin` (the printed part's frame, Marlin's rules)."""
        return fit_marlin(geometry, start, step_distance, workspace, hold_step_distance, first_layer_weight)

    def own_calibrations(self, model: MarlinDelta, measuring: Measuring,
                         radius: float) -> dict[str, MarlinDelta]:
        """``G33`` with its default points (:func:`~.calibrate.marlin_g33`) at printable radius ``radius``."""
        result = marlin_g33(model, measuring.heights, radius, DEFAULT_POINTS)
        return {f"{self.title} G33 (P{DEFAULT_POINTS})": result.values}

    def probe_program(self, points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
        """:func:`~.probing.marlin_probe_program` (``G28``, then ``G30`` with the nozzle above each point)."""
        return marlin_probe_program(points, title, clearance)


#: Marlin, the firmware.
MARLIN = Marlin()
