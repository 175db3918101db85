"""Where a printer's identification holds: the σ of its nozzle correction over the printable volume.

A corrected command is the one that puts the identified printer's nozzle on the target; the real
printer differs from the identified one by the estimation error δθ of its parameters (covariance
Σ, :func:`~.fit.identify_printer`), so the nozzle lands at ``target + J δθ``, with J the exact
nozzle sensitivity (:func:`~.fit.point_rows`: the error model's plate sensitivity with the
nozzle's lever) at the readings that command the target. No measurement sees the printer shifted
along its bed or turned about its normal; the correction is made in the controller's frame, whose
shift and turn over the first layer (:func:`~deltacal.holds.bed_points`) are the controller's own
(:func:`~deltacal.controller.targets.aligned_to_controller`), so those motions are taken out of J:
``J' = J − A(p) A_bed⁺ J_bed,xy`` (A: :func:`~deltacal.holds.in_plane_motion`), and
``Cov(p) = J' Σ J'ᵀ``. :func:`where_it_holds` evaluates it on the grid of
:class:`~deltacal.holds.WhereItHolds`; :func:`holds_in_words` says where the nozzle is known to
better than a bound. Vectorised over points. Units: mm and rad.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ...errormodels import ErrorModel, get_model
from ...exceptions import AssemblyError
from ...geometry import DeltaGeometry, Workspace
from ...holds import DEFAULT_BOUND, DETERMINED, WhereItHolds, bed_points, in_plane_motion
from ...kinematics import exact
from ...rotations import skew


def point_rows(geometry: DeltaGeometry, model: ErrorModel, q: np.ndarray, local: np.ndarray):
    """A plate point in {O} at readings q, (N, 3), and its exact sensitivity to the model's parameters.

    Args:
        geometry: The printer, at which the sensitivity is taken.
        model: Its error model.
        q: Readings [mm], (N, 3).
        local: The point in the plate frame [mm], (3,) (the nozzle: ``geometry.tool``).

    Returns:
        The point (N, 3) and its displacement per unit parameter (N, 3, n): the plate's sensitivity
        (:meth:`~deltacal.errormodels.ErrorModel.sensitivity`) with the point's lever.
    """
    if not len(q):  # no readings (a printer identified without probe heights)
        return np.zeros((0, 3)), np.zeros((0, 3, model.size))
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)
    arm = pose.rotation @ local  # (N, 3)
    point = pose.position + arm
    return point, S[:, :3] - np.einsum("nkl,nlp->nkp", skew(arm), S[:, 3:])


def readings_at(geometry: DeltaGeometry, points: np.ndarray) -> np.ndarray:
    """Readings that put the geometry's nozzle at points [mm], (N, 3); NaN rows where it cannot."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    with np.errstate(invalid="ignore"):
        return exact.inverse(geometry, points, check=False)


def _sensitivity(geometry: DeltaGeometry, model: ErrorModel,
                 points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nozzle's sensitivity at the readings of points, (K, 3, n), and the mask of the points reached."""
    q = readings_at(geometry, points)
    ok = np.all(np.isfinite(q), axis=1)
    while np.any(ok):
        kept = np.flatnonzero(ok)
        try:
            return point_rows(geometry, model, q[kept], geometry.tool)[1], ok
        except AssemblyError as exc:  # readings the forward cannot assemble back: out of reach too
            ok[kept[np.asarray(exc.indices, dtype=int)] if exc.indices else kept] = False
    return np.zeros((0, 3, model.size)), ok


def bed_gauge(geometry: DeltaGeometry, model: ErrorModel, radius: float) -> np.ndarray:
    """The shift along the bed and turn about its normal each parameter moves the first layer by, (3, n).

    The least-squares in-plane motion of the nozzle's x, y displacements over the first layer's
    points (:func:`~deltacal.holds.bed_points`): the motion the controller's frame takes back.
    """
    points = bed_points(radius)
    J, ok = _sensitivity(geometry, model, points)
    A = in_plane_motion(points[ok])[:, :2]
    return np.linalg.lstsq(A.reshape(-1, 3), J[:, :2].reshape(-1, model.size), rcond=None)[0]


def correction_sensitivity(geometry: DeltaGeometry, model: ErrorModel, points: np.ndarray,
                           radius: float) -> tuple[np.ndarray, np.ndarray]:
    """J': the corrected nozzle's displacement per unit parameter at points, in the controller's frame.

    Args:
        geometry: The identified printer.
        model: Its error model.
        points: Targets [mm], (N, 3).
        radius: The printable radius, whose first layer fixes the frame along the bed [mm].

    Returns:
        J' (K, 3, n) at the points reached, and the mask of those points (N,).
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    J, ok = _sensitivity(geometry, model, points)
    return J - in_plane_motion(points[ok]) @ bed_gauge(geometry, model, radius), ok


def correction_covariance(geometry: DeltaGeometry, model: ErrorModel, covariance: np.ndarray,
                          points: np.ndarray, radius: float) -> np.ndarray:
    """Covariance of where a corrected command puts the nozzle at points [mm²], (N, 3, 3); NaN out of reach.

    Args:
        geometry: The identified printer.
        model: Its error model.
        covariance: Its parameters' covariance (the model's order) [mm², rad²], (n, n).
        points: Targets [mm], (N, 3).
        radius: The printable radius (the first layer that fixes the frame along the bed) [mm].
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    J, ok = correction_sensitivity(geometry, model, points, radius)
    out = np.full((points.shape[0], 3, 3), np.nan)
    out[ok] = np.einsum("nir,rs,njs->nij", J, covariance, J)
    return out


