"""Klipper behind the firmware interface (:class:`~..base.Firmware`): a thin layer over its modules.

Each method delegates: the configuration to :mod:`.config`, the model and the controller to
:mod:`.model`, the fit to :mod:`.fit`, the probe program to :mod:`.probing`. :data:`KLIPPER` is the one
instance. Units: mm, angles in rad.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ....gcode.dialect import ArcP, Dialect
from ....geometry import DeltaGeometry, Workspace
from ....towers import per_tower
from ..base import PROBE_CLEARANCE, Firmware, Measuring
from .calibrate import (
    BASIC_TITLE,
    ENHANCED_TITLE,
    klipper_basic,
    klipper_enhanced,
    object_pairs,
    probe_points,
)
from .config import KlipperConfig, is_klipper_config, klipper_config_text, load_klipper, read_klipper_config
from .fit import KlipperFit, fit_klipper
from .macros import read_macros
from .model import KlipperController, KlipperDelta
from .probing import klipper_probe_program

if TYPE_CHECKING:
    from ...robot import NominalLinearDelta


class Klipper(Firmware[KlipperDelta]):
    """Klipper: ``printer.cfg``, :class:`~.model.KlipperDelta`, :class:`~.model.KlipperController`."""

    name: ClassVar[str] = "klipper"
    title: ClassVar[str] = "Klipper"
    step_distance_keys: ClassVar[str] = "sections [stepper_a..c], key rotation_distance"
    config_file: ClassVar[str] = "printer.cfg"
    calibrated_file: ClassVar[str] = "printer_calibrated.cfg"
    minimum_z_key: ClassVar[str] = "minimum_z_position"

    def is_config(self, path: str | Path) -> bool:
        """A ``*.cfg`` file, or one with a ``[printer]`` section (:func:`~.config.is_klipper_config`)."""
        return is_klipper_config(path)

    def read_config(self, path: str | Path) -> KlipperDelta:
        """``printer.cfg`` read as Klipper reads it (:func:`~.config.load_klipper`)."""
        return load_klipper(path)

    def nominal(self, printer: NominalLinearDelta) -> KlipperDelta:
        """:meth:`KlipperDelta.from_printer <.model.KlipperDelta.from_printer>`."""
        return KlipperDelta.from_printer(printer)

    def start(self, geometry: DeltaGeometry) -> KlipperDelta:
        """:meth:`KlipperDelta.from_geometry <.model.KlipperDelta.from_geometry>`."""
        return KlipperDelta.from_geometry(geometry)

    def controller(self, model: KlipperDelta, step_distance: np.ndarray | float) -> KlipperController:
        """:class:`~.model.KlipperController` of the values, readings counted in ``step_distance`` [mm].

        ``step_distance`` is each tower's (3,), or one number for the three.
        """
        return KlipperController(model, per_tower("step_distance", step_distance))

    def config_text(self, model: KlipperDelta, source: str | Path | KlipperConfig | None = None,
                    title: str = "", notes: list[str] | tuple[str, ...] = (), complete: bool = False) -> str:
        """:func:`~.config.klipper_config_text`."""
        return klipper_config_text(model, source, title, notes, complete)

    def fit(self, geometry: DeltaGeometry, start: KlipperDelta, step_distance: np.ndarray | float,
            workspace: Workspace, hold_step_distance: bool = False,
            first_layer_weight: float = 0.0) -> KlipperFit:
        """:func:`~.fit.fit_klipper` (the printed part's frame)."""
        return fit_klipper(geometry, start, step_distance, workspace, hold_step_distance=hold_step_distance,
                           first_layer_weight=first_layer_weight)

    def own_calibrations(self, model: KlipperDelta, measuring: Measuring,
                         radius: float) -> dict[str, KlipperDelta]:
        """``DELTA_CALIBRATE`` (basic) and with ``DELTA_ANALYZE`` (enhanced), :mod:`.calibrate`.

        Its 7 probe points at ``[delta_calibrate] radius`` = ``radius`` are probed, then its
        object's 12 distances measured (one probing and one print for both).
        """
        xy = probe_points(radius)
        probe = np.column_stack([xy, measuring.heights(model, xy)])
        pairs = object_pairs()
        distances = measuring.distances(model, pairs)
        return {BASIC_TITLE: klipper_basic(model, probe),
                ENHANCED_TITLE: klipper_enhanced(model, probe, pairs, distances)}

    def probe_program(self, points: np.ndarray, title: str = "", clearance: float = PROBE_CLEARANCE) -> str:
        """:func:`~.probing.klipper_probe_program` (``G28``, then ``PROBE`` above each point)."""
        return klipper_probe_program(points, title, clearance)

    def dialect(self, path: str | Path) -> Dialect:
        """Klipper's reading of G-code with ``printer.cfg``.

        G91 makes E relative too, and G90 leaves M83's E relative (``gcode_move.py``: E is an
        increment when either holds); a ``P`` on an arc is never read (``gcode_arcs.py``); G28
        leaves every carriage at its endstop; the macros are ``printer.cfg``'s
        (:func:`~.macros.read_macros`).
        """
        home = load_klipper(path).positions(np.zeros((1, 3)))[0]
        return Dialect("klipper", g91_moves_e=True, arc_p=ArcP.IGNORED, home=tuple(home.tolist()),
                       macros=read_macros(read_klipper_config(path)))


#: Klipper, the firmware.
KLIPPER = Klipper()
