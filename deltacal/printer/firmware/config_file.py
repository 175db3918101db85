"""A firmware's configuration given to a job (``--controller SETTINGS [--firmware NAME]``): told, read once.

Without a name the firmware is told from the file's content
(:func:`~deltacal.printer.firmware.config_firmware`); with one, it is the firmware of that name among
:func:`~deltacal.printer.firmware.firmwares`. A file of
deltacal's own (a robot file, a calibration) is refused as a firmware's settings. :func:`read_firmware_config`
tells the firmware and reads its values once, for every use a job makes of them (the controller, the
same-printer check, the reading of G-code); a printer's calibration (or robot file) and the firmware's
values are checked to be of one printer (:func:`check_printer_values`).
"""

from __future__ import annotations

import tomllib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...controller.targets import CommandModel
from ...controller_record import ControllerRecord, changes_in_words, files_digest
from ...exceptions import AssemblyError, ConvergenceError, GeometryError, InputError, UsageError
from ...gcode.dialect import Dialect
from ...geometry import DeltaGeometry
from ..identification.anchor import controller_shift, reanchored, same_commands
from . import check_config_firmware, config_firmware, firmware_named, firmwares
from .base import Firmware, FirmwareModel, RotaryFirmwareController

if TYPE_CHECKING:
    from ...calibration import Calibration
    from ...measured_record import MeasuredRecord

#: A recorded value changed: its key, the recorded value and the one now (None: no such key).
Change = tuple[str, float | None, float | None]


def firmware_names() -> tuple[str, ...]:
    """The names ``--firmware`` takes (and ``export --controller``), in the firmwares' order."""
    return tuple(firmware.name for firmware in firmwares())


def settings_files() -> str:
    """What a printer's ``--controller`` takes: each firmware's usual file (``printer.cfg|config.g|...``)."""
    return "|".join(firmware.config_file for firmware in firmwares())


def settings_needed(files: Sequence[str | Path], kind: str, why: str, calibration: Calibration | None = None,
                    source: str | Path = "") -> UsageError:
    """The refusal of a printer's files given without ``--controller``: naming them, why, what to give.

    Args:
        files: The files of commanded positions (measurements, templates).
        kind: What they are (``"measurements"``).
        why: What the firmware's settings are to them (``"the settings they were made with"``).
        calibration: The printer's calibration: its recorded configuration (``[controller]``) is the
            one to give; None, or none recorded: any firmware's usual file.
        source: The calibration's file, for the message.
    """
    record = calibration.controller if calibration is not None else None
    recorded = firmware_named(record.firmware) if record is not None else None
    names = ", ".join(str(f) for f in files)
    head = f"{names}: a printer's {kind} are of commanded positions: give --controller"
    if record is None or recorded is None:
        return UsageError(f"{head} {settings_files()} ({why})")
    return UsageError(f"{head} {recorded.config_file} ({why}: {source} was identified with "
                      f"{recorded.title}'s {record.source})")


def told_firmware(path: str | Path, name: str | None) -> Firmware[Any]:
    """The firmware of ``--controller PATH``: the one named, else the one whose settings the file is.

    Raises:
        UsageError: a file of deltacal's own (a robot file...), an unknown name, or no name and a
            file no firmware recognises.
        InputError: a name given for a file that is another firmware's configuration by its content
            (:func:`~deltacal.printer.firmware.check_config_firmware`).
    """
    refuse_deltacal_file(path)
    if name is not None:
        named = firmware_named(name)
        if named is None:
            raise UsageError(f"--firmware {name}: one of {'|'.join(firmware_names())}")
        check_config_firmware(path, named)
        return named
    firmware = config_firmware(path)
    if firmware is None:
        raise UsageError(f"--controller {path}: not a firmware's settings that deltacal recognises (a "
                         "Klipper printer.cfg, a Marlin M503 capture...): give --firmware "
                         f"{'|'.join(firmware_names())}")
    return firmware


