"""What each route to a Cartesian controller leaves, for the report (issue 22).

Beside the predicted-accuracy map: the TCP error over the same slices that the controller's joint
offsets alone, or its per-limb values, leave once fitted to the calibration
(:func:`deltacal.controller.fit_controller`, started from the nominal controller with the map's
tool), the error of the targets sent as they are, and corrected targets, which leave only what the
calibration leaves (the map itself). With a true geometry, each fit's error on it too. Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..calibration import Calibration
from ..controller import FIT_KINDS, Controller, fit_controller
from ..controller.fit import tcp_errors
from ..exceptions import DeltacalError
from ..geometry import DeltaGeometry
from .accuracy import AccuracyMap


@dataclass(frozen=True)
class Route:
    """One route and the TCP error it leaves over the slices [mm] (NaN: not computed).

    Attributes:
        name: ``"nominal"``, ``"offsets"``, ``"limbs"``.
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
    """The routes computed, or why none could be (``note``)."""

    routes: list[Route]
    points: int
    note: str = ""


def controller_routes(calibration: Calibration, amap: AccuracyMap,
                      truth: DeltaGeometry | None = None) -> ControllerRoutes:
    """The TCP error each controller route leaves over the accuracy map's slices (see the module)."""
    points = np.concatenate([s.points.reshape(-1, 3) for s in amap.slices])
    sigma = np.concatenate([v.ravel() for v in amap.sigma])
    points = points[np.all(np.isfinite(points), axis=1) & np.isfinite(sigma)]
    geometry = calibration.geometry.with_tool(amap.tool)
    true_tool = truth.with_tool(amap.tool) if truth is not None else None
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