#: Rings of the grid beyond the printable radius, out to the controller's reach, at most.
REACH_RINGS = 4


def where_it_holds(geometry: DeltaGeometry, model: ErrorModel, covariance: np.ndarray, workspace: Workspace,
                   measured_top: float = 0.0, reach: float | None = None) -> WhereItHolds:
    """The σ of the nozzle correction on the grid of :class:`~deltacal.holds.WhereItHolds` over the volume.

    Args:
        geometry: The identified printer.
        model: Its error model.
        covariance: Its parameters' covariance (the model's order), (n, n).
        workspace: The printable cylinder (its radius; heights from the bed to its top).
        measured_top: The highest nozzle height a measurement was made at [mm].
        reach: The controller's radius, when it commands the nozzle beyond the printable one [mm]: the
            grid goes on out to it (:data:`REACH_RINGS` rings), so that a target there has the σ the
            model gives it, not the printable radius's edge's (a rotary printer's arms reach far beyond
            the bed a calibration measured). The frame along the bed stays the printable radius's.
    """
    radius, azimuth, height = WhereItHolds.grid(workspace.radius, workspace.top_z)
    if reach is not None and reach > workspace.radius:
        rings = min(REACH_RINGS, int(np.ceil((reach - workspace.radius) / np.diff(radius)[-1])))
        radius = np.concatenate([radius, np.linspace(workspace.radius, reach, rings + 1)[1:]])
    cov = correction_covariance(geometry, model, covariance, WhereItHolds.nodes(radius, azimuth, height),
                                workspace.radius)
    horizontal = np.sqrt(np.clip(np.linalg.eigvalsh(np.nan_to_num(cov[:, :2, :2]))[:, -1], 0.0, None))
    vertical = np.sqrt(np.clip(cov[:, 2, 2], 0.0, None))
    reached = np.all(np.isfinite(cov.reshape(-1, 9)), axis=1)
    shape = (radius.size, azimuth.size, height.size)
    return WhereItHolds(radius, azimuth, height, np.where(reached, horizontal, np.inf).reshape(shape),
                        np.where(reached, vertical, np.inf).reshape(shape), float(measured_top))