def refuse_deltacal_file(path: str | Path, option: str = "--controller") -> None:
    """A usage error if ``path``, given as a firmware's settings, is deltacal's own file (a robot file)."""
    own = deltacal_file(path)
    if own is not None:
        raise UsageError(f"{option} {path}: {own}, not a firmware's configuration: give the printer's "
                         "settings (Klipper's printer.cfg, Marlin's M503 capture)")


def deltacal_file(path: str | Path) -> str | None:
    """What file of deltacal's own ``path`` is (``"a deltacal robot file"``), or None (none of its)."""
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    kind = data.get("format")
    if isinstance(kind, str) and kind.startswith("deltacal-"):
        return f"a deltacal file (format = {kind!r})"
    return "a deltacal robot file" if isinstance(data.get("geometry"), dict) else None


@dataclass(frozen=True)
class FirmwareConfig:
    """A firmware's configuration file, its firmware told and its values read once.

    Attributes:
        firmware: The firmware whose settings the file is.
        values: Its values (:meth:`~deltacal.printer.firmware.base.Firmware.read_config`).
        path: The file.
    """

    firmware: Firmware[Any]
    values: FirmwareModel
    path: str

    @classmethod
    def read(cls, firmware: Firmware[Any], path: str | Path) -> FirmwareConfig:
        """``path`` read as ``firmware``'s configuration (told already).

        Raises:
            InputError: the configuration's first problem.
        """
        return cls(firmware, firmware.read_config(path), str(path))

    def controller(self, step_distance: Any = None) -> CommandModel:
        """The firmware with these values as the controller of readings counted in ``step_distance`` [mm].

        By default the configuration's own step distance, the same on the three towers
        (:meth:`~deltacal.printer.firmware.base.Firmware.configured_controller`).
        """
        return self.firmware.configured_controller(self.values, step_distance, self.path)

    def dialect(self) -> Dialect:
        """The firmware's reading of G-code with this configuration (its values not read again)."""
        return self.firmware.dialect(self.path, self.values)

    def record(self) -> ControllerRecord:
        """What a calibration identified with this configuration records of it (``[controller]``).

        The firmware's name, the file as given, the sha256 of every file it read (itself first:
        :meth:`~deltacal.printer.firmware.base.Firmware.config_files`) and its values by the
        firmware's keys (:meth:`~deltacal.printer.firmware.base.Firmware.values_read`).
        """
        with warnings.catch_warnings():  # the configuration's warnings were said when it was read
            warnings.simplefilter("ignore")
            files = self.firmware.config_files(self.path)
        return ControllerRecord(self.firmware.name, self.path, files_digest(files),
                                self.firmware.values_read(self.values))

    def anchor(self, calibration: Calibration, source: str | Path) -> tuple[Calibration, tuple[str, ...]]:
        """The calibration as these values command it, and what to say; another firmware or printer refused.

        First against the calibration's geometry (:meth:`check_printer`: another printer's values),
        then against the controller the calibration recorded (``[controller]``): another firmware is
        refused (:func:`recorded_firmware`); the same values: the calibration as it is, nothing said;
        values changed: re-anchored (:mod:`~deltacal.printer.identification.anchor`: its measurements
        identified again with the start moved as the values moved it), said in one line naming each
        changed key (recorded -> now), unless one is beyond what a build could change
        (:meth:`~deltacal.printer.firmware.base.Firmware.check_same_printer` of the recorded values
        and these: another printer, refused naming it). A calibration that records no controller (a
        file written before it was recorded) is taken as it is, said; a geometry file (the printer
        alone) records none and says nothing. One that records no measurements cannot be
        re-anchored: taken as identified, said.

        Returns:
            The calibration to use and the lines to say (none: the values it was identified with).

        Raises:
            InputError: another firmware, or another printer, naming the key.
        """
        self.check_printer(calibration.geometry, source)
        recorded_firmware(calibration, source, self.firmware, self.path)
        record = calibration.controller
        if record is None:
            if not calibration.base:  # a geometry file: the printer alone, no controller to record
                return calibration, ()
            return calibration, (f"{source} records no controller (written before calibrations recorded "
                                 f"the one they were identified with): {self.path}'s values are taken to "
                                 "be that one's",)
        changes = record.changes(self.firmware.values_read(self.values))
        if not changes:
            return calibration, ()
        recorded = self.firmware.with_values(self.values, record.values)
        self.firmware.check_same_printer(recorded, self.values,
                                         f"{source}'s recorded controller {record.source}", self.path)
        said = f"{self.path}: values changed since {source} was identified with {record.source}: " \
               f"{changes_in_words(changes)}; "
        if calibration.measured is None:
            return calibration, (said + f"{source} records no measurements to re-anchor with (written before "
                                 f"they were recorded): its correction is taken as identified, relative to "
                                 f"{record.source}'s values; identify again to follow {self.path}",)
        try:
            moved = reanchored_to(self.firmware, calibration, self.values)
        except (ValueError, ConvergenceError, AssemblyError) as exc:
            raise InputError(f"{said}re-anchoring {source} to these values failed ({exc}): measure the "
                             f"printer again and identify through {self.path}", self.path) from None
        if moved is None:
            return calibration, (said + "they move no nozzle (limits only): the calibration is used as "
                                 "identified",)
        return moved, (
            said + f"re-anchored: what its measurements determine is kept, the rest follows {self.path}; if "
            "the printer itself changed (rods, probe, effector), measure it again and identify",)

    def check_printer(self, geometry: DeltaGeometry, source: str | Path) -> None:
        """Refuse these values if of another printer than ``geometry`` (:func:`check_printer_values`)."""
        check_printer_values(self.firmware, geometry, self.values, source, self.path)


