"""Fits that refuse to lie: the residuals tested against the σ given, and the likely causes named.

After a fit, ``s0² = χ² / (m − r)`` is 1 within ``±sqrt(2 / (m − r))`` when the σ given are
right and the model holds. Three verdicts:

* **good**: ``s0²`` within :func:`excess_bound` (5 standard deviations of s0² above 1) and
  every identified deviation plausible (:func:`implausible_deviations`);
* **moderate excess**: ``s0²`` above that bound but below :data:`POOR_FIT`, no implausible
  deviation, and no other reading of the data fits clearly better: unmodelled effects (or σ
  a little small). Reported with the variance factor, not refused;
* **poor**: ``s0²`` above :data:`POOR_FIT` (residuals ten times the σ given), an implausible
  deviation, or another reading of the same data that fits clearly better
  (:func:`readings`: orientations read as radians, another point for the rows, two point
  labels swapped, the measurements in an instrument's own frame). :class:`PoorFitError`
  names the readings that the data support.

Why these numbers: a model that leaves unmodelled effects of the size of the measurement noise
gives s0² of a few; ten times the σ (s0² = 100) is what data errors give (a reflector on another
point: tens of mm; radians in degree columns; a frame metres away), never the noise. A reading
"fits clearly better" when it halves χ² (for hundreds of rows, thousands of standard
deviations of χ²).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import replace

import numpy as np

from ..exceptions import PoorFitError as PoorFitError  # its former home: still importable
from ..geometry import DeltaGeometry
from ..observations import Measurements
from .options import FitOptions, Frame

#: s0² above which a fit is refused whatever else is found: residuals ten times the σ given.
POOR_FIT = 100.0
#: An identified length deviation beyond this fraction of the arm length is implausible.
PLAUSIBLE_LENGTH = 0.05
#: An identified tilt of an actuator axis beyond this is implausible [rad] (encoder offsets may
#: be anything: they are where the user zeroed the encoders).
PLAUSIBLE_TILT = math.radians(5.0)
#: Another reading of the data is supported when its χ² is below this fraction of the fit's ...
CLEARLY_BETTER = 0.5
#: ... and its own s0² below this (residuals within about 3 σ: it fits the data, give or take
#: unmodelled effects; a model too simple for the robot fits no reading that well).
FITS_WELL = 10.0


#: Stations reviewed one by one at most (each of their readings is one more fit).
STATIONS_REVIEWED = 6


def excess_bound(dof: int) -> float:
    """Largest s0² that noise alone gives, 5 standard deviations above 1: ``1 + 5 sqrt(2 / dof)``."""
    return 1.0 + 5.0 * math.sqrt(2.0 / max(dof, 1))


def implausible_deviations(start: DeltaGeometry, geometry: DeltaGeometry) -> list[str]:
    """Elements of the identified geometry that no manufacturing error explains.

    Ball centres, rod lengths and axis points that moved by more than
    :data:`PLAUSIBLE_LENGTH` of the arm length (a printer's: of its rod length; its carriage
    balls are on its tower), and actuator axes tilted by more than :data:`PLAUSIBLE_TILT`.
    """
    arm = start.chain.limb_length(start.arm_ball, start.rod_length)
    limit = PLAUSIBLE_LENGTH * arm
    found = []
    for label, a, b in (
        ("plate balls", start.plate_ball, geometry.plate_ball),
        ("arm balls", start.arm_ball, geometry.arm_ball),
        ("axis points", start.axis_point, geometry.axis_point),
    ):
        moved = float(np.max(np.linalg.norm(b - a, axis=-1)))
        if moved > limit:
            found.append(f"{label} moved by up to {moved:.3g} mm")
    rods = float(np.max(np.abs(geometry.rod_length - start.rod_length)))
    if rods > limit:
        found.append(f"rod lengths changed by up to {rods:.3g} mm")
    cos = np.clip(np.sum(start.axis_direction * geometry.axis_direction, axis=1), -1.0, 1.0)
    tilt = float(np.max(np.arccos(cos)))
    if tilt > PLAUSIBLE_TILT:
        found.append(f"actuator axes tilted by up to {math.degrees(tilt):.3g} deg")
    return found


def readings(
    measurements: Measurements, point_names: list[str], options: FitOptions
) -> Iterator[tuple[str, Measurements, FitOptions]]:
    """Other readings of the same data, one per plausible mistake.

    Args:
        measurements: The measurements as read.
        point_names: The robot's plate points (``tcp`` and the named ones).
        options: The fit asked for (its frame, distances and free points).

    Yields:
        ``(cause, measurements, options)``: the cause in words and the fit to try.
    """
    for cause, other, frame, points in _readings(measurements, point_names, options.frame, options.distances,
                                                 options.free_points):
        yield cause, other, replace(options, frame=frame, free_points=points)


def _readings(
    measurements: Measurements, point_names: list[str], frame: Frame, distances: bool,
    free_points: Sequence[str] = (),
) -> Iterator[tuple[str, Measurements, Frame, tuple[str, ...]]]:
    """:func:`readings` as ``(cause, measurements, frame, free_points)``."""
    points = tuple(free_points)
    has = measurements.has_orientation
    if np.any(has) and not distances:
        assert measurements.rotation_vector is not None
        yield (
            "the orientation columns rx_deg, ry_deg, rz_deg hold radians, not degrees",
            replace(measurements, rotation_vector=measurements.rotation_vector * (180.0 / math.pi)),
            frame,
            points,
        )
    names = list(dict.fromkeys(measurements.point))
    if len(names) == 1:
        for other in point_names:
            if other != names[0]:
                yield (
                    f"the rows measure point {other!r}, not {names[0]!r} (a point column missing or wrong)",
                    replace(measurements, point=[other] * len(measurements)),
                    frame,
                    (),
                )
    elif len(names) <= 4:
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                swap = {a: b, b: a}
                yield (
                    f"the point labels {a!r} and {b!r} are swapped",
                    replace(measurements, point=[swap.get(p, p) for p in measurements.point]),
                    frame,
                    points,
                )
    yield from _station_readings(measurements, names, frame, points)
    named = tuple(n for n in names if n != "tcp")
    if len(names) > 1 and named and set(named) - set(points) and not distances:
        # one point is held so that the rest can be told from the plate geometry
        freed = named[1:] if len(named) == len(names) else named
        yield (
            f"the position on the plate of {', '.join(map(repr, freed))} differs from the robot file "
            f"(a reflector offset: identify with --free-points {' '.join(freed)})",
            measurements,
            frame,
            tuple(dict.fromkeys(points + freed)),
        )
    if frame == "base" and not distances:
        yield (
            "the measurements are in the instrument's own frame (identify with --frame free)",
            measurements,
            "free",
            points,
        )


def _station_readings(
    measurements: Measurements, names: list[str], frame: Frame, points: tuple[str, ...]
) -> Iterator[tuple[str, Measurements, Frame, tuple[str, ...]]]:
    """The mistakes of one station alone: its positions in metres, its point labels swapped.

    A file-wide reading cannot explain them (the other stations are right), and the fit said "no
    single cause stands out". At most :data:`STATIONS_REVIEWED` stations: each reading is a fit.
    """
    stations = list(measurements.stations)
    if not 1 < len(stations) <= STATIONS_REVIEWED:
        return
    station = np.array(measurements.station)
    for name in stations:
        rows = station == name
        yield (
            f"the positions of station {name!r} are in metres, not millimetres",
            replace(measurements, position=np.where(rows[:, None], measurements.position * 1000.0,
                                                    measurements.position)),
            frame,
            points,
        )
        if 1 < len(names) <= 4:
            for i, a in enumerate(names):
                for b in names[i + 1 :]:
                    swap = {a: b, b: a}
                    labels = [swap.get(p, p) if here else p
                              for p, here in zip(measurements.point, rows, strict=True)]
                    yield (
                        f"the point labels {a!r} and {b!r} are swapped in station {name!r}",
                        replace(measurements, point=labels),
                        frame,
                        points,
                    )


def verdict(
    result, start: DeltaGeometry, alternatives: list[tuple[str, float, list[str]]]
) -> tuple[bool, list[str]]:
    """Whether a fit is poor, and the causes the data support.

    A reading is supported when its fit fits (s0² below :data:`FITS_WELL`) and
    either fits clearly better (s0² below :data:`CLEARLY_BETTER` of the fit's) or, where
    the fit's geometry is implausible, fits as well with a plausible geometry (a reflector
    label wrong by a common shift of the plate points that the ball centres absorb).

    Args:
        result: The fit.
        start: The geometry it started from.
        alternatives: ``(cause, s0² of that reading's fit, its implausible deviations)``.

    Returns:
        ``(poor, causes)``.
    """
    s0 = quality_factor(result)
    odd = implausible_deviations(start, result.geometry)
    causes = [
        cause
        for cause, alt, alt_odd in sorted(alternatives, key=lambda a: a[1])
        if alt < FITS_WELL and not alt_odd and (alt < CLEARLY_BETTER * s0 or (odd and alt <= 1.1 * s0))
    ]
    poor = bool(causes) or bool(odd) or s0 > POOR_FIT
    return poor, causes


def quality_factor(result) -> float:
    """s0² without the measurements flagged as outliers (they are reported on their own)."""
    inliers = result.inlier_variance_factor
    return float(inliers) if math.isfinite(inliers) else float(result.variance_factor)


def needs_review(result, start: DeltaGeometry) -> bool:
    """Whether a fit's residuals or deviations call for trying other readings of the data."""
    dof = max((result.independent_rows or result.n_rows) - result.rank, 1)
    return quality_factor(result) > excess_bound(dof) or bool(implausible_deviations(start, result.geometry))


def poor_fit_message(result, start: DeltaGeometry, causes: list[str], model_note: str = "") -> str:
    """One line: what is wrong with the fit, and the likely causes (``model_note``: a model that fits)."""
    dof = max((result.independent_rows or result.n_rows) - result.rank, 1)
    s0 = quality_factor(result)
    text = (
        f"the fit does not match the σ given: variance factor s0² = {s0:.3g} "
        f"(residuals {math.sqrt(s0):.3g} times σ; noise alone gives at most {excess_bound(dof):.3g}"
        + (", outliers left out)" if result.outliers else ")")
    )
    odd = implausible_deviations(start, result.geometry)
    if odd:
        text += " and the identified geometry is implausible (" + "; ".join(odd) + ")"
    if causes or model_note:
        return text + "; most likely: " + "; or ".join([*causes, model_note] if model_note else causes)
    return text + (
        "; no single cause stands out: check the units, the frame, the point of each row, the σ given "
        "and the model"
    )
