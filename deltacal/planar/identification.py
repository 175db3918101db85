"""Identification of the planar mechanism: classical (Eq. 38, 74) and complete (Eq. 39-40, 69-73)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..exceptions import ConvergenceError, IdentificationError
from ..identifiability import BaseParameters, base_parameters
from .geometry import (
    PAPER_BASE_ORDER,
    PARAMETER_NAMES,
    SIMPLIFIED_NAMES,
    PlanarGeometry,
    SimplifiedModel,
)
from .kinematics import forward_position, sensitivity


def _weights(noise_std: Sequence[float] | None) -> np.ndarray:
    if noise_std is None:
        return np.ones(3)
    s = np.asarray(noise_std, dtype=float)
    if s.shape != (3,) or np.any(s <= 0.0):
        raise ValueError(f"noise_std must be three positive values (x, y, alpha), got {noise_std}")
    return 1.0 / s


def _check_measurements(q: np.ndarray, measured: np.ndarray) -> None:
    if q.ndim != 1 or measured.shape != (q.size, 3):
        raise ValueError(
            f"measurements must be q of shape (m,) and poses of shape (m, 3); got {q.shape} "
            f"and {measured.shape}"
        )


def _standard_deviations(A: np.ndarray, residual: np.ndarray, known_weights: bool) -> np.ndarray:
    """Standard deviations of a least-squares estimate from the QR factor of A."""
    R = scipy.linalg.qr(A, mode="r")[0][: A.shape[1]]
    Rinv = scipy.linalg.solve_triangular(R, np.eye(A.shape[1]))
    dof = A.shape[0] - A.shape[1]
    factor = 1.0 if known_weights else float(residual @ residual) / max(dof, 1)
    return np.sqrt(factor * np.sum(Rinv**2, axis=1))


@dataclass(frozen=True)
class SimplifiedIdentification:
    """Result of the classical (simplified model) identification.

    Attributes:
        delta: Estimated ``[δq0 [rad], δl [mm]]`` (Eq. 74).
        std: Their standard deviations.
        model: The corrected simplified model.
        residual_rms: RMS of the (weighted) residuals at the solution.
    """

    delta: np.ndarray
    std: np.ndarray
    model: SimplifiedModel
    residual_rms: float
    names: tuple[str, ...] = SIMPLIFIED_NAMES


def identify_simplified(
    q: np.ndarray,
    measured: np.ndarray,
    nominal: SimplifiedModel,
    noise_std: Sequence[float] | None = None,
    coordinates: Sequence[str] = ("x",),
    max_iterations: int = 20,
) -> SimplifiedIdentification:
    """Classical calibration: identify ``[δq0, δl]`` from tool measurements (Eq. 38).

    Gauss-Newton on the stacked rows of every configuration. By default only the
    operational coordinate x is used, as in Eq. 38; ``("x", "y")`` also fits the
    vertical coordinate of the virtual bar (the alpha rows would carry no
    information: this model cannot rotate the plate).

    Args:
        q: Joint readings of the m measurement configurations [rad], shape (m,).
        measured: Measured tool poses ``(x, y, alpha)`` [mm, mm, rad], shape (m, 3).
        nominal: The simplified model before calibration.
        noise_std: Standard deviations of the measurements (x, y, alpha) used as
            weights [mm, mm, rad]; None for unweighted least squares (Eq. 26).
        coordinates: Which measured coordinates to fit, among "x" and "y".
        max_iterations: Gauss-Newton iterations allowed.

    Returns:
        The identification.

    Raises:
        IdentificationError: If fewer than 2 configurations are given.
        ConvergenceError: If Gauss-Newton does not converge.
    """
    q = np.asarray(q, dtype=float)
    measured = np.asarray(measured, dtype=float)
    _check_measurements(q, measured)
    rows = []
    for name in coordinates:
        if name not in ("x", "y"):
            raise ValueError(f"coordinates of the simplified model are 'x' and 'y', got {name!r}")
        rows.append("xy".index(name))
    if not rows:
        raise ValueError("coordinates is empty")
    if q.size < 2:
        raise IdentificationError(f"classical identification needs >= 2 configurations, got {q.size}")
    w = _weights(noise_std)[rows]

    def linearise(model: SimplifiedModel) -> tuple[np.ndarray, np.ndarray]:
        r = ((measured - model.forward_pose(q))[:, rows] * w).ravel()
        A = (model.sensitivity(q)[:, rows, :] * w[None, :, None]).reshape(-1, 2)
        return r, A

    delta = np.zeros(2)
    scale = float(np.linalg.norm(measured[:, rows] * w))
    for _ in range(max_iterations):
        r, A = linearise(nominal.corrected(delta))
        step = np.linalg.lstsq(A, r, rcond=None)[0]
        delta = delta + step
        if np.linalg.norm(A @ step) <= 1e-13 * scale:
            break
    else:
        raise ConvergenceError("classical identification did not converge")
    model = nominal.corrected(delta)
    r, A = linearise(model)
    return SimplifiedIdentification(
        delta=delta,
        std=_standard_deviations(A, r, noise_std is not None),
        model=model,
        residual_rms=float(np.sqrt(np.mean(r**2))),
    )


@dataclass(frozen=True)
class CompleteIdentification:
    """Result of the identification of the complete model's base parameters (Eq. 25-26, 73).

    Attributes:
        base: The base parameters (which are kept, the regroupings, rank...).
        estimate: Estimated base parameter values ``δk_C^b`` [rad, mm...], shape (rank,).
        std: Their standard deviations, shape (rank,).
        nominal: The geometry the errors are relative to.
        residual_rms: RMS of the (weighted) residuals at the solution.
        iterations: Gauss-Newton iterations done.
    """

    base: BaseParameters
    estimate: np.ndarray
    std: np.ndarray
    nominal: PlanarGeometry
    residual_rms: float
    iterations: int
    names: tuple[str, ...] = field(default=PARAMETER_NAMES)

    @property
    def delta(self) -> np.ndarray:
        """A full error vector ``δk_C`` with these base values (non-kept parameters 0)."""
        return self.base.expand(self.estimate)

    @property
    def geometry(self) -> PlanarGeometry:
        """The identified geometry (nominal plus :attr:`delta`)."""
        return self.nominal.perturbed(self.delta)

    def labels(self) -> list[str]:
        """Readable base parameters, e.g. ``δa2x − δb2x`` (Eq. 70-72)."""
        return self.base.labels()

    def regroupings(self) -> list[str]:
        """Labels of the base parameters that regroup more than one parameter."""
        rows = np.count_nonzero(self.base.regrouping, axis=1) > 1
        return [label for label, many in zip(self.labels(), rows, strict=True) if many]


def identify_complete(
    q: np.ndarray,
    measured: np.ndarray,
    nominal: PlanarGeometry,
    noise_std: Sequence[float] | None = None,
    prefer: Sequence[str] | None = PAPER_BASE_ORDER,
    rtol: float = 1e-8,
    max_iterations: int = 20,
) -> CompleteIdentification:
    """Improved calibration: identify the complete model's base parameters (Eq. 23-26).

    The base parameters come from the QR decomposition of the stacked sensitivity
    S_G at the nominal geometry (Eq. 23-25, :func:`deltacal.identifiability.base_parameters`);
    with ``prefer = PAPER_BASE_ORDER`` they are Savoure's Eq. 73. The estimate is then
    refined by Gauss-Newton on the closed-form model (the paper stops after the first,
    linear, step).

    Args:
        q: Joint readings of the m measurement configurations [rad], shape (m,).
        measured: Measured tool poses ``(x, y, alpha)`` [mm, mm, rad], shape (m, 3).
        nominal: The nominal mechanism, with the tool h used for the measurements.
        noise_std: Standard deviations (x, y, alpha) used as weights [mm, mm, rad];
            None for unweighted least squares (Eq. 26).
        prefer: Preference order of the parameters kept in the base; None lets the
            pivoted QR choose.
        rtol: Rank tolerance of the QR decomposition.
        max_iterations: Gauss-Newton iterations allowed.

    Returns:
        The identification.

    Raises:
        IdentificationError: If the measurements identify nothing or are too few.
        ConvergenceError: If Gauss-Newton does not converge.
    """
    q = np.asarray(q, dtype=float)
    measured = np.asarray(measured, dtype=float)
    _check_measurements(q, measured)
    w = _weights(noise_std)

    def regressor(geometry: PlanarGeometry) -> np.ndarray:
        return (sensitivity(q, geometry) * w[None, :, None]).reshape(-1, len(PARAMETER_NAMES))

    base = base_parameters(regressor(nominal), list(PARAMETER_NAMES), rtol=rtol, prefer=prefer)
    if base.rank == 0 or 3 * q.size <= base.rank:
        raise IdentificationError(
            f"{q.size} configuration(s) cannot identify the {base.rank} base parameter(s)"
        )
    estimate = np.zeros(base.rank)
    scale = float(np.linalg.norm(measured * w))
    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        geometry = nominal.perturbed(base.expand(estimate))
        r = ((measured - forward_position(q, geometry)) * w).ravel()
        A = regressor(geometry)[:, base.base]
        step = np.linalg.lstsq(A, r, rcond=None)[0]
        estimate = estimate + step
        if np.linalg.norm(A @ step) <= 1e-13 * scale:
            break
    else:
        raise ConvergenceError("complete identification did not converge")
    geometry = nominal.perturbed(base.expand(estimate))
    r = ((measured - forward_position(q, geometry)) * w).ravel()
    A = regressor(geometry)[:, base.base]
    return CompleteIdentification(
        base=base,
        estimate=estimate,
        std=_standard_deviations(A, r, noise_std is not None),
        nominal=nominal,
        residual_rms=float(np.sqrt(np.mean(r**2))),
        iterations=iterations,
    )


# --------------------------------------------------------------------------------------------
# Compensation