@dataclass(frozen=True)
class RotaryFirmwareConfig:
    """A firmware's configuration of a rotary Delta printer, read once: its controller and reading of G-code.

    Attributes:
        firmware: The firmware whose settings the file is.
        rotary: Its model of the printer as the controller of the arms' readings
            (:meth:`~deltacal.printer.firmware.base.Firmware.rotary_controller`).
        path: The file.
    """

    firmware: Firmware[Any]
    rotary: RotaryFirmwareController
    path: str

    def controller(self, step_distance: Any = None) -> CommandModel:
        """The firmware as the controller of the arms' readings [rad] (``step_distance`` unused: angles)."""
        return self.rotary

    def dialect(self) -> Dialect:
        """The firmware's reading of G-code with this configuration (its home the rotary model's)."""
        return self.firmware.dialect(self.path, self.rotary.firmware)

    def record(self) -> ControllerRecord:
        """What a rotary printer's calibration records of this configuration (``[controller]``)."""
        with warnings.catch_warnings():  # the configuration's warnings were said when it was read
            warnings.simplefilter("ignore")
            files = self.firmware.config_files(self.path)
        return ControllerRecord(self.firmware.name, self.path, files_digest(files), self.rotary.values_read())

    def anchor(self, calibration: Calibration, source: str | Path) -> tuple[Calibration, tuple[str, ...]]:
        """A rotary robot's calibration moved into the firmware's frame (the bed's), and what to say.

        Its geometry and its nominal robot both move up by the firmware's bed height below {O}, the
        nominal robot's nozzle drop placing the bed (a geometry file: its own), so that targets and
        commands are the firmware's coordinates, as G-code gives them. Another firmware than the one a
        calibration recorded (``[controller]``) is refused. Values changed since: the calibration is
        put in the bed's frame as the recorded values placed it (the bed is where it was measured),
        then re-anchored (:func:`rotary_reanchored_to`), said in one line naming each changed key
        (recorded -> now), unless the recorded values are of another printer
        (:meth:`~deltacal.printer.firmware.controller.RotaryFirmwareController.check_same_values`:
        refused naming the key).

        Raises:
            InputError: another firmware or printer, naming it; a calibration with no measurements
                recorded, or one whose re-anchoring failed, through changed values.
        """
        changes = self._changes(calibration, source)
        if not changes:
            said_frame = self._frame(calibration, source, self.rotary)
            return in_firmware_frame(calibration, self.rotary), (said_frame,)
        recorded, placed, said = self._reanchored(calibration, source, changes)
        return placed, (said, self._frame(calibration, source, recorded))

    def anchor_in_own_frame(self, calibration: Calibration, source: str | Path
                            ) -> tuple[Calibration, tuple[str, ...]]:
        """The calibration as :meth:`anchor` re-anchors it, left in its own frame {O} (``export``'s).

        The same values as recorded (or none recorded): the calibration itself, nothing said (the
        firmware's export puts it in its frame, and says where). Values changed: re-anchored in the
        bed's frame as :meth:`anchor` does, then moved back down by these values' bed height
        (:func:`out_of_firmware_frame`), so that an export moving it up by them finds it there; the
        one line said. Refused as :meth:`anchor` refuses.
        """
        changes = self._changes(calibration, source)
        if not changes:
            return calibration, ()
        _, placed, said = self._reanchored(calibration, source, changes)
        return out_of_firmware_frame(placed, self.rotary), (said,)

    def _changes(self, calibration: Calibration, source: str | Path) -> list[Change]:
        """The recorded values these change (none: the same, or none recorded); another firmware refused."""
        recorded_firmware(calibration, source, self.firmware, self.path)
        record = calibration.controller
        return [] if record is None else list(record.changes(self.rotary.values_read()))

    def _reanchored(self, calibration: Calibration, source: str | Path, changes: list[Change]
                    ) -> tuple[RotaryFirmwareController, Calibration, str]:
        """The recorded values' controller, the calibration re-anchored to these (bed frame), what to say."""
        record = calibration.controller
        assert record is not None
        recorded = self.rotary.with_values(record.values)
        self.rotary.check_same_values(recorded, f"{source}'s recorded controller {record.source}", self.path)
        said = f"{self.path}: values changed since {source} was identified with {record.source}: " \
               f"{changes_in_words(changes)}; "
        again = f"measure the printer again and identify through {self.path} (or give {record.source})"
        if calibration.measured is None:
            raise InputError(f"{said}{source} records no measurements to re-anchor with: {again}", self.path)
        placed = in_firmware_frame(calibration, recorded)
        try:
            moved = rotary_reanchored_to(placed, recorded, self.rotary)
        except (ValueError, ConvergenceError, AssemblyError) as exc:
            raise InputError(f"{said}re-anchoring {source} to these values failed ({exc}): {again}",
                             self.path) from None
        if moved is None:
            return recorded, placed, said + "they move no nozzle: the calibration is used as identified"
        return recorded, moved, said + (f"re-anchored: what its measurements determine is kept, the rest "
                                        f"follows {self.path}; if the printer itself changed (arms, probe, "
                                        "effector), measure it again and identify")

    def _frame(self, calibration: Calibration, source: str | Path, rotary: RotaryFirmwareController) -> str:
        """Where the firmware's frame is in the calibration's {O}, ``rotary``'s values placing its bed."""
        nominal = calibration.nominal
        return (f"{self.path}: targets and commands in {self.firmware.title}'s frame: its bed (z = 0) at z = "
                f"{-rotary.bed_height(nominal):g} mm in {source}'s frame (shoulder height + nozzle drop "
                f"{-float(nominal.tool[2]):g} mm)")


