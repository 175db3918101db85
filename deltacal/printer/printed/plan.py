"""``plan --object`` for a linear Delta printer: which distances of the printed object to measure.

The distances are chosen among the object's candidate pairs (:mod:`.object`) to maximise
what the probe heights and they together tell about the printer: a greedy D-optimal selection
(Bayesian: ``log det(I + Σ w wᵀ)``, each row ``w`` a measurement's sensitivity in units of each
parameter's build tolerance and of the measurement's σ, so that the criterion is defined whatever
the rank, as the identification's priors are, :func:`deltacal.printer.identification.fit.identify_printer`).
The probe heights' rows start the information; each step adds the pair that increases the log
determinant most (``log(1 + wᵀ A⁻¹ w)``) among the pairs still possible: one feature per site
(a pair fixes the level of its sites), and no printed feature in the way of a chosen pair.

The printer is a :class:`~.target.PrinterToPlan` (a linear Delta printer and its firmware's values,
or a rotary Delta printer and its firmware's rotary controller), everything in the bed's frame.
The rows come from a callable (:data:`RowsFunction`): by default the printer's complete model
(54 parameters: ``printer`` or ``rotary_printer``, :func:`model_rows`), read through the firmware's
inverse model of the commanded positions; :func:`geometric_rows` is a model-free stand-in (an affine
distortion of the volume and its change with height) that prefers long pairs in several directions and
heights.
Units: mm and rad.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ...errormodels import get_model
from ...exceptions import PlanningError
from ...geometry import Tolerances
from ...identifiability import BaseParameters
from ..firmware.base import FirmwareModel
from ..identification.fit import PrinterMeasurements, measured_combinations, residuals_and_regressor
from ..robot import NominalLinearDelta
from .labels import BallLabel, NoLabelRoom, labels_mesh, place_labels
from .object import (
    BALL_DIAMETER,
    CALIPER_RANGE,
    LOWEST_LEVEL,
    MAX_DISTANCES,
    CaliperTooShort,
    ObjectLayout,
    blocking,
    candidate_pairs,
    object_layout,
    object_mesh,
    probe_grid,
)
from .target import PrinterToPlan, printer_to_plan

#: Rows of the probe heights and of candidate pairs: ``rows(probe (N, 3), pairs (P, 2, 3))`` ->
#: ``(probe rows (N, n), pair rows (P, n))``, each in units of the parameters' prior σ and of the
#: measurement's σ (commanded positions in, [mm]).
RowsFunction = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class ObjectPlan:
    """What to probe, print and measure on a printer.

    Attributes:
        probe: Commanded probe points (z = 0) [mm], (N, 3).
        features: Commanded centres of the printed features [mm], (F, 3).
        pairs: The features of each distance to measure, indices into ``features``, (M, 2).
        log_det: ``log det(I + Σ w wᵀ)`` of the probe heights and the chosen distances.
        log_det_probe: The same for the probe heights alone.
        probe_only: What the probe heights alone identify (``None`` with model-free rows).
        with_distances: What the probe heights and the distances identify (``None`` likewise).
        labels: Each feature's label, in the order of ``features`` (:mod:`.labels`).
        top_level: The layout's top level [mm] (the features chosen may stand lower); NaN: not given.
    """

    probe: np.ndarray
    features: np.ndarray
    pairs: np.ndarray
    log_det: float
    log_det_probe: float
    probe_only: BaseParameters | None = None
    with_distances: BaseParameters | None = None
    labels: tuple[BallLabel, ...] = ()
    top_level: float = float("nan")

    @property
    def names(self) -> list[str]:
        """The name printed beside each feature, in the order of ``features``."""
        return [label.name for label in self.labels]

    @property
    def pair_positions(self) -> np.ndarray:
        """Commanded centres of each pair's features ``x1, y1, z1, x2, y2, z2`` [mm], (M, 6)."""
        return np.hstack([self.features[self.pairs[:, 0]], self.features[self.pairs[:, 1]]])

    @property
    def lengths(self) -> np.ndarray:
        """Commanded centre distance of each pair [mm], (M,)."""
        return np.linalg.norm(self.features[self.pairs[:, 0]] - self.features[self.pairs[:, 1]], axis=1)

    def mesh(self):
        """The features: balls on their posts (a ``trimesh.Trimesh``, mm, in the printer's coordinates)."""
        return object_mesh(self.features)

    def labelled_mesh(self):
        """The object to print: the features and their labels' tiles, none touching another [mm]."""
        import trimesh

        if not self.labels:
            return self.mesh()
        return trimesh.util.concatenate([self.mesh(), labels_mesh(self.labels)])

    def added_names(self) -> list[str]:
        """Parameters the distances add to what the probe heights identify (their base parameters)."""
        if self.probe_only is None or self.with_distances is None:
            return []
        before = set(self.probe_only.base_names)
        return [n for n in self.with_distances.base_names if n not in before]


