"""A printer's measurements that do not fit the others: data snooping around the fit without them.

A printer's fit has priors (the build tolerances, scaled by the evidence): a gross error in one row
(a caliper distance mistyped by 2 mm, a probe height 1 mm off) does not stand out in the fit's own
residuals as it does in a rotary Delta's. The tolerances' scale goes to its bound to follow the bad
row, the weakly measured combinations take it up, and what is left is spread over many rows. The
test is therefore made around the fit *without* the suspects, as a fixed point:

1. fit without the measurements flagged so far (none at first);
2. linearise every row, the flagged ones included, at that fit, and test each measurement by
   iterated data snooping (:func:`deltacal.identification.outliers.data_snooping`, Baarda, at
   :data:`~deltacal.identification.outliers.OUTLIER_THRESHOLD` σ), the design being the
   combinations the rows know better than their tolerances (:func:`seen_design`);
3. stop when the flagged measurements are those of the fit; else fit again without them.

A row flagged only because the gross one dragged the fit is cleared at the next step (its residual
is small about the fit without the gross row). Measured on 14 simulated printers (kits and
well-built ones, the object ``plan --object`` plans: 49 probe heights, 40 distances): a probe height
0.1-1 mm off and a distance 1-10 mm off found on each, the right row alone; a distance 0.2 mm (10 σ)
off on 12 of them; nothing in the clean measurements of any.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...identification.outliers import OUTLIER_THRESHOLD, data_snooping

#: Fits without the suspects at most (the fixed point is reached in two or three).
ROUNDS = 5
#: Singular value of the whitened regressor (parameters in units of their tolerance) above which a
#: combination is the measurements' (known better than its tolerance, as
#: :func:`~deltacal.printer.identification.fit.measured_combinations` counts them): the snooping's design.
#: The others are held by the priors: free in the design, a row alone seeing one of them would have
#: a leverage near 1 and a tiny residual blown up into a false alarm.
SEEN = 1.0

#: ``fit(kept)``: the whitened residuals (m,) and regressor (m, n) of every row, at the fit made with
#: the measurements ``kept`` (a mask over the measurements) alone; the regressor's columns in units of
#: each parameter's tolerance.
FitWithout = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class Outliers:
    """Measurements that do not fit the others, and their rows about the fit without them.

    Attributes:
        indices: The measurements flagged, sorted (a printer's: its probe heights, then its
            distances, then its measured positions, in the order of
            :class:`~deltacal.printer.identification.fit.PrinterMeasurements`).
        residual: The whitened residual (measured − the fit's, divided by σ) of every row at the
            fit without them, (m,).
        kept: The measurements not flagged, a mask, (number of measurements,).
    """

    indices: np.ndarray
    residual: np.ndarray
    kept: np.ndarray


def seen_design(W: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the combinations the rows know better than their tolerances, (m, rank).

    Args:
        W: The whitened regressor, its columns in units of each parameter's tolerance, (m, n).
    """
    U, s, _ = np.linalg.svd(W, full_matrices=False)
    return U[:, s > SEEN]


def find_outliers(fit: FitWithout, measurement: np.ndarray, kind: np.ndarray) -> Outliers:
    """The measurements that do not fit the others, found about the fit without them.

    Each round fits without the measurements flagged so far, tests the others by data snooping and
    keeps, of those flagged, only the ones that still stand out about that fit (:func:`stand_out`):
    a row flagged at first only because a gross one dragged the fit is cleared, whatever the order
    in which the snooping set them aside.

    Args:
        fit: The fit without some measurements (:data:`FitWithout`).
        measurement: The measurement of each row (0, 1, ...: a measurement's rows are tested together), (m,).
        kind: The kind of each row (probe height, distance, position coordinate), (m,): each kind's
            residuals are scaled by their own robust spread before the test.

    Returns:
        The measurements flagged (none: an empty array) and the rows at the fit without them.
    """
    count = int(measurement.max()) + 1 if measurement.size else 0
    flagged = np.zeros(0, dtype=int)
    for _ in range(ROUNDS):
        kept = ~np.isin(np.arange(count), flagged)
        r, W = fit(kept)
        design, rows = seen_design(W), kept[measurement]
        new = data_snooping(design[rows], r[rows], measurement[rows], kind[rows])
        found = np.union1d(stand_out(design, r, measurement, kind, flagged), new).astype(int)
        if np.array_equal(found, flagged):
            break
        flagged = found
    else:
        kept = ~np.isin(np.arange(count), flagged)
        r, _ = fit(kept)
    return Outliers(flagged, r, kept)


def stand_out(design: np.ndarray, r: np.ndarray, measurement: np.ndarray, kind: np.ndarray,
              suspects: np.ndarray) -> np.ndarray:
    """Of the suspect measurements, those whose rows stand out from what the others predict.

    Each suspect is tested on its own about the linear fit of the rows of no suspect: its prediction
    error ``e = r_g - design_g x`` against its covariance ``I + design_g N⁺ design_gᵀ`` (N the
    normal matrix of those rows), each row divided by its kind's robust spread there (at least 1),
    at :data:`~deltacal.identification.outliers.OUTLIER_THRESHOLD` σ, as the snooping tests.

    Args:
        design: The snooping's design over every row (:func:`seen_design`), (m, rank).
        r: The whitened residuals of every row, (m,).
        measurement: The measurement of each row, (m,).
        kind: The kind of each row, (m,).
        suspects: The measurements to test, sorted.

    Returns:
        The suspects that stand out, sorted.
    """
    import scipy.stats  # as data_snooping: needed only here

    if suspects.size == 0:
        return suspects
    clean = ~np.isin(measurement, suspects)
    A = design[clean]
    inverse = np.linalg.pinv(A.T @ A)
    x = inverse @ (A.T @ r[clean])
    e = r - design @ x
    leverage = np.clip(np.einsum("ij,jk,ik->i", A, inverse, A), 0.0, 1.0 - 1e-12)
    spread = np.ones(len(r))
    for k in np.unique(kind):
        standardised = np.abs(e[clean & (kind == k)]) / np.sqrt(1.0 - leverage[kind[clean] == k])
        if standardised.size:
            spread[kind == k] = max(1.0, 1.4826 * float(np.median(standardised)))
    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    out = []
    for g in suspects:
        rows = measurement == g
        Dg, eg = design[rows], e[rows] / spread[rows]
        covariance = np.eye(len(eg)) + Dg @ inverse @ Dg.T
        statistic = float(eg @ np.linalg.solve(covariance, eg))
        if statistic > float(scipy.stats.chi2.isf(p_value, len(eg))):
            out.append(int(g))
    return np.array(out, dtype=int)