def in_firmware_frame(calibration: Calibration, rotary: RotaryFirmwareController) -> Calibration:
    """A rotary printer's calibration (in {O}) moved up into a firmware's frame by its values' bed height.

    Its geometry, nominal robot and where it holds along the bed, by the nominal robot's nozzle drop
    (:meth:`~deltacal.printer.firmware.controller.RotaryFirmwareController.in_bed_frame`); where it
    holds is in the firmware's frame already.
    """
    nominal = calibration.nominal
    holds = calibration.holds
    if holds is not None and holds.along_bed is not None:
        holds = replace(holds, along_bed=rotary.in_bed_frame(holds.along_bed, nominal))
    return replace(calibration, geometry=rotary.in_bed_frame(calibration.geometry, nominal),
                   nominal=rotary.in_bed_frame(nominal), holds=holds)


def out_of_firmware_frame(calibration: Calibration, rotary: RotaryFirmwareController) -> Calibration:
    """A rotary printer's calibration in a firmware's frame moved back down into {O} by its bed height.

    The inverse of :func:`in_firmware_frame` (the bed height of the calibration's nominal robot's
    nozzle drop, which the move keeps): its geometry, nominal robot and where it holds along the bed.
    """
    down = np.array([0.0, 0.0, -rotary.bed_height(calibration.nominal)])
    holds = calibration.holds
    if holds is not None and holds.along_bed is not None:
        holds = replace(holds, along_bed=holds.along_bed.moved_rigidly(np.eye(3), down))
    return replace(calibration, geometry=calibration.geometry.moved_rigidly(np.eye(3), down),
                   nominal=calibration.nominal.moved_rigidly(np.eye(3), down), holds=holds)


