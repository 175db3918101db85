"""Outliers: iterated data snooping (Baarda) on groups of rows."""

from __future__ import annotations

import numpy as np

#: Standardised residual [σ] above which a measurement is flagged as an outlier.
OUTLIER_THRESHOLD = 4.0


def data_snooping(W: np.ndarray, rw: np.ndarray, measurement: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """Measurements that do not fit the others, by iterated data snooping (Baarda) on groups.

    Each measurement's rows g are tested by the drop of χ² its deletion would give,
    ``T_g = r_gᵀ (I − H_gg)⁻¹ r_g`` (H: hat matrix, so a high-leverage pose is tested
    by what the others predict for it), against the χ² quantile of
    :data:`OUTLIER_THRESHOLD` σ for its number of rows, each row's residual divided by
    ``max(1, s)``, s the robust (median) scale of the residuals of its kind (so σ given
    too small, or a model blind to the orientations, does not flag everything). The
    worst measurement is set aside and the fit redone, at most for a quarter of the
    measurements: one gross error no longer flags the rows it drags.
    """
    import scipy.stats  # here, not at the top: it takes 0.15-0.3 s to import, needed only by this test

    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    quantile: dict[int, float] = {}
    ids = np.unique(measurement)
    active = np.ones(rw.size, dtype=bool)
    flagged: list[int] = []
    for _ in range(max(1, ids.size // 4)):
        if np.count_nonzero(active) <= W.shape[1] + 1:
            break
        Q, _ = np.linalg.qr(W[active])
        r = rw[active] - Q @ (Q.T @ rw[active])
        leverage = np.clip(np.sum(Q**2, axis=1), 0.0, 1.0 - 1e-12)
        standardised = np.abs(r) / np.sqrt(1.0 - leverage)
        for k in np.unique(kind):
            of_kind = kind[active] == k
            r[of_kind] /= max(1.0, 1.4826 * float(np.median(standardised[of_kind])))
        meas = measurement[active]
        worst, worst_ratio = -1, 1.0
        ids_now, counts = np.unique(meas, return_counts=True)
        order = np.argsort(meas, kind="stable")  # rows grouped by measurement
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        for size in np.unique(counts):  # groups of one size at once (poses: 6 rows, points: 3...)
            groups = np.flatnonzero(counts == size)
            rows = order[starts[groups][:, None] + np.arange(size)[None, :]]  # (G, size)
            Qg = Q[rows]  # (G, size, rank)
            A = np.eye(size)[None] - Qg @ np.swapaxes(Qg, 1, 2)
            rg = r[rows]
            T = np.einsum("gi,gi->g", rg, (np.linalg.pinv(A, rcond=1e-12) @ rg[..., None])[..., 0])
            if size not in quantile:
                quantile[size] = float(scipy.stats.chi2.isf(p_value, size))
            ratio = T / quantile[size]
            k = int(np.argmax(ratio))
            if ratio[k] > worst_ratio:
                worst, worst_ratio = int(ids_now[groups[k]]), float(ratio[k])
        if worst < 0:
            break
        flagged.append(worst)
        active &= measurement != worst
    return np.array(sorted(flagged), dtype=int)
