"""Corrected targets: what to send a controller so that the real robot's TCP lands on the targets.

A controller takes Cartesian targets and commands the readings its own model's inverse gives
(:class:`~deltacal.controller.model.Controller`). The readings that put the identified robot's TCP
on a target are those of exact compensation (:func:`deltacal.compensation.compensate`, which refuses
what the real robot cannot reach or reaches near a singularity, and checks the working assembly).
The target to send is the controller's forward model of those readings: its inverse then returns
them exactly (checked here to :data:`ROUND_TRIP_TOLERANCE`), whatever the controller's values.
Vectorised over targets. Units: mm and rad.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..calibration import Calibration
from ..compensation import compensate
from ..exceptions import UnreachableError
from ..geometry import DeltaGeometry
from ..kinematics.singularity import COMMAND_MARGIN
from .model import Controller

#: Largest difference between the readings wanted and those the controller's inverse gives for the
#: corrected target [rad]: a round trip through its closed-form forward and inverse models (1e-15
#: rad measured); beyond, the readings are on the model's other (knee-in) branch.
ROUND_TRIP_TOLERANCE = 1e-9


class CorrectedTargets(NamedTuple):
    """Corrected targets and the readings they make the controller command.

    Attributes:
        commands: Targets to send the controller, in its frame (the base frame {O}) [mm], (N, 3).
        readings: The readings its inverse gives for them, which put the real TCP on the
            targets [rad], (N, 3).
    """

    commands: np.ndarray
    readings: np.ndarray


def corrected_targets(
    calibration: Calibration | DeltaGeometry,
    controller: Controller,
    targets: np.ndarray,
    min_margin: float = 1.0,
) -> CorrectedTargets:
    """The targets to send ``controller`` so that the calibrated robot's TCP reaches ``targets``.

    Args:
        calibration: The calibration (or the identified geometry itself).
        controller: The controller's model.
        targets: Desired TCP positions in the base frame {O} [mm], (N, 3).
        min_margin: Singularity margin required of both the real robot (as
            :func:`~deltacal.compensation.compensate`) and the controller's model at the readings.

    Returns:
        The commands [mm] and readings [rad], each (N, 3).

    Raises:
        UnreachableError: naming the targets by index: out of the real robot's reach or near its
            singularities (compensate's reasons), or not commandable through the controller's
            model (``controller_out_of_reach``: no assembly of its model at those readings, or only
            on its knee-in branch) or near its singularities (``controller_singular``).
    """
    geometry = calibration.geometry if isinstance(calibration, Calibration) else calibration
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    q = compensate(geometry, targets, "exact", min_margin=min_margin)
    virtual = controller.virtual
    plate = virtual.forward(q, check=False)
    unassembled = ~np.all(np.isfinite(plate), axis=1)
    if np.any(unassembled):
        raise UnreachableError.from_mask(unassembled, targets, UnreachableError.CONTROLLER_OUT_OF_REACH)
    # the margin before the round trip: near a singularity the inverse loses digits (arccos near ±1)
    near = ~(COMMAND_MARGIN.margin(virtual, q, plate) >= min_margin)
    if np.any(near):
        raise UnreachableError.from_mask(near, targets, UnreachableError.CONTROLLER_SINGULAR)
    with np.errstate(invalid="ignore"):
        apart = np.abs((virtual.inverse(plate, check=False) - q + np.pi) % (2.0 * np.pi) - np.pi)
    other_branch = ~np.all(apart <= ROUND_TRIP_TOLERANCE, axis=1)
    if np.any(other_branch):
        raise UnreachableError.from_mask(other_branch, targets, UnreachableError.CONTROLLER_OUT_OF_REACH)
    return CorrectedTargets(plate + controller.tool, q)