def rotary_reanchored_to(calibration: Calibration, recorded: RotaryFirmwareController,
                         now: RotaryFirmwareController) -> Calibration | None:
    """A rotary printer's calibration (in the bed's frame) re-anchored from its recorded values to ``now``.

    A rotary firmware's reading of an arm is its angle, counted from the endstop angle its values
    give: the recorded readings are counted again as ``now`` counts the same steps
    (:meth:`~deltacal.printer.firmware.controller.RotaryFirmwareController.recounted`); the start
    moves from the printer the recorded values' forward model describes, in their readings, to the
    one ``now``'s describes, in its own
    (:func:`~deltacal.printer.identification.anchor.controller_shift`); the measurements are
    identified again from it (:func:`~deltacal.printer.identification.anchor.reanchored`), where it
    holds given out to ``now``'s reach. None when the two put the nozzle alike at every arm position
    compared (the same steps through both).
    """
    record = calibration.measured
    assert record is not None

    def before(q: np.ndarray) -> np.ndarray:
        return recorded.forward(q, check=False)

    def same_steps(q: np.ndarray) -> np.ndarray:
        return now.forward(now.recounted(q, recorded), check=False)

    def after(q: np.ndarray) -> np.ndarray:
        return now.forward(q, check=False)

    if same_commands(calibration, before, same_steps):
        return None
    counted = recounted_record(record, recorded, now)
    return reanchored(calibration, controller_shift(calibration, before, after), counted, now.reach_radius)


def recounted_record(record: MeasuredRecord, recorded: RotaryFirmwareController,
                     now: RotaryFirmwareController) -> MeasuredRecord:
    """A rotary printer's recorded measurements, their readings counted again as ``now`` counts the steps.

    The probe's and the printed pairs' readings (the arms' angles ``recorded``'s values counted,
    :meth:`~deltacal.printer.firmware.controller.RotaryFirmwareController.recounted`); the distances,
    heights and the fit's choices as recorded.
    """
    return replace(record, probe=now.recounted(record.probe, recorded),
                   pairs=now.recounted(record.pairs.reshape(-1, 3), recorded).reshape(record.pairs.shape))


def settings_read(firmware: Firmware[Any], path: str | Path) -> FirmwareConfig | RotaryFirmwareConfig:
    """``path`` read as ``firmware``'s configuration (told already): a rotary or a linear Delta printer's.

    Raises:
        InputError: the configuration's first problem.
    """
    rotary = firmware.rotary_controller(path)
    if rotary is not None:
        return RotaryFirmwareConfig(firmware, rotary, str(path))
    return FirmwareConfig.read(firmware, path)


