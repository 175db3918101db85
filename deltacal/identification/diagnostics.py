"""Checks before a fit: plausible measurements, enough and well-spread poses, richer options."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errormodels import ErrorModel
from ..exceptions import AssemblyError, IdentificationError
from ..geometry import DeltaGeometry
from ..identifiability import BaseParameters, base_parameters
from ..kinematics import exact
from ..observations import DISTANCE, POSITION, Measurements, Rows, build_rows, predicted_points
from .frames import frame_columns
from .options import FitOptions


def _stations_in_metres(measurements: Measurements) -> list[str]:
    """Stations whose measured positions spread 300 to 3000 times less than the widest station's."""
    stations = list(measurements.stations)
    if len(stations) < 2:
        return []
    station = np.array(measurements.station)
    spread = {}
    for name in stations:
        p = measurements.position[station == name]
        spread[name] = float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))
    widest = max(spread.values())
    return [name for name, s in spread.items() if 300.0 < widest / max(s, 1e-300) < 3000.0]


def check_plausible(
    start: DeltaGeometry, measurements: Measurements, rows: Rows, frame_free: bool = False
) -> None:
    """Refuse measurements no robot near ``start`` can have produced, before fitting them.

    Manufacturing errors move the measured points by similar amounts all over the
    workspace, so at the start geometry the position errors are alike. All of them
    large means wrong units or frame; a few far larger than the rest (three times the
    median, ten robust deviations and 5 % of the arm length) are gross errors that a
    least-squares fit would spread over every parameter (and hide: a lone far pose has
    a leverage near 1).
    """
    arm = float(np.mean(np.linalg.norm(start.arm_ball.mean(axis=1), axis=1)))
    position = rows.kind == POSITION
    if np.any(position):
        error = np.linalg.norm(rows.residual[position].reshape(-1, 3), axis=1)
        which = rows.measurement[position][::3]
    else:
        error = np.abs(rows.residual[rows.kind == DISTANCE])
        which = np.array([], dtype=int)
    if not error.size:
        return
    median = float(np.median(error))
    metres = _stations_in_metres(measurements)
    if median > 0.2 * arm and metres:
        raise IdentificationError(
            f"the positions of station(s) {', '.join(map(repr, metres))} spread about 1000 times less than "
            "those of the other stations: in metres, not millimetres? Convert them (x1000) or measure again"
        )
    if median > 0.2 * arm:
        where = (
            "that each station's measurements are of one rigid set-up"
            if frame_free
            else "the frame (measured in a tracker's own frame? identify with --frame free)"
        )
        raise IdentificationError(
            f"the measured positions are a median {median:.4g} mm from where the nominal robot puts "
            f"them (arms of {arm:.4g} mm): check the units (readings in degrees, positions in mm), "
            f"{where}, and the robot file"
        )
    spread = 1.4826 * float(np.median(np.abs(error - median)))
    gross = error > max(3.0 * median, median + 10.0 * spread, 0.05 * arm)
    if which.size and np.any(gross):
        k = int(np.argmax(np.where(gross, error, -np.inf)))
        raise IdentificationError(
            f"the measured position is up to {error[k]:.4g} mm from where the nominal robot puts it "
            f"at the row's readings, the other rows a median {median:.4g} mm: a typing error in the "
            "readings or the position? Correct or remove the row",
            rows=which[gross],
        )


def _reference_regressor(
    start: DeltaGeometry, measurements: Measurements, model: ErrorModel, options: FitOptions,
    stations: list[str], orientation: bool = False, extra_point: bool = False,
) -> np.ndarray | None:
    """Weighted regressor of well-spread poses with the same kinds of measurement, or richer ones.

    Readings: 30 random poses within ±15 deg of the median measured readings; at each,
    every (point, with orientation) combination of the measurements. ``orientation``
    adds orientations, ``extra_point`` a second point off the first. None if fewer than
    10 of these poses assemble.
    """
    rng = np.random.default_rng(0)
    q = np.median(measurements.q, axis=0) + rng.uniform(-1.0, 1.0, (30, 3)) * math.radians(15.0)
    try:
        exact.forward(start, q)
    except AssemblyError as exc:
        q = np.delete(q, exc.indices, axis=0)
    kinds = sorted(set(zip(measurements.point, measurements.has_orientation.tolist(), strict=True)))
    if orientation:
        kinds = sorted({(name, True) for name, _ in kinds})
    geometry = start
    if extra_point:
        plate = float(np.mean(np.linalg.norm(start.plate_ball.mean(axis=1), axis=1)))
        offset = start.point(kinds[0][0]) + plate * np.array([1.0, 0.6, -0.5])
        geometry = replace(start, points={**start.points, "_extra": offset})
        kinds = kinds + [("_extra", kinds[0][1])]
    if len(q) < 10:
        return None
    point = [name for _ in q for name, _ in kinds]
    has = np.array([o for _ in q for _, o in kinds])
    # with free frames, the poses shared round-robin among the stations
    station = [stations[k % len(stations)] for k in range(len(q)) for _ in kinds] if stations else []
    ref = Measurements(q=np.repeat(q, len(kinds), axis=0), position=np.zeros((has.size, 3)), point=point,
                       rotation_vector=np.where(has[:, None], 0.0, np.full((has.size, 3), np.nan)),
                       station=station)
    try:
        pose = exact.forward(geometry, ref.q)
        rows = build_rows(geometry, ref, model.sensitivity, options.sigma_position, options.sigma_angle,
                          distances=options.distances, pairs=options.pairs, pose=pose)
    except AssemblyError:
        return None
    W = rows.weighted[1]
    if stations:
        seen = replace(ref, position=predicted_points(geometry, ref, pose))
        W = np.hstack([W, frame_columns(rows, seen, stations) / rows.sigma[:, None]])
    return W


