"""Identifiable (base) parameters of a linear regressor by QR decomposition.

The regressor W (rows: measurements, columns: parameter deviations) is
column-scaled and decomposed by a pivoted QR, ``W P = Q R`` (Savoure 2006,
Sec. II-B-2 and Eq. 25; Besnard and Khalil 2001). The numerical rank r counts
the diagonal entries ``|R_kk| > rtol |R_00|``. Writing ``R = [R1 R2]`` with R1
the leading r x r block, every measurement depends on the parameters only
through the base parameters

    beta = dk_1 + R1^-1 R2 dk_2,

so each base parameter is a kept column plus a linear regrouping of the
dropped ones (for instance ``δa2x − δb2x``, Savoure Eq. 70-72).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Regrouping coefficients below this (relative) are printed as absent.
_COEFF_PRINT_TOL = 1e-6


@dataclass(frozen=True)
class BaseParameters:
    """Base parameters of a regressor.

    Attributes:
        names: Names of all the regressor's columns (parameters).
        rank: Numerical rank.
        base: Column indices of the kept parameters, one per base parameter.
        regrouping: Matrix (rank, n): base parameter k equals ``regrouping[k] @ dk``.
        unidentifiable: Columns that are not kept (absent from the measurements, or
            folded into base parameters).
        condition_number: Condition number of the column-scaled base regressor.
        scale: Column scales used (norm of each column, 1 for zero columns).
        pivots: |R_kk| of the scaled decomposition, in pivot order.
    """

    names: list[str]
    rank: int
    base: list[int]
    regrouping: np.ndarray
    unidentifiable: list[int]
    condition_number: float
    scale: np.ndarray
    pivots: np.ndarray

    @property
    def base_names(self) -> list[str]:
        """Names of the kept parameters."""
        return [self.names[k] for k in self.base]

    @property
    def unidentifiable_names(self) -> list[str]:
        """Names of the parameters that are not kept."""
        return [self.names[k] for k in self.unidentifiable]

    @property
    def absent(self) -> list[int]:
        """Columns that appear in no base parameter: they do not affect the measurements."""
        used = np.any(np.abs(self.regrouping) > _COEFF_PRINT_TOL, axis=0)
        return [k for k in range(len(self.names)) if not used[k]]

    def labels(self, prefix: str = "δ") -> list[str]:
        """Readable base parameters, e.g. ``δa2x − δb2x`` or ``δq0 + 0.5 δl1``."""
        return [self._label(k, prefix) for k in range(self.rank)]

    def _label(self, k: int, prefix: str) -> str:
        row = self.regrouping[k]
        lead = self.base[k]
        terms = [(lead, row[lead])]
        others = [int(j) for j in np.flatnonzero(np.abs(row) > _COEFF_PRINT_TOL) if j != lead]
        terms += [(j, row[j]) for j in others]
        out = ""
        for n, (j, c) in enumerate(terms):
            mag = abs(c)
            sign = "−" if c < 0 else "+"
            coeff = "" if abs(mag - 1.0) < 1e-9 else f"{mag:.6g} "
            name = f"{prefix}{self.names[j]}"
            if n == 0:
                out = ("−" if c < 0 else "") + coeff + name
            else:
                out += f" {sign} {coeff}{name}"
        return out

    def project(self, full: np.ndarray) -> np.ndarray:
        """Base parameter values of a full parameter deviation vector (or batch)."""
        return np.asarray(full) @ self.regrouping.T

    def expand(self, base_values: np.ndarray) -> np.ndarray:
        """The full deviation vector with the kept parameters set and the others zero.

        It has the same effect on every measurement as any full vector whose base
        parameters are ``base_values``.
        """
        full = np.zeros(len(self.names))
        full[self.base] = base_values
        return full


#: Two columns whose remaining norms differ by less than this (the columns are scaled to unit
#: norm, so it is relative to the largest pivot) are tied in the pivoted QR; the tie goes to the
#: one earlier in the model's parameter order. Symmetric columns (the three encoder offsets of a
#: symmetric pose set) differ only in the last bits, which BLAS rounds differently on different
#: CPUs: without this rule the base parameters named would depend on the machine.
TIE_RTOL = 1e-9


def pivoted_qr(A: np.ndarray, tie_rtol: float = TIE_RTOL) -> tuple[np.ndarray, np.ndarray]:
    """Householder QR with column pivoting whose ties are broken by column order.

    At step j the column with the largest remaining norm is moved to position j,
    as in LAPACK's ``geqp3``, except that every column within ``tie_rtol * |R_00|``
    of that largest norm counts as tied and the one with the lowest original index
    wins. Remaining norms are recomputed at each step (no downdating), so the
    choice does not drift with rounding. A tall matrix is first reduced to its triangular
    factor (LAPACK), so the pivoting costs O(n³), vectorised per step.

    Args:
        A: Matrix, shape (m, n).
        tie_rtol: Tie tolerance relative to the first pivot |R_00|.

    Returns:
        ``(diag, perm)``: |R_jj| for j < min(m, n), and the column permutation (R = Qᵀ A[:, perm]).
    """
    R = np.array(A, dtype=float, copy=True)
    if R.shape[0] > R.shape[1]:
        # a tall matrix: its triangular factor has the same column norms and the same pivoting
        # (Qᵀ keeps every norm), at n x n instead of m x n for each of the n steps below
        R = np.asarray(np.linalg.qr(R, mode="r"))
    m, n = R.shape
    perm = np.arange(n)
    steps = min(m, n)
    diag = np.zeros(steps)
    top = 0.0
    for j in range(steps):
        remaining = np.sqrt(np.einsum("ij,ij->j", R[j:, j:], R[j:, j:]))
        best = float(remaining.max())
        if j == 0:
            top = best
        if best <= 0.0:
            break
        tied = np.flatnonzero(remaining >= best - tie_rtol * top)
        p = j + int(tied[np.argmin(perm[j + tied])])
        if p != j:
            R[:, [j, p]] = R[:, [p, j]]
            perm[[j, p]] = perm[[p, j]]
        x = R[j:, j]
        alpha = -math.copysign(float(np.linalg.norm(x)), float(x[0]))
        v = x.copy()
        v[0] -= alpha
        vnorm = float(np.linalg.norm(v))
        if vnorm > 0.0:
            v /= vnorm
            R[j:, j:] -= 2.0 * np.outer(v, v @ R[j:, j:])
        diag[j] = abs(alpha)
    return diag, perm


def base_parameters(
    regressor: np.ndarray,
    names: Sequence[str],
    rtol: float = 1e-8,
    prefer: Sequence[str] | None = None,
    tie_rtol: float = TIE_RTOL,
    exclude: Sequence[str] = (),
    rank: int | None = None,
) -> BaseParameters:
    """Find the base parameters of a regressor.

    Args:
        regressor: W, shape (m, n).
        names: The n parameter names.
        rtol: Rank tolerance relative to the largest pivot |R_00| (columns scaled to
            unit norm first, so that units do not decide the rank).
        prefer: Optional preference order of parameter names: the rank comes from the
            pivoted QR as always, but when parameters are regrouped the earliest in this
            list is kept (Gram-Schmidt of the columns in this order). Without it, the
            pivoted QR's choice is kept (the best-conditioned columns, ties to the
            earlier parameter: see :data:`TIE_RTOL`).
        tie_rtol: Tie tolerance of the pivoted QR (:func:`pivoted_qr`).
        exclude: Parameters never kept (held at their start value, folded into the others
            where the regressor allows, like any dependent parameter).
        rank: The number of base parameters, when a criterion other than ``rtol`` decides it
            (at most the numerical rank).

    Returns:
        The base parameters.
    """
    W = np.asarray(regressor, dtype=float)
    m, n = W.shape
    if len(names) != n:
        raise ValueError(f"{len(names)} names for {n} columns")
    scale = np.linalg.norm(W, axis=0)
    scale = np.where(scale > 0.0, scale, 1.0)
    Ws = W / scale
    if m > n:
        # everything below depends on the columns' inner products only, which the triangular
        # factor keeps (W = Q R, Q with orthonormal columns): n x n instead of m x n
        Ws = np.asarray(np.linalg.qr(Ws, mode="r"))
        m = n
    excluded = [k for k, name in enumerate(names) if name in set(exclude)]
    allowed = np.setdiff1d(np.arange(n), excluded)
    diag, perm = pivoted_qr(Ws[:, allowed], tie_rtol)
    perm = np.concatenate([allowed[perm], np.asarray(excluded, dtype=int)])
    top = diag[0] if diag.size else 0.0
    numerical = int(np.sum(diag > rtol * top)) if top > 0 else 0
    rank = numerical if rank is None else min(int(rank), numerical)
    pivots = diag
    if prefer is None:
        kept = [int(k) for k in perm[:rank]]
        dropped = [int(k) for k in perm[rank:]]
    else:
        # same rank; the kept columns chosen in the preferred order (Gram-Schmidt, twice)
        order = [list(names).index(p) for p in prefer if p in names]
        order += [k for k in range(n) if k not in order]
        order = [k for k in order if k not in excluded] + excluded
        kept, dropped = [], []
        basis = np.zeros((m, 0))
        for k in order:
            col = Ws[:, k]
            resid = col - basis @ (basis.T @ col)
            resid = resid - basis @ (basis.T @ resid)
            norm = float(np.linalg.norm(resid))
            if len(kept) < rank and k not in excluded and norm > rtol * max(top, 1e-300):
                kept.append(k)
                basis = np.column_stack([basis, resid / norm])
            else:
                dropped.append(k)
    regrouping = np.zeros((rank, n))
    if rank:
        W1 = Ws[:, kept]
        # beta_scaled = dk1_s + X dk2_s with W1 X = W2 (exact for dependent columns)
        X = np.linalg.lstsq(W1, Ws[:, dropped], rcond=None)[0] if dropped else np.zeros((rank, 0))
        regrouping[np.arange(rank), kept] = 1.0
        if dropped:
            # back to physical units: beta_k (units of param kept[k]) = dk1 + diag(1/s1) X diag(s2) dk2
            regrouping[:, dropped] = X * (scale[dropped][None, :] / scale[kept][:, None])
        sv = np.linalg.svd(W1, compute_uv=False)
        cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    else:
        cond = float("inf")
    regrouping[np.abs(regrouping) < 1e-12] = 0.0
    return BaseParameters(
        names=list(names),
        rank=rank,
        base=[int(k) for k in kept],
        regrouping=regrouping,
        unidentifiable=sorted(int(k) for k in dropped),
        condition_number=cond,
        scale=scale,
        pivots=np.asarray(pivots),
    )