def reanchored_to(firmware: Firmware[Any], calibration: Calibration,
                  now: FirmwareModel) -> Calibration | None:
    """The calibration re-anchored from the values it recorded (``[controller]``) to ``now``'s.

    Each set of values as the firmware's controller (its forward model, readings counted in the
    calibration's step distance), their move in the model's parameters
    (:func:`~deltacal.printer.identification.anchor.controller_shift`), the measurements identified
    again from the start moved by it (:func:`~deltacal.printer.identification.anchor.reanchored`).
    None when the two command alike (the values changed are limits: ``M208 Z``, a print radius).
    """
    assert calibration.controller is not None and calibration.measured is not None
    recorded = firmware.with_values(now, calibration.controller.values)
    step = calibration.geometry.step_distance
    assert step is not None  # a printer's calibration counts its readings in its step distance
    old, new = firmware.controller(recorded, step), firmware.controller(now, step)

    def before(q: np.ndarray) -> np.ndarray:
        return old.forward(q, check=False)

    def after(q: np.ndarray) -> np.ndarray:
        return new.forward(q, check=False)

    if same_commands(calibration, before, after):
        return None
    return reanchored(calibration, controller_shift(calibration, before, after))


def recorded_firmware(calibration: Calibration, source: str | Path, firmware: Firmware[Any] | None = None,
                      given: str | Path | None = None) -> Firmware[Any] | None:
    """The firmware a printer's calibration was identified with (``[controller]``), or None (not recorded).

    Args:
        calibration: The calibration.
        source: Its file, for the message.
        firmware: The firmware a route is given (``--controller``'s, ``--firmware``), refused if
            another; None: none given.
        given: What named ``firmware`` (its configuration), for the message; by default its name.

    Raises:
        InputError: ``firmware`` is not the recorded one (naming both), or the recorded firmware is
            not one deltacal knows.
    """
    record = calibration.controller
    if record is None:
        return None
    recorded = firmware_named(record.firmware)
    if recorded is None:
        known = "|".join(firmware_names())
        raise InputError(f"firmware {record.firmware!r} is not one deltacal knows ({known})", str(source),
                         "key controller.firmware")
    if firmware is not None and firmware is not recorded:
        what = f"{given if given is not None else 'the firmware given'} is {firmware.title}'s"
        raise InputError(f"identified with {recorded.title} ({record.source}), but {what}: a calibration "
                         f"serves the firmware it was measured with; give {recorded.title}'s "
                         f"({recorded.config_file})", str(source))
    return recorded


def read_firmware_config(path: str | Path, name: str | None = None) -> FirmwareConfig:
    """A firmware's configuration (``--controller``), the firmware told (:func:`told_firmware`) and read once.

    Raises:
        UsageError: as :func:`told_firmware`.
        InputError: the configuration's first problem.
    """
    return FirmwareConfig.read(told_firmware(path, name), path)


def controller_firmware(path: str | Path, name: str | None = None) -> Firmware[Any] | None:
    """The firmware whose configuration a ``--controller`` file is, or None (a controller or robot file).

    With a name (``--firmware``) the file is that firmware's (:func:`told_firmware`); without, it is
    one when a firmware recognises it (:func:`~deltacal.printer.firmware.config_firmware`).
    """
    return told_firmware(path, name) if name is not None else config_firmware(path)


def controller_config(path: str | Path, name: str | None = None) -> FirmwareConfig | None:
    """A ``--controller`` file as a firmware's configuration read once, or None (a controller or robot file).

    The firmware as :func:`controller_firmware` tells it.
    """
    firmware = controller_firmware(path, name)
    return None if firmware is None else FirmwareConfig.read(firmware, path)


def check_printer_values(firmware: Firmware[Any], geometry: DeltaGeometry, model: FirmwareModel,
                         source: str | Path, config: str | Path) -> None:
    """Refuse a firmware's values ``model`` (read from ``config``) of another printer than ``geometry``.

    The geometry's values are the firmware's at its tolerances' centre
    (:meth:`~deltacal.printer.firmware.base.Firmware.start`), in the configuration's step distance when
    the geometry holds none (a calibration written before it was kept).

    Raises:
        InputError: naming both values (or the geometry the firmware's model cannot hold).
    """
    if geometry.step_distance is None:
        geometry = replace(geometry, step_distance=model.step_distance)
    try:
        ours = firmware.start(geometry)
    except GeometryError as exc:
        raise InputError(str(exc), str(source)) from None
    firmware.check_same_printer(ours, model, f"{source}'s geometry", str(config))
