"""What a job is asked: one value per command, its options' combinations checked once, in the value.

``deltacal identify ...`` is argparse, then an :class:`IdentifyRequest`, then the robot kind's wing's job
(:mod:`deltacal.wings`): a program that builds the request itself gets the command line's refusals,
word for word (:class:`~deltacal.exceptions.UsageError`: status 2 on the command line). Each field
is the option of the same name (``--sigma-height`` is ``sigma_height``); None is an option not given.
A value checks, when it is made, what holds for either kind of robot (``__post_init__``); what holds
for one kind only is checked by the methods its wing calls (:meth:`IdentifyRequest.rotary_fit`,
:meth:`SimulateRequest.check_printer`...), once the robot file tells the kind. Files are checked by
the job, before any work (:mod:`deltacal.io.paths`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..compensation import METHODS
from ..controller import FIT_KINDS
from ..errormodels import MODEL_NAMES, PRINTER_MODEL_NAMES
from ..exceptions import UsageError
from ..gcode import MAX_COORDINATE_MM, MIN_SEGMENT_MM, is_gcode_path
from ..holds import DEFAULT_BOUND
from ..identification import FitOptions
from ..identification.options import Frame, Pairs
from ..observations import SIGMA_ANGLE_DEG, SIGMA_POSITION
from ..printer.firmware import firmware_named, firmwares
from ..printer.firmware.config_file import firmware_names, settings_files, settings_needed
from ..printer.simulation import TOLERANCE_CLASSES

Path_ = str | Path
#: ``plan`` options of pose planning, which ``--object`` does not take.
POSE_OPTIONS = ("model", "n", "epsilon", "strategy", "measure", "points", "count", "pool", "seed", "payload",
                "n_max")
#: ``plan --object`` options, which pose planning does not take.
OBJECT_OPTIONS = ("controller", "firmware", "distances", "probe_grid", "caliper")
#: ``simulate`` options of a rotary Delta's measurements, which a printer's simulation does not take.
ROTARY_SIMULATE_OPTIONS = ("points", "sigma_position", "sigma_angle", "no_orientation", "repeats", "payload",
                           "compliance", "station")
#: ``simulate`` options of a printer's simulation, which a rotary Delta's does not take.
PRINTER_SIMULATE_OPTIONS = ("controller", "firmware", "distances_output", "sigma_height", "sigma_distance",
                            "probe_offset", "tolerances")


def _option(name: str) -> str:
    """``--sigma-height`` of the field ``sigma_height``."""
    return "--" + name.replace("_", "-")


def _given(value: Any, names: tuple[str, ...]) -> list[str]:
    """The fields of ``names`` given (not None, not False) in ``value``."""
    return [n for n in names if getattr(value, n) not in (None, False)]


def _check_firmware(name: str | None) -> None:
    if name is not None and firmware_named(name) is None:
        raise UsageError(f"--firmware {name}: one of {'|'.join(firmware_names())}")


@dataclass(frozen=True, eq=False)
class IdentifyRequest:
    """``deltacal identify NOMINAL MEASUREMENTS... -o OUTPUT``: the geometry from measurements.

    A rotary Delta's measurements are one CSV file (:meth:`rotary_fit`); a printer's its probe
    heights, then its distances files, of commanded positions through ``controller``
    (:meth:`printer_model`). Units: mm and deg, as the options.
    """

    nominal: Path_
    measurements: tuple[Path_, ...]
    output: Path_
    model: str | None = None
    sigma_position: float = SIGMA_POSITION
    sigma_angle: float = SIGMA_ANGLE_DEG
    linear: bool = False
    distances: bool = False
    pairs: Pairs | None = None
    frame: Frame = "base"
    accept_poor_fit: bool = False
    free_points: tuple[str, ...] = ()
    compliance: bool = False
    rigid: bool = False
    controller: Path_ | None = None
    firmware: str | None = None
    probe_offset: np.ndarray | None = None
    sigma_height: float = 0.01
    sigma_distance: float = 0.02
    tolerance_scale: float | None = None
    live_correction_off: bool = False

    def __post_init__(self) -> None:
        given = self.measurements
        object.__setattr__(self, "measurements", (given,) if isinstance(given, (str, Path)) else tuple(given))
        object.__setattr__(self, "free_points", tuple(self.free_points))
        offset = np.zeros(3) if self.probe_offset is None else np.asarray(self.probe_offset, dtype=float)
        object.__setattr__(self, "probe_offset", offset)
        _check_firmware(self.firmware)

    def rotary_fit(self) -> FitOptions:
        """A rotary Delta's identification: its options checked, the fit's options (:class:`FitOptions`)."""
        if len(self.measurements) != 1:
            raise UsageError(f"a rotary Delta's measurements are one CSV file, got {len(self.measurements)}")
        if self.controller is not None or self.firmware is not None:
            flag = "controller" if self.controller is not None else "firmware"
            raise UsageError(f"--{flag} applies to a printer's measurements (of commanded positions)")
        if self.tolerance_scale is not None:
            raise UsageError("--tolerance-scale applies to a printer's measurements")
        if self.live_correction_off:
            raise UsageError("--live-correction-off applies to a printer's measurements")
        if self.rotary_model not in MODEL_NAMES:
            raise UsageError(f"--model {self.model}: a rotary Delta's models are {', '.join(MODEL_NAMES)}")
        if self.pairs is not None and not self.distances:
            raise UsageError("--pairs applies to --distances only")
        if self.rigid and self.compliance:
            raise UsageError("--rigid and --compliance: choose one (--rigid fits actuators that do not "
                             "yield)")
        try:  # every option is checked once, by FitOptions
            return FitOptions(method="linear" if self.linear else "iterated",
                              sigma_position=self.sigma_position, sigma_angle=math.radians(self.sigma_angle),
                              distances=self.distances, pairs=self.pairs or "all", frame=self.frame,
                              accept_poor_fit=self.accept_poor_fit, free_points=self.free_points,
                              compliance=self.compliance)
        except ValueError as exc:
            raise UsageError(f"options that do not go together: {exc}") from exc

    @property
    def rotary_model(self) -> str:
        """The error model of a rotary Delta (default ``complete``)."""
        return self.model or "complete"

    def printer_model(self, default: str = "printer") -> str:
        """A printer's identification: its options checked, its error model (``default`` if not given)."""
        if self.controller is None:
            raise settings_needed(self.measurements, "measurements", "the firmware's settings they were made "
                                  "with, which turn them into the printer's readings")
        model = self.model or default
        if model not in PRINTER_MODEL_NAMES:
            raise UsageError(f"--model {model}: a printer's models are {', '.join(PRINTER_MODEL_NAMES)}")
        for flag in ("distances", "compliance", "free_points", "pairs"):
            if getattr(self, flag):
                raise UsageError(f"{_option(flag)} applies to a rotary Delta's measurements")
        return model


