"""What an identification returns: the identified geometry, base parameters with σ, residuals."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..geometry import DeltaGeometry
from ..holds import WhereItHolds
from ..identifiability import BaseParameters
from ..observations import DISTANCE, ORIENTATION, POSITION, Rows
from .columns import COMPLIANCE_NAMES, GEOMETRY, Column
from .frames import InstrumentFrame
from .outliers import OUTLIER_THRESHOLD


@dataclass(frozen=True)
class ResidualStats:
    """RMS and max of residuals by kind: positions, distances and probe heights [mm], orientations [rad]."""

    position_rms: float = float("nan")
    position_max: float = float("nan")
    orientation_rms: float = float("nan")
    orientation_max: float = float("nan")
    distance_rms: float = float("nan")
    distance_max: float = float("nan")
    height_rms: float = float("nan")
    height_max: float = float("nan")

    @classmethod
    def from_rows(cls, rows: Rows) -> ResidualStats:
        """Statistics of a set of rows; a position's error is its 3-D norm."""
        out = {}
        for kind, key in ((POSITION, "position"), (ORIENTATION, "orientation"), (DISTANCE, "distance")):
            mask = rows.kind == kind
            if not np.any(mask):
                continue
            r = rows.residual[mask]
            if kind != DISTANCE:
                r = np.linalg.norm(r.reshape(-1, 3), axis=1)
            out[f"{key}_rms"] = float(np.sqrt(np.mean(r**2)))
            out[f"{key}_max"] = float(np.max(np.abs(r)))
        return cls(**out)

    def as_dict(self) -> dict[str, float]:
        """The statistics that exist, orientations in degrees."""
        out = {}
        for k, v in self.__dict__.items():
            if math.isfinite(v):
                out[k.replace("orientation", "orientation_deg") if "orientation" in k else k + "_mm"] = (
                    math.degrees(v) if "orientation" in k else v
                )
        return out


