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

from typing import NamedTuple, Protocol

import numpy as np

from ..calibration import Calibration
from ..compensation import compensate
from ..exceptions import GeometryError, UnreachableError
from ..geometry import DeltaGeometry
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
) -> CorrectedTargets:
    """The targets to send ``controller`` so that the calibrated robot's TCP reaches ``targets``.

    Args:
        calibration: The calibration (or the identified geometry itself).
        controller: The controller's model (a rotary :class:`~deltacal.controller.Controller`, or
            a printer's firmware, :class:`~deltacal.printer.firmware.klipper.model.KlipperController`).
        targets: Desired TCP positions in the base frame {O} [mm], (N, 3).
        min_margin: Singularity margin required of both the real robot (as
            :func:`~deltacal.compensation.compensate`) and the controller's model at the readings.
        payload: Mass at the TCP [kg]: with compliant actuators the loaded TCP reaches the targets
            (the readings are exact compensation's with this payload).

    Returns:
        The commands [mm] and readings [rad; a printer's, mm], each (N, 3).

    Raises:
        GeometryError: the controller is not of the robot's kind (a rotary Delta's for a printer).
        UnreachableError: naming the targets by index: out of the real robot's reach or near its
            singularities (compensate's reasons), or not commandable through the controller's
            model (``controller_out_of_reach``: no assembly of its model at those readings, or only
            on its other branch) or near its singularities (``controller_singular``).
    """
    geometry = calibration.geometry if isinstance(calibration, Calibration) else calibration
    virtual = controller.virtual
    if virtual.chain != geometry.chain:
        raise GeometryError(f"the controller {controller.name or ''!r} runs a {virtual.chain.name} Delta's "
                            f"model, the robot {geometry.name or ''!r} is a {geometry.chain.name} one")
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
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
