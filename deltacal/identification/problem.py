"""The build phase of a fit: what is fitted to what, as one value.

A :class:`Problem` holds the measurements, the error model, the options and the
:class:`~.columns.Columns` of the regressor, and computes the rows (weighted residuals and
regressor, :func:`deltacal.observations.build_rows`) at any geometry and instrument frames, and
the geometry and frames a step of the parameters leads to.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..errormodels import ErrorModel
from ..exceptions import IdentificationError
from ..geometry import DeltaGeometry
from ..kinematics import exact
from ..observations import DISTANCE, Measurements, Rows, build_rows, distance_residual_stats
from ..resources import require_memory
from .columns import Columns, build_columns
from .compliance import loaded_readings, with_compliance, with_compliance_moved
from .frames import InstrumentFrame, frame_columns, in_base_frame, initial_frames
from .options import FitOptions
from .points import point_columns, with_points_moved
from .result import ResidualStats

#: Peak memory of a fit per element of the sensitivity S (M, 6, n): S, the rows, their
#: scaled and whitened copies, QR factors and trial rows, as measured on 20,000 positions.
_BYTES_PER_ELEMENT = 8 * 12


@dataclass(frozen=True)
class Problem:
    """A fit to do: measurements, model, options and the regressor's columns.

    Attributes:
        start: The geometry the fit starts from (nominal).
        measurements: The measurements fitted.
        model: The error model.
        options: The fit's options.
        columns: The regressor's columns (model, frames, free points).
        frames: The instrument frames at the start (``frame="free"``), else empty.
    """

    start: DeltaGeometry
    measurements: Measurements
    model: ErrorModel
    options: FitOptions
    columns: Columns
    frames: dict[str, InstrumentFrame] = field(default_factory=dict)

    def rows_at(self, geometry: DeltaGeometry, frames: dict[str, InstrumentFrame]) -> Rows:
        """The rows at a geometry and frames: residuals, and the regressor of every column."""
        opt, stations, points = self.options, list(self.columns.stations), list(self.columns.points)
        seen = in_base_frame(self.measurements, frames) if frames else self.measurements
        sensitivity = self.model.sensitivity
        if self.columns.compliance:  # rows of the loaded robot, the compliances' columns last
            seen = loaded_readings(geometry, seen)
            sensitivity = with_compliance(sensitivity, seen.payload_kg)
        pose = exact.forward(geometry, seen.q)
        rows = build_rows(
            geometry, seen, sensitivity, opt.sigma_position, opt.sigma_angle,
            distances=opt.distances, pairs=opt.pairs, pose=pose,
        )
        n_model = self.columns.n_model
        extra = [rows.regressor[:, :n_model]]
        if frames:
            centres = np.array([frames[name].centre for name in stations])
            extra.append(frame_columns(rows, seen, stations, centres))
        if points:
            extra.append(point_columns(rows, seen, points, pose.rotation))
        extra.append(rows.regressor[:, n_model:])
        return replace(rows, regressor=np.hstack(extra)) if len(extra) > 2 else rows

    def stats(self, geometry: DeltaGeometry, rows: Rows) -> ResidualStats:
        """Residual statistics of rows at a geometry; distances pair by pair, in bounded memory."""
        if not np.any(rows.kind == DISTANCE):
            return ResidualStats.from_rows(rows)
        pose = exact.forward(geometry, self.measurements.q)
        rms, worst = distance_residual_stats(geometry, self.measurements, pose, self.options.pairs)
        return ResidualStats(distance_rms=rms, distance_max=worst)

    def moved(
        self, geometry: DeltaGeometry, frames: dict[str, InstrumentFrame], full: np.ndarray
    ) -> tuple[DeltaGeometry, dict[str, InstrumentFrame]]:
        """The geometry and frames after a step ``full`` of every column's parameter."""
        n_model, n_fixed = self.columns.n_model, self.columns.n_fixed
        corrections = full[n_model:n_fixed].reshape(-1, 6)
        moved_geometry = self.model.apply(geometry, full[:n_model])
        if self.columns.points:
            moves = full[n_fixed : n_fixed + 3 * len(self.columns.points)]
            points = list(self.columns.points)
            moved_geometry = with_points_moved(moved_geometry, points, moves.reshape(-1, 3))
        if self.columns.compliance:
            moved_geometry = with_compliance_moved(moved_geometry, full[-3:])
        return (
            moved_geometry,
            {s: frames[s].corrected(c) for s, c in zip(self.columns.stations, corrections, strict=True)},
        )


def _require_memory(measurements: Measurements, columns: int, options: FitOptions) -> None:
    """Refuse up front a fit whose rows would not fit the memory available (one line, no swap)."""
    needed = _BYTES_PER_ELEMENT * 6.0 * len(measurements) * max(columns, 1)
    advice = "use fewer measurements"
    if options.distances and options.pairs == "all":
        advice += ", --pairs reference or a Bai model (bai18: 18 columns)"
    what = f"identification from {len(measurements):,} measurements with {columns} parameters"
    require_memory(needed, what, advice)


def build_problem(
    start: DeltaGeometry, measurements: Measurements, model: ErrorModel, options: FitOptions
) -> Problem:
    """The problem of fitting ``model`` to ``measurements`` from ``start``.

    Raises:
        IdentificationError: a free point is not among the measured points.
    """
    for name in options.free_points:
        if name not in measurements.point:
            measured = ", ".join(dict.fromkeys(measurements.point))
            raise IdentificationError(
                f"free point {name!r} is not measured; the measured points are {measured}"
            )
    stations = measurements.stations if options.frame == "free" else []
    frames: dict[str, InstrumentFrame] = {}
    if stations:
        frames = initial_frames(start, measurements, exact.forward(start, measurements.q))
    columns = build_columns(model, stations, options.free_points, options.compliance)
    _require_memory(measurements, len(columns.columns), options)
    return Problem(start, measurements, model, options, columns, frames)
