"""Outliers: iterated data snooping (Baarda) on groups of rows."""

from __future__ import annotations

import numpy as np

#: Standardised residual [σ] above which a measurement is flagged as an outlier.
OUTLIER_THRESHOLD = 4.0


def data_snooping(
    W: np.ndarray,
    rw: np.ndarray,
    measurement: np.ndarray,
    kind: np.ndarray,
    mixing: np.ndarray | None = None,
) -> np.ndarray:
    """Measurements that do not fit the others, by iterated data snooping (Baarda) on groups.

    Rows sharing noise (distances: ``mixing`` given, see
    :attr:`deltacal.observations.Rows.mixing`) are tested by :func:`correlated_snooping`.

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

    if mixing is not None:
        return correlated_snooping(W, rw, mixing)
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


def correlated_snooping(W: np.ndarray, r: np.ndarray, mixing: np.ndarray) -> np.ndarray:
    """Data snooping of rows that share the noise of the measurements (distances between positions).

    A gross error in measurement j moves its position by some δ_j (3 components):
    the rows see it through the mixing's three columns of j. After whitening by the
    mixing's SVD ``U S Vᵀ`` (``T = S⁻¹ Uᵀ``, as the fit is) those columns are
    ``C_j = T mixing_j = Vᵀ_j``, and the test of Baarda's alternative ``y = W x + C_j δ_j``
    is ``T_j = uᵀ N⁺ u``, ``u = C_jᵀ P r``, ``N = C_jᵀ P C_j`` (P: the residual projector
    of the whitened design), χ² with rank(N) degrees of freedom under the null
    hypothesis: the stated level holds for correlated rows too. Testing the unwhitened
    rows as if independent flagged 2-10 % of clean measurements (issue 12). The worst
    measurement is set aside by adding its columns to the design (which removes
    exactly its information) and the test repeated, as :func:`data_snooping` does.

    Args:
        W: Rows of the regressor divided by their σ, shape (K, n).
        r: Residuals divided by their σ, shape (K,).
        mixing: d(rows / σ) / d(positions / σ_position), shape (K, 3M).

    Returns:
        Indices of the flagged measurements, sorted.
    """
    U, S, Vt = np.linalg.svd(mixing, full_matrices=False)
    keep = S > S[0] * 1e-10
    T = U[:, keep].T / S[keep, None]
    rw, Ww = T @ r, T @ W
    C = Vt[keep].reshape(int(np.count_nonzero(keep)), -1, 3)  # (rows, M, 3): whitened bias columns
    M = C.shape[1]
    import scipy.stats  # here, not at the top: see data_snooping

    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    design = Ww
    flagged: list[int] = []
    for _ in range(max(1, M // 4)):
        if rw.size <= design.shape[1] + 1:
            break
        Q, R = np.linalg.qr(design)
        Q = Q[:, np.abs(np.diag(R)) > 1e-12 * max(float(np.abs(R).max()), 1e-300)]
        e = rw - Q @ (Q.T @ rw)
        PC = C - np.einsum("ra,amk->rmk", Q, np.einsum("ra,rmk->amk", Q, C))
        u = np.einsum("rmk,r->mk", PC, e)  # (M, 3)
        N = np.einsum("rmi,rmj->mij", PC, PC)  # C_jᵀ P C_j, (M, 3, 3)
        # robust scale of the whitened residuals: σ given too small does not flag everything
        H = np.sum(Q**2, axis=1)
        scale = max(1.0, 1.4826 * float(np.median(np.abs(e) / np.sqrt(np.clip(1.0 - H, 1e-12, None)))))
        w, V = np.linalg.eigh(N)
        top = np.maximum(w[:, -1:], 1e-300)
        informative = w > 1e-9 * top
        dof = informative.sum(axis=1)
        z = np.einsum("mik,mi->mk", V, u)  # u in the eigenbasis of N
        Tj = np.sum(np.where(informative, z**2 / np.where(informative, w, 1.0), 0.0), axis=1) / scale**2
        quantile = np.full(M, np.inf)
        for d in np.unique(dof[dof > 0]):
            quantile[dof == d] = float(scipy.stats.chi2.isf(p_value, int(d)))
        ratio = Tj / quantile
        ratio[flagged] = 0.0
        worst = int(np.argmax(ratio))
        if ratio[worst] <= 1.0:
            break
        flagged.append(worst)
        design = np.hstack([design, C[:, worst, :]])
    return np.array(sorted(flagged), dtype=int)