def _separated(
    base: BaseParameters, W: np.ndarray, richer: BaseParameters, W_richer: np.ndarray
) -> list[str]:
    """Parameters involved in the directions the richer regressor identifies and W does not."""

    def null(A: np.ndarray, rank: int) -> np.ndarray:
        return np.linalg.svd(A / richer.scale, full_matrices=True)[2][rank:].T

    N, N_richer = null(W, base.rank), null(W_richer, richer.rank)
    U, sv, _ = np.linalg.svd(N - N_richer @ (N_richer.T @ N), full_matrices=False)
    lost = U[:, sv > 0.5]
    return [base.names[k] for k in np.flatnonzero(np.max(np.abs(lost), axis=1, initial=0.0) > 0.2)]


def check_rank(
    start: DeltaGeometry, measurements: Measurements, model: ErrorModel, base: BaseParameters,
    W: np.ndarray, options: FitOptions, stations: list[str] | None = None,
) -> list[str]:
    """Compare the rank with what well-spread poses of the same kinds give.

    Raises IdentificationError if the poses are too few or too alike, naming the
    parameters lost and how many poses are needed; returns hints on what richer
    measurements (orientations, a second point) would identify. The options give the σ of
    the measurements, distances and their pairs, and the rank tolerance.
    """
    stations = list(stations or [])
    distances, pairs, rtol = options.distances, options.pairs, options.rtol
    args = (start, measurements, model, options, stations)
    W_ref = _reference_regressor(*args)
    if W_ref is None:
        return []
    ref = base_parameters(W_ref, base.names, rtol=rtol)
    M = len(measurements)
    if base.rank < ref.rank:
        if distances:
            needed = ref.rank + 1 if pairs == "reference" else math.ceil(0.5 + math.sqrt(0.25 + 2 * ref.rank))
        else:
            needed = math.ceil(ref.rank * M / W.shape[0])
        spread = _spread_advice(start, measurements)
        if M < needed:
            raise IdentificationError(
                f"too few measurements: {M} give {W.shape[0]} equations, but model {model.name} has "
                f"{ref.rank} parameters identifiable from such measurements: measure at least {needed} "
                f"poses (two to three times as many for a useful estimate), {spread}"
            )
        lost = _separated(base, W, ref, W_ref)
        raise IdentificationError(
            f"the {M} measurements identify only {base.rank} of the {ref.rank} parameters model "
            f"{model.name} can identify from such measurements: the poses are too alike to separate "
            f"{_names_text(lost)}; {spread} would help"
        )
    hints = []
    one_point = len(set(measurements.point)) == 1
    has_orientation = bool(np.any(measurements.has_orientation))
    richer: list[tuple[str, bool, bool]] = []
    if not has_orientation and not distances:
        richer.append(("orientation measurements (rx_deg, ry_deg, rz_deg)", True, False))
    if not has_orientation and one_point:
        richer.append(("a second point measured on the plate, off the first", False, True))
    for label, orientation, extra_point in richer:
        W_rich = _reference_regressor(*args, orientation=orientation, extra_point=extra_point)
        if W_rich is None:
            continue
        rich = base_parameters(W_rich, base.names, rtol=rtol)
        if rich.rank > ref.rank:
            gained = _separated(ref, W_ref, rich, W_rich)
            hints.append(f"{label} would identify {rich.rank - ref.rank} more base parameter(s), "
                         f"separating {_names_text(gained)}")
    return hints


def _names_text(names: list[str], limit: int = 12) -> str:
    if not names:
        return "some of them"
    return ", ".join(names[:limit]) + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _spread_advice(start: DeltaGeometry, measurements: Measurements) -> str:
    """Which poses would help, from where the measured ones are."""
    size = float(np.mean(start.rod_length))
    z_span = float(np.ptp(measurements.position[:, 2]))
    radius = float(np.max(np.linalg.norm(measurements.position[:, :2], axis=1)))
    where = []
    if z_span < 0.05 * size:
        where.append(f"on the workspace's top and bottom layers (these span only {z_span:.3g} mm in z)")
    if radius < 0.05 * size:
        where.append(f"on the workspace's rim (these stay within {radius:.3g} mm of the axis)")
    if not where:
        return ("poses spread over the whole workspace (its top and bottom layers, centre and rim, each "
                "arm over a wide range of angles)")
    return "poses " + " and ".join(where)
