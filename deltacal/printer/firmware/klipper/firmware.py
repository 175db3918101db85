"""Klipper behind the firmware interface (:class:`~..base.Firmware`): a thin layer over its modules.

Each method delegates: the configuration to :mod:`.config`, the model and the controller to
:mod:`.model`, the fit to :mod:`.fit`, the probe program to :mod:`.probing`. :data:`KLIPPER` is the one
instance. Units: mm, angles in rad.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ....exceptions import InputWarning
from ....gcode.dialect import ArcP, Dialect, LineReading, Unread
from ....geometry import DeltaGeometry, Workspace
from ....holds import DEFAULT_BOUND
from ....towers import per_tower
from ...files.importer import OUTPUT_FILES, PrinterImport
from ..base import PROBE_CLEARANCE, Firmware, FirmwareFit, Flatness, Measuring
from ..live_correction import LiveCorrection
from ..owner_keys import OwnerKeys
from ..probe_log import ProbeLog
from ..rotary_values import RotaryValues
from ..value_keys import ValueKey
from .calibrate import (
    BASIC_TITLE,
    ENHANCED_TITLE,
    klipper_basic,
    klipper_enhanced,
    object_pairs,
    probe_points,
)
from .config import (
    APPLY_NOTE,
    LIVE_OFF,
    LIVE_ON,
    LIVE_SECTION_FILE,
    KlipperConfig,
    is_klipper_config,
    is_klipper_config_name,
    klipper_config_text,
    load_klipper,
    read_klipper_config,
)
from .fit import fit_klipper
from .importer import import_klipper, write_import
from .live.export import LIVE_FILES, export_live
from .log import is_console, is_probe_log, probe_offsets, read_probe_log
from .macros import read_macros, with_moving_commands
from .model import KlipperController, KlipperDelta
from .probing import klipper_manual_heights, klipper_probe_program, klipper_probe_travel
from .rotary_config import is_rotary_config, rotary_from_config
from .rotary_controller import KlipperRotaryController
from .rotary_export import export_rotary
from .rotary_importer import import_rotary, write_rotary_import
from .rotary_model import KlipperRotaryDelta
from .saved import read_saved_calibration

if TYPE_CHECKING:
    from ....calibration import Calibration
    from ...robot import NominalLinearDelta
    from ..probe_log import ProbeLog
    from ..probing import ProbeTravel


#: Where the firmware keeps each value an owner adjusts (:class:`~..owner_keys.OwnerKeys`).
OWNER_KEYS = OwnerKeys(
    towers=("A", "B", "C"), rod_names=("a", "b", "c"), endstop="[stepper_{lower}] position_endstop",
    travel="[stepper_{lower}] rotation_distance", rods="[stepper_{lower}] arm_length",
    angle="[stepper_{lower}] angle", bed_tilt="", where="printer.cfg",
)


class Klipper(Firmware[KlipperDelta]):
    """Klipper: ``printer.cfg``, :class:`~.model.KlipperDelta`, :class:`~.model.KlipperController`."""

    name: ClassVar[str] = "klipper"
    title: ClassVar[str] = "Klipper"
    step_distance_keys: ClassVar[str] = "sections [stepper_a..c], key rotation_distance"
    classical_keys: ClassVar[tuple[str, str, str]] = ("delta_radius", "arm_length", "position_endstop")
    config_file: ClassVar[str] = "printer.cfg"
    calibrated_file: ClassVar[str] = "printer_calibrated.cfg"
    minimum_z_key: ClassVar[str] = "minimum_z_position"
    apply_note: ClassVar[str] = APPLY_NOTE
    owner_keys: ClassVar[OwnerKeys] = OWNER_KEYS
    export_file: ClassVar[str] = "CALIBRATED.cfg"
    values_words: ClassVar[str] = "the [printer] and [stepper_a..c] values of printer.cfg"
    value_names: ClassVar[Mapping[str, str]] = MappingProxyType({
        "delta_radius": "[printer] delta_radius",
        "angle_a": "[stepper_a] angle",
        "angle_b": "[stepper_b] angle",
        "angle_c": "[stepper_c] angle",
        "arm_length_a": "[stepper_a] arm_length",
        "arm_length_b": "[stepper_b] arm_length",
        "arm_length_c": "[stepper_c] arm_length",
        "position_endstop_a": "[stepper_a] position_endstop",
        "position_endstop_b": "[stepper_b] position_endstop",
        "position_endstop_c": "[stepper_c] position_endstop",
        "step_distance_a": "[stepper_a] rotation_distance",
        "step_distance_b": "[stepper_b] rotation_distance",
        "step_distance_c": "[stepper_c] rotation_distance",
    })
    value_keys: ClassVar[Mapping[str, ValueKey]] = MappingProxyType({
        "printer.delta_radius": ValueKey("delta_radius"),
        "printer.print_radius": ValueKey("print_radius"),
        "printer.minimum_z_position": ValueKey("minimum_z_position"),
        **{f"stepper_{t}.{key}": ValueKey(field, k, unit)
           for k, t in enumerate("abc")
           for key, field, unit in (("angle", "angle", "deg"), ("arm_length", "arm_length", ""),
                                    ("position_endstop", "position_endstop", ""),
                                    ("step_distance", "step_distance", ""))},
    })
    export_needs_config: ClassVar[str] = (
        "--controller klipper: rotation_distance is the step distance times each tower's "
        "full_steps_per_rotation x microsteps, which the calibration does not hold: give --config "
        "printer.cfg (the configuration the printer runs), or --keep-rotation-distance to keep the printer's "
        "own rotation_distance")
    exports_minimum_z: ClassVar[bool] = True
    live_files: ClassVar[tuple[str, ...]] = LIVE_FILES

    def is_config(self, path: str | Path) -> bool:
        """A file with a ``[printer]`` section (:func:`~.config.is_klipper_config`)."""
        return is_klipper_config(path)

    def is_config_name(self, path: str | Path) -> bool:
        """A ``*.cfg`` file (:func:`~.config.is_klipper_config_name`)."""
        return is_klipper_config_name(path)

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
            first_layer_weight: float = 0.0, minimax: bool = False,
            grid: np.ndarray | None = None, flatness: Flatness = None,
            hold: Sequence[str] = ()) -> FirmwareFit[KlipperDelta]:
        """:func:`~.fit.fit_klipper` (the printed part's frame)."""
        return fit_klipper(geometry, start, step_distance, workspace, hold_step_distance=hold_step_distance,
                           grid=grid, first_layer_weight=first_layer_weight, minimax=minimax,
                           flatness=flatness, hold=hold)

    def export_live(self, calibration: Calibration, config: str | Path, folder: str | Path,
                    source: str = "", sigma_bound: float = DEFAULT_BOUND) -> tuple[str, ...]:
        """The module ``deltacal_geometry.py`` and its section (:func:`~.live.export.export_live`).

        A ``kinematics: rotary_delta`` configuration's through Klipper's rotary kinematics
        (:meth:`rotary_controller`; the calibration in its frame, the bed's).
        """
        return export_live(calibration, config, folder, source, bound=sigma_bound,
                           rotary=self.rotary_controller(config)).lines

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

    def calibrated_from_saved(self, path: str | Path) -> bool:
        """Whether ``printer.cfg``'s SAVE_CONFIG block holds ``[delta_calibrate]`` measurements."""
        return not read_saved_calibration(read_klipper_config(path)).empty

    def probe_program(self, points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
        """:func:`~.probing.klipper_probe_program` (``G28``, then ``PROBE`` above each point)."""
        return klipper_probe_program(points, title, clearance, live)

    def probe_travel(self, path: str | Path) -> ProbeTravel:
        """:func:`~.probing.klipper_probe_travel`: above the probe's ``z_offset`` of ``printer.cfg``."""
        return klipper_probe_travel(read_klipper_config(path))

    def manual_heights(self, path: str | Path) -> str | None:
        """:func:`~.probing.klipper_manual_heights`: ``MANUAL_PROBE`` at each point, without a probe."""
        return klipper_manual_heights(read_klipper_config(path))

    def rotary_controller(self, path: str | Path) -> KlipperRotaryController | None:
        """A ``kinematics: rotary_delta`` configuration: :class:`~.rotary_controller.KlipperRotaryController`.

        None for any other kinematics (:meth:`read_config` reads a linear Delta's).
        """
        config = read_klipper_config(path)
        if not is_rotary_config(config):
            return None
        return KlipperRotaryController(rotary_from_config(config))

    def rotary_export(self, path: str | Path, calibration: Calibration, source: str | Path,
                      volume: Workspace | None = None, where: str = "") -> RotaryValues | None:
        """A ``kinematics: rotary_delta`` configuration: :func:`~.rotary_export.export_rotary`.

        None for any other kinematics (a linear Delta's configuration). ``volume``: the printable volume
        in the calibration's frame {O} (``where``: where from), or None: the configuration's own.
        """
        config = read_klipper_config(path)
        if not is_rotary_config(config):
            return None
        return export_rotary(config, calibration, source, volume, where)

    def live_correction(self, path: str | Path) -> LiveCorrection | None:
        """Where ``printer.cfg`` includes ``export --live``'s section (:attr:`~.config.KlipperConfig.live`).

        Missing includes are not warned of here: the reading of the configuration warns once.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            where = read_klipper_config(path).live
        if not where:
            return None
        remove = f"remove the [include {LIVE_SECTION_FILE}]"
        return LiveCorrection(str(path), where, LIVE_OFF, LIVE_ON, remove)

    def config_files(self, path: str | Path) -> tuple[Path, ...]:
        """``printer.cfg`` and every file it includes (:attr:`~.config.KlipperConfig.files`).

        Missing includes are not warned of here: the reading of the configuration warns once.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InputWarning)
            return tuple(Path(name) for name in read_klipper_config(path).files)

    def dialect(self, path: str | Path, model: KlipperDelta | KlipperRotaryDelta | None = None) -> Dialect:
        """Klipper's reading of G-code with ``printer.cfg``.

        G91 makes E relative too, and G90 leaves M83's E relative (``gcode_move.py``: E is an
        increment when either holds); a ``P`` on an arc is never read (``gcode_arcs.py``); G28
        leaves every carriage at its endstop; the macros are ``printer.cfg``'s
        (:func:`~.macros.read_macros`), and a program's own probing or bed mesh command
        (``BED_MESH_CALIBRATE``, ``PROBE`` ...) leaves the position unknown as in a macro
        (:func:`~.macros.with_moving_commands`). A rotary_delta configuration's ``model``
        (:class:`~.rotary_model.KlipperRotaryDelta`) is read alike, its home its own. A line's command is
        its first word, after any whitespace (``str.strip``) and a line number (:data:`KLIPPER_LINES`).
        """
        home = (load_klipper(path) if model is None else model).home_position
        return Dialect(self.title, g91_moves_e=True, arc_p=ArcP.IGNORED, home=tuple(home.tolist()),
                       macros=with_moving_commands(read_macros(read_klipper_config(path))),
                       lines=KLIPPER_LINES)

    def is_probe_log(self, text: str) -> bool:
        """Klipper's probe results, or a log's marks (:func:`~.log.is_probe_log`)."""
        return is_probe_log(text)

    def is_console(self, text: str) -> bool:
        """A console's ``// `` lines (:func:`~.log.is_console`)."""
        return is_console(text)

    def read_probe_log(self, path: str | Path, config: str | Path | None = None,
                       text: str | None = None) -> ProbeLog:
        """:func:`~.log.read_probe_log`: the offsets of the log's own configuration, else printer.cfg's."""
        if config is None:
            return read_probe_log(path, text)
        return read_probe_log(path, text, probe_offsets(read_klipper_config(config)), str(config))

    def import_config(self, path: str | Path, folder: str | Path, effector_radius: float | None = None,
                      rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
        """:func:`~.importer.import_klipper` written by :func:`~.importer.write_import`.

        A ``kinematics: rotary_delta`` configuration: :func:`~.rotary_importer.import_rotary` (a
        rotary robot file).
        """
        config = read_klipper_config(path)
        if is_rotary_config(config):
            rotary = import_rotary(config, effector_radius, rod_spacing, nozzle_drop)
            return write_rotary_import(rotary, path, folder)
        imported = import_klipper(path, effector_radius, rod_spacing, nozzle_drop)
        written = write_import(imported, folder)
        saved = imported.saved
        defaults = f"; defaults taken: {', '.join(imported.defaults)}" if imported.defaults else ""
        said = [f"wrote {written[0]}: Klipper's model of {path} (delta_radius "
                f"{imported.klipper.delta_radius:g} mm){defaults}"]
        if saved.empty:
            said.append("no [delta_calibrate] measurements in its SAVE_CONFIG block: no probe.csv, no "
                        "distances.csv")
        for file in written[1:]:
            rows = saved.height.size if file.name == OUTPUT_FILES[1] else saved.distance.size
            said.append(f"wrote {file}: {rows} rows saved by Klipper's DELTA_CALIBRATE / DELTA_ANALYZE")
        return PrinterImport(tuple(written), tuple(said))


#: How Klipper finds a line's command (``klippy/gcode.py``, ``_process_commands``): the line stripped
#: of whitespace (``str.strip``), upper case, split at its letters; the command is the text before the
#: first letter, the letters and the number after them (after an ``N`` line number). A line of axis
#: words (``X40 Y0 Z10``) is the command ``X40``, and one with text before its first letter
#: (``\ufeffG1``, ``\0G1``, ``1G1``) the command ``\ufeffG1``: "Unknown command", not run.
KLIPPER_LINES = LineReading(axis_words=Unread.IGNORED, axis_words_why="Klipper answers 'Unknown command' "
                            "and does not move", junk=Unread.IGNORED)

#: Klipper, the firmware.
KLIPPER = Klipper()
