"""Compiled null-space pieces of one pose: the affine set ``T = T0 + Z z`` of
``A T = b`` and the minimum of a maximum of lines.

References: :func:`tension_opt.problem.affine.pinv_and_null` (SVD; here a Householder QR of
``A^T``, which gives the same minimum-norm ``T0`` and an orthonormal basis of the same
null space) and :func:`tension_opt.problem.affine.min_of_max_lines`.
"""

from __future__ import annotations

import math

from numba import njit
from numpy.typing import NDArray

__all__ = ["COND_LIMIT", "column_norm", "null_space", "null_space_work", "reflect"]

#: Poses whose (Frobenius) condition estimate of ``A`` reaches this are left to the
#: numpy path, whose singular values decide the rank exactly (it bounds the 2-norm
#: condition number from above, so a pose below it is of full rank by numpy's
#: test, ``RANK_TOL = 1e-10``, too).
COND_LIMIT = 1e8


@njit(cache=True)
def null_space_work(m: int, n: int) -> int:
    """Floats of work space :func:`null_space` needs for ``A`` of shape (n, m)."""
    return m * n + 3 * n + n * n


@njit(cache=True, error_model="numpy", inline="always")
def column_norm(W: NDArray, o: int, k: int, length: int) -> float:
    """Norm of entries ``k..length-1`` of the column stored flat from ``W[o]``."""
    norm = 0.0
    for i in range(k, length):
        norm += W[o + i] * W[o + i]
    return math.sqrt(norm)


@njit(cache=True, error_model="numpy", inline="always")
def reflect(W: NDArray, length: int, k: int, count: int, norm: float) -> tuple[float, float]:
    """One Householder step on ``count`` columns stored flat in ``W``, each ``length``
    long (column j from ``W[j * length]``): the reflector of column k (of entries ``k..``,
    of norm ``norm > 0``) is written over those entries and applied to the columns after
    it. Returns ``(alpha, beta)``: the new diagonal entry and the reflector's factor
    (``I - beta v v^T``)."""
    o = k * length
    top = W[o + k]
    alpha = -norm if top >= 0.0 else norm
    beta = 1.0 / (norm * (norm + abs(top)))  # 2 / |v|^2, v = x - alpha e_k
    W[o + k] = top - alpha
    for j in range(k + 1, count):
        oj = j * length
        dot = 0.0
        for i in range(k, length):
            dot += W[o + i] * W[oj + i]
        dot *= beta
        for i in range(k, length):
            W[oj + i] -= dot * W[o + i]
    return alpha, beta


@njit(cache=True, error_model="numpy")
def null_space(A: NDArray, b: NDArray, T0: NDArray, Z: NDArray, work: NDArray) -> bool:
    """Minimum-norm solution ``T0`` (m,) of ``A T = b`` and an orthonormal basis ``Z``
    (m, m - n) of the null space of ``A`` (n, m), written in place.

    Householder QR of ``A^T = Q R``: ``Z`` is the last ``m - n`` columns of ``Q`` and
    ``T0 = Q_1 R^{-T} b``, each found by applying the reflectors to ``m - n + 1``
    vectors (``Q`` itself is never formed). Returns False (nothing usable written)
    where ``A`` is singular or its condition estimate ``||R||_F ||R^-1||_F`` reaches
    :data:`COND_LIMIT`. ``work`` holds at least :func:`null_space_work` floats; its
    matrices are indexed flat (a reshaped view costs more than the arithmetic at these
    sizes).
    """
    n, m = A.shape
    r = m - n
    # Row j of W: column j of A^T, contiguous. Reduced in place: its entries j.. become
    # reflector j, its entries before j the column j of R above the diagonal.
    W = work[:m * n]
    diag = work[m * n:m * n + n]  # R's diagonal
    betas = work[m * n + n:m * n + 2 * n]  # reflector j is I - betas[j] v v^T
    y = work[m * n + 2 * n:m * n + 3 * n]
    for j in range(n):
        for i in range(m):
            W[j * m + i] = A[j, i]
    for k in range(n):
        norm = column_norm(W, k * m, k, m)
        if norm == 0.0 or not math.isfinite(norm):
            return False
        diag[k], betas[k] = reflect(W, m, k, n, norm)
    if not _well_conditioned(W, diag, n, m, work[m * n + 3 * n:]):
        return False
    # R^T y = b (forward substitution), then T0 = Q [y; 0] and Z = Q [0; I].
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= W[i * m + j] * y[j]
        y[i] = s / diag[i]
    for i in range(m):
        T0[i] = y[i] if i < n else 0.0
        for j in range(r):
            Z[i, j] = 1.0 if i == n + j else 0.0
    for k in range(n - 1, -1, -1):
        o = k * m
        beta = betas[k]
        dot = 0.0
        for i in range(k, m):
            dot += W[o + i] * T0[i]
        dot *= beta
        for i in range(k, m):
            T0[i] -= dot * W[o + i]
        for j in range(r):
            dot = 0.0
            for i in range(k, m):
                dot += W[o + i] * Z[i, j]
            dot *= beta
            for i in range(k, m):
                Z[i, j] -= dot * W[o + i]
    return True


@njit(cache=True, error_model="numpy")
def _well_conditioned(W: NDArray, diag: NDArray, n: int, m: int, work: NDArray) -> bool:
    """Whether the triangle ``R`` (diagonal ``diag``, ``R[i, j] = W[j * m + i]`` above
    it) has ``||R||_F ||R^-1||_F`` below :data:`COND_LIMIT` (an upper bound of its
    2-norm condition number); ``work`` holds ``n * n`` floats."""
    norm_r = 0.0
    for j in range(n):
        if diag[j] == 0.0:
            return False
        norm_r += diag[j] * diag[j]
        for i in range(j):
            norm_r += W[j * m + i] * W[j * m + i]
    inv = work  # R^-1 (n, n) flat, upper triangular, column j in row j
    norm_inv = 0.0
    for j in range(n):
        oj = j * n
        inv[oj + j] = 1.0 / diag[j]
        norm_inv += inv[oj + j] * inv[oj + j]
        for i in range(j - 1, -1, -1):
            s = 0.0
            for k in range(i + 1, j + 1):
                s += W[k * m + i] * inv[oj + k]
            inv[oj + i] = -s / diag[i]
            norm_inv += inv[oj + i] * inv[oj + i]
    cond = math.sqrt(norm_r) * math.sqrt(norm_inv)
    return math.isfinite(cond) and cond < COND_LIMIT