@dataclass(frozen=True, eq=False)
class SimulateRequest:
    """``deltacal simulate NOMINAL POSES... (--perturb SEED | --truth TRUE) -o OUTPUT``.

    A rotary Delta's tracker (and probe) measurements at the readings of one POSES file
    (:meth:`check_rotary`); a printer's probe heights and printed distances, ``plan --object``'s
    templates filled through its firmware (:meth:`check_printer`). ``station``: (name,
    :class:`~deltacal.identification.frames.InstrumentFrame`) pairs; ``compliance``: one or three
    compliances [rad/N m] as text (``"1e-5"``, ``"1e-5,2e-5,0"``).
    """

    nominal: Path_
    poses: tuple[Path_, ...]
    output: Path_
    perturb: int | None = None
    truth: Path_ | None = None
    seed: int = 0
    points: str | None = None
    sigma_position: float | None = None
    sigma_angle: float | None = None
    no_orientation: bool = False
    repeats: int | None = None
    payload: tuple[float, ...] | None = None
    compliance: str | None = None
    station: tuple[tuple[str, Any], ...] | None = None
    controller: Path_ | None = None
    firmware: str | None = None
    distances_output: Path_ | None = None
    sigma_height: float | None = None
    sigma_distance: float | None = None
    probe_offset: np.ndarray | None = None
    tolerances: str | None = None

    def __post_init__(self) -> None:
        poses = (self.poses,) if isinstance(self.poses, (str, Path)) else self.poses
        object.__setattr__(self, "poses", tuple(poses))
        if (self.perturb is None) == (self.truth is None):
            raise UsageError("the true robot: give --perturb SEED or --truth TRUE.toml (one of them)")
        _check_firmware(self.firmware)
        if self.tolerances is not None and self.tolerances not in TOLERANCE_CLASSES:
            raise UsageError(f"--tolerances {self.tolerances}: one of {', '.join(TOLERANCE_CLASSES)}")
        if self.compliance is not None:
            self.compliances()
        names = [name for name, _ in self.station or []]
        if len(set(names)) != len(names):
            raise UsageError(f"--station: each station once, got {', '.join(names)}")

    def compliances(self) -> np.ndarray:
        """``--compliance``: one value for the three actuators or three, finite, >= 0 [rad/N m], (3,)."""
        text = str(self.compliance)
        try:
            values = [float(p) for p in text.split(",")]
        except ValueError:
            raise UsageError(f"--compliance: numbers [rad/N m] expected, got {text!r}") from None
        if len(values) not in (1, 3) or not all(math.isfinite(v) and v >= 0.0 for v in values):
            raise UsageError(f"--compliance: one or three finite non-negative numbers [rad/N m], got "
                             f"{text!r}")
        return np.broadcast_to(np.array(values), (3,)).copy()

    def check_rotary(self) -> None:
        """A rotary Delta's simulation: one POSES file, no printer option."""
        given = [name for name in PRINTER_SIMULATE_OPTIONS if getattr(self, name) is not None]
        if given:
            raise UsageError(f"{_option(given[0])} applies to a printer's simulation (kind = 'linear')")
        if len(self.poses) != 1:
            raise UsageError(f"a rotary Delta's simulation reads one POSES file, got {len(self.poses)}")

    def check_printer(self) -> tuple[Path_, Path_ | None]:
        """A printer's simulation: the probe template and the distances template (or None), checked."""
        given = _given(self, ROTARY_SIMULATE_OPTIONS)
        if given:
            raise UsageError(f"{_option(given[0])} applies to a rotary Delta's simulation, not to a "
                             "printer's")
        if self.controller is None:
            raise settings_needed(self.poses, "templates", "the firmware's settings the simulated printer "
                                  "runs")
        if len(self.poses) > 2:
            raise UsageError(f"a printer's templates are PROBE.csv and at most one DISTANCES.csv, got "
                             f"{len(self.poses)} files")
        distance_file = self.poses[1] if len(self.poses) == 2 else None
        if distance_file is not None and self.distances_output is None:
            raise UsageError(f"{distance_file}: give --distances-output OUT.csv for the filled distances")
        if distance_file is None and self.distances_output is not None:
            raise UsageError("--distances-output needs a DISTANCES.csv template after PROBE.csv")
        if self.tolerances is not None and self.truth is not None:
            raise UsageError("--tolerances applies to --perturb (the true printer of --truth is given)")
        return self.poses[0], distance_file