def firmware_determination(geometry: DeltaGeometry, model: ErrorModel, covariance: np.ndarray,
                           tolerances: np.ndarray, workspace: Workspace) -> dict[str, float]:
    """How well the measurements determine each firmware value: its σ after them over the tolerances'.

    The firmware's classical values (the ``klipper`` error model's: a radius, each tower's angle,
    arm, endstop and step scale, which every firmware's values are) that best fit a printer over the
    printable volume are, to first order, ``v = G θ`` of its parameters θ: with J the nozzle's
    sensitivity over a grid of the volume (:func:`point_rows`) less the shift along the bed and the
    turn about its normal (the printed part's frame, where tower C's angle is held), and F the
    parameters that move the printer as each value does (least squares on the plate's
    sensitivities), ``G = (J F)⁺ J``. A value's σ after the measurements is ``√ diag(G Σ Gᵀ)``, from
    the build tolerances alone ``√ diag(G Σ₀ Gᵀ)``. The value with the largest ratio above
    :data:`~deltacal.holds.DETERMINED` is held (kept at the firmware's own), and the others judged
    again without it, until every value left is determined: an endstop the data fix only with its
    tower's step distance is determined once the step distance is kept.

    Args:
        geometry: The identified printer.
        model: Its error model.
        covariance: Its parameters' covariance after the measurements, (n, n).
        tolerances: Their σ from the build tolerances alone (the bed's place left out), (n,).
        workspace: The printable volume.

    Returns:
        The ratio of the two σ for each of the ``klipper`` error model's names (at its last judgement);
        none for a printer of another chain than that model's (a rotary printer's values are not these).
    """
    firmware = get_model("klipper")
    if firmware.chain != geometry.chain:
        return {}
    grid = WhereItHolds.nodes(*WhereItHolds.grid(workspace.radius, workspace.top_z))
    q = readings_at(geometry, grid)
    q = q[np.all(np.isfinite(q), axis=1)]
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose)
    moves = firmware.sensitivity(geometry, q, pose).reshape(-1, firmware.size)
    F = np.linalg.lstsq(S.reshape(-1, model.size), moves, rcond=None)[0]
    lever = skew(pose.rotation @ geometry.tool)
    J = (S[:, :3] - np.einsum("nkl,nlp->nkp", lever, S[:, 3:])).reshape(-1, model.size)
    A = in_plane_motion(pose.point(geometry.tool)).reshape(-1, 3)
    J = J - A @ np.linalg.lstsq(A, J, rcond=None)[0]  # the printed part's frame
    ratio = dict.fromkeys(firmware.names, 1.0)
    free = [k for k, name in enumerate(firmware.names) if name != "angle_c"]  # the part's turn
    while free:
        G = np.linalg.pinv(J @ F[:, free], rcond=1e-9) @ J
        after = np.sqrt(np.einsum("kn,nm,km->k", G, covariance, G))
        before = np.sqrt(np.einsum("kn,n,kn->k", G, tolerances**2, G))
        judged = after / np.maximum(before, 1e-300)
        for k, r in zip(free, judged, strict=True):
            ratio[firmware.names[k]] = float(r)
        worst = int(np.argmax(judged))
        if judged[worst] <= DETERMINED:
            break
        free.pop(worst)
    return ratio


def values_in_words(holds: WhereItHolds, name: Callable[[str], str] = str) -> str:
    """Which of the firmware's values the measurements determine, and which export keeps, in one sentence.

    ``name`` gives each value (its name in :attr:`WhereItHolds.values`) in the firmware's words.
    """
    named = [n for n in holds.values if n != "angle_c"]  # the part's turn: every fit holds it
    if not named:
        return ""
    kept = [n for n in holds.undetermined() if n in named]
    determined = [name(n) for n in named if n not in kept]
    words = f"the measurements determine the firmware's {', '.join(determined) or 'no value'}"
    if kept:
        words += (f"; not {', '.join(name(n) for n in kept)} (σ over {DETERMINED:.2g} of their build "
                  "tolerance): export keeps the firmware's own")
    return words


def holds_in_words(holds: WhereItHolds, bound: float = DEFAULT_BOUND) -> str:
    """Where the calibration determines the nozzle to better than ``bound``, in one sentence.

    E.g. "the nozzle is known within 0.05 mm (σ) up to z = 3.1 mm over r <= 116 mm (0.082 mm at
    the bed at r = 152 mm); 0.9 mm at z = 50 mm: the measurements are all at one height (z up to
    18 mm): print the tall object (`deltacal plan --object`) to calibrate heights".
    """
    full = float(holds.radius[-1])
    radius = holds.held_radius(bound)
    if not math.isfinite(radius):
        bed = holds.level_sigma()[0]
        where = f"the nozzle is known within {bound:g} mm (σ) nowhere: {bed:.3g} mm at the bed"
        up_to = -math.inf
    else:
        up_to = holds.held_up_to(bound, radius)
        if up_to >= holds.height[-1] and radius >= full:
            return (f"the nozzle is known within {bound:g} mm (σ) over the whole printable volume (r <= "
                    f"{full:g} mm, z up to {holds.height[-1]:g} mm; {holds.level_sigma().max():.3g} mm at "
                    "most)")
        where = (f"the nozzle is known within {bound:g} mm (σ) up to z = {up_to:.3g} mm over r <= "
                 f"{radius:.3g} mm")
        if radius < full:
            where += f" ({holds.level_sigma()[0]:.3g} mm at the bed out to r = {full:g} mm)"
    above = [k for k in range(holds.height.size) if holds.height[k] > max(up_to, 0.0)]
    probe = next((k for k in above if holds.height[k] >= 50.0), above[-1] if above else None)
    if probe is not None:
        where += f"; {holds.level_sigma(max(radius, 0.0))[probe]:.3g} mm at z = {holds.height[probe]:g} mm"
    if holds.bed_level:
        where += (f": the measurements are all at one height (z up to {holds.measured_top:.3g} mm): print "
                  "the tall object (`deltacal plan --object`) to calibrate heights")
    return where + "; elsewhere compensate sends the controller's own commands"
