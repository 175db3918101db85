"""Outliers: iterated data snooping (Baarda) on groups of rows."""

from __future__ import annotations

import numpy as np

from ..observations import SharedReference

#: Standardised residual [σ] above which a measurement is flagged as an outlier.
OUTLIER_THRESHOLD = 4.0


def data_snooping(
    W: np.ndarray,
    rw: np.ndarray,
    measurement: np.ndarray,
    kind: np.ndarray,
    shared: SharedReference | None = None,
    nuisance: np.ndarray | None = None,
) -> np.ndarray:
    """Measurements that do not fit the others, by iterated data snooping (Baarda) on groups.

    Reference distances, which share noise (``shared``, see
    :class:`deltacal.observations.SharedReference`), are tested by :func:`reference_snooping`.
    Rows with ``nuisance`` columns projected out (distances of all pairs stated as
    positions, :attr:`deltacal.observations.Rows.nuisance`) are tested with those columns
    in the design: the test of a position given the rigid motions the distances cannot see.

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

    if shared is not None:
        return reference_snooping(W, rw, shared)
    if nuisance is not None:
        W = np.hstack([W, nuisance])
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


def _chi2_quantiles(dof: np.ndarray, p_value: float) -> np.ndarray:
    """χ² quantile of each test's degrees of freedom (inf where none)."""
    import scipy.stats

    out = np.full(dof.shape, np.inf)
    for d in np.unique(dof[dof > 0]):
        out[dof == d] = float(scipy.stats.chi2.isf(p_value, int(d)))
    return out


def reference_snooping(W: np.ndarray, r: np.ndarray, shared: SharedReference) -> np.ndarray:
    """Data snooping of reference distances, which share the noise of their first position.

    A gross error δ in a measured position moves the rows that use it: the row of a
    second position b_k through ``n_k · δ`` (one column, the row's whitened unit column
    ``c_k = T e_k``), a group's first position through every row of the group (three
    columns ``C = T G``). With T the whitening of :class:`SharedReference` both are a
    low-rank update of the identity, so Baarda's test ``uᵀ N⁺ u`` (``u = Cᵀ P e``,
    ``N = Cᵀ P C``, P the residual projector of the whitened design) costs a few
    products per row: χ² with rank(N) degrees of freedom under the null hypothesis, so
    the stated level holds for correlated rows. The worst measurement is set aside by
    adding its columns to the design (which removes exactly its information) and the test
    repeated, as :func:`data_snooping` does.

    Args:
        W: Rows of the regressor divided by their σ, shape (K, n).
        r: Residuals divided by their σ, shape (K,).
        shared: The rows' shared first positions and whitening.

    Returns:
        Indices of the flagged measurements, sorted.
    """
    import scipy.stats

    p_value = 2.0 * scipy.stats.norm.sf(OUTLIER_THRESHOLD)
    rw, design = shared.whiten(r), shared.whiten(W)
    g, n, core = shared.group, shared.direction, shared.core
    gram = shared.group_sums(n)  # GᵀG per group, (G, 3, 3)
    Mn = np.einsum("kij,kj->ki", core[g], n)  # M n_k, (K, 3)
    A = np.eye(3) + core @ gram  # T G = √2 G A per group
    ids = np.concatenate([shared.second, np.unique(shared.first)])
    flagged: list[int] = []
    for _ in range(max(1, ids.size // 4)):
        if rw.size <= design.shape[1] + 1:
            break
        Q, R = np.linalg.qr(design)
        Q = Q[:, np.abs(np.diag(R)) > 1e-12 * max(float(np.abs(R).max()), 1e-300)]
        e = rw - Q @ (Q.T @ rw)
        H = np.sum(Q**2, axis=1)
        scale = max(1.0, 1.4826 * float(np.median(np.abs(e) / np.sqrt(np.clip(1.0 - H, 1e-12, None)))))
        Ge, GQ = shared.group_sums(e), shared.group_sums(Q)  # (G, 3), (G, 3, p)
        # second positions: one column each, c_k = √2 (e_k + G M n_k)
        u = np.sqrt(2.0) * (e + np.einsum("ki,ki->k", Mn, Ge[g]))
        Qc = np.sqrt(2.0) * (Q + np.einsum("ki,kip->kp", Mn, GQ[g]))
        cc = 2.0 * (1.0 + 2.0 * np.einsum("ki,ki->k", n, Mn) + np.einsum("ki,kij,kj->k", Mn, gram[g], Mn))
        N = cc - np.sum(Qc**2, axis=1)
        t_second = np.where(N > 1e-9 * cc, u**2 / np.where(N > 1e-9 * cc, N, 1.0), 0.0)
        # first positions: three columns per group, C = √2 G A
        uf = np.sqrt(2.0) * np.einsum("gji,gj->gi", A, Ge)
        QC = np.sqrt(2.0) * np.einsum("gjp,gji->gpi", GQ, A)
        NF = 2.0 * np.einsum("gji,gjk,gkl->gil", A, gram, A) - np.einsum("gpi,gpj->gij", QC, QC)
        w, V = np.linalg.eigh(NF)
        informative = w > 1e-9 * np.maximum(w[:, -1:], 1e-300)
        z = np.einsum("gik,gi->gk", V, uf)
        t_first = np.sum(np.where(informative, z**2 / np.where(informative, w, 1.0), 0.0), axis=1)
        T = np.concatenate([t_second, t_first]) / scale**2
        dof = np.concatenate([(N > 1e-9 * cc).astype(int), informative.sum(axis=1)])
        ratio = T / _chi2_quantiles(dof, p_value)
        ratio[np.isin(ids, flagged)] = 0.0
        worst = int(np.argmax(ratio))
        if ratio[worst] <= 1.0:
            break
        flagged.append(int(ids[worst]))
        if worst < n.shape[0]:
            column = np.zeros((rw.size, 1))
            rows = g == g[worst]
            column[rows, 0] = np.sqrt(2.0) * (n[rows] @ Mn[worst])
            column[worst, 0] += np.sqrt(2.0)
        else:
            k = worst - n.shape[0]
            rows = g == k
            column = np.zeros((rw.size, 3))
            column[rows] = np.sqrt(2.0) * (n[rows] @ A[k])
        design = np.hstack([design, column])
    return np.array(sorted(flagged), dtype=int)
