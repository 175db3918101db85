"""Residuals of each measurement before (nominal) and after (identified) calibration, recomputed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..calibration import Calibration
from ..exceptions import AssemblyError
from ..identification.frames import in_base_frame, initial_frames
from ..io import read_measurement_file, unassembled_rows
from ..kinematics import exact
from ..observations import Measurements, distance_pairs, predicted_points
from ..rotations import rotation_from_vector, vector_from_rotation

#: Relative disagreement between the recomputed residual RMS and the file's beyond which the
#: measurements are said not to be those the calibration was identified from.
MISMATCH_RTOL = 0.02


@dataclass(frozen=True)
class MeasurementResiduals:
    """Per-measurement residuals of a calibration's measurement file.

    Attributes:
        source: The measurement file.
        kind: ``"position"`` (3-D distance measured − predicted) or ``"distance"`` (RMS of the
            residuals of the distances between this position and the others of its point).
        lines: Line of each measurement in the file, (M,).
        before: Residual at the nominal geometry [mm], (M,).
        after: Residual at the identified geometry [mm], (M,).
        orientation_before: Orientation residual [deg], (M,), NaN where not measured.
        orientation_after: The same after calibration [deg].
        position: Where the measured point stood, in the robot base frame [mm], (M, 3).
        outlier: Whether each measurement's line is one the calibration flagged, (M,).
        warnings: Disagreements with the calibration file (wrong file?).
    """

    source: str
    kind: str
    lines: np.ndarray
    before: np.ndarray
    after: np.ndarray
    orientation_before: np.ndarray
    orientation_after: np.ndarray
    position: np.ndarray
    outlier: np.ndarray
    warnings: tuple[str, ...] = ()

    @property
    def rms_before(self) -> float:
        """RMS of the residuals before calibration [mm]."""
        return float(np.sqrt(np.mean(self.before**2)))

    @property
    def rms_after(self) -> float:
        """RMS of the residuals after calibration [mm]."""
        return float(np.sqrt(np.mean(self.after**2)))


def _per_measurement_distance(geometry, measurements: Measurements, pose) -> np.ndarray:
    """RMS over the pairs holding each measurement of the distance residuals [mm], (M,)."""
    predicted = predicted_points(geometry, measurements, pose)
    ab = distance_pairs(measurements, "all")
    a, b = ab[:, 0], ab[:, 1]
    measured = np.linalg.norm(measurements.position[b] - measurements.position[a], axis=1)
    r = measured - np.linalg.norm(predicted[b] - predicted[a], axis=1)
    M = len(measurements)
    total = np.bincount(a, r**2, M) + np.bincount(b, r**2, M)
    count = np.bincount(a, None, M) + np.bincount(b, None, M)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(total / count)


def _orientation(measurements: Measurements, pose) -> np.ndarray:
    out = np.full(len(measurements), np.nan)
    has = measurements.has_orientation
    if np.any(has):
        assert measurements.rotation_vector is not None
        R = rotation_from_vector(measurements.rotation_vector[has])
        err = vector_from_rotation(R @ np.swapaxes(pose.rotation[has], 1, 2))
        out[has] = np.degrees(np.linalg.norm(err, axis=1))
    return out


def measurement_residuals(calibration: Calibration, path: str | Path) -> MeasurementResiduals:
    """Residuals of each measurement of ``path`` at the nominal and the identified geometries.

    Measurements in instrument frames are carried into the base frame by the frames of the
    calibration file (after) and by the closed-form first estimate from the nominal geometry
    (before, as identification starts). A calibration identified from distances (its residual
    summaries are distances) gets distance residuals.

    Raises:
        InputError: a bad measurement file, or readings the nominal or identified robot
            cannot assemble (naming the file, line and column).
    """
    read = read_measurement_file(path, calibration.geometry.point_names)
    measurements, file_lines = read.measurements, np.asarray(read.lines)
    warnings = list(read.warnings)
    recorded = calibration.residuals_after
    distances = math.isfinite(recorded.distance_rms) or math.isfinite(recorded.distance_max)
    nominal, identified = calibration.nominal, calibration.geometry
    poses = []
    for geometry, robot in ((nominal, "the nominal robot"), (identified, "the identified robot")):
        try:
            poses.append(exact.forward(geometry, measurements.q))
        except AssemblyError as exc:  # named by the file's lines, as identify names them
            if not exc.indices:
                raise
            raise unassembled_rows(exc, path, file_lines, measurements.q,
                                   f"{robot} of {calibration.source}") from exc
    pose0, pose1 = poses
    if distances:
        before = _per_measurement_distance(nominal, measurements, pose0)
        after = _per_measurement_distance(identified, measurements, pose1)
        seen = measurements
        expected = recorded.distance_rms
    else:
        seen0, seen = measurements, measurements
        if calibration.frames:
            unknown = sorted(set(measurements.stations) - set(calibration.frames))
            if unknown:
                warnings.append(f"{path}: station(s) {', '.join(unknown)} have no frame in "
                                f"{calibration.source}: their residuals are meaningless")
            frames = {s: f.frame for s, f in calibration.frames.items()}
            seen0 = in_base_frame(measurements, initial_frames(nominal, measurements, pose0))
            seen = in_base_frame(measurements, {s: frames.get(s, f) for s, f in
                                                initial_frames(identified, measurements, pose1).items()})
        before = np.linalg.norm(seen0.position - predicted_points(nominal, seen0, pose0), axis=1)
        after = np.linalg.norm(seen.position - predicted_points(identified, seen, pose1), axis=1)
        expected = recorded.position_rms
    result = MeasurementResiduals(
        source=str(path),
        kind="distance" if distances else "position",
        lines=file_lines,
        before=before,
        after=after,
        orientation_before=np.full(len(measurements), np.nan) if distances else _orientation(seen0, pose0),
        orientation_after=np.full(len(measurements), np.nan) if distances else _orientation(seen, pose1),
        position=predicted_points(identified, measurements, pose1),
        outlier=(np.isin(file_lines, calibration.outlier_lines) if calibration.outlier_lines
                 else np.isin(np.arange(1, len(measurements) + 1), calibration.outlier_rows)),
        warnings=(),
    )
    if math.isfinite(expected):
        got = result.rms_after
        if abs(got - expected) > MISMATCH_RTOL * max(expected, 1e-9):
            warnings.append(
                f"{path}: residual RMS after calibration recomputed as {got:.6g} mm where "
                f"{calibration.source} says {expected:.6g} mm: are these the measurements it was "
                "identified from?"
            )
    missing = sorted(set(calibration.outlier_lines) - set(result.lines.tolist()))
    if missing:
        warnings.append(f"{path}: outlier line(s) {', '.join(map(str, missing))} of {calibration.source} "
                        "are not data rows of this file")
    return MeasurementResiduals(**{**result.__dict__, "warnings": tuple(warnings)})