@dataclass(frozen=True)
class IdentificationResult:
    """The outcome of an identification.

    Attributes:
        model: Name of the error model.
        method: ``"linear"`` or ``"iterated"``.
        geometry: The identified full geometry.
        start: The geometry identification started from (nominal).
        base: Base parameters (rank, regroupings, condition number).
        values: Identified value of each base parameter (units of its kept parameter).
        sigma: Standard deviation of each base parameter.
        correlation: Correlation matrix of the base parameters.
        before: Residual statistics at the start.
        after: Residual statistics at the identified geometry.
        outliers: Indices of measurements flagged as outliers.
        iterations: Gauss-Newton iterations (1 for linear).
        variance_factor: s0² = χ² / (m − r) at the end.
        units: Unit of each base parameter.
        n_rows: Number of regressor rows.
        independent_rows: Number of independent rows (all-pair distances: 3n - 6 per point, not
            the pairs); 0 when not known (a result built by hand): ``n_rows`` stands for it.
        residual_after: Residual of every row at the end [mm or rad].
        hints: What richer measurements would identify.
        frames: The identified instrument frame of each station (``frame="free"``), or empty.
        gauge_motion: Rigid motion removed to put the robot in the axes gauge: (translation
            [mm], rotation [rad]) (``frame="free"``).
        absorbed: Parameters of the geometry that the frames (nearly) absorb, held at their
            start value (see :data:`deltacal.identification.frames.FRAME_RTOL`).
        warnings: What is doubtful about the fit (see :mod:`deltacal.identification.quality`).
        inlier_variance_factor: s0² of the rows of the measurements not flagged as outliers.
        confounded: Coordinates of free points that the geometry's own parameters already
            account for (held at their given values).
        columns: The record (name, kind, unit) of each parameter of ``base.names``, in order.
        holds: Where a printer's calibration holds: the σ of its nozzle correction over the
            printable volume (:class:`~deltacal.holds.WhereItHolds`), or None (a rotary Delta's).
        tolerance_scale: The factor a printer's fit took its build tolerances by (nan: not a printer's).
    """

    model: str
    method: str
    geometry: DeltaGeometry
    start: DeltaGeometry
    base: BaseParameters
    values: np.ndarray
    sigma: np.ndarray
    correlation: np.ndarray
    before: ResidualStats
    after: ResidualStats
    outliers: list[int]
    iterations: int
    variance_factor: float
    units: list[str]
    n_rows: int
    residual_after: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    independent_rows: int = 0
    hints: tuple[str, ...] = ()
    frames: dict[str, InstrumentFrame] = field(default_factory=dict)
    gauge_motion: tuple[float, float] = (0.0, 0.0)
    absorbed: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    inlier_variance_factor: float = float("nan")
    confounded: tuple[str, ...] = ()
    columns: tuple[Column, ...] = ()
    holds: WhereItHolds | None = None
    tolerance_scale: float = float("nan")

    def __post_init__(self) -> None:
        if len(self.columns) != len(self.base.names):
            raise ValueError(
                f"columns must hold one record per parameter of base.names ({len(self.base.names)}), "
                f"got {len(self.columns)}"
            )

    @property
    def deviation(self) -> np.ndarray:
        """Deviations of the error model's parameters from the start (frames and free points left out)."""
        full = self.base.expand(self.values)
        return full[[c.kind == GEOMETRY for c in self.columns]]

    @property
    def rank(self) -> int:
        """Numerical rank of the regressor."""
        return self.base.rank

    @property
    def condition_number(self) -> float:
        """Condition number of the column-scaled base regressor."""
        return self.base.condition_number

    @property
    def labels(self) -> list[str]:
        """Readable base parameters (regroupings)."""
        return self.base.labels()

    def strong_correlations(self, threshold: float = 0.9, limit: int = 5) -> list[tuple[int, int, float]]:
        """Pairs of base parameters (indices) with |correlation| above ``threshold``, strongest first."""
        C = np.triu(self.correlation, k=1)
        a, b = np.nonzero(np.abs(C) > threshold)
        # strongest first; equal to 1e-9 (symmetric limbs give equal correlations, which
        # rounding would order differently on different CPUs) in the order of the parameters
        order = np.lexsort((b, a, -np.round(np.abs(C[a, b]), 9)))[:limit]
        return [(int(a[k]), int(b[k]), float(C[a[k], b[k]])) for k in order]

    def report(self, file_lines: Sequence[int] | np.ndarray | None = None) -> str:
        """A readable report: base parameters with σ, what is not identifiable, residuals, outliers.

        Args:
            file_lines: The line in its file of each measurement, to name the outliers by; without
                it they are named by their 1-based row.
        """
        named = [
            f"line {int(file_lines[k])}" if file_lines is not None else f"row {k + 1}" for k in self.outliers
        ]
        lines = [
            f"model {self.model} ({len(self.base.names)} parameters), method {self.method}, "
            f"{self.iterations} iteration(s), {self.n_rows} equations",
            f"rank {self.rank} of {len(self.base.names)}, condition number {self.condition_number:.4g}",
            "",
            "identified base parameters (value ± σ):",
        ]
        width = max((len(s) for s in self.labels), default=10)
        for label, v, s, u in zip(self.labels, self.values, self.sigma, self.units, strict=True):
            if u == "rad":
                lines.append(f"  {label:<{width}}  {math.degrees(v):+12.6f} ± {math.degrees(s):.6f} deg")
            elif u == "rad/Nm":  # an actuator's compliance, shown in µrad per N m
                lines.append(f"  {label:<{width}}  {1e6 * v:+12.6f} ± {1e6 * s:.6f} µrad/N m")
            else:
                lines.append(f"  {label:<{width}}  {v:+12.6f} ± {s:.6f} mm")
        absent = self.base.absent
        folded = [
            k for k in self.base.unidentifiable
            if k not in absent and self.base.names[k] not in (*self.absorbed, *self.confounded)
        ]
        points = [n for n in self.confounded if n not in COMPLIANCE_NAMES]
        if points:
            lines.append("")
            lines.append("free point coordinates confounded with the plate geometry (its own parameters "
                         "already account for them, e.g. a common shift of every plate point with the "
                         "plate balls moves nothing measured; held at their given values):")
            lines.append("  " + ", ".join(points))
        compliances = [n for n in self.confounded if n in COMPLIANCE_NAMES]
        if compliances:
            lines.append("")
            lines.append("compliances not identifiable (the gravity torques vary too little over the "
                         "measurements: measure at two payloads, far apart; held at zero): "
                         + ", ".join(compliances))
        if self.absorbed:
            lines.append("")
            lines.append("absorbed by the instrument frame(s) (rigid motions of the robot; held):")
            lines.append("  " + ", ".join(self.absorbed))
        if folded:
            lines.append("")
            lines.append("not identifiable on their own (folded into the base parameters above):")
            lines.append("  " + ", ".join(self.base.names[k] for k in folded))
        if absent:
            lines.append("not seen by these measurements at all (left at their start value):")
            lines.append("  " + ", ".join(self.base.names[k] for k in absent))
        lines += [f"hint: {h}" for h in self.hints]
        lines.append("")
        lines += self._residual_lines()
        lines += self._frame_lines()
        lines.append(f"variance factor s0² = {self.variance_factor:.3g} (1 if the σ given are right)")
        lines += [f"warning: {w}" for w in self.warnings]
        strong = self.strong_correlations()
        if strong:
            lines.append(
                "strongest correlations: "
                + "; ".join(f"{self.labels[a]} ~ {self.labels[b]} {c:+.3f}" for a, b, c in strong)
            )
        if self.outliers:
            lines.append(
                f"outliers (data snooping at {OUTLIER_THRESHOLD:g} σ): "
                + ", ".join(named)
            )
        else:
            lines.append("outliers: none")
        return "\n".join(lines)

    def _residual_lines(self) -> list[str]:
        """The residuals' RMS and max before and after, by kind."""
        lines = ["residuals             before        after"]
        for key, unit, scale in (
            ("position", "mm", 1.0),
            ("distance", "mm", 1.0),
            ("height", "mm", 1.0),
            ("orientation", "deg", math.degrees(1.0)),
        ):
            b_rms = getattr(self.before, f"{key}_rms")
            if not math.isfinite(b_rms):
                continue
            a_rms = getattr(self.after, f"{key}_rms")
            b_max = getattr(self.before, f"{key}_max")
            a_max = getattr(self.after, f"{key}_max")
            lines.append(f"  {key} RMS [{unit}]  {b_rms * scale:12.6f} {a_rms * scale:12.6f}")
            lines.append(f"  {key} max [{unit}]  {b_max * scale:12.6f} {a_max * scale:12.6f}")
        return lines

    def _frame_lines(self) -> list[str]:
        if not self.frames:
            return []
        lines = ["instrument frame(s): pose of the robot base {O} in each station's frame {T}"]
        for name, f in self.frames.items():
            rv, rs = np.degrees(f.rotation_vector), np.degrees(f.rotation_sigma)
            lines.append(
                f"  station {name}: rotation {np.array2string(rv, precision=6)} ± "
                f"{np.array2string(rs, precision=6)} deg, translation "
                f"{np.array2string(f.translation, precision=4)} ± "
                f"{np.array2string(f.translation_sigma, precision=4)} mm"
            )
        lines.append(
            "  gauge: {O} is where the identified actuator axes have no net rigid motion from the nominal "
            f"ones (the fit's frame moved by {self.gauge_motion[0]:.4g} mm and "
            f"{math.degrees(self.gauge_motion[1]):.4g} deg to get there; the base parameter values above "
            "are the fit's, before that move)"
        )
        return lines
