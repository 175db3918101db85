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

Few measurements (Klipper's saved ``DELTA_CALIBRATE``: 7 heights, 12 distances) leave the snooping
blind: the combinations seen take 11 to 15 of the 19 rows, the 4 to 8 left are shared by every row,
and one distance 1 mm off raises every distance's residual alike, so the kind's robust spread (the
median) takes the error for the distances' noise. There :func:`lone_misfit` decides, by leaving each
measurement out in turn with the build tolerances as the other measurements' equals (their priors
are rows of the test): the one whose absence leaves the rest at their noise, when no other's does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

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

#: Share of a measurement's own error its residual keeps (its redundancy, ``1 − h``, the priors
#: counted) below which the other measurements barely see an error in it.
UNSEEN = 0.05

#: ``fit(kept)``: the whitened residuals (m,) and regressor (m, n) of every row, at the fit made with
#: the measurements ``kept`` (a mask over the measurements) alone, and that fit's values (n,); the
#: regressor's columns and the values in units of each parameter's tolerance (the prior N(0, I)).
FitWithout = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


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
        undecided: Measurements any one of which, left out, leaves the others at their noise, when
            none stands out from the rest of them (:func:`lone_misfit`): one is likely off, the
            others cannot tell which; sorted, empty when none or when one is flagged.
        unseen: Measurements whose own error the others barely see (:data:`UNSEEN`): a gross
            error there is not found, sorted.
    """

    indices: np.ndarray
    residual: np.ndarray
    kept: np.ndarray
    undecided: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    unseen: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


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
    in which the snooping set them aside. When the snooping ends with one measurement or none, the
    leave-one-out of the first fit (:func:`lone_misfit`, the priors as rows) decides instead where
    it has a verdict: the one it names, or none flagged and the ones it cannot tell apart.

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
    first: Lone | None = None
    for _ in range(ROUNDS):
        kept = ~np.isin(np.arange(count), flagged)
        r, W, values = fit(kept)
        if first is None:
            first = lone_misfit(W, r, values, measurement)
        design, rows = seen_design(W), kept[measurement]
        new = data_snooping(design[rows], r[rows], measurement[rows], kind[rows])
        found = np.union1d(stand_out(design, r, measurement, kind, flagged), new).astype(int)
        if np.array_equal(found, flagged):
            break
        flagged = found
    else:
        kept = ~np.isin(np.arange(count), flagged)
        r = fit(kept)[0]
    assert first is not None
    none = np.zeros(0, dtype=int)
    if flagged.size > 1 or not (first.named.size or first.undecided.size):
        return Outliers(flagged, r, kept, none, first.unseen)
    if not np.array_equal(flagged, first.named):  # one error at most: the leave-one-out's verdict
        kept = ~np.isin(np.arange(count), first.named)
        r = fit(kept)[0]
    return Outliers(first.named, r, kept, first.undecided, first.unseen)


@dataclass(frozen=True)
class Lone:
    """:func:`lone_misfit`'s verdict (measurement indices, sorted, each possibly empty).

    Attributes:
        named: The one measurement whose absence alone leaves the others at their noise.
        undecided: Several such, none preferred (then ``named`` is empty).
        unseen: The measurements whose own error the others barely see (:data:`UNSEEN`).
    """

    named: np.ndarray
    undecided: np.ndarray
    unseen: np.ndarray


def lone_misfit(W: np.ndarray, r: np.ndarray, values: np.ndarray, measurement: np.ndarray) -> Lone:
    """The one measurement whose absence leaves the others at their noise, by leaving each out in turn.

    Linearised at the fit of every row: the rows and the priors together (the regressor over the
    identity, the residuals over minus the values, all in units of σ and of the tolerances), χ² of
    the least squares fit and its hat matrix H. Leaving measurement g out lowers χ² by
    ``T_g = e_gᵀ (I − H_gg)⁻¹ e_g`` (exactly: the fit without g, with the priors, in one step);
    χ²_g = χ² − T_g is what the others leave, and ``s² = max(1, χ²_g / (m − m_g))`` their noise
    about it (m rows; with the priors as rows the degrees of freedom are the rows').

    Decided without float ties: g* leaves the least; nothing is named unless ``T_g* / s²`` is
    beyond :data:`~deltacal.identification.outliers.OUTLIER_THRESHOLD` σ (χ², m_g* degrees), nor
    when, g* left out, the same test at that s² finds another (more than one error, or a misfit of
    the whole: a bed that moved, a biased probe). The measurements h whose χ²_h is within the 1-degree
    quantile of that level (times s²) of χ²_g* would explain the misfit as well: g* is named when it
    is alone among them, else all of them are undecided. A measurement of redundancy
    ``min eig(I − H_gg)`` below :data:`UNSEEN` is unseen.

    Args:
        W: The whitened regressor, in units of each parameter's tolerance, (m, n).
        r: The whitened residuals at the fit, (m,).
        values: The fit's values in units of the tolerances (the prior's residual is minus them), (n,).
        measurement: The measurement of each row, (m,).

    Returns:
        The verdict (:class:`Lone`).
    """
    import scipy.stats  # as data_snooping: needed only here

    none = np.zeros(0, dtype=int)
    y = np.concatenate([r, -values])
    ids, left, drop, size, redundancy = _left_out(W, y, measurement, np.ones(r.size, dtype=bool))
    unseen = ids[redundancy < UNSEEN].astype(int)
    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    best, s2 = _stands_out(left, drop, size, r.size, p_value)
    if best < 0:
        return Lone(none, none, unseen)
    again = _left_out(W, y, measurement, measurement != ids[best])
    if _stands_out(again[1], again[2], again[3], r.size - int(size[best]), p_value, s2)[0] >= 0:
        return Lone(none, none, unseen)  # not one error alone
    alike = ids[(left - left[best]) / s2 <= float(scipy.stats.chi2.isf(p_value, 1))].astype(int)
    return Lone(alike, none, unseen) if alike.size == 1 else Lone(none, alike, unseen)


def _left_out(W: np.ndarray, y: np.ndarray, measurement: np.ndarray, rows: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each measurement of ``rows`` left out in turn (:func:`lone_misfit`'s linear fit, the priors kept).

    Returns:
        The measurements (sorted), the χ² each leaves, the χ² each takes away, its rows, its redundancy.
    """
    m, n = W.shape
    keep = np.concatenate([rows, np.ones(n, dtype=bool)])
    Q, _ = np.linalg.qr(np.vstack([W, np.eye(n)])[keep])
    full = y[keep] - Q @ (Q.T @ y[keep])
    e, of = full[:int(rows.sum())], measurement[rows]
    ids = np.unique(of)
    drop, redundancy, size = np.zeros(ids.size), np.zeros(ids.size), np.zeros(ids.size, dtype=int)
    for i, g in enumerate(ids):
        at = np.flatnonzero(of == g)
        R = np.eye(at.size) - Q[at] @ Q[at].T
        redundancy[i], size[i] = float(np.min(np.linalg.eigvalsh(R))), at.size
        drop[i] = float(e[at] @ np.linalg.lstsq(R, e[at], rcond=1e-12)[0])
    return ids, float(full @ full) - drop, drop, size, redundancy


def _stands_out(left: np.ndarray, drop: np.ndarray, size: np.ndarray, m: int, p_value: float,
                noise: float | None = None) -> tuple[int, float]:
    """The measurement whose absence leaves the least (its index there; −1: none stands out), and s².

    s² is the others' noise about the fit without it (``noise`` when given).
    """
    import scipy.stats

    if not left.size:
        return -1, 1.0
    best = int(np.argmin(left))
    s2 = noise if noise is not None else max(1.0, float(left[best]) / max(m - int(size[best]), 1))
    significant = drop[best] / s2 > float(scipy.stats.chi2.isf(p_value, int(size[best])))
    return (best if significant else -1), s2


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
