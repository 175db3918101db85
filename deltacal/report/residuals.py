"""Residuals of each measurement before (nominal) and after (identified) calibration, recomputed.

A rotary Delta's measurement file (positions, distances) is read as ``identify`` reads it; a
printer's files (``probe.csv``, ``distances.csv``) are of commanded positions, turned into the
readings the firmware commanded through its settings (:func:`printer_residuals`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..calibration import Calibration
from ..exceptions import AssemblyError, InputError
from ..identification.frames import in_base_frame, initial_frames
from ..io import read_measurement_file, unassembled_rows
from ..kinematics import exact
from ..observations import Measurements, distance_pairs, predicted_points
from ..printer.files.measurements import printer_file_kind, read_printed_distances, read_probe_heights
from ..rotations import rotation_from_vector, vector_from_rotation

if TYPE_CHECKING:
    from ..geometry import DeltaGeometry
    from ..printer.firmware.base import FirmwareModel

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


def measurement_residuals(calibration: Calibration, path: str | Path | Sequence[str | Path],
                          controller: FirmwareModel | None = None) -> MeasurementResiduals:
    """Residuals of each measurement of ``path`` at the nominal and the identified geometries.

    Measurements in instrument frames are carried into the base frame by the frames of the
    calibration file (after) and by the closed-form first estimate from the nominal geometry
    (before, as identification starts). A calibration identified from distances (its residual
    summaries are distances) gets distance residuals.

    A printer's calibration takes its measurement files (probe heights, distances) and the
    firmware's values they were commanded with: :func:`printer_residuals`.

    Args:
        calibration: The calibration.
        path: Its measurement file (a printer's: one file or more).
        controller: A printer's firmware values (its ``--controller`` settings); else None.

    Raises:
        InputError: a bad measurement file, or readings the nominal or identified robot
            cannot assemble (naming the file, line and column).
    """
    paths = [path] if isinstance(path, str | Path) else list(path)
    if calibration.geometry.chain.firmware:
        return printer_residuals(calibration, paths, controller)
    if len(paths) != 1:
        raise InputError(f"a rotary Delta's calibration takes one measurement file, got {len(paths)}",
                         str(paths[-1]))
    path = paths[0]
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



@dataclass(frozen=True)
class _FileResiduals:
    """One printer file's residuals [mm] (absolute values), lines and where each was measured."""

    kind: str
    before: np.ndarray
    after: np.ndarray
    lines: np.ndarray
    position: np.ndarray


def printer_residuals(calibration: Calibration, paths: Sequence[str | Path],
                      controller: FirmwareModel | None) -> MeasurementResiduals:
    """Residuals of a printer's probe heights and distances at its nominal and identified geometries.

    Each file is told by its columns (:func:`~deltacal.printer.files.measurements.printer_file_kind`);
    the probe heights come first, then the distances, each in the order given (as ``identify``
    takes them: the calibration's outlier rows count in that order). Each commanded position is
    turned into the readings the firmware commanded through its values ``controller``, counted in the
    calibration's step distance; a probe height's residual is the trigger height less the nozzle's
    height above the bed there (the nozzle the probe point: ``identify``'s default), a distance's the
    measured one less the one between the printed features, both as absolute values. The source
    names each file with its count and RMS before and after.

    Raises:
        InputError: no firmware values, a file that is neither, a bad file, or a position the firmware
            or the printer cannot reach (naming the file and line).
    """
    if controller is None:
        raise InputError("a printer's measurements are of commanded positions: give the firmware settings "
                         "they were made with (--controller printer.cfg, config.g or an M503 capture)",
                         str(paths[0]))
    kinds = [printer_file_kind(path) for path in paths]
    if None in kinds:
        raise InputError("neither probe heights (x_mm,y_mm,z_mm) nor distances (x1_mm..z2_mm,distance_mm): a "
                         "printer's calibration takes its probe.csv and distances.csv",
                         str(paths[kinds.index(None)]), "line 1")
    ordered = sorted(range(len(paths)), key=lambda k: kinds[k] != "probe")  # stable: probe heights first
    files = [(str(paths[k]), _printer_file(calibration, paths[k], controller)) for k in ordered]
    warnings = []
    for what, expected in (("probe height", calibration.residuals_after.height_rms),
                           ("distance", calibration.residuals_after.distance_rms)):
        got = _rms(np.concatenate([np.zeros(0), *(r.after for _, r in files if r.kind == what)]))
        if math.isfinite(got) and math.isfinite(expected) and abs(got - expected) > MISMATCH_RTOL * max(
                expected, 1e-9):
            warnings.append(f"{what} residual RMS after calibration recomputed as {got:.6g} mm where "
                            f"{calibration.source} says {expected:.6g} mm: are these the measurements (and "
                            "the firmware settings) it was identified from?")
    lines = np.concatenate([r.lines for _, r in files])
    return MeasurementResiduals(
        source=", ".join(f"{path} ({len(r.lines)} {r.kind}s: RMS {_rms(r.before):.4g} mm before, "
                         f"{_rms(r.after):.4g} mm after)" for path, r in files),
        kind=" and ".join(dict.fromkeys(r.kind for _, r in files)), lines=lines,
        before=np.concatenate([r.before for _, r in files]),
        after=np.concatenate([r.after for _, r in files]),
        orientation_before=np.full(len(lines), np.nan), orientation_after=np.full(len(lines), np.nan),
        position=np.concatenate([r.position for _, r in files]),
        outlier=np.isin(np.arange(1, len(lines) + 1), calibration.outlier_rows), warnings=tuple(warnings))


def _printer_file(calibration: Calibration, path: str | Path, controller: FirmwareModel) -> _FileResiduals:
    """A printer's measurement file's residuals at the nominal and the identified printer."""
    step = calibration.geometry.step_distance
    step = controller.step_distance if step is None else step
    geometries = (calibration.nominal, calibration.geometry)
    if printer_file_kind(path) == "probe":
        heights = read_probe_heights(path)
        lines = np.asarray(heights.lines)
        tip = [_nozzle(g, controller, heights.commanded, step, path, lines) for g in geometries]
        before, after = (np.abs(heights.heights - p[:, 2]) for p in tip)
        return _FileResiduals("probe height", before, after, lines, tip[1])
    printed = read_printed_distances(path)
    lines = np.asarray(printed.lines)
    ends = [_nozzle(g, controller, printed.pairs.reshape(-1, 3), step, path, np.repeat(lines, 2))
            for g in geometries]
    ends = [p.reshape(-1, 2, 3) for p in ends]
    before, after = (np.abs(printed.distance - np.linalg.norm(p[:, 0] - p[:, 1], axis=1)) for p in ends)
    return _FileResiduals("distance", before, after, lines, ends[1].mean(axis=1))


def _nozzle(geometry: DeltaGeometry, controller: FirmwareModel, commanded: np.ndarray, step,
            path: str | Path, lines: np.ndarray) -> np.ndarray:
    """Where the printer of ``geometry`` puts its nozzle at commanded positions, through the firmware [mm]."""
    readings = controller.inverse(commanded, step, check=False)
    bad = np.flatnonzero(~np.all(np.isfinite(readings), axis=1))
    try:
        if not bad.size:
            return exact.forward(geometry, readings).point(geometry.tool)
    except AssemblyError as exc:
        bad = np.asarray(exc.indices if exc.indices else [0])
    k = int(bad[0])
    raise InputError(f"the commanded position {np.round(commanded[k], 4).tolist()} mm is out of reach of the "
                     f"firmware settings or of the printer {geometry.name!r} (another printer's file?)",
                     str(path), f"line {int(lines[k])}")


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2))) if values.size else math.nan
