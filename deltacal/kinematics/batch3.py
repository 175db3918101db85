"""Batched 3-vector and 3x3 algebra in component-first layout, for the exact solvers' hot loops.

A batch of N vectors is an array of shape (3, N) and a batch of 3x3 matrices (3, 3, N):
the pose index is last, so every operation below is a handful of elementwise numpy
operations on contiguous rows of length N. For the small matrices of the Delta's rod
equations this is several times faster than ``np.linalg.solve`` or ``einsum`` on (N, 3, 3)
stacks, whose per-matrix overhead dominates (measured in ``scripts/bench.py``).

The solves are by the adjugate (Cramer's rule): exact in exact arithmetic, and as accurate
as a pivoted LU for the well-conditioned matrices they are used on; where a matrix is
singular the solution is not finite, which callers test (and fall back to a pivoted solver).
"""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of vectors along the first axis: shapes (3, ...) broadcast together."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products along the first axis: (3, ...) with (3, ...) -> (...)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Products of 3x3 matrices (3, 3, N) by matrices (3, K, N) or vectors (3, N)."""
    if b.ndim == a.ndim - 1:
        return a[:, 0] * b[0] + a[:, 1] * b[1] + a[:, 2] * b[2]
    return a[:, 0, None] * b[0] + a[:, 1, None] * b[1] + a[:, 2, None] * b[2]


def adjugate(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Adjugates and determinants of 3x3 matrices (3, 3, N): ``m @ adj = det I``.

    Returns:
        The adjugates, (3, 3, N), and the determinants, (N,).
    """
    r0, r1, r2 = m[0], m[1], m[2]
    c0 = cross(r1, r2)  # the adjugate's columns: m^-1 = [r1 x r2, r2 x r0, r0 x r1] / det
    adj = np.stack([c0, cross(r2, r0), cross(r0, r1)], axis=1)
    return adj, dot(r0, c0)


def solve(m: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solutions x of ``m x = b`` for 3x3 matrices (3, 3, N) and right-hand sides (3, N) or (3, K, N).

    Returns:
        x (shaped as b) and the determinants of m, (N,): rows where a determinant is zero
        or tiny are not solved meaningfully (the caller tests and falls back).
    """
    adj, det = adjugate(m)
    with np.errstate(divide="ignore", invalid="ignore"):
        return matmul(adj, b) / det, det


def rotation_from_vector(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices (3, 3, N) of rotation vectors (3, N), by Rodrigues' formula.

    ``exp([phi]x) = cos t I + (sin t / t) [phi]x + ((1 - cos t) / t^2) phi phiᵀ`` with
    ``t = |phi|``; below t = 1e-3 the two coefficients are their Taylor series (truncation
    below 1e-19), which are exact at t = 0 where the quotients are not.
    """
    t2 = dot(phi, phi)
    t = np.sqrt(t2)
    small = t < 1e-3
    ts = np.where(small, 1.0, t)
    h = np.sin(0.5 * ts) / ts
    a = np.where(small, 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0), np.sin(ts) / ts)  # sin t / t
    b = np.where(small, 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0), 2.0 * h * h)  # (1 - cos t) / t^2
    c = 1.0 - b * t2  # cos t
    bp = b * phi
    out = bp[:, None] * phi[None]
    ap = a * phi
    out[0, 0] += c
    out[1, 1] += c
    out[2, 2] += c
    out[0, 1] -= ap[2]
    out[0, 2] += ap[1]
    out[1, 0] += ap[2]
    out[1, 2] -= ap[0]
    out[2, 0] -= ap[1]
    out[2, 1] += ap[0]
    return out
