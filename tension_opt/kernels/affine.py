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

__all__ = ["COND_LIMIT", "null_space", "null_space_work"]

#: Poses whose (Frobenius) condition estimate of ``A`` reaches this are left to the
#: numpy path, whose singular values decide the rank exactly (it bounds the 2-norm
#: condition number from above, so a pose below it is of full rank by numpy's
#: test, ``RANK_TOL = 1e-10``, too).
COND_LIMIT = 1e8


@njit(cache=True)
def null_space_work(m: int, n: int) -> int:
    """Floats of work space :func:`null_space` needs for ``A`` of shape (n, m)."""
    return 2 * m * n + m * m + n + n * n


@njit(cache=True, error_model="numpy")
def null_space(A: NDArray, b: NDArray, T0: NDArray, Z: NDArray, work: NDArray) -> bool:
    """Minimum-norm solution ``T0`` (m,) of ``A T = b`` and an orthonormal basis ``Z``
    (m, m - n) of the null space of ``A`` (n, m), written in place.

    Householder QR of ``A^T = Q R``: ``Z`` is the last ``m - n`` columns of ``Q`` and
    ``T0 = Q_1 R^{-T} b``. Returns False (nothing usable written) where ``A`` is
    singular or its condition estimate ``||R||_F ||R^-1||_F`` reaches
    :data:`COND_LIMIT`. ``work`` holds at least :func:`null_space_work` floats; its
    matrices are indexed flat, row by row (a reshaped view costs more than the
    arithmetic at these sizes).
    """
    n, m = A.shape
    M = work[:m * n]  # A^T (m, n), reduced to R in its top rows
    V = work[m * n:2 * m * n]  # Householder vectors (n, m)
    Q = work[2 * m * n:2 * m * n + m * m]  # (m, m)
    y = work[2 * m * n + m * m:2 * m * n + m * m + n]
    for i in range(m):
        for j in range(n):
            M[i * n + j] = A[j, i]
    for k in range(n):
        norm = 0.0
        for i in range(k, m):
            norm += M[i * n + k] * M[i * n + k]
        norm = math.sqrt(norm)
        if norm == 0.0 or not math.isfinite(norm):
            return False
        alpha = -norm if M[k * n + k] >= 0.0 else norm
        vk = k * m
        for i in range(k, m):
            V[vk + i] = M[i * n + k]
        V[vk + k] -= alpha
        vnorm = 0.0
        for i in range(k, m):
            vnorm += V[vk + i] * V[vk + i]
        vnorm = math.sqrt(vnorm)
        for i in range(k, m):
            V[vk + i] /= vnorm
        for j in range(k, n):
            dot = 0.0
            for i in range(k, m):
                dot += V[vk + i] * M[i * n + j]
            for i in range(k, m):
                M[i * n + j] -= 2.0 * dot * V[vk + i]
    for i in range(m):
        for j in range(m):
            Q[i * m + j] = 1.0 if i == j else 0.0
    for k in range(n - 1, -1, -1):
        vk = k * m
        for j in range(m):
            dot = 0.0
            for i in range(k, m):
                dot += V[vk + i] * Q[i * m + j]
            for i in range(k, m):
                Q[i * m + j] -= 2.0 * dot * V[vk + i]
    if not _well_conditioned(M, n, work[2 * m * n + m * m + n:]):
        return False
    # R^T y = b (forward substitution), then T0 = Q_1 y.
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= M[j * n + i] * y[j]
        y[i] = s / M[i * n + i]
    for i in range(m):
        s = 0.0
        for j in range(n):
            s += Q[i * m + j] * y[j]
        T0[i] = s
        for j in range(m - n):
            Z[i, j] = Q[i * m + n + j]
    return True


@njit(cache=True, error_model="numpy")
def _well_conditioned(M: NDArray, n: int, work: NDArray) -> bool:
    """Whether the triangle ``R`` (top n x n of ``M``, flat with rows of n) has
    ``||R||_F ||R^-1||_F`` below :data:`COND_LIMIT` (an upper bound of its 2-norm
    condition number); ``work`` holds ``n * n`` floats."""
    norm_r = 0.0
    for i in range(n):
        for j in range(i, n):
            norm_r += M[i * n + j] * M[i * n + j]
        if M[i * n + i] == 0.0:
            return False
    inv = work  # R^-1 (n, n) flat, upper triangular, column by column
    norm_inv = 0.0
    for j in range(n):
        inv[j * n + j] = 1.0 / M[j * n + j]
        norm_inv += inv[j * n + j] * inv[j * n + j]
        for i in range(j - 1, -1, -1):
            s = 0.0
            for k in range(i + 1, j + 1):
                s += M[i * n + k] * inv[k * n + j]
            inv[i * n + j] = -s / M[i * n + i]
            norm_inv += inv[i * n + j] * inv[i * n + j]
    cond = math.sqrt(norm_r) * math.sqrt(norm_inv)
    return math.isfinite(cond) and cond < COND_LIMIT


