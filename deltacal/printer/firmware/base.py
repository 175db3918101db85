"""The interface a printer's firmware implements (Klipper now; Marlin and RepRapFirmware next).

A firmware holds its own classical model of the printer (vertical towers, one rod length per tower,
a point effector) with the values of its configuration file. What deltacal needs of it, each
firmware gives through one :class:`Firmware`:

* its configuration file read into its values (:meth:`Firmware.read_config`), and its files told
  from deltacal's own (:meth:`Firmware.is_config`);
* its model with those values (:class:`FirmwareModel`): a commanded nozzle position to steps
  below the endstops and back; the model of the perfect printer (:meth:`Firmware.nominal`) and of
  an identified geometry at its tolerances' centre (:meth:`Firmware.start`);
* its limits on the commands it takes, as its configuration sets them (:meth:`FirmwareModel.outside`,
  :meth:`FirmwareModel.refusal`: a :class:`~deltacal.controller.limits.CommandLimits`), so that
  every command deltacal writes for it is one it accepts, and a refusal names the key to change;
* the firmware as the controller of the printer's readings (:meth:`Firmware.controller`, a
  :class:`~deltacal.controller.targets.CommandModel`: what corrected targets and G-code go
  through), also from its configuration file (:meth:`Firmware.load_controller`);
* a configuration written with new values (:meth:`Firmware.config_text`, :meth:`Firmware.save_config`);
* the values that fit an identified geometry best (:meth:`Firmware.fit`: a :class:`FirmwareFit`, the
  same value for every firmware);
* two sets of values refused when they are of different printers (:meth:`Firmware.check_same_printer`:
  a calibration and the configuration of another printer);
* a program in its own dialect that probes the bed at given points and says each result on its
  console (:meth:`Firmware.probe_program`), travelling between them above the probe's trigger
  height as its configuration sets it (:meth:`Firmware.probe_travel`), whose log is read back
  into probe heights (:meth:`Firmware.is_probe_log`, :meth:`Firmware.read_probe_log`);
* its configuration read into deltacal's robot file and measurement files, as ``deltacal import``
  writes them (:meth:`Firmware.import_config`);
* its reading of G-code (:meth:`Firmware.dialect`): E under G91, arcs' P words, where a homing
  leaves the nozzle, the macros its configuration defines;
* its own calibration, emulated (:meth:`Firmware.own_calibrations`), measuring a printer through
  a :class:`Measuring`, for the comparison with deltacal's.

deltacal's readings of a printer are the carriages' travels below the endstops counted in the
printer's nominal step distance: reading = steps × that step distance. Units: mm, the models'
angles in rad (the configuration files' in the firmware's own units).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, ClassVar, Generic, Protocol, TypeVar

import numpy as np

from ...controller.targets import CommandModel, corrected_targets
from ...exceptions import InputError
from ...gcode.dialect import GENERIC, Dialect
from ...geometry import DeltaGeometry, Workspace
from ...holds import DEFAULT_BOUND, WhereItHolds
from ...io.atomic import atomic_write_text
from ..files.same_printer import ENDSTOP_MM, LENGTH_RTOL, STEP_DISTANCE_RTOL, check_same_values
from .bed import bed_grid
from .controller import RotaryFirmwareController
from .live_correction import LiveCorrection
from .owner_keys import OwnerKeys
from .probe_log import ProbeLog
from .probing import PROBE_CLEARANCE, ProbeTravel
from .value_keys import ValueKey

if TYPE_CHECKING:
    from ...calibration import Calibration
    from ..files.importer import PrinterImport
    from ..robot import NominalLinearDelta
    from .rotary_values import RotaryValues


#: Margin below the lowest corrected bed point of the lowest Z admitted [mm].
BED_MARGIN_MM = 0.01


class FirmwareModel(Protocol):
    """A firmware's kinematic model with its configuration's values.

    Attributes:
        name: A name (the configuration file's).
        step_distance: The carriage travel per (micro)step of each tower [mm], (3,).
    """

    @property
    def name(self) -> str: ...  # noqa: D102

    @property
    def step_distance(self) -> np.ndarray: ...  # noqa: D102

    @property
    def towers(self) -> np.ndarray:
        """Tower positions ``(X_i, Y_i)`` [mm], (3, 2)."""

    @property
    def carriage_top(self) -> np.ndarray:
        """Carriage point heights at the endstops ``E_i`` [mm], (3,)."""

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps below the endstops the firmware commands for nozzle targets [mm], (N, 3) -> (N, 3)."""

    def positions(self, steps: np.ndarray, check: bool = True) -> np.ndarray:
        """The firmware's nozzle positions at steps below the endstops, (N, 3) -> (N, 3) [mm]."""

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """The readings (steps × the printer's ``step_distance`` [mm]) for nozzle targets, (N, 3) [mm]."""

    def forward(self, readings: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Nozzle positions at readings (travels counted in ``step_distance`` [mm]), (N, 3) [mm]."""

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which of the firmware's limits each command breaks, (N, 3) [mm] -> (N,) integers (0: none)."""

    def refusal(self, commands: np.ndarray) -> str:
        """One line on refused commands: the limit, and the configuration key and value that admit them."""

    def with_minimum_z(self, minimum_z: float) -> FirmwareModel:
        """The same values with the lowest Z the firmware accepts set to ``minimum_z`` [mm]."""


class ErrorFigures(Protocol):
    """Nozzle errors over the printable volume and the first layer [mm] (a fit's ``ErrorStats``)."""

    @property
    def max_3d(self) -> float:
        """Largest 3-D error over the volume's grid."""

    @property
    def rms_3d(self) -> float:
        """Root mean square 3-D error over the volume's grid."""

    @property
    def flatness(self) -> float:
        """Largest |z error| over the first layer's disc."""

    @property
    def flatness_pv(self) -> float:
        """Peak to valley of the z error over the first layer's disc."""

    def as_dict(self) -> dict[str, float]:
        """The figures by name [mm]."""


class Measuring(Protocol):
    """A printer measured through a firmware's values (a real one, or a simulation)."""

    def heights(self, model: FirmwareModel, xy: np.ndarray) -> np.ndarray:
        """The commanded z at which the probe triggers over the bed at commanded x, y [mm], (N, 2) -> (N,)."""

    def distances(self, model: FirmwareModel, pairs: np.ndarray) -> np.ndarray:
        """Distances between features printed at commanded positions [mm], (M, 6) -> (M,)."""


ModelT = TypeVar("ModelT", bound=FirmwareModel)


#: The classical delta values every firmware holds, in Klipper's words (each firmware's fit knows its
#: own values of each): a radius, each tower's angle, arm, endstop and step distance.
CLASSICAL_NAMES = (
    "delta_radius", "angle_a", "angle_b", "angle_c", "arm_length_a", "arm_length_b", "arm_length_c",
    "position_endstop_a", "position_endstop_b", "position_endstop_c",
    "step_distance_a", "step_distance_b", "step_distance_c",
)


def classical_name(name: str) -> str:
    """A :class:`~deltacal.holds.WhereItHolds` value's name as in :data:`CLASSICAL_NAMES`.

    The ``klipper`` error model's names: ``endstop_a`` is ``position_endstop_a``, ``scale_a`` is
    ``step_distance_a``.
    """
    if name == "delta_radius":
        return name
    kind, _, tower = name.rpartition("_")
    return f"{ {'endstop': 'position_endstop', 'scale': 'step_distance'}.get(kind, kind)}_{tower}"


def undetermined_values(holds: WhereItHolds | None) -> tuple[str, ...]:
    """The classical values (:data:`CLASSICAL_NAMES`) a calibration's measurements do not determine.

    Those of :meth:`~deltacal.holds.WhereItHolds.undetermined` (:func:`classical_name`); none without
    that knowledge (a calibration written before it was kept).
    """
    if holds is None:
        return ()
    named = [classical_name(name) for name in holds.undetermined()]
    # tower C's angle is the printed part's turn, held by every fit
    return tuple(name for name in CLASSICAL_NAMES if name in named and name != "angle_c")


#: The first layer's bounds of :func:`least_largest` [mm]: None (the start's), its largest |z error|
#: (its peak to valley then bounded by twice that alone), or both (largest |z error|, peak to valley).
Flatness = float | tuple[float, float] | None

@dataclass(frozen=True)
class FirmwareFit(Generic[ModelT]):
    """A firmware's values fitted to an identified printer, and what they leave (any firmware's).

    Attributes:
        values: The fitted values, as the firmware writes them.
        fitted: Names (the firmware's) of the values fitted.
        held: Names held at the start's values (asked, a gauge the firmware holds, or not
            identifiable over the grid).
        unidentifiable: The held values the grid cannot tell apart from the others.
        singular_values: Singular values of the column-scaled Jacobian, largest first.
        before: Errors with the start's values [mm].
        after: Errors with the fitted values, through the firmware's model [mm].
        iterations: Gauss-Newton iterations (of the last fit, where the firmware fits twice).
        points: Number of grid points.
    """

    values: ModelT
    fitted: list[str]
    held: list[str]
    unidentifiable: list[str]
    singular_values: np.ndarray
    before: ErrorFigures
    after: ErrorFigures
    iterations: int
    points: int


def classical_values(model: FirmwareModel) -> tuple[float, np.ndarray, np.ndarray]:
    """A firmware model's classical delta values, in any firmware's words.

    The radius is the towers' mean distance from the centre; each tower's endstop the carriage's
    travel from its endstop to the bed's centre (the nozzle's height there, centred, when the
    carriage is at its endstop: Klipper's ``position_endstop``); its arm the rod from the carriage
    point, at that travel, to the nozzle at the bed's centre.

    Returns:
        The radius [mm], the arm lengths [mm] (3,) and the endstops [mm] (3,).
    """
    towers = np.asarray(model.towers, dtype=float)
    endstop = model.steps(np.zeros((1, 3)), check=False)[0] * model.step_distance
    arm = np.hypot(model.carriage_top - endstop, np.linalg.norm(towers, axis=1))
    return float(np.mean(np.linalg.norm(towers, axis=1))), arm, endstop


class Firmware(ABC, Generic[ModelT]):
    """A printer's firmware: its configuration file, its model, its controller, its fitted values.

    Attributes:
        name: The firmware's name, lower case (``"klipper"``).
        title: The name users read (``"Klipper"``).
        step_distance_keys: Where its configuration sets the towers' step distances (for messages).
        classical_keys: Its names of a model's radius, arm lengths and endstops (for messages).
        config_file: The usual name of its configuration file (``printer.cfg``).
        calibrated_file: The name deltacal gives a file of fitted values (``printer_calibrated.cfg``).
        minimum_z_key: Where its configuration sets the lowest Z it accepts (``minimum_z_position``).
        apply_note: How to put the values :meth:`config_text` writes into the printer (one line,
            the first comment of the file and said by ``deltacal export``), whatever the
            configuration the printer runs (:meth:`apply_note_for` says it for one).
        export_file: The file ``deltacal export --controller NAME -o`` writes, as its help names it.
        values_words: What its exported values are, in its own words (``"M665, M666 and M92 lines"``).
        value_names: Each classical value (:data:`CLASSICAL_NAMES`) in its own words (``"M666 Y"``);
            :meth:`value_name`.
        export_needs_config: Why the exported values need the configuration the printer runs
            (``--config``) unless the step distances are held, or "" (they do not: the step
            distances alone give the firmware's values).
        exports_minimum_z: Whether the exported values carry the lowest Z the firmware accepts (Klipper's
            ``minimum_z_position``), lowered by export to admit the corrected bed (:meth:`admit_bed`).
        live_files: The files of a correction the firmware runs itself (``export --live``, Klipper's
            module and its section: :meth:`export_live`), or none (the firmware has none).
    """

    name: ClassVar[str]
    title: ClassVar[str]
    step_distance_keys: ClassVar[str]
    #: Its names of the radius, the arm lengths and the endstops of :func:`classical_values` (for messages).
    classical_keys: ClassVar[tuple[str, str, str]] = ("radius", "arm length", "endstop")
    config_file: ClassVar[str]
    calibrated_file: ClassVar[str]
    minimum_z_key: ClassVar[str]
    apply_note: ClassVar[str]
    #: Where it keeps each value an owner adjusts, in its words (:class:`~.owner_keys.OwnerKeys`).
    owner_keys: ClassVar[OwnerKeys]
    export_file: ClassVar[str]
    values_words: ClassVar[str]
    value_names: ClassVar[Mapping[str, str]] = MappingProxyType({})
    #: Every value its configuration sets that its model holds, by the firmware's own key
    #: (``"stepper_a.position_endstop"``, ``"M665.L"``): what a calibration records of it.
    value_keys: ClassVar[Mapping[str, ValueKey]] = MappingProxyType({})
    export_needs_config: ClassVar[str] = ""
    exports_minimum_z: ClassVar[bool] = False
    live_files: ClassVar[tuple[str, ...]] = ()
    #: Whether the firmware's probe program, run on a printer without a probe, asks for each height by
    #: hand and answers it as a probe's (RRF's ``G30`` with ``M558 P0``): ``plan --object`` then writes
    #: it beside :meth:`manual_heights`'s line.
    probes_by_hand: ClassVar[bool] = False

    @abstractmethod
    def is_config(self, path: str | Path) -> bool:
        """Whether a file (a command's ``--controller``) is this firmware's configuration by its content."""

    def is_config_name(self, path: str | Path) -> bool:
        """Whether a file's name alone says it is this firmware's configuration (none by default).

        Asked only when no firmware recognises the file by its content (:meth:`is_config`).
        """
        return False

    @abstractmethod
    def read_config(self, path: str | Path) -> ModelT:
        """The firmware's model with the values of its configuration file.

        Raises:
            InputError: naming the file and the key (and value) of the first problem found.
        """

    @abstractmethod
    def nominal(self, printer: NominalLinearDelta) -> ModelT:
        """The values that make the firmware's model the perfect printer built to these values."""

    @abstractmethod
    def start(self, geometry: DeltaGeometry) -> ModelT:
        """The values of a printer's geometry at its tolerances' centre (a fit's start)."""

    @abstractmethod
    def controller(self, model: ModelT, step_distance: np.ndarray | float) -> CommandModel:
        """The firmware with these values as the controller of readings counted in ``step_distance`` [mm]."""

    @abstractmethod
    def config_text(self, model: ModelT, source: str | Path | None = None, title: str = "",
                    notes: list[str] | tuple[str, ...] = (), complete: bool = False) -> str:
        """The configuration file's text with these values.

        Args:
            model: The values.
            source: The configuration the printer runs, for what the values do not hold (its
                steppers' microstepping, say).
            title: A first comment line (what the values are).
            notes: More comment lines.
            complete: A whole configuration the firmware (and :meth:`read_config`) reads, the values
                written exactly; else only the keys of the values, to replace those of the
                printer's configuration.
        """

    @abstractmethod
    def fit(self, geometry: DeltaGeometry, start: ModelT, step_distance: np.ndarray | float,
            workspace: Workspace, hold_step_distance: bool = False,
            first_layer_weight: float = 0.0, minimax: bool = False,
            grid: np.ndarray | None = None, flatness: Flatness = None,
            hold: Sequence[str] = ()) -> FirmwareFit[ModelT]:
        """The values that leave the least nozzle error of an identified printer over its printable volume.

        Args:
            geometry: The identified printer (a prismatic chain; the true bed is z = 0).
            start: The values to start from.
            step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
            workspace: The printable cylinder.
            hold_step_distance: Keep the start's step distances.
            first_layer_weight: Weight of the first layer's height errors (0: the volume alone).
            minimax: The least largest error over the volume, not the least squares, the first layer
                no less flat than the least squares leave it (:func:`~.fitting.least_largest`):
                what ``export`` writes.
            grid: The nozzle targets the errors are judged at [mm], (N, 3) (default: a grid of the
                printable volume, :func:`~deltacal.printer.firmware.fitting.printable_grid`).
            flatness: With ``minimax``, the first layer's largest |height error| allowed instead [mm].
            hold: More values to keep at the start's, by their classical names (:data:`CLASSICAL_NAMES`:
                ``delta_radius``, ``angle_a``, ``arm_length_a``, ``position_endstop_a``,
                ``step_distance_a``...): the firmware holds its values of those.
        """

    @abstractmethod
    def probe_program(self, points: np.ndarray, title: str = "",
                      clearance: float | ProbeTravel = PROBE_CLEARANCE,
                      live: LiveCorrection | None = None) -> str:
        """A program that homes, then probes the bed at each point in order, each result on the console.

        The nozzle is moved above each point at ``clearance`` and the firmware's probing command
        run there; between points it rises back to ``clearance``. The points' x, y are written as
        the firmware echoes them (to the micrometre), so that its log names the same points.

        Args:
            points: The commanded nozzle positions to probe [mm], (N, 2) or (N, 3) (z ignored).
            title: A first comment line (what the points are).
            clearance: The nozzle's height above the bed while it moves between points [mm], or
                the configuration's :meth:`probe_travel` (its reason then in the header).
            live: The configuration's :meth:`live_correction`: turned off first, on again last.
        """

    def rotary_controller(self, path: str | Path) -> RotaryFirmwareController | None:
        """The firmware as the controller of the rotary Delta printer whose configuration ``path`` is.

        None when ``path`` configures a linear Delta (:meth:`read_config` reads it), and for a firmware
        that runs no rotary Delta (the default).

        Raises:
            InputError: a rotary configuration's first problem.
        """
        return None

    def rotary_export(self, path: str | Path, calibration: Calibration, source: str | Path,
                      volume: Workspace | None = None, where: str = "") -> RotaryValues | None:
        """The rotary printer ``path`` configures: values fitted over ``volume`` ({O}; None: its own)."""
        return None

    def live_correction(self, path: str | Path) -> LiveCorrection | None:
        """Where the configuration ``path`` includes deltacal's live correction, or None (it does not).

        A firmware that runs deltacal's correction on every move itself (Klipper's ``export --live``
        module) is measured with it off and never sent a program corrected offline
        (:mod:`.live_correction`). By default None: the firmware has no such module.
        """
        return None

    def values_read(self, model: ModelT) -> dict[str, float]:
        """Every value of :attr:`value_keys` the model holds, by the firmware's key, in its units."""
        read = {key: where.read(model) for key, where in self.value_keys.items()}
        return {key: value for key, value in read.items() if value is not None}

    def with_values(self, model: ModelT, values: Mapping[str, float]) -> ModelT:
        """``model`` with the values of :attr:`value_keys` set from ``values`` (those it holds)."""
        changed: dict[str, object] = {}
        for key, where in self.value_keys.items():
            if key not in values:
                continue
            if where.index is None:
                changed[where.field] = where.held(float(values[key]))
            else:
                array = np.array(changed.get(where.field, getattr(model, where.field)), dtype=float)
                array[where.index] = where.held(float(values[key]))
                changed[where.field] = array
        return replace(model, **changed)  # type: ignore[type-var]

    def value_name(self, name: str) -> str:
        """A classical value's name (:data:`CLASSICAL_NAMES`) in the firmware's words (``value_names``)."""
        return self.value_names.get(name, name)

    def probe_travel(self, path: str | Path) -> ProbeTravel:
        """The height :meth:`probe_program` travels at between points, from the firmware's configuration.

        Above the probe's trigger height (the nozzle's height above the bed when the probe
        triggers), by the firmware's own travel height or a margin
        (:func:`~.probing.probe_travel`).

        Raises:
            InputError: the trigger height is not known (by default: the firmware's is never read).
        """
        raise InputError(f"deltacal does not read {self.title}'s probe: the height to travel at between "
                         "probe points, above the probe's trigger height, is not known", str(path))

    def manual_heights(self, path: str | Path) -> str | None:
        """How to measure the probe heights by hand, in one line, when the configuration has no probe.

        ``plan --object`` then writes no probe program (:meth:`probe_travel` is not known; unless
        :attr:`probes_by_hand`) and says this line instead: the firmware's own way of a paper test
        at each point of probe.csv, the answer to write in it and how to give it to ``identify`` (or
        to leave the heights out).

        Returns:
            The line, or None: the configuration has a probe (by default: the firmware's probe is
            taken as there, :meth:`probe_travel` says otherwise).
        """
        return None

    def apply_note_for(self, source: str | Path | None) -> str:
        """How to put the values written for the configuration ``source`` into the printer, in one line.

        Where the configuration keeps them (RepRapFirmware's ``config.g`` or ``config-override.g``);
        by default :attr:`apply_note`.

        Raises:
            InputError: the configuration's first problem.
        """
        return self.apply_note

    def export_live(self, calibration: Calibration, config: str | Path, folder: str | Path,
                    source: str = "", sigma_bound: float = DEFAULT_BOUND) -> tuple[str, ...]:
        """Write the correction the firmware runs itself (:attr:`live_files`) in ``folder``; what to say.

        Computed for the values of the configuration ``config`` the printer runs (``export --live``).

        Args:
            calibration: The printer's calibration.
            config: The configuration the printer runs.
            folder: The output folder (made if missing; its parent must exist).
            source: The calibration's file, for the files and the messages.
            sigma_bound: The σ of a correction accepted [mm], where the calibration knows where it
                holds (the offline route's ``--sigma-bound``).

        Raises:
            InputError: the configuration's first problem (by default: the firmware has none).
        """
        raise InputError(f"{self.title} runs no correction of deltacal's own (export --live)", str(config))

    def own_calibrations(self, model: ModelT, measuring: Measuring, radius: float) -> dict[str, ModelT]:
        """The firmware's own calibration of a printer, emulated: the values each variant leaves, by name.

        Args:
            model: The values the printer runs (the calibration's start).
            measuring: The printer, measured through given values (each variant measures afresh,
                in the order of the returned names).
            radius: The printable radius [mm] (each firmware probes within it by its own rule).

        Returns:
            The calibrated values by the name users read (``"Marlin G33 (P4)"``); none for a
            firmware without a calibration of its own.
        """
        return {}

    def admit_bed(self, model: ModelT, calibration: Calibration | DeltaGeometry,
                  step_distance: np.ndarray | float, radius: float, bound: float = DEFAULT_BOUND) -> ModelT:
        """The values with the lowest Z lowered, if need be, to admit the corrected bed.

        Where the true bed (z = 0 of an identified printer) is lower than the firmware's model puts
        it, a corrected first layer is commanded below the firmware's z = 0. The bed's disk of
        ``radius`` (rings and points every :data:`~.bed.BED_GRID_MM`) is corrected through the firmware as
        ``compensate`` corrects it (:func:`~deltacal.controller.corrected_targets`: where a calibration
        holds within ``bound``, in the controller's frame); the lowest Z commanded, less
        :data:`BED_MARGIN_MM`, rounded down to 0.01 mm, becomes the lowest Z accepted when it is below
        the model's.

        Args:
            model: The firmware's values (what a program is corrected for).
            calibration: The calibration (or the identified printer itself: corrected everywhere;
                its true bed is z = 0).
            step_distance: The step distance its readings count in [mm].
            radius: The printable radius [mm].
            bound: The σ of a correction applied [mm] (compensate's ``--sigma-bound``).
        """
        lowest = self.bed_minimum_z(model, calibration, step_distance, radius, bound)
        return model if lowest is None else model.with_minimum_z(lowest)  # type: ignore[return-value]

    def bed_minimum_z(self, model: ModelT, calibration: Calibration | DeltaGeometry,
                      step_distance: np.ndarray | float, radius: float,
                      bound: float = DEFAULT_BOUND) -> float | None:
        """The lowest Z :meth:`admit_bed` sets [mm], or None if the values admit the corrected bed."""
        controller = self.controller(model, step_distance)
        commands = corrected_targets(calibration, controller, bed_grid(radius), bound=bound).commands
        lowest = math.floor((float(np.min(commands[:, 2])) - BED_MARGIN_MM) * 100.0) / 100.0
        low = model.outside(np.array([[0.0, 0.0, lowest]])) != 0
        return lowest if bool(low[0]) else None

    def save_config(self, path: str | Path, model: ModelT, source: str | Path | None = None, title: str = "",
                    notes: list[str] | tuple[str, ...] = (), complete: bool = False) -> Path:
        """Write :meth:`config_text` to ``path`` atomically; returns the path."""
        return atomic_write_text(path, self.config_text(model, source, title, notes, complete))

    def load_controller(self, path: str | Path,
                        step_distance: np.ndarray | float | None = None) -> CommandModel:
        """The firmware as a controller, from its configuration file.

        Args:
            path: The configuration file.
            step_distance: The step distance the printer's readings count in [mm] (the printer's
                nominal one: each tower's (3,), or one number for the three); by default the
                configuration's own, which must then be the same on the three towers (a
                configuration whose towers differ may be one fitted to a calibration, no longer
                the printer's nominal one).

        Raises:
            InputError: the file's first problem, or towers stepping differently without
                ``step_distance``.
        """
        return self.configured_controller(self.read_config(path), step_distance, path)

    def configured_controller(self, model: ModelT, step_distance: np.ndarray | float | None,
                              source: str | Path) -> CommandModel:
        """The firmware as a controller with the values ``model`` read from the configuration ``source``.

        Args:
            model: The values (:meth:`read_config` of ``source``).
            step_distance: As :meth:`load_controller`'s: by default the configuration's own, the
                same on the three towers.
            source: The configuration, for the message.

        Raises:
            InputError: towers stepping differently without ``step_distance``.
        """
        if step_distance is None:
            steps = model.step_distance
            if np.any(steps != steps[0]):
                raise InputError(f"the towers' step distances differ ({', '.join(f'{v:.9g}' for v in steps)} "
                                 "mm): the step distance the printer's readings count in is not known; give "
                                 "the configuration the calibration was measured with", str(source),
                                 self.step_distance_keys)
            step_distance = float(steps[0])
        return self.controller(model, step_distance)

    def check_same_printer(self, model: ModelT, other: ModelT, our_source: str, their_source: str) -> None:
        """Refuse two sets of values (a calibration's, a configuration's) of different printers.

        Compared by :func:`classical_values` and the step distances, each against the bound of
        :mod:`~deltacal.printer.files.same_printer`: the radius and the arms within
        :data:`~deltacal.printer.files.same_printer.LENGTH_RTOL` of ``model``'s, the endstops within
        :data:`~deltacal.printer.files.same_printer.ENDSTOP_MM`, the step distances within
        :data:`~deltacal.printer.files.same_printer.STEP_DISTANCE_RTOL`.

        Args:
            model: The first values (a calibration's or a robot file's: :meth:`start`, :meth:`nominal`).
            other: The second (a configuration's: :meth:`read_config`).
            our_source: Where the first come from, for the message.
            their_source: Where the second come from.

        Raises:
            InputError: one line naming the first value too far apart, in both sources.
        """
        radius, arm, endstop = classical_values(model)
        their_radius, their_arm, their_endstop = classical_values(other)
        keys = self.classical_keys
        check_same_values(keys[0], np.array(radius), np.array(their_radius), LENGTH_RTOL * radius, our_source,
                          their_source)
        check_same_values(keys[1], arm, their_arm, LENGTH_RTOL * arm, our_source, their_source)
        check_same_values(keys[2], endstop, their_endstop, ENDSTOP_MM, our_source, their_source)
        steps = np.asarray(model.step_distance, dtype=float)
        check_same_values("step distance", steps, other.step_distance, STEP_DISTANCE_RTOL * steps, our_source,
                          their_source)

    def dialect(self, path: str | Path, model: ModelT | None = None) -> Dialect:
        """The firmware's reading of G-code with the configuration file ``path``.

        A firmware without rules of its own reads G-code as
        :data:`~deltacal.gcode.dialect.GENERIC` does (ambiguities refused), with where its
        homing leaves the nozzle: its model's position with every carriage at its endstop.

        Args:
            path: The configuration.
            model: Its values, if already read (:meth:`read_config`): not read again.

        Raises:
            InputError: the configuration's first problem.
        """
        model = self.read_config(path) if model is None else model
        return GENERIC.with_home(model.positions(np.zeros((1, 3)))[0])

    def config_files(self, path: str | Path) -> tuple[Path, ...]:
        """Every file the configuration ``path`` reads (itself first): none may be overwritten by an output.

        Klipper's includes, RepRapFirmware's files ``config.g`` runs (``M501``'s ``config-override.g``,
        ``M98``'s) and its ``homedelta.g``; by default the file alone.

        Raises:
            InputError: the configuration's first problem.
        """
        return (Path(path),)

    def calibrated_from_saved(self, path: str | Path) -> bool:
        """Whether the configuration's values were calibrated by the firmware from measurements it saved.

        Klipper's ``SAVE_CONFIG`` after ``DELTA_CALIBRATE`` keeps the probe heights (and
        ``DELTA_ANALYZE``'s distances) beside the values fitted to them; ``deltacal import`` reads
        those measurements back. A firmware that saves none: False.
        """
        return False

    def is_probe_log(self, text: str) -> bool:
        """Whether a file's text is a log of this firmware: its probe results, or marks only a log has.

        None by default.
        """
        return False

    def is_console(self, text: str) -> bool:
        """Whether a file's text has the marks of this firmware's console that other files may share too.

        (Klipper's ``// `` lines: a RepRapFirmware ``config.g`` or a Marlin ``Configuration.h`` may
        hold one.) Asked only when no firmware recognises the file as a configuration by its content.
        None by default.
        """
        return False

    def read_probe_log(self, path: str | Path, config: str | Path | None = None,
                       text: str | None = None) -> ProbeLog:
        """The probe results of a log of this firmware, in its order.

        Args:
            path: The log (or a console saved from the firmware's host).
            config: The firmware's configuration, for its probe's offsets (the trigger height).
            text: The log's text, if already read.

        Raises:
            InputError: the log's first problem (by default: the firmware's logs are not read).
        """
        raise InputError(f"deltacal reads no probe results of {self.title}'s logs", str(path))

    def import_config(self, path: str | Path, folder: str | Path, effector_radius: float | None = None,
                      rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
        """The printer as its configuration finds it, written in ``folder`` (``deltacal import``).

        Writes ``printer.toml`` (:func:`~deltacal.printer.files.importer.write_printer_file`) and the
        measurements the configuration holds, if any (the names of
        :data:`~deltacal.printer.files.importer.OUTPUT_FILES`).

        Args:
            path: The configuration.
            folder: An existing folder.
            effector_radius: Effector centre to each ball pair's midpoint [mm] (None: a default).
            rod_spacing: Between a pair's two balls [mm] (None: a default).
            nozzle_drop: The nozzle below the effector's ball plane [mm] (None: a default).

        Raises:
            InputError: the configuration's first problem (by default: not read).
        """
        raise InputError(f"deltacal import does not read {self.title}'s settings", str(path))
