"""A calibration: what identification found, as one value that everything above it reads.

:class:`Calibration` holds the identified geometry, the nominal one it started from, the error
model, the base parameters with σ and correlations, the instrument frames, the fit's quality and
the actuators' compliances, all in the library's units (mm, rad, rad/N m).
:meth:`Calibration.from_result` builds it from an identification;
:func:`deltacal.io.load_calibration` / :func:`deltacal.io.save_calibration` read and write it
(converting to and from the file's degrees); compensation, the report and the export take the
value, never the file. Compliances identified with the geometry are ``geometry.compliance`` (what
exact compensation uses), their σ :attr:`Calibration.compliance_sigma` (the file's
``[compliance]``). The linear compensators' view of it (:meth:`Calibration.linear`) refuses a
calibration identified with free instrument frames: its base parameters are in the fit's own
gauge, which those compensators cannot follow.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal, cast, get_args

import numpy as np

from .compensation import LinearCalibration
from .controller_record import ControllerRecord
from .errormodels import ErrorModel, get_model
from .exceptions import InputError
from .geometry import DeltaGeometry
from .holds import WhereItHolds
from .identification.columns import COMPLIANCE, COMPLIANCE_NAMES, FRAME, GEOMETRY, POINT, ParameterKind
from .identification.frames import InstrumentFrame, axes_motion
from .identification.options import Method
from .identification.result import IdentificationResult, ResidualStats
from .measured_record import MeasuredRecord
from .towers import written_per_tower

#: The unit of a base parameter's value and σ: a length, an angle or an actuator's compliance.
BaseUnit = Literal["mm", "rad", "rad/Nm"]

#: How far ``[geometry]`` may be from ``[nominal]`` moved by the base parameters: lengths [mm],
#: angles and unit vectors [rad]. Identification composes its steps, the file sums them: the two
#: differ by second-order terms, measured up to 2e-5 mm and 6e-7 rad with Bai's tolerances; an
#: edit that changes a compensation by 1 µm is above these.
SECTIONS_TOLERANCE = {"mm": 1e-3, "rad": 1e-5}

_SECTION_KEYS = (
    # (DeltaGeometry field, TOML key in a limb or at the top, unit)
    ("tool", "tool_mm", "mm"),
    ("axis_point", "axis_point_mm", "mm"),
    ("axis_direction", "axis_direction", "rad"),
    ("encoder_offset", "encoder_offset_deg", "rad"),
    ("arm_ball", "arm_ball_mm", "mm"),
    ("plate_ball", "plate_ball_mm", "mm"),
    ("rod_length", "rod_length_mm", "mm"),
)


def kind_of(name: str) -> ParameterKind:
    """The kind of a base parameter written without one (files of earlier versions)."""
    if name in COMPLIANCE_NAMES:
        return COMPLIANCE
    return FRAME if name.startswith("T[") else POINT if name.startswith("P[") else GEOMETRY


@dataclass(frozen=True)
class BaseParameter:
    """One identified base parameter, in the library's units.

    Attributes:
        name: The kept parameter (``T[station].rx``... for an instrument frame's).
        regrouping: What it stands for, e.g. ``δb11x − δa11y``.
        value: Identified value in ``unit``.
        sigma: Its standard deviation in ``unit``.
        unit: ``"mm"``, ``"rad"`` or ``"rad/Nm"`` (a compliance).
        kind: ``"geometry"``, ``"frame"``, ``"point"`` or ``"compliance"``
            (:mod:`deltacal.identification.columns`).
    """

    name: str
    regrouping: str
    value: float
    sigma: float
    unit: BaseUnit
    kind: ParameterKind = GEOMETRY

    @property
    def is_frame(self) -> bool:
        """Whether it is an instrument frame's parameter (not the robot's)."""
        return self.kind == FRAME

    @property
    def terms(self) -> list[str]:
        """The parameter names the regrouping holds, the kept one first."""
        return re.findall(r"δ(\S+)", self.regrouping)


@dataclass(frozen=True)
class FrameRecord:
    """An instrument station's frame: the pose of {O} in {T}, ``y_T = R(rotation) y_O + translation``.

    Attributes:
        name: The station.
        rotation: Rotation vector of {O} in {T} [rad], (3,).
        translation: Origin of {O} in {T} [mm], (3,).
        rotation_sigma: σ of a small rotation about the axes of {T} [rad], (3,).
        translation_sigma: σ of the origin along the axes of {T} [mm], (3,).
    """

    name: str
    rotation: np.ndarray
    translation: np.ndarray
    rotation_sigma: np.ndarray
    translation_sigma: np.ndarray

    @classmethod
    def from_frame(cls, name: str, frame: InstrumentFrame) -> FrameRecord:
        """The record of an identified frame.

        Its rotation vector goes through degrees and back (``np.radians(np.degrees(...))``), as
        calibrations have always held it: the files written from it stay the same to the last digit.
        """
        return cls(name, np.radians(np.degrees(frame.rotation_vector)),
                   np.asarray(frame.translation, dtype=float), np.asarray(frame.rotation_sigma, dtype=float),
                   np.asarray(frame.translation_sigma, dtype=float))

    @property
    def frame(self) -> InstrumentFrame:
        """The frame as the library uses it."""
        return InstrumentFrame.from_vectors(self.rotation, self.translation)


@dataclass(frozen=True)
class Calibration:
    """An identified robot: geometry, model, base parameters, frames and the fit's quality.

    Built by :meth:`from_result` from an identification, or read from its file. What a file
    written by an earlier version lacks takes the default below.

    Attributes:
        geometry: The identified geometry (what exact compensation uses).
        nominal: The geometry identification started from.
        model: The error model.
        base: The base parameters, in the fit's order.
        correlation: Their correlation matrix.
        method: ``"linear"`` or ``"iterated"``; None when not recorded.
        rank: Rank of the regressor (number of base parameters).
        parameters: Number of parameters of the model (and frames).
        condition_number: Condition number of the scaled base regressor (nan: not recorded).
        iterations: Gauss-Newton iterations (0: not recorded).
        variance_factor: s0² of the fit (nan: not recorded).
        unidentifiable: Parameters not kept as base parameters.
        residuals_before: Residual statistics at the nominal geometry [mm, rad] (nan: not recorded).
        residuals_after: The same at the identified geometry.
        outlier_lines: Lines of the measurement file flagged as outliers (command line).
        outlier_rows: Their 1-based data rows.
        frames: Instrument frames by station (empty: measured in the base frame).
        compliance_sigma: σ of the actuators' compliances [rad/N m] when they were identified with
            the geometry (0 for one the measurements could not identify), else None; the
            compliances themselves are ``geometry.compliance`` (:attr:`compliance`).
        holds: Where a printer's calibration holds: the σ of its nozzle correction over the
            printable volume (:class:`~deltacal.holds.WhereItHolds`), which ``compensate``, ``export``,
            the report and the live Klipper module read; None for a rotary Delta's, or a file written
            before it was known (corrected everywhere).
        controller: The firmware configuration a printer's calibration was identified with
            (:class:`~deltacal.controller_record.ControllerRecord`: the file's ``[controller]``); None for
            a rotary Delta's, or a file written before it was recorded.
        measured: What a printer's calibration was identified from, and how
            (:class:`~deltacal.measured_record.MeasuredRecord`: the file's ``[measured]``), to identify it
            again against another controller's values; None for a rotary Delta's, or a file written
            before it was recorded.
        source: The file it was read from ("" when built in memory).
    """

    geometry: DeltaGeometry
    nominal: DeltaGeometry
    model: ErrorModel
    base: list[BaseParameter]
    correlation: np.ndarray
    method: Method | None = None
    rank: int = 0
    parameters: int = 0
    condition_number: float = np.nan
    iterations: int = 0
    variance_factor: float = np.nan
    unidentifiable: list[str] = field(default_factory=list)
    residuals_before: ResidualStats = field(default_factory=ResidualStats)
    residuals_after: ResidualStats = field(default_factory=ResidualStats)
    outlier_lines: list[int] = field(default_factory=list)
    outlier_rows: list[int] = field(default_factory=list)
    frames: dict[str, FrameRecord] = field(default_factory=dict)
    compliance_sigma: np.ndarray | None = None
    holds: WhereItHolds | None = None
    controller: ControllerRecord | None = None
    measured: MeasuredRecord | None = None
    source: str = ""

    @classmethod
    def from_result(cls, result: IdentificationResult,
                    lines: Sequence[int] | np.ndarray | None = None) -> Calibration:
        """The calibration an identification found.

        Args:
            result: The identification (:func:`~deltacal.identification.identify`, or a printer's).
            lines: The line of each measurement in the file it came from: the outliers are then
                also named by line (``outlier_lines``).

        Raises:
            ValueError: the result's method is neither ``"linear"`` nor ``"iterated"``.
        """
        if result.method not in get_args(Method):
            raise ValueError(f"method must be 'linear' or 'iterated', got {result.method!r}")
        kinds = {c.name: c.kind for c in result.columns}
        base = []
        for label, name, v, s, u in zip(result.labels, result.base.base_names, result.values, result.sigma,
                                        result.units, strict=True):
            kind = kinds.get(name, kind_of(name))
            base.append(BaseParameter(name, label, float(v), float(s), _unit(kind, u), kind))
        compliance_sigma = None
        if any(c.kind == COMPLIANCE for c in result.columns):
            sigma = {p.name: p.sigma for p in base if p.kind == COMPLIANCE}
            compliance_sigma = np.array([sigma.get(n, 0.0) for n in COMPLIANCE_NAMES])
        return cls(
            geometry=result.geometry, nominal=result.start, model=get_model(result.model), base=base,
            correlation=np.asarray(result.correlation, dtype=float), method=cast(Method, result.method),
            rank=result.rank, parameters=len(result.base.names),
            condition_number=float(result.condition_number), iterations=result.iterations,
            variance_factor=float(result.variance_factor),
            unidentifiable=list(result.base.unidentifiable_names),
            residuals_before=result.before, residuals_after=result.after,
            outlier_lines=[] if lines is None else [int(lines[k]) for k in result.outliers],
            outlier_rows=[int(k) + 1 for k in result.outliers],
            frames={name: FrameRecord.from_frame(name, f) for name, f in result.frames.items()},
            compliance_sigma=compliance_sigma, holds=result.holds,
        )

    @property
    def compliance(self) -> np.ndarray | None:
        """The actuators' compliances [rad/N m] when identified (``geometry.compliance``), else None."""
        return None if self.compliance_sigma is None else self.geometry.compliance

    @property
    def robot(self) -> str:
        """The robot's name."""
        return self.geometry.name or self.nominal.name or "Delta robot"

    @property
    def robot_index(self) -> list[int]:
        """Indices of the robot's base parameters (instrument frames' left out)."""
        return [k for k, p in enumerate(self.base) if not p.is_frame]

    @property
    def robot_names(self) -> list[str]:
        """Names of the robot's base parameters (the model's kept parameters)."""
        return [self.base[k].name for k in self.robot_index]

    @property
    def instrument(self) -> dict[str, InstrumentFrame]:
        """The instrument frames as the library uses them, by station."""
        return {name: record.frame for name, record in self.frames.items()}

    def covariance(self) -> np.ndarray:
        """Covariance of the robot's base parameters (mm, rad): ``diag(σ) C diag(σ)``.

        The marginal one: an instrument frame's parameters are nuisance parameters, their
        rows and columns are dropped.
        """
        k = self.robot_index
        sigma = np.array([self.base[i].sigma for i in k])
        return sigma[:, None] * self.correlation[np.ix_(k, k)] * sigma[None, :]

    def explain(self, name: str) -> str:
        """Why a parameter is not identifiable, in words."""
        hosts = [p for p in self.base if name in p.terms[1:]]
        if hosts:
            within = ", ".join(f"{p.name} ({p.regrouping})" for p in hosts)
            return (f"absorbed by other parameters: its effect on the measurements is the same as that of "
                    f"a combination of kept ones, so it is folded into {within} and held at its nominal "
                    "value")
        return ("not excited by the measurements: moving it changes none of them (nor, for these kinds of "
                "measurement, the pose of the plate), so it is held at its nominal value")

    def deviation(self) -> tuple[np.ndarray, np.ndarray]:
        """The model's parameter vector (base values, others zero) [mm, rad] and the tool's move [mm]."""
        deviation, tool_move = np.zeros(self.model.size), np.zeros(3)
        for p in self.base:
            if p.kind == POINT and p.name.startswith("P[tcp]."):  # the tool identified as a free point
                tool_move["xyz".index(p.name[-1])] = p.value
            elif p.kind == GEOMETRY:
                deviation[self.model.names.index(p.name)] = p.value
        return deviation, tool_move

    def predicted_geometry(self) -> DeltaGeometry:
        """``nominal`` moved by the base parameters (what ``geometry`` must be, up to the gauge)."""
        deviation, tool_move = self.deviation()
        nominal = self.nominal.with_tool(self.nominal.tool + tool_move)
        predicted = self.model.apply(nominal, deviation)
        if self.frames:
            # identified with free instrument frames: the geometry was moved to the axes gauge after
            # the fit, a rigid motion the base parameters do not hold; they agree modulo it
            predicted = predicted.moved_rigidly(*axes_motion(predicted, self.geometry))
        return predicted

    def check(self) -> None:
        """Refuse a calibration whose geometry is not its nominal moved by its base parameters.

        Exact compensation, the report and the export read ``geometry``; the linear methods
        read ``nominal`` and the base parameters. A file edited in one place only would make
        them command different robots.

        Raises:
            InputError: naming both keys (see docs/errors.md).
        """
        along = None if self.holds is None else self.holds.along_bed
        if along is not None and along.chain != self.geometry.chain:
            raise InputError(f"[holds.along_bed] is {along.chain.words.a_kind}'s geometry, [geometry] "
                             f"{self.geometry.chain.words.a_kind}'s (it must be the same printer's)",
                             self.source)
        steps = [self.geometry.step_distance, self.nominal.step_distance]
        known = [v for v in steps if v is not None]
        if len(known) == 1 or (len(known) == 2 and not np.array_equal(known[0], known[1])):
            written = [None if v is None else written_per_tower(v) for v in steps]
            raise InputError(
                f"[geometry] and [nominal] disagree: key geometry.step_distance_mm = {written[0]}, but key "
                f"nominal.step_distance_mm = {written[1]} (the readings of both count steps in the same step "
                "distances; edit both)", self.source)
        predicted = self.predicted_geometry()
        for name, key, unit in _SECTION_KEYS:
            got = np.asarray(getattr(self.geometry, name), dtype=float)
            want = np.asarray(getattr(predicted, name), dtype=float)
            if name == "tool":
                got, want = got[None], want[None]
            off = np.abs(got - want).reshape(len(got), -1).max(axis=1)
            bad = np.flatnonzero(off > SECTIONS_TOLERANCE[unit])
            if bad.size:
                i = int(bad[0])
                where = key if name == "tool" else f"limb[{i + 1}].{key}"
                shown = np.degrees if key.endswith("_deg") else (lambda v: v)
                raise InputError(
                    f"[geometry] and [nominal] disagree: key geometry.{where} = "
                    f"{np.round(shown(got[i]), 6).tolist()}, but key nominal.{where} moved by the base "
                    f"parameters gives {np.round(shown(want[i]), 6).tolist()} (a file edited in one place "
                    "only? edit both, or identify again)",
                    self.source,
                )

    def where_held(self) -> WhereItHolds | None:
        """Where the calibration holds, for the routes that correct only there; None: corrected everywhere.

        None for a robot whose identification does not say it (a rotary Delta's) and for a geometry
        file (the robot alone, known exactly). A printer's calibration without its ``[holds]`` table
        (written before it existed, or cut by hand) is refused: corrected everywhere it would carry
        corrections its measurements do not determine, and ``--sigma-bound`` would mean nothing.

        Raises:
            InputError: a printer's calibration without where it holds (see docs/errors.md).
        """
        if self.holds is None and self.base and self.geometry.chain.says_where_it_holds:
            raise InputError(
                "no [holds] table: this printer's calibration does not say where it holds (the σ of its "
                "corrections, which compensate --controller, export and export --live correct within "
                "--sigma-bound), written before it was known or cut; identify the printer again (deltacal "
                "identify PRINTER.toml PROBE.csv DISTANCES.csv --controller CONFIG -o CALIBRATION.toml)",
                self.source, "key holds")
        return self.holds

    def linear(self) -> LinearCalibration:
        """What the linear compensators (savoure, bai) need: nominal, model and deviation.

        Raises:
            InputError: the calibration was identified with free instrument frames (its base
                parameters are in the fit's own gauge, which the linear methods cannot follow).
        """
        if self.frames:
            raise InputError(
                "identified with a free instrument frame: its base parameters are in the fit's own gauge, "
                "which savoure and bai cannot follow; use the exact method", self.source, "key instrument",
            )
        deviation, tool_move = self.deviation()
        return LinearCalibration(nominal=self.nominal.with_tool(self.nominal.tool + tool_move),
                                 model=self.model, deviation=deviation)


def holds_of(calibration: Calibration | DeltaGeometry) -> WhereItHolds | None:
    """Where a calibration (or a geometry: everywhere, None) holds, checked (:meth:`Calibration.where_held`).

    Raises:
        InputError: a printer's calibration without where it holds.
    """
    return calibration.where_held() if isinstance(calibration, Calibration) else None


def _unit(kind: ParameterKind, unit: str) -> BaseUnit:
    """A base parameter's unit from its kind and its column's unit (any but rad counts as mm)."""
    if kind == COMPLIANCE:
        return "rad/Nm"
    return "rad" if unit == "rad" else "mm"
