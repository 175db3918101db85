"""Bai's κ(n) rule (Eq. 21): the least n whose condition number has settled."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errormodels import ErrorModel
from ..exceptions import PlanningError
from ..geometry import NominalDelta
from ..identifiability import base_parameters
from ..observations import SIGMA_ANGLE, SIGMA_POSITION
from .poses import bai_poses, rough_poses
from .regressor import (
    RANK_RTOL,
    ROUGH,
    check_measurement,
    default_points,
    identification_matrix,
    planning_model,
)


def _scaled_condition(H: np.ndarray, scaled: bool) -> float:
    """Condition number of H (columns to unit norm first if ``scaled``); inf if rank deficient."""
    if scaled:
        norms = np.linalg.norm(H, axis=0)
        H = H / np.where(norms > 0.0, norms, 1.0)
    sv = np.linalg.svd(H, compute_uv=False)
    if sv.size == 0 or sv[-1] <= RANK_RTOL * sv[0] or H.shape[0] < H.shape[1]:
        return math.inf
    return float(sv[0] / sv[-1])


# --------------------------------------------------------------------------- κ(n) rule
@dataclass(frozen=True)
class ConditionCurve:
    """κ(n) of Bai's pose sets and its relative change (Bai 2015, Eq. 21, Fig. 6-7).

    Attributes:
        model: Error model name.
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured.
        layers: ``"top-bottom"`` (fine step, 2n + 1 poses) or ``"middle"`` (rough step, n + 1).
        n: Poses per circle, shape (k,), consecutive.
        kappa: κ_n, condition number of H(n) restricted to the identifiable columns, (k,);
            inf where H(n) does not identify them all.
        epsilon: ε_n = |κ_n − κ_{n−1}| / κ_n (a fraction, not %), (k,); NaN for the first n,
            inf where κ_n or κ_{n−1} is inf.
        base_names: Identifiable (base) parameters, found on the largest pose set.
        scaled: Whether the columns were scaled to unit norm before taking κ.
    """

    model: str
    measurement: str
    points: list[str]
    layers: str
    n: np.ndarray
    kappa: np.ndarray
    epsilon: np.ndarray
    base_names: list[str]
    scaled: bool

    def least_n(self, epsilon0: float, n_min: int = 3) -> int:
        """Bai's Eq. 21: the least n >= n_min with ε_n <= ε0.

        Args:
            epsilon0: Threshold ε0 as a fraction (Bai's 1 % is 0.01).
            n_min: Least n allowed (Bai: 3).

        Raises:
            PlanningError: no n of the curve satisfies the rule.
        """
        ok = (self.n >= n_min) & (self.epsilon <= epsilon0)
        if not np.any(ok):
            raise PlanningError(
                f"no n in {int(self.n[0])}..{int(self.n[-1])} has a relative change of κ below "
                f"{100.0 * epsilon0:g} % for model {self.model} ({self.measurement}); "
                f"smallest: {100.0 * float(np.nanmin(self.epsilon[self.n >= n_min])):.3g} %"
            )
        return int(self.n[np.argmax(ok)])

    def table(self) -> str:
        """The curve as aligned text: n, poses, κ_n, ε_n [%]."""
        per = 2 if self.layers == "top-bottom" else 1
        lines = [f"{'n':>4} {'poses':>6} {'kappa':>12} {'eps %':>10}"]
        for n, k, e in zip(self.n, self.kappa, self.epsilon, strict=True):
            lines.append(f"{int(n):>4} {per * int(n) + 1:>6} {k:>12.6g} {100.0 * e:>10.4g}")
        return "\n".join(lines)


def condition_curve(
    nominal: NominalDelta,
    model: str | ErrorModel,
    measurement: str = "distance",
    points: Sequence[str] | None = None,
    n_max: int = 20,
    layers: str | None = None,
    scaled: bool = True,
    sigma_position: float = SIGMA_POSITION,
    sigma_angle: float = SIGMA_ANGLE,
) -> ConditionCurve:
    """κ(n) of Bai's pose sets for n = 2..n_max (Bai 2015, Eq. 21, Fig. 6-7).

    H(n) is the weighted identification matrix (:func:`identification_matrix`) of
    the pose set with n poses per circle. κ_n is the condition number of H(n)
    restricted to the model's identifiable columns, which are found once, by
    :func:`deltacal.identifiability.base_parameters`, on the largest set, so that
    every κ_n measures the same parameters.

    Which κ: with ``scaled`` (default) each column is scaled to unit norm first;
    κ is then independent of the parameters' units, which matters for the models
    that mix mm and rad (``classical``, ``complete``), and restricting to the
    identifiable columns keeps it finite for models that distances cannot fully
    identify. Bai's curves are the plain κ of H (``scaled=False``); his models
    18 and 32 have their position parameters in mm (``L Δθ``...), so the two agree
    in spirit, not to the digit.

    Args:
        nominal: The robot, with a workspace.
        model: Error model or name (:data:`PLAN_MODELS`; ``rough`` for the encoder offsets).
        measurement: ``pose``, ``position`` or ``distance``.
        points: Plate points measured (default: :func:`default_points`).
        n_max: Largest n.
        layers: ``"top-bottom"`` or ``"middle"``; default ``middle`` for the rough model.
        scaled: Scale columns to unit norm before taking κ (see above).
        sigma_position: σ of a position coordinate [mm] (weights pose rows).
        sigma_angle: σ of an orientation component [rad].
    """
    check_measurement(measurement)
    error_model = planning_model(model) if isinstance(model, str) else model
    if layers is None:
        layers = "middle" if error_model.name == ROUGH else "top-bottom"
    if layers not in ("top-bottom", "middle"):
        raise ValueError(f"layers must be 'top-bottom' or 'middle', got {layers!r}")
    if n_max < 3:
        raise ValueError(f"n_max must be at least 3, got {n_max}")
    geometry = nominal.geometry()
    pts = default_points(geometry, error_model, measurement) if points is None else list(points)
    make = bai_poses if layers == "top-bottom" else rough_poses
    ns = np.arange(2, n_max + 1)
    H = [
        identification_matrix(
            geometry, error_model, make(nominal, int(n)).q, measurement, pts, sigma_position, sigma_angle
        )
        for n in ns
    ]
    base = base_parameters(H[-1], error_model.names, rtol=RANK_RTOL)
    kappa = np.array([_scaled_condition(h[:, base.base], scaled) for h in H])
    epsilon = np.full(ns.size, np.nan)
    with np.errstate(invalid="ignore"):
        change = np.abs(np.diff(kappa)) / kappa[1:]
    finite = np.isfinite(kappa[1:]) & np.isfinite(kappa[:-1])
    epsilon[1:] = np.where(finite, change, np.inf)
    return ConditionCurve(
        model=error_model.name,
        measurement=measurement,
        points=pts,
        layers=layers,
        n=ns,
        kappa=kappa,
        epsilon=epsilon,
        base_names=base.base_names,
        scaled=scaled,
    )