@dataclass(frozen=True, eq=False)
class PlanRequest:
    """``deltacal plan NOMINAL -o OUTPUT``: measurement poses, or (``object``) a printer's printed object.

    Pose planning (a rotary Delta): Bai's circles and κ(n) rule (``strategy`` ``bai``, the default)
    or a D-optimal selection from a random pool (``doptimal``). ``object``: a printer's probe grid
    and the object it prints and measures, through its firmware (``controller``); ``output`` is then
    a folder.
    """

    nominal: Path_
    output: Path_
    object: bool = False
    controller: Path_ | None = None
    firmware: str | None = None
    distances: int | None = None
    probe_grid: int | None = None
    caliper: float | None = None
    model: str | None = None
    n: int | None = None
    epsilon: float | None = None
    strategy: str | None = None
    measure: str | None = None
    points: str | None = None
    count: int | None = None
    pool: int | None = None
    seed: int | None = None
    payload: tuple[float, ...] | None = None
    n_max: int | None = None

    def __post_init__(self) -> None:
        _check_firmware(self.firmware)
        if self.object:
            given = [name for name in POSE_OPTIONS if getattr(self, name) is not None]
            if given:
                raise UsageError(f"{_option(given[0])} applies to pose planning, not to --object")
            if self.controller is None:
                raise UsageError(f"{self.nominal}: --object needs --controller {settings_files()}: the "
                                 "firmware's settings the object is printed with")
            return
        given = [name for name in OBJECT_OPTIONS if getattr(self, name) is not None]
        if given:
            raise UsageError(f"{_option(given[0])} applies to --object (a printer's calibration object)")
        if self.strategy not in (None, "bai", "doptimal"):
            raise UsageError(f"--strategy {self.strategy}: bai or doptimal")
        if self.strategy != "doptimal":
            if self.payload is not None:
                raise UsageError("--payload applies to --strategy doptimal (planning for the compliances)")
            if self.count is not None:
                raise UsageError("--count applies to --strategy doptimal; the bai strategy chooses n by "
                                 "Eq. 21 (or --n)")
            return
        if self.n is not None or self.epsilon is not None:
            raise UsageError("--n and --epsilon apply to --strategy bai, not doptimal")
        if self.measurement == "distance":
            raise UsageError("D-optimal selection is for pose or position measurements (--measure)")

    @property
    def measurement(self) -> str:
        """What is measured: ``measure``, else distances (Bai's distance models and rough) or poses."""
        if self.measure is not None:
            return self.measure
        return "distance" if (self.model or "complete") in ("bai18", "bai36", "bai32", "rough") else "pose"


