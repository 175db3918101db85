"""What each route to a Cartesian controller (or a printer's firmware) leaves, for the report.

Beside the predicted-accuracy map: the TCP error over the same slices that the controller's joint
offsets alone, or its per-limb values, leave once fitted to the calibration
(:func:`deltacal.controller.fit_controller`, started from the nominal controller with the map's
tool), the error of the targets sent as they are, and corrected targets, which leave only what the
calibration leaves (the map itself). A printer's controller is its firmware, reached through its
interface (:class:`~deltacal.printer.firmware.base.Firmware`): the firmware with the nominal values,
and its values fitted as ``export --controller NAME`` fits them. With a true geometry, each fit's
error on it too. Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..calibration import Calibration
from ..controller import FIT_KINDS, Controller, fit_controller
from ..controller.fit import tcp_errors
from ..exceptions import DeltacalError
from ..geometry import DeltaGeometry, Workspace
from ..kinematics import exact
from ..printer.firmware import firmwares
from ..printer.firmware.base import Firmware
from ..printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from .accuracy import AccuracyMap, less_bed_motion, reachable_readings


@dataclass(frozen=True)
class Route:
    """One route and the TCP error it leaves over the slices [mm] (NaN: not computed).

    Attributes:
        name: ``"nominal"``, ``"offsets"``, ``"limbs"``, or a firmware's name (its values fitted).
        max_error: Largest TCP error on the identified robot.
        rms_error: RMS TCP error on the identified robot.
        true_max_error: The same on the true robot (simulations).
        true_rms_error: The same on the true robot.
        held: Values held at nominal (not identifiable over the slices).
    """

    name: str
    max_error: float
    rms_error: float
    true_max_error: float = math.nan
    true_rms_error: float = math.nan
    held: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class ControllerRoutes:
    """The routes computed, or why none could be (``note``); a printer's: its ``firmware``'s."""

    routes: list[Route]
    points: int
    note: str = ""
    firmware: Firmware[Any] | None = None


def controller_routes(calibration: Calibration, amap: AccuracyMap, truth: DeltaGeometry | None = None,
                      firmware: Firmware[Any] | None = None) -> ControllerRoutes:
    """The TCP error each controller route leaves over the accuracy map's slices (see the module).

    Args:
        calibration: The calibration.
        amap: Its accuracy map (the slices, the tool).
        truth: The true geometry (simulations), or None.
        firmware: A printer's firmware (default: the first of
            :func:`~deltacal.printer.firmware.firmwares`, Klipper); unused for a rotary Delta.
    """
    points = np.concatenate([s.points.reshape(-1, 3) for s in amap.slices])
    sigma = np.concatenate([v.ravel() for v in amap.sigma])
    points = points[np.all(np.isfinite(points), axis=1) & np.isfinite(sigma)]
    geometry = calibration.geometry.with_tool(amap.tool)
    true_tool = truth.with_tool(amap.tool) if truth is not None else None
    if geometry.chain.firmware:
        return _firmware_routes(firmware or firmwares()[0], calibration.nominal.with_tool(amap.tool),
                                geometry, true_tool, points)
    try:
        start = Controller.from_geometry(calibration.nominal).replace(tool=amap.tool)
        routes = []
        for kind in FIT_KINDS:
            fit = fit_controller(geometry, start, points, kind)
            if kind == FIT_KINDS[0]:
                routes.append(Route("nominal", fit.max_error_before, fit.rms_error_before,
                                    *_on(true_tool, start, points)))
            routes.append(Route(kind, fit.max_error, fit.rms_error, *_on(true_tool, fit.controller, points),
                                held=fit.held))
    except DeltacalError as exc:
        return ControllerRoutes([], points.shape[0], f"not computed: {exc}")
    return ControllerRoutes(routes, points.shape[0])


def _on(truth: DeltaGeometry | None, controller: Controller, points: np.ndarray) -> tuple[float, float]:
    """Max and RMS TCP error of the true robot commanded by the controller (NaN without a truth)."""
    if truth is None:
        return math.nan, math.nan
    error = np.linalg.norm(tcp_errors(truth, controller, points), axis=1)
    return float(error.max()), float(np.sqrt(np.mean(error**2)))


def _firmware_routes(firmware: Firmware[Any], nominal: DeltaGeometry, geometry: DeltaGeometry,
                     truth: DeltaGeometry | None, points: np.ndarray) -> ControllerRoutes:
    """A printer's firmware with its nominal values: the nozzle error of the targets sent as they are.

    The firmware's model with the nominal values is the perfect printer's (the nozzle the TCP). Each
    error is less the shift along the bed and turn about its normal that fit it best: no probe height
    or printed distance sees them, a printed part is the same part (as the map's actual errors).
    """
    q = reachable_readings(nominal, points)
    ok = np.all(np.isfinite(q), axis=1)
    if not np.any(ok):
        return ControllerRoutes([], points.shape[0], "not computed: no slice point within the nominal reach",
                                firmware)
    q, points = q[ok], points[ok]
    routes = [Route("nominal", *_nozzle_error(geometry, q, points), *_nozzle_error(truth, q, points))]
    note = "Errors less the shift along the bed and the turn about its normal that fit them best (no " \
           "measurement sees them)."
    try:
        routes.append(_fitted_route(firmware, nominal, geometry, truth, points))
    except DeltacalError as exc:
        note += f" Firmware values fitted: not computed: {exc}"
    return ControllerRoutes(routes, points.shape[0], note, firmware)


def _fitted_route(firmware: Firmware[Any], nominal: DeltaGeometry, geometry: DeltaGeometry,
                  truth: DeltaGeometry | None, points: np.ndarray) -> Route:
    """The firmware's values fitted to the calibration over the slice points, as ``export --controller NAME``.

    Raises:
        GeometryError: no step distance in the calibration (an older file), or a nozzle off axis.
        UnreachableError: a point out of the firmware's reach.
    """
    step = nominal.step_distance
    start = firmware.start(nominal)  # refuses a nominal without its step distance
    assert step is not None
    radius = float(np.max(np.hypot(points[:, 0], points[:, 1])))
    top = float(np.max(points[:, 2]))
    fit = firmware.fit(geometry, start, step, Workspace(radius, top, top), grid=points,
                       first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, minimax=True)
    q = fit.values.inverse(points, step)
    return Route(firmware.name, *_nozzle_error(geometry, q, points), *_nozzle_error(truth, q, points),
                 held=fit.held)


def _nozzle_error(printer: DeltaGeometry | None, q: np.ndarray, points: np.ndarray) -> tuple[float, float]:
    """Max and RMS nozzle error [mm] of a printer at readings q, less the best bed motion (NaN: none)."""
    if printer is None:
        return math.nan, math.nan
    error, _ = less_bed_motion(points, exact.forward(printer, q).point(printer.tool) - points)
    size = np.linalg.norm(error, axis=1)
    return float(size.max()), float(np.sqrt(np.mean(size**2)))