def model_rows(printer: NominalLinearDelta | PrinterToPlan, firmware: FirmwareModel | None = None,
               model: str | None = None, tolerances: Tolerances | None = None) -> RowsFunction:
    """Rows of the printer's complete model (or ``model``) at the nominal printer, read through the firmware.

    The commanded positions become readings through the firmware's inverse model (what the
    printer does when told to go there); the rows are the identification's
    (:func:`~deltacal.printer.identification.fit.residuals_and_regressor`), scaled by each
    parameter's build tolerance (``model.prior_sigma``; by default the printer's).

    Args:
        printer: A linear printer's robot file (with ``firmware``), or a printer to plan for.
        firmware: The linear printer's firmware values; None for a :class:`~.target.PrinterToPlan`.
        model: The error model's name (default: the printer's, :attr:`~.target.PrinterToPlan.model`).
        tolerances: The prior (default: the printer's).
    """
    target = printer_to_plan(printer, firmware)
    geometry = target.geometry()
    error_model = get_model(model or target.model)
    prior = error_model.prior_sigma(tolerances or target.tolerances)

    def rows(probe: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        readings = target.readings(probe)
        ends = target.readings(pairs.reshape(-1, 3)).reshape(-1, 2, 3)
        data = PrinterMeasurements(readings, ends, np.linalg.norm(pairs[:, 0] - pairs[:, 1], axis=1))
        _, W, kind = residuals_and_regressor(geometry, error_model, data)
        W = W * prior
        return W[kind == 0], W[kind == 1]

    return rows


def geometric_rows(probe: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Model-free rows: a distance's change under an affine distortion of the volume, varying with height.

    ``δp = (A + z B) p / L`` with 18 unknowns (A, B) and L = 100 mm: a pair's row is
    ``uᵀ δ(p1 − p2)`` with u their direction, so long pairs in many directions, at several heights
    and slanted weigh most. Probe heights give no row (they see no distortion of this kind's
    shape, only the bed).
    """
    scale = 100.0
    a, b = pairs[:, 0] / scale, pairs[:, 1] / scale
    u = (pairs[:, 0] - pairs[:, 1]) / np.linalg.norm(pairs[:, 0] - pairs[:, 1], axis=1)[:, None]
    dA = np.einsum("pk,pl->pkl", u, a - b).reshape(len(pairs), 9)
    dB = np.einsum("pk,pl->pkl", u, a * a[:, 2:3] - b * b[:, 2:3]).reshape(len(pairs), 9)
    return np.zeros((len(probe), 18)), np.hstack([dA, dB]) / 0.02


class TooFewDistances(CaliperTooShort):
    """Fewer distances than asked can be measured together on the object.

    Attributes:
        offered: How many can.
        asked: How many were asked.
    """

    def __init__(self, offered: int, asked: int) -> None:
        self.offered, self.asked = offered, asked
        super().__init__(f"the object offers only {offered} distances that can be measured together; "
                         f"{asked} asked")


def select_pairs(rows: np.ndarray, information: np.ndarray, count: int, layout: ObjectLayout,
                 pairs: np.ndarray, blocks: np.ndarray, at_least: int | None = None) -> np.ndarray:
    """Greedy D-optimal choice of ``count`` candidate pairs (indices into ``pairs``), or fewer.

    Args:
        rows: Each candidate's row, (P, n).
        information: The information before any distance (``I + Σ`` probe rows' products), (n, n).
        count: Pairs to choose.
        layout: The object's sites and levels (one feature per site).
        pairs: The candidates' features, indices into ``layout.centres``, (P, 2).
        blocks: Which features stand in each candidate's way (:func:`blocking`), (P, F).
        at_least: Fewer pairs than ``count`` are chosen when no more can be measured together, if
            at least this many (default ``count``).

    Raises:
        TooFewDistances: fewer than ``at_least`` pairs can be measured together.
    """
    inverse = np.linalg.inv(information)
    site = layout.site_of
    level = np.full(len(layout.sites), -1)  # the level printed on each site, -1: none yet
    printed = np.zeros(len(site), dtype=bool)
    chosen: list[int] = []
    for _ in range(count):
        s1, s2 = site[pairs[:, 0]], site[pairs[:, 1]]
        f_level = layout.level_of
        fits = (((level[s1] < 0) | (level[s1] == f_level[pairs[:, 0]]))
                & ((level[s2] < 0) | (level[s2] == f_level[pairs[:, 1]])))
        clear = ~np.any(blocks & printed[None, :], axis=1)
        if chosen:  # a new feature must not stand in a chosen pair's way
            in_way = np.any(blocks[chosen], axis=0)
            new_ok = ~in_way[pairs[:, 0]] & ~in_way[pairs[:, 1]]
            clear &= new_ok | (printed[pairs[:, 0]] & printed[pairs[:, 1]])
        possible = fits & clear
        possible[chosen] = False
        if not np.any(possible):
            if len(chosen) >= (count if at_least is None else at_least):
                break
            raise TooFewDistances(len(chosen), count)
        gain = np.einsum("pk,kl,pl->p", rows, inverse, rows)
        gain = np.where(possible, gain, -np.inf)
        best = int(np.argmax(gain))
        w = rows[best]
        v = inverse @ w
        inverse = inverse - np.outer(v, v) / (1.0 + w @ v)
        chosen.append(best)
        for f in pairs[best]:
            level[site[f]] = layout.level_of[f]
            printed[f] = True
    return np.array(chosen, dtype=int)


def plan_object(
    printer: NominalLinearDelta | PrinterToPlan,
    firmware: FirmwareModel | None = None,
    count: int | None = None,
    probe_count: int = 9,
    caliper: float = CALIPER_RANGE,
    rows: RowsFunction | None = None,
) -> ObjectPlan:
    """Plan the probe grid, the printed object and the distances to measure on it.

    Args:
        printer: The nominal linear printer (its robot file, with a ``[workspace]``), or a printer to
            plan for (:class:`~.target.PrinterToPlan`: a rotary Delta printer's).
        firmware: The linear printer's firmware model (printer.cfg) the probing and the print are
            commanded with; None for a :class:`~.target.PrinterToPlan` (its own).
        count: Distances to measure (at most :data:`MAX_DISTANCES`); None: as many as the object
            offers to measure together, :data:`MAX_DISTANCES` at most.
        probe_count: Probe points across the bed (odd; Klipper's ``round_probe_count``: 7 keeps 29
            points of its 7 × 7 grid within the radius, 9 keeps 49).
        caliper: The caliper's longest outside reading [mm].
        rows: The rows of the selection (default: the complete model, :func:`model_rows`).

    Raises:
        PlanningError: no workspace, too many distances, a caliper too short (the message gives the
            shortest that would do), a feature out of the firmware's reach, no room for a label.
    """
    printer = printer_to_plan(printer, firmware)
    if printer.workspace is None:
        raise PlanningError("the printer's robot file has no [workspace]: the printable cylinder is needed")
    if count is not None and not 1 <= count <= MAX_DISTANCES:
        raise PlanningError(f"distances to measure must be 1 to {MAX_DISTANCES}, got {count}")
    probe = probe_grid(printer.workspace.radius, probe_count)
    complete = rows is None
    rows_of = model_rows(printer) if rows is None else rows
    top: float | None = None
    while True:  # on a small bed, lower the object until every ball's label has room
        try:
            plan = _labelled(printer, count, caliper, probe, rows_of, top)
            break
        except NoLabelRoom:
            current = float(object_layout(printer.workspace, printer.tower_azimuth, caliper, top).levels[-1])
            if current - LABEL_ROOM_STEP < LOWEST_LEVEL + BALL_DIAMETER:
                raise
            top = current - LABEL_ROOM_STEP
    if complete:
        plan = _with_identifiability(plan, printer)
    return plan


#: How much lower the object's top level is taken each time a ball's label finds no room [mm].
LABEL_ROOM_STEP = 5.0


def _labelled(printer: PrinterToPlan, count: int | None, caliper: float, probe: np.ndarray,
              rows_of: RowsFunction, top: float | None) -> ObjectPlan:
    """The plan of the object with its top level at most ``top``, its balls labelled.

    Raises:
        PlanningError: a caliper too short (the message gives the shortest that would do).
        NoLabelRoom: a ball's label finds no room on the bed.
    """
    assert printer.workspace is not None  # plan_object refused a printer without one
    try:
        layout, pairs, chosen, information, pair_rows = _chosen(printer, count, caliper, probe, rows_of, top)
    except CaliperTooShort as exc:
        raise PlanningError(f"{exc}{_longer(printer, count, caliper, probe, rows_of, exc, top)}") from None
    used = np.unique(pairs[chosen].reshape(-1))
    index = np.full(len(layout.centres), -1)
    index[used] = np.arange(len(used))
    rows_chosen = pair_rows[chosen]
    log_det_probe = float(np.linalg.slogdet(information)[1])
    log_det = float(np.linalg.slogdet(information + rows_chosen.T @ rows_chosen)[1])
    features = layout.centres[used]
    return ObjectPlan(probe=probe, features=features, pairs=index[pairs[chosen]], log_det=log_det,
                      log_det_probe=log_det_probe,
                      labels=place_labels(features, index[pairs[chosen]], printer.workspace.radius),
                      top_level=float(layout.levels[-1]))


def _chosen(printer: PrinterToPlan, count: int | None, caliper: float, probe: np.ndarray,
            rows_of: RowsFunction, top: float | None = None
            ) -> tuple[ObjectLayout, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The object's layout, candidate pairs, chosen ones, the probe's information and the pairs' rows.

    The layout's top level at most ``top`` (None: as the caliper and the pads allow).

    Raises:
        CaliperTooShort: the caliper is too short for the levels, or for ``count`` distances (one
            without ``count``).
    """
    assert printer.workspace is not None  # plan_object refused a printer without one
    layout = object_layout(printer.workspace, printer.tower_azimuth, caliper, top)
    pairs = candidate_pairs(layout, caliper)
    needed = 1 if count is None else count
    if len(pairs) < needed:
        raise CaliperTooShort(f"a caliper of {caliper:g} mm is too short: it reaches {len(pairs)} pairs of "
                              f"the object's features, {needed} needed")
    probe_rows, pair_rows = rows_of(probe, layout.centres[pairs])
    information = np.eye(pair_rows.shape[1]) + probe_rows.T @ probe_rows
    wanted = MAX_DISTANCES if count is None else count
    chosen = select_pairs(pair_rows, information, min(wanted, len(pairs)), layout, pairs,
                          blocking(layout, pairs), at_least=needed)
    return layout, pairs, chosen, information, pair_rows


def _longer(printer: PrinterToPlan, count: int | None, caliper: float, probe: np.ndarray,
            rows_of: RowsFunction, short: CaliperTooShort, top: float | None = None) -> str:
    """What to do when the caliper is too short: fewer distances, or the shortest caliper that works [mm].

    The caliper is found to the whole mm by bisection between the one given and the longest reading
    the printable cylinder holds (its diameter, height and a ball): one that works next to one that
    does not, for the object as planned (its top level at most ``top``).
    """
    assert printer.workspace is not None
    workspace = printer.workspace

    def works(length: float) -> bool:
        try:
            _chosen(printer, count, length, probe, rows_of, top)
        except CaliperTooShort:
            return False
        return True

    longest = 2.0 * workspace.radius + workspace.height + BALL_DIAMETER
    low, high = int(np.floor(caliper)), int(np.ceil(longest))
    offered = short.offered if isinstance(short, TooFewDistances) else 0
    fewer = f"--distances {offered}, or " if offered else ""
    if high <= low or not works(high):
        return f": {fewer.removesuffix(', or ')}" if fewer else ""
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (low, middle) if works(middle) else (middle, high)
    return f": {fewer}a caliper of {high} mm (--caliper {high}; {low} mm is too short)"


def _with_identifiability(plan: ObjectPlan, printer: PrinterToPlan) -> ObjectPlan:
    """The plan with what the probe heights alone, and with the distances, identify (complete model)."""
    geometry = printer.geometry()
    probe = printer.readings(plan.probe)
    ends = printer.readings(plan.pair_positions.reshape(-1, 3)).reshape(-1, 2, 3)
    model, tolerances = printer.model, printer.tolerances
    alone = measured_combinations(geometry, PrinterMeasurements(probe), model, tolerances)
    both = measured_combinations(geometry, PrinterMeasurements(probe, ends, plan.lengths), model, tolerances)
    return replace(plan, probe_only=alone, with_distances=both)