@dataclass(frozen=True, eq=False)
class ExportRequest:
    """``deltacal export CALIBRATION (--mjcf ROBOT.xml | --controller KIND -o OUTPUT)``.

    ``mjcf``: the robot as an MJCF model (either kind; ``home``: the readings of its 'home'
    keyframe as text, deg or a printer's mm). ``controller``: a rotary Delta's controller values
    that fit best (``offsets``, ``limbs``), or a firmware's (its name: ``klipper``, ``marlin``,
    ``rrf``; ``config``: the configuration the printer runs; ``keep_rotation_distance``: its step
    distances held; ``sigma_bound``: the values fitted where the calibration's σ is within it [mm]);
    ``robot``: the robot file whose ``[workspace]`` the fit covers. ``live``: the
    correction the firmware runs itself (Klipper's module and its section,
    :attr:`~deltacal.printer.firmware.base.Firmware.live_files`), computed through the values of
    ``config``, written in the folder ``output``.
    """

    calibration: Path_
    mjcf: Path_ | None = None
    controller: str | None = None
    output: Path_ | None = None
    config: Path_ | None = None
    keep_rotation_distance: bool = False
    robot: Path_ | None = None
    name: str | None = None
    home: str | None = None
    live: bool = False
    sigma_bound: float = DEFAULT_BOUND

    def __post_init__(self) -> None:
        if not self.sigma_bound > 0.0:
            raise UsageError(f"--sigma-bound {self.sigma_bound:g}: the σ of a correction accepted must be "
                             "positive")
        if (self.mjcf is None) == (self.controller is None):
            raise UsageError("give --mjcf ROBOT.xml or --controller KIND (one of them)")
        firmware = firmware_named(self.controller) if self.controller is not None else None
        if self.live:
            self._check_live(firmware)
            return
        if firmware is not None:
            if self.output is None:
                raise UsageError(f"--controller {firmware.name} needs -o {firmware.export_file}, the "
                                 f"{firmware.title} values to write")
            if self.home is not None:
                raise UsageError("--home applies to --mjcf")
            return
        if self.controller is not None:
            if self.controller not in FIT_KINDS:
                raise UsageError(f"--controller {self.controller}: one of "
                                 f"{'|'.join((*FIT_KINDS, *firmware_names()))}")
            if self.output is None:
                raise UsageError("--controller needs -o CONTROLLER.toml, the controller file to write")
            if self.home is not None:
                raise UsageError("--home applies to --mjcf")
        if self.config is not None or self.keep_rotation_distance:
            raise UsageError("--config and --keep-rotation-distance apply to --controller "
                             f"{'|'.join(firmware_names())}")
        if self.mjcf is not None and (self.output is not None or self.robot is not None):
            raise UsageError(f"{'-o' if self.output is not None else '--robot'} applies to --controller; "
                             "--mjcf names its own output")

    def _check_live(self, firmware: Any) -> None:
        """``--live``: a firmware that runs a correction of its own, its configuration and a folder."""
        live = [f for f in firmwares() if f.live_files]
        if firmware is None or not firmware.live_files:
            raise UsageError(f"--live applies to --controller {'|'.join(f.name for f in live)} (the module "
                             f"{' or '.join(f.title for f in live)} runs)")
        if self.config is None or self.output is None:
            raise UsageError(f"--live needs --config {firmware.config_file} (the values {firmware.title} "
                             "runs: the correction is computed through them) and -o OUTDIR (the folder of "
                             f"{', '.join(firmware.live_files)})")
        if self.keep_rotation_distance or self.robot is not None or self.home is not None:
            raise UsageError(f"--live takes {firmware.title}'s values and volume from --config alone: leave "
                             "out --keep-rotation-distance, --robot and --home")


