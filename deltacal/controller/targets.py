"""Corrected targets: what to send a controller so that the real robot's TCP lands on the targets.

A controller takes Cartesian targets and commands the readings its own model's inverse gives: a
rotary Delta's :class:`~deltacal.controller.model.Controller`, or a printer's firmware
(:class:`~deltacal.printer.firmware.klipper.model.KlipperController`, Klipper's delta kinematics), both a
:class:`CommandModel`. The readings that put the identified robot's TCP on a target are those of
exact compensation (:func:`deltacal.compensation.compensate`, which refuses what the real robot
cannot reach or reaches near a singularity, and checks the working assembly). The target to send
is the controller's forward model of those readings: its inverse then returns them exactly
(checked here to the chain's :attr:`~deltacal.chains.Chain.round_trip_tolerance`), whatever the
controller's values. Vectorised over targets. Units: mm and rad (a printer's readings: mm).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Protocol

import numpy as np

from ..arguments import points_array
from ..calibration import Calibration, holds_of
from ..compensation import compensate
from ..exceptions import GeometryError, UnreachableError
from ..geometry import DeltaGeometry
from ..holds import DEFAULT_BOUND, WhereItHolds, bed_points
from ..kinematics import exact
from ..kinematics.closed_form import VirtualDelta
from ..kinematics.singularity import COMMAND_MARGIN
from .limits import CommandLimits


class CommandModel(Protocol):
    """What corrected targets need of a controller: its model, forward and inverse, in readings.

    Attributes:
        name: The controller's name.
        tool: Its TCP in its model's plate frame [mm], (3,).
        virtual: Its model as a :class:`VirtualDelta` whose readings are deltacal's and whose
            plate point plus ``tool`` is the TCP (its singularities are judged on it).
        interpolation: How it moves between two targets (``"cartesian"``: a straight line in its
            own Cartesian frame, what the G-code route corrects for).
        home: The TCP position a homing (G28) leaves it at [mm], (3,), or None if not known.
        limits: The limits it puts on the commands it takes (a firmware's), or None if none known.
    """

    @property
    def name(self) -> str: ...  # noqa: D102

    @property
    def tool(self) -> np.ndarray: ...  # noqa: D102

    @property
    def virtual(self) -> VirtualDelta: ...  # noqa: D102

    @property
    def interpolation(self) -> str: ...  # noqa: D102

    @property
    def home(self) -> np.ndarray | None: ...  # noqa: D102

    @property
    def limits(self) -> CommandLimits | None: ...  # noqa: D102

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """The TCP target whose inverse is ``readings``, (N, 3) -> (N, 3) [mm] (NaN rows unchecked)."""

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """The readings commanded for TCP targets, (N, 3) [mm] -> (N, 3) (NaN rows unchecked)."""


class CorrectedTargets(NamedTuple):
    """Corrected targets and the readings they make the controller command.

    Attributes:
        commands: Targets to send the controller, in its frame (the base frame {O}) [mm], (N, 3).
        readings: The readings its inverse gives for them, which put the real TCP on the
            targets [rad; a printer's, mm], (N, 3).
    """

    commands: np.ndarray
    readings: np.ndarray


def corrected_targets(
    calibration: Calibration | DeltaGeometry,
    controller: CommandModel,
    targets: np.ndarray,
    min_margin: float = 1.0,
    payload: float = 0.0,
    bound: float = DEFAULT_BOUND,
    refuse: bool = False,
) -> CorrectedTargets:
    """The targets to send ``controller`` so that the calibrated robot's TCP reaches ``targets``.

    A printer's calibration that knows where it holds (:attr:`Calibration.holds
    <deltacal.calibration.Calibration.holds>`) corrects only there: its identified printer is first
    put in the controller's frame (:func:`aligned_to_controller`: no correction moves the part along
    the bed or turns it), then each command is the controller's own (the target) plus the
    correction times its weight (:meth:`~deltacal.holds.WhereItHolds.weights`, the horizontal and
    the vertical part each by its own σ): the correction where its σ is at most half the bound (along
    the bed, for a calibration measured at one height, what of it stands out of its σ, eased in:
    :func:`~deltacal.holds.significance_weight`), the controller's own command where its σ is above the
    bound (or, along the bed from bed-level data, the correction within its σ of zero), blended
    smoothly between. A geometry, or a rotary Delta's calibration, is
    corrected everywhere; a printer's calibration that does not say where it holds (a file without
    ``[holds]``) is refused.

    Args:
        calibration: The calibration (or the identified geometry itself).
        controller: The controller's model (a rotary :class:`~deltacal.controller.Controller`, or
            a printer's firmware, :class:`~deltacal.printer.firmware.klipper.model.KlipperController`).
        targets: Desired TCP positions in the base frame {O} [mm], (N, 3) (or (3,): one target).
        min_margin: Singularity margin required of both the real robot (as
            :func:`~deltacal.compensation.compensate`) and the controller's model at the readings.
        payload: Mass at the TCP [kg]: with compliant actuators the loaded TCP reaches the targets
            (the readings are exact compensation's with this payload).
        bound: The σ of a correction accepted [mm] (``math.inf``: every correction applied).
        refuse: Refuse the targets where the correction is not wholly applied (its weight below 1)
            instead of blending in the controller's own command.

    Returns:
        The commands [mm] and readings [rad; a printer's, mm], each (N, 3).

    Raises:
        ValueError: targets of another shape (:func:`~deltacal.arguments.points_array`).
        InputError: a printer's calibration that does not say where it holds (no ``[holds]``:
            :meth:`~deltacal.calibration.Calibration.where_held`).
        GeometryError: the controller is not of the robot's kind (a rotary Delta's for a printer).
        UnreachableError: naming the targets by index: out of the real robot's reach or near its
            singularities (compensate's reasons), or not commandable through the controller's
            model (``controller_out_of_reach``: no assembly of its model at those readings, or only
            on its other branch) or near its singularities (``controller_singular``), or (with
            ``refuse``) where the calibration does not hold (``not_held``).
    """
    held = weighted_targets(calibration, controller, targets, min_margin, payload, bound, refuse)
    return CorrectedTargets(held.commands, held.readings)


class WeightedTargets(NamedTuple):
    """Corrected targets, their readings, and how much of the calibration's correction each carries.

    Attributes:
        commands: Targets to send the controller [mm], (N, 3).
        readings: The readings its inverse gives for them [rad; a printer's, mm], (N, 3).
        weights: The weight of each command's correction along the bed and in height (1: all of
            it, 0: the controller's own command), (N, 2); ones where the calibration corrects
            everywhere.
    """

    commands: np.ndarray
    readings: np.ndarray
    weights: np.ndarray


def weighted_targets(
    calibration: Calibration | DeltaGeometry,
    controller: CommandModel,
    targets: np.ndarray,
    min_margin: float = 1.0,
    payload: float = 0.0,
    bound: float = DEFAULT_BOUND,
    refuse: bool = False,
) -> WeightedTargets:
    """:func:`corrected_targets` with the weight of each command's correction (see there)."""
    if not isinstance(calibration, Calibration | DeltaGeometry):  # a result's σ grid would go unread
        raise TypeError(f"calibration must be a Calibration or a DeltaGeometry; got "
                        f"{type(calibration).__name__}")
    geometry = calibration.geometry if isinstance(calibration, Calibration) else calibration
    holds = holds_of(calibration)  # a printer's calibration without it refused
    virtual = controller.virtual
    if virtual.chain != geometry.chain:
        raise GeometryError(f"the controller {controller.name or ''!r} runs a {virtual.chain.name} Delta's "
                            f"model, the robot {geometry.name or ''!r} is a {geometry.chain.name} one")
    targets = points_array(targets, "targets")
    everywhere = np.ones((targets.shape[0], 2))
    if holds is None:
        return WeightedTargets(*_checked(geometry, controller, targets, min_margin, payload), everywhere)
    if not math.isfinite(bound):
        whole = _framed(geometry, holds, controller, targets, min_margin, payload)
        return WeightedTargets(whole, controller.inverse(whole, check=False), everywhere)
    weights = holds.weights(targets, bound)
    if refuse and np.any(weights < 1.0):
        raise UnreachableError.from_mask(np.any(weights < 1.0, axis=1), targets, UnreachableError.NOT_HELD)
    commands = targets.copy()
    acting = np.flatnonzero(np.any(weights > 0.0, axis=1))
    if acting.size:  # where the correction has no weight the identified printer is not asked
        try:
            full = _framed(geometry, holds, controller, targets[acting], min_margin, payload)
        except UnreachableError as exc:
            raise UnreachableError.from_mask(np.isin(np.arange(targets.shape[0]), acting[exc.indices]),
                                             targets, exc.reason) from None
        change = full - targets[acting]
        weights[acting] = holds.weights(targets[acting], bound, change)
        commands[acting] = targets[acting] + weights[acting][:, [0, 0, 1]] * change
    readings = controller.inverse(commands, check=False)
    bad = ~np.all(np.isfinite(readings), axis=1)
    if np.any(bad):
        raise UnreachableError.from_mask(bad, targets, UnreachableError.CONTROLLER_OUT_OF_REACH)
    return WeightedTargets(commands, readings, weights)


def _framed(geometry: DeltaGeometry, holds: WhereItHolds, controller: CommandModel, targets: np.ndarray,
            min_margin: float, payload: float) -> np.ndarray:
    """The whole correction's commands in the controller's frame [mm], (N, 3), checked.

    Along the bed from :attr:`WhereItHolds.along_bed <deltacal.holds.WhereItHolds.along_bed>` when
    the calibration has one (the combinations the measurements determine), in height from the
    identified printer (:func:`printers_in_frame`).
    """
    printers = printers_in_frame(geometry, holds, controller)
    commands = [_checked(g, controller, targets, min_margin, payload).commands for g in printers]
    commands[0][:, :2] = commands[-1][:, :2]
    return commands[0]


def printers_in_frame(geometry: DeltaGeometry, holds: WhereItHolds,
                      controller: CommandModel) -> list[DeltaGeometry]:
    """The printers a correction follows, in the controller's frame: in height, then along the bed.

    The identified printer (:func:`aligned_to_controller`), then, when the calibration has one,
    :attr:`WhereItHolds.along_bed <deltacal.holds.WhereItHolds.along_bed>` (one printer: both).
    """
    radius = holds.printable_radius  # the first layer that fixes the frame along the bed
    return [aligned_to_controller(g, controller, radius)
            for g in (geometry, holds.along_bed) if g is not None]


def _checked(geometry: DeltaGeometry, controller: CommandModel, targets: np.ndarray, min_margin: float,
             payload: float) -> CorrectedTargets:
    """The commands that put ``geometry``'s TCP on the targets, checked through the controller's model."""
    virtual = controller.virtual
    q = compensate(geometry, targets, "exact", min_margin=min_margin, payload=payload)
    commands = controller.forward(q, check=False)
    unassembled = ~np.all(np.isfinite(commands), axis=1)
    if np.any(unassembled):
        raise UnreachableError.from_mask(unassembled, targets, UnreachableError.CONTROLLER_OUT_OF_REACH)
    # the margin before the round trip: near a singularity the inverse loses digits (arccos near ±1)
    near = ~(COMMAND_MARGIN.margin(virtual, q, commands - controller.tool) >= min_margin)
    if np.any(near):
        raise UnreachableError.from_mask(near, targets, UnreachableError.CONTROLLER_SINGULAR)
    with np.errstate(invalid="ignore"):
        apart = virtual.chain.wrap(controller.inverse(commands, check=False) - q)
    other_branch = ~np.all(np.abs(apart) <= virtual.chain.round_trip_tolerance, axis=1)
    if np.any(other_branch):
        raise UnreachableError.from_mask(other_branch, targets, UnreachableError.CONTROLLER_OUT_OF_REACH)
    return CorrectedTargets(commands, q)


def aligned_to_controller(geometry: DeltaGeometry, controller: CommandModel, radius: float) -> DeltaGeometry:
    """A printer moved along its bed and turned about its normal into the controller's frame.

    No probe height and no distance sees a printer shifted along its bed or turned about its normal:
    the identification leaves that motion wherever its priors put it, and a command through another
    configuration would carry it. Here it is the controller's: the identified printer's nozzle at
    the readings the controller commands for the first layer's points (:func:`~deltacal.holds.bed_points`
    over ``radius``) has, after the motion, the controller's mean place and turn (the closed-form
    least-squares rotation and shift of the plane, Kabsch in 2-D). Nothing moves vertically.

    Args:
        geometry: The identified printer.
        controller: The controller's model.
        radius: The printable radius [mm].

    Returns:
        The printer moved (the same printer: every measurement it predicts is unchanged).
    """
    points = bed_points(radius)
    q = controller.inverse(points, check=False)
    ok = np.all(np.isfinite(q), axis=1)
    nozzle = exact.forward(geometry, q[ok]).point(geometry.tool)[:, :2]
    goal = points[ok, :2]
    a, b = nozzle - nozzle.mean(axis=0), goal - goal.mean(axis=0)
    angle = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
    c, s = math.cos(angle), math.sin(angle)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    shift = goal.mean(axis=0) - rotation[:2, :2] @ nozzle.mean(axis=0)
    return geometry.moved_rigidly(rotation, np.array([shift[0], shift[1], 0.0]))
