"""RepRapFirmware behind the firmware interface (:class:`~..base.Firmware`): a thin layer over its modules.

Each method delegates: the configuration to :mod:`.config`, the model and the controller to
:mod:`.model`, the fit to :mod:`.fit`, the probe program to :mod:`.probing`. :data:`RRF_FIRMWARE`
is the one instance. Units: mm, angles in rad.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ....exceptions import InputWarning
from ....gcode.dialect import Dialect
from ....geometry import DeltaGeometry, Workspace
from ....towers import per_tower
from ..base import PROBE_CLEARANCE, Firmware, FirmwareFit, Flatness, Measuring
from ..live_correction import LiveCorrection
from ..owner_keys import OwnerKeys
from ..probing import PAPER_MM
from ..value_keys import ValueKey
from .apply import rrf_apply_note, rrf_config_files
from .calibrate import BED_MARGIN, DEFAULT_FACTORS, TILT_FACTORS, rrf_g32
from .config import (
    APPLY_NOTE,
    is_rrf_config,
    load_rrf,
    read_rrf_settings,
    rrf_config_text,
    rrf_manual_probe,
    rrf_probe_offsets,
)
from .dialect import rrf_dialect
from .fit import fit_rrf
from .homing import homed_position
from .importer import import_rrf
from .log import is_rrf_probe_log, read_rrf_probe_log
from .model import RRFController, RRFDelta
from .probing import rrf_manual_heights, rrf_probe_program, rrf_probe_travel

if TYPE_CHECKING:
    from ...files.importer import PrinterImport
    from ...robot import NominalLinearDelta
    from ..probe_log import ProbeLog
    from ..probing import ProbeTravel


#: Where the firmware keeps each value an owner adjusts (:class:`~..owner_keys.OwnerKeys`).
OWNER_KEYS = OwnerKeys(
    towers=("X", "Y", "Z"), rod_names=("X", "Y", "Z"), endstop="M666 {tower}", travel="M92 {tower}",
    rods="M665 L (tower {rod}'s of a:b:c)", angle="M665 {tower} (angle correction)", bed_tilt="M666 A B",
    where="config.g / config-override.g",
)


class RRF(Firmware[RRFDelta]):
    """RepRapFirmware 3.x: ``config.g``, :class:`~.model.RRFDelta`, :class:`~.model.RRFController`."""

    name: ClassVar[str] = "rrf"
    title: ClassVar[str] = "RepRapFirmware"
    step_distance_keys: ClassVar[str] = "M92 X Y Z (steps per mm)"
    classical_keys: ClassVar[tuple[str, str, str]] = ("M665 R", "M665 L", "homed height M665 H + M666")
    config_file: ClassVar[str] = "config.g"
    calibrated_file: ClassVar[str] = "config-override.g"
    minimum_z_key: ClassVar[str] = "M208 Z minimum"
    apply_note: ClassVar[str] = APPLY_NOTE
    owner_keys: ClassVar[OwnerKeys] = OWNER_KEYS
    export_file: ClassVar[str] = "CALIBRATED.g"
    values_words: ClassVar[str] = "M665 and M666 lines for config-override.g, M92 for config.g"
    probes_by_hand: ClassVar[bool] = True  # G30 S-1 with M558 P0: RRF asks the user to jog Z
    value_names: ClassVar[Mapping[str, str]] = MappingProxyType({
        "delta_radius": "M665 R",
        "angle_a": "M665 X",
        "angle_b": "M665 Y",
        "angle_c": "M665 Z",
        "arm_length_a": "M665 L a",
        "arm_length_b": "M665 L b",
        "arm_length_c": "M665 L c",
        "position_endstop_a": "M666 X",
        "position_endstop_b": "M666 Y",
        "position_endstop_c": "M666 Z",
        "step_distance_a": "M92 X",
        "step_distance_b": "M92 Y",
        "step_distance_c": "M92 Z",
    })

    value_keys: ClassVar[Mapping[str, ValueKey]] = MappingProxyType({
        "M665.R": ValueKey("radius"), "M665.H": ValueKey("homed_height"), "M665.B": ValueKey("print_radius"),
        **{f"M665.L.{t}": ValueKey("diagonal", k) for k, t in enumerate("abc")},
        **{f"M665.{axis}": ValueKey("angle_correction", k, "deg") for k, axis in enumerate("XYZ")},
        **{f"M666.{axis}": ValueKey("endstop_adjustment", k) for k, axis in enumerate("XYZ")},
        **{f"M666.{axis}": ValueKey("tilt", k, "percent") for k, axis in enumerate("AB")},
        **{f"M92.{axis}": ValueKey("step_distance", k, "inverse") for k, axis in enumerate("XYZ")},
        "M208.Z": ValueKey("z_min"),
    })

    def is_config(self, path: str | Path) -> bool:
        """A ``*.g`` running ``M665`` or ``M669``, not Marlin's (:func:`~.config.is_rrf_config`)."""
        return is_rrf_config(path)

    def read_config(self, path: str | Path) -> RRFDelta:
        """``config.g`` (or ``config-override.g``) run as RRF runs it (:func:`~.config.load_rrf`)."""
        return load_rrf(path)

    def nominal(self, printer: NominalLinearDelta) -> RRFDelta:
        """:meth:`RRFDelta.from_printer <.model.RRFDelta.from_printer>`."""
        return RRFDelta.from_printer(printer)

    def start(self, geometry: DeltaGeometry) -> RRFDelta:
        """:meth:`RRFDelta.from_geometry <.model.RRFDelta.from_geometry>`."""
        return RRFDelta.from_geometry(geometry)

    def controller(self, model: RRFDelta, step_distance: np.ndarray | float) -> RRFController:
        """:class:`~.model.RRFController` of the values, readings counted in ``step_distance`` [mm]."""
        return RRFController(model, per_tower("step_distance", step_distance))

    def config_text(
        self,
        model: RRFDelta,
        source: str | Path | None = None,
        title: str = "",
        notes: list[str] | tuple[str, ...] = (),
        complete: bool = False,
    ) -> str:
        """:func:`~.config.rrf_config_text`, its second line :meth:`apply_note_for` ``source``."""
        note = self.apply_note_for(None if complete else source)
        return rrf_config_text(model, source, title, notes, complete, note)

    def apply_note_for(self, source: str | Path | None) -> str:
        """:func:`~.apply.rrf_apply_note`: the lines of ``config.g`` or ``config-override.g`` to replace."""
        return rrf_apply_note(source)

    def fit(
        self,
        geometry: DeltaGeometry,
        start: RRFDelta,
        step_distance: np.ndarray | float,
        workspace: Workspace,
        hold_step_distance: bool = False,
        first_layer_weight: float = 0.0,
        minimax: bool = False,
        grid: np.ndarray | None = None,
        flatness: Flatness = None,
        hold: Sequence[str] = (),
    ) -> FirmwareFit[RRFDelta]:
        """:func:`~.fit.fit_rrf` (the printed part's frame, ``M665 Z`` held as ``G32`` holds it)."""
        return fit_rrf(
            geometry,
            start,
            step_distance,
            workspace,
            hold_step_distance=hold_step_distance,
            grid=grid,
            first_layer_weight=first_layer_weight,
            minimax=minimax,
            flatness=flatness,
            hold=hold,
        )

    def own_calibrations(self, model: RRFDelta, measuring: Measuring, radius: float) -> dict[str, RRFDelta]:
        """``G32`` with 6 factors (the configuration tool's bed.g) and with 8 (the bed's tilt too).

        bed.g's probe radius is ``radius`` less :data:`~.calibrate.BED_MARGIN` (:func:`~.calibrate.rrf_g32`).
        """
        return {f"{self.title} G32 (S{s})": rrf_g32(model, measuring.heights, radius - BED_MARGIN, s)
                for s in (DEFAULT_FACTORS, TILT_FACTORS)}

    def probe_program(self, points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
        """:func:`~.probing.rrf_probe_program` (``G28``, then an echo and ``G30 S-1`` above each point)."""
        return rrf_probe_program(points, title, clearance, live)

    def probe_travel(self, path: str | Path) -> ProbeTravel:
        """:func:`~.probing.rrf_probe_travel`: ``G31 Z`` + ``M558 H`` of ``config.g`` (``M501`` followed).

        A file ``config.g`` runs and that is missing is not warned of here: the reading of the
        configuration (:meth:`read_config`, before the probe program is planned) warns once.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            return rrf_probe_travel(read_rrf_settings(path))

    def manual_heights(self, path: str | Path) -> str | None:
        """:func:`~.probing.rrf_manual_heights`: with ``M558 P0``, RRF's manual probing by probe.gcode."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            return rrf_manual_heights(read_rrf_settings(path))

    def config_files(self, path: str | Path) -> tuple[Path, ...]:
        """:func:`~.apply.rrf_config_files`: ``config.g``, the files it runs and ``homedelta.g``."""
        return rrf_config_files(path)

    def dialect(self, path: str | Path, model: RRFDelta | None = None) -> Dialect:
        """RepRapFirmware's reading of G-code with ``config.g``.

        E is relative exactly when M83 holds: G90/G91 set only ``axesRelative``, M82/M83
        ``drivesRelative`` (``GCodes2.cpp``); a ``P`` on an arc sets I/O bits or a laser's power,
        never a count of turns (``GCodes.cpp``, ``HandleArc``: one turn at most, a whole circle
        where the ends meet), so it is read as absent; G28 runs ``homedelta.g``, whose ``G1 H1``
        moves stop each carriage at its endstop (``OnHomingSwitchTriggered``): the nozzle is where
        RRF's model puts those carriages, moved on by the literal moves ``homedelta.g`` makes after
        them when it lies beside ``config.g`` (:func:`~.homing.homed_position`). No macros are read.
        A line's command is its first letter after the indentation (:data:`~.dialect.RRF_LINES`);
        the commands that set the values the program is corrected for are refused
        (:func:`~.dialect.rrf_rules`).

        Raises:
            InputError: the configuration's first problem, or a move of ``homedelta.g`` whose end
                is not known.
        """
        model = load_rrf(path) if model is None else model
        home, _ = homed_position(path, model)
        return rrf_dialect(model, home)

    def is_probe_log(self, text: str) -> bool:
        """RRF's answers to ``G30 S-1`` (:func:`~.log.is_rrf_probe_log`)."""
        return is_rrf_probe_log(text)

    def read_probe_log(self, path: str | Path, config: str | Path | None = None,
                       text: str | None = None) -> ProbeLog:
        """:func:`~.log.read_rrf_probe_log`, the trigger height ``G31 Z`` of ``config.g`` if given.

        With ``M558 P0`` (RRF's manual probing) the trigger height is the paper's,
        :data:`~..probing.PAPER_MM`: RRF answers the height the user left the nozzle at.
        """
        if config is None:
            return read_rrf_probe_log(path, text)
        settings = read_rrf_settings(config)
        manual = rrf_manual_probe(settings)
        offsets = rrf_probe_offsets(settings)
        if manual is not None:  # the user's height at each G30 S-1: the paper's, not G31 Z
            offsets = replace(offsets, z=PAPER_MM)
        log = read_rrf_probe_log(path, text, offsets)
        given = f"G31 Z of {config}" if "G31 Z" in settings.values else \
            f"RepRapFirmware's default trigger height: no G31 Z in {config}"
        return replace(log, trigger_source=given if manual is None else
                       f"the paper test: M558 P0 of {config}, line {manual.line}, RRF's manual probing")

    def import_config(self, path: str | Path, folder: str | Path, effector_radius: float | None = None,
                      rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
        """:func:`~.importer.import_rrf`: ``printer.toml`` of RRF's model of ``config.g``."""
        return import_rrf(path, folder, effector_radius, rod_spacing, nozzle_drop)


#: RepRapFirmware, the firmware.
RRF_FIRMWARE = RRF()