@dataclass(frozen=True, eq=False)
class CompensateRequest:
    """``deltacal compensate CALIBRATION TARGETS -o OUTPUT``: joint readings, or a controller's targets.

    ``targets``: a CSV of TCP targets, or a G-code program (``.gcode``, ``.gco``, ``.g``, ``.nc``)
    for ``controller`` (a controller file, a robot file, or a printer's firmware configuration);
    ``start``: the TCP's position at the program's start [mm]; ``segment_mm``: its longest move
    sent [mm]; ``payload``: the mass at the TCP [kg]; ``sigma_bound``: a printer's correction applied
    where its σ is at most half of it, the controller's own command where it is above it [mm];
    ``refuse_unheld``: refuse such targets instead.
    """

    calibration: Path_
    targets: Path_
    output: Path_
    method: str = "exact"
    frame: str = "base"
    station: str | None = None
    controller: Path_ | None = None
    firmware: str | None = None
    payload: float = 0.0
    segment_mm: float | None = None
    start: tuple[float, float, float] | None = None
    sigma_bound: float = DEFAULT_BOUND
    refuse_unheld: bool = False

    def __post_init__(self) -> None:
        if not self.sigma_bound > 0.0:
            raise UsageError(f"--sigma-bound {self.sigma_bound:g}: the σ of a correction accepted must be "
                             "positive")
        if self.firmware is not None and self.controller is None:
            raise UsageError("--firmware applies with --controller (the firmware's configuration)")
        if self.controller is None and (self.refuse_unheld or self.sigma_bound != DEFAULT_BOUND):
            option = "--refuse-unheld" if self.refuse_unheld else f"--sigma-bound {self.sigma_bound:g}"
            raise UsageError(f"{option} applies with --controller: it bounds a printer's corrections of its "
                             "firmware's commands, where its calibration holds")
        _check_firmware(self.firmware)
        if self.method not in METHODS:
            raise UsageError(f"--method {self.method}: one of {', '.join(METHODS)}")
        if self.controller is not None and self.method != "exact":
            raise UsageError("--method applies to joint readings: --controller's corrected targets come "
                             "from the exact compensation")
        if self.payload and self.method != "exact":
            raise UsageError(f"--payload: the {self.method} method cannot represent a payload (the linear "
                             "compensators know no gravity); use --method exact")
        if self.program:
            self._check_program()
            return
        if self.segment_mm is not None or self.start is not None:
            raise UsageError("--segment-mm and --start apply to a G-code program (.gcode, .gco, .g, .nc)")
        if self.frame != "instrument" and self.station is not None:
            raise UsageError("--station applies to --frame instrument only")

    @property
    def program(self) -> bool:
        """Whether the targets are a G-code program (by the file's name)."""
        return is_gcode_path(self.targets)

    def _check_program(self) -> None:
        if self.controller is None:
            raise UsageError(f"{self.targets}: a G-code program goes to a controller: give --controller (a "
                             "controller file, the robot file for its nominal controller, or a printer's "
                             "firmware configuration)")
        if self.frame != "base":
            raise UsageError("a G-code program is in the controller's frame, the robot base {O}: --frame "
                             "instrument applies to a targets CSV")
        if self.segment_mm is not None and self.segment_mm < MIN_SEGMENT_MM:
            raise UsageError(f"--segment-mm {self.segment_mm:g}: below {MIN_SEGMENT_MM:g} mm (100 times "
                             "the output's 0.1 µm resolution) the segments follow the rounding, not the "
                             "path, and the program grows without use")
        if self.start is not None and not all(abs(v) <= MAX_COORDINATE_MM for v in self.start):
            start = ",".join(f"{v:g}" for v in self.start)
            raise UsageError(f"--start {start}: beyond ±{MAX_COORDINATE_MM:g} mm, out of reach of any robot "
                             "(the TCP's position in mm)")


