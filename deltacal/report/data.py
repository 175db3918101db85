"""What a report shows of a calibration file, read and checked (one-line errors naming the key)."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errormodels import ErrorModel, get_model
from ..exceptions import InputError
from ..geometry import DeltaGeometry
from ..identification.frames import InstrumentFrame
from ..io import CALIBRATION_FORMAT, check_format, geometry_from_dict, instrument_tables, read_toml
from ..io.toml import _shown, _Table

#: Tolerance on the correlation matrix read from a file (it is written rounded to 6 decimals).
CORRELATION_ATOL = 1e-5


@dataclass(frozen=True)
class BaseParameter:
    """One identified base parameter as the calibration file gives it.

    Attributes:
        name: The kept parameter (``T[station].rx``... for an instrument frame's).
        regrouping: What it stands for, e.g. ``δb11x − δa11y``.
        value: Identified value in ``unit``.
        sigma: Its standard deviation in ``unit``.
        unit: ``"mm"`` or ``"deg"``.
    """

    name: str
    regrouping: str
    value: float
    sigma: float
    unit: str

    @property
    def is_frame(self) -> bool:
        """Whether it is an instrument frame's parameter (not the robot's)."""
        return self.name.startswith("T[")

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
    """An instrument station's frame as the file gives it (pose of {O} in {T}), degrees and mm."""

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
class CalibrationReport:
    """Everything a report shows of a calibration file.

    Attributes:
        source: The file.
        model: The error model.
        method: ``linear`` or ``iterated``.
        rank: Rank of the regressor (number of base parameters).
        parameters: Number of parameters of the model (and frames).
        condition_number: Condition number of the scaled base regressor.
        iterations: Gauss-Newton iterations.
        variance_factor: s0² of the fit.
        unidentifiable: Parameters not kept as base parameters.
        residuals_before: Summary statistics at the nominal geometry (file's keys).
        residuals_after: The same at the identified geometry.
        outlier_lines: Lines of the measurement file flagged as outliers (written by the command line).
        outlier_rows: Their 1-based data rows (written whenever the calibration is saved).
        base: The base parameters, in the file's order.
        correlation: Their correlation matrix.
        geometry: The identified geometry.
        nominal: The geometry identification started from.
        frames: Instrument frames by station (empty: measured in the base frame).
    """

    source: str
    model: ErrorModel
    method: str
    rank: int
    parameters: int
    condition_number: float
    iterations: int
    variance_factor: float
    unidentifiable: list[str]
    residuals_before: dict[str, float]
    residuals_after: dict[str, float]
    outlier_lines: list[int]
    outlier_rows: list[int]
    base: list[BaseParameter]
    correlation: np.ndarray
    geometry: DeltaGeometry
    nominal: DeltaGeometry
    frames: dict[str, FrameRecord] = field(default_factory=dict)

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


def _parameter(item: Mapping, source: str, k: int) -> BaseParameter:
    t = _Table(item, source, f"calibration.base_parameter[{k + 1}].")
    name = t.string("name")
    regrouping = t.string("regrouping", default=f"δ{name}")
    if t.has("value_deg"):
        value, unit = t.number("value_deg"), "deg"
        sigma = t.number("sigma_deg")
    else:
        value, unit = t.number("value_mm"), "mm"
        sigma = t.number("sigma_mm")
    if sigma < 0.0:
        raise t.error(f"sigma_{unit}", f"must not be negative, got {sigma!r}")
    return BaseParameter(name, regrouping, value, sigma, unit)


def _frames(data: Mapping, source: str) -> dict[str, FrameRecord]:
    return {name: FrameRecord(name=name, **item) for name, item in instrument_tables(data, source).items()}


def _summary(cal: _Table, name: str) -> dict[str, float]:
    t = cal.table(name, required=False)
    if t is None:
        return {}
    return {str(k): t.number(str(k)) for k in t.data}


def load_calibration_report(path: str | Path) -> CalibrationReport:
    """Read a calibration file written by ``deltacal identify`` for a report.

    Raises:
        InputError: naming the file, the key and the value that is wrong.
    """
    source = str(path)
    data = read_toml(path)
    if check_format(data, source) != CALIBRATION_FORMAT:
        raise InputError(f"not a calibration file (format {_shown(data.get('format'))}, expected "
                         f"{CALIBRATION_FORMAT!r})", source, "key format")
    top = _Table(data, source)
    cal = top.table("calibration")
    assert cal is not None
    for key in ("geometry", "nominal"):
        if not isinstance(data.get(key), Mapping):
            raise InputError("missing required table", source, f"key {key}")
    geometry = geometry_from_dict(data["geometry"], source, "geometry.")
    nominal = geometry_from_dict(data["nominal"], source, "nominal.")
    try:
        model = get_model(cal.string("model"))
    except ValueError as exc:
        raise cal.error("model", str(exc)) from None
    raw = cal.raw("base_parameter")
    if not isinstance(raw, list) or not raw or not all(isinstance(x, Mapping) for x in raw):
        raise cal.error("base_parameter",
                        "must be a non-empty array of tables [[calibration.base_parameter]]")
    base = [_parameter(item, source, k) for k, item in enumerate(raw)]
    for k, p in enumerate(base):
        if not p.is_frame and p.name not in model.names:
            raise InputError(f"{p.name!r} is not a parameter of model {model.name}", source,
                             f"key calibration.base_parameter[{k + 1}].name")
    r = len(base)
    C = cal.vector("correlation", (r, r))
    if np.max(np.abs(C - C.T)) > CORRELATION_ATOL or np.max(np.abs(np.diag(C) - 1.0)) > CORRELATION_ATOL:
        raise cal.error("correlation", "must be symmetric with ones on the diagonal")
    if np.max(np.abs(C)) > 1.0 + CORRELATION_ATOL:
        raise cal.error("correlation", f"values must lie within [-1, 1], got {float(np.max(np.abs(C)))!r}")
    unident = cal.raw("unidentifiable") if cal.has("unidentifiable") else []
    if not isinstance(unident, list) or not all(isinstance(x, str) for x in unident):
        raise cal.error("unidentifiable", f"must be an array of names, got {_shown(unident)}")
    lines = cal.raw("outlier_lines") if cal.has("outlier_lines") else []
    if not isinstance(lines, list) or not all(isinstance(x, int) and not isinstance(x, bool) for x in lines):
        raise cal.error("outlier_lines", f"must be an array of line numbers, got {_shown(lines)}")
    rows = cal.raw("outlier_rows") if cal.has("outlier_rows") else []
    if not isinstance(rows, list) or not all(isinstance(x, int) and not isinstance(x, bool) for x in rows):
        raise cal.error("outlier_rows", f"must be an array of row numbers, got {_shown(rows)}")
    rank = int(cal.number("rank")) if cal.has("rank") else r
    return CalibrationReport(
        source=source,
        model=model,
        method=cal.string("method", default="?"),
        rank=rank,
        parameters=int(cal.number("parameters")) if cal.has("parameters") else model.size,
        condition_number=cal.number("condition_number") if cal.has("condition_number") else math.nan,
        iterations=int(cal.number("iterations")) if cal.has("iterations") else 0,
        variance_factor=cal.number("variance_factor") if cal.has("variance_factor") else math.nan,
        unidentifiable=list(unident),
        residuals_before=_summary(cal, "residuals_before"),
        residuals_after=_summary(cal, "residuals_after"),
        outlier_lines=[int(n) for n in lines],
        outlier_rows=[int(n) for n in rows],
        base=base,
        correlation=0.5 * (C + C.T),
        geometry=geometry,
        nominal=nominal,
        frames=_frames(data, source),
    )
