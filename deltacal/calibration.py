"""A calibration: what identification found, as one value that everything above it reads.

:class:`Calibration` holds the identified geometry, the nominal one it started from, the error
model, the base parameters with σ and correlations, the instrument frames, the fit's quality and
(later) the actuators' compliances. It is read and written by
:func:`deltacal.io.load_calibration` / :func:`deltacal.io.save_calibration` only; compensation,
the report and the export take the value, never the file. Compliances identified with the
geometry are in ``geometry.compliance`` (what exact compensation uses) and, with their σ, in
:attr:`Calibration.compliance` / :attr:`Calibration.compliance_sigma` (the file's
``[compliance]``). The linear compensators' view of it
(:meth:`Calibration.linear`) refuses a calibration identified with free instrument frames: its
base parameters are in the fit's own gauge, which those compensators cannot follow.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .compensation import LinearCalibration
from .errormodels import ErrorModel
from .exceptions import InputError
from .geometry import DeltaGeometry
from .identification.columns import COMPLIANCE, COMPLIANCE_NAMES, FRAME, GEOMETRY, POINT, ParameterKind
from .identification.frames import InstrumentFrame, axes_motion

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
    """One identified base parameter.

    Attributes:
        name: The kept parameter (``T[station].rx``... for an instrument frame's).
        regrouping: What it stands for, e.g. ``δb11x − δa11y``.
        value: Identified value in ``unit``.
        sigma: Its standard deviation in ``unit``.
        unit: ``"mm"``, ``"deg"`` or ``"rad/Nm"`` (a compliance).
        kind: ``"geometry"``, ``"frame"``, ``"point"`` or ``"compliance"``
            (:mod:`deltacal.identification.columns`).
    """

    name: str
    regrouping: str
    value: float
    sigma: float
    unit: str
    kind: ParameterKind = GEOMETRY

    @property
    def is_frame(self) -> bool:
        """Whether it is an instrument frame's parameter (not the robot's)."""
        return self.kind == FRAME

    @property
    def si_value(self) -> float:
        """The value in the library's units (mm or rad)."""
        return math.radians(self.value) if self.unit == "deg" else self.value

    @property
    def si_sigma(self) -> float:
        """σ in the library's units (mm or rad)."""
        return math.radians(self.sigma) if self.unit == "deg" else self.sigma

    @property
    def terms(self) -> list[str]:
        """The parameter names the regrouping holds, the kept one first."""
        return re.findall(r"δ(\S+)", self.regrouping)


@dataclass(frozen=True)
class FrameRecord:
    """An instrument station's frame (pose of {O} in {T}), degrees and mm, with σ."""

    name: str
    rotation_deg: np.ndarray
    translation_mm: np.ndarray
    rotation_sigma_deg: np.ndarray
    translation_sigma_mm: np.ndarray

    @property
    def frame(self) -> InstrumentFrame:
        """The frame as the library uses it."""
        return InstrumentFrame.from_vectors(np.radians(self.rotation_deg), self.translation_mm)


@dataclass(frozen=True)
class Calibration:
    """An identified robot: geometry, model, base parameters, frames and the fit's quality.

    Attributes:
        geometry: The identified geometry (what exact compensation uses).
        nominal: The geometry identification started from.
        model: The error model.
        base: The base parameters, in the fit's order.
        correlation: Their correlation matrix.
        method: ``linear`` or ``iterated``.
        rank: Rank of the regressor (number of base parameters).
        parameters: Number of parameters of the model (and frames).
        condition_number: Condition number of the scaled base regressor.
        iterations: Gauss-Newton iterations.
        variance_factor: s0² of the fit.
        unidentifiable: Parameters not kept as base parameters.
        residuals_before: Summary statistics at the nominal geometry.
        residuals_after: The same at the identified geometry.
        outlier_lines: Lines of the measurement file flagged as outliers (command line).
        outlier_rows: Their 1-based data rows.
        frames: Instrument frames by station (empty: measured in the base frame).
        compliance: Actuator compliances [rad/N m] when identified, else None (the same values
            as ``geometry.compliance``).
        compliance_sigma: Their σ [rad/N m] (0 for one the measurements could not identify).
        source: The file it was read from ("" when built in memory).
    """

    geometry: DeltaGeometry
    nominal: DeltaGeometry
    model: ErrorModel
    base: list[BaseParameter]
    correlation: np.ndarray
    method: str = "?"
    rank: int = 0
    parameters: int = 0
    condition_number: float = math.nan
    iterations: int = 0
    variance_factor: float = math.nan
    unidentifiable: list[str] = field(default_factory=list)
    residuals_before: dict[str, float] = field(default_factory=dict)
    residuals_after: dict[str, float] = field(default_factory=dict)
    outlier_lines: list[int] = field(default_factory=list)
    outlier_rows: list[int] = field(default_factory=list)
    frames: dict[str, FrameRecord] = field(default_factory=dict)
    compliance: np.ndarray | None = None
    compliance_sigma: np.ndarray | None = None
    source: str = ""

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
        sigma = np.array([self.base[i].si_sigma for i in k])
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
                tool_move["xyz".index(p.name[-1])] = p.si_value
            elif p.kind == GEOMETRY:
                deviation[self.model.names.index(p.name)] = p.si_value
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
        if self.geometry.step_distance != self.nominal.step_distance:
            raise InputError(
                f"[geometry] and [nominal] disagree: key geometry.step_distance_mm = "
                f"{self.geometry.step_distance}, but key nominal.step_distance_mm = "
                f"{self.nominal.step_distance} "
                "(the readings of both count steps in one step distance; edit both)", self.source)
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