@dataclass(frozen=True, eq=False)
class ReportRequest:
    """``deltacal report CALIBRATION -o REPORT.html``: one self-contained HTML page of a calibration.

    ``tool``: the TCP in the plate frame for the accuracy map [mm]; ``payload``: the payload whose
    deflection is mapped [kg]; ``firmware``: a printer's firmware, whose values the page fits and
    names (default: ``controller``'s, else Klipper's); ``measurements``: the file the calibration was
    identified from (residual plots), a printer's probe heights and distances files, with
    ``controller``: the firmware's settings they were commanded with (of ``firmware`` when named);
    ``history``: a printer's earlier calibrations, oldest first (the page shows its history).
    """

    calibration: Path_
    output: Path_
    measurements: tuple[Path_, ...] | None = None
    truth: Path_ | None = None
    tool: np.ndarray | None = None
    robot: Path_ | None = None
    payload: float = 0.0
    no_view: bool = False
    firmware: str | None = None
    controller: Path_ | None = None
    history: tuple[Path_, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("measurements", "history"):
            given = getattr(self, name)
            if given is not None:
                files = (given,) if isinstance(given, (str, Path)) else tuple(given)
                object.__setattr__(self, name, files)
        _check_firmware(self.firmware)


@dataclass(frozen=True, eq=False)
class CompareRequest:
    """``deltacal compare OLD.toml NEW.toml [NEWER.toml ...] [-o compare.html]``: what changed in a printer.

    ``new``: the newer calibration, or several, oldest first (each step between consecutive ones
    compared); ``output``: an HTML page of the changes (None: the lines alone).
    """

    old: Path_
    new: Path_ | tuple[Path_, ...]
    output: Path_ | None = None

    def __post_init__(self) -> None:
        files = (self.new,) if isinstance(self.new, (str, Path)) else tuple(self.new)
        object.__setattr__(self, "new", files)

    @property
    def files(self) -> tuple[Path_, ...]:
        """The calibration files, oldest first."""
        assert isinstance(self.new, tuple)
        return (self.old, *self.new)


@dataclass(frozen=True, eq=False)
class ImportRequest:
    """``deltacal import INPUT -o OUTPUT``: a printer as its configuration finds it, or a log's probe results.

    A configuration (``printer.cfg``, ``config.g``, an ``M503`` capture): ``output`` is the folder of
    the robot file (and the measurements the configuration saved); ``effector_radius``, ``rod_spacing``
    and ``nozzle_drop`` [mm] are what no configuration holds (:meth:`check_config`). A log: ``output``
    is the probe heights file; ``config`` the printer's configuration, for its probe's offsets
    (:meth:`check_log`). What the input is, its content tells, or ``firmware`` names its firmware
    (:func:`~deltacal.printer.firmware.input_firmware`).
    """

    input: Path_
    output: Path_
    config: Path_ | None = None
    effector_radius: float | None = None
    rod_spacing: float | None = None
    nozzle_drop: float | None = None
    firmware: str | None = None

    def __post_init__(self) -> None:
        _check_firmware(self.firmware)

    def check_config(self, title: str) -> None:
        """A configuration, read as the firmware ``title``'s: no log's option."""
        if self.config is not None:
            raise UsageError(f"--config applies to a log; {self.input} is read as {title}'s configuration")

    def check_log(self) -> None:
        """A log: no configuration's option, and a file (not a folder) to write."""
        given = _given(self, ("effector_radius", "rod_spacing", "nozzle_drop"))
        if given:
            raise UsageError(f"{_option(given[0])} applies to a configuration; {self.input} is a log")
        if Path(self.output).is_dir():
            raise UsageError(f"{self.output}: a log's probe results go to a file (-o probe.csv); this is a "
                             "folder")
