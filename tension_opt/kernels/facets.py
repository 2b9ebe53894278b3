"""Normals of the hyperplanes that ``n - 1`` columns of a structure matrix span, compiled.

The twin of the singular value decomposition in :mod:`tension_opt.dynamics.facets`
(the reference): for each pose and each subset of ``n - 1`` columns, a Householder QR
of the ``n x (n - 1)`` matrix; the last column of its orthogonal factor is the unit
normal (up to sign, which does not matter: the facets take both). A subset whose
columns are dependent (a diagonal of the triangular factor below ``1e-12`` of the
largest column) gets a zero normal, as in the reference.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["column_normal", "subset_normals"]


@njit(cache=True, error_model="numpy")
def column_normal(B: NDArray, vs: NDArray, out: NDArray) -> None:
    """Unit normal of the columns of ``B`` (n, n - 1) into ``out`` (n,); ``B`` is
    overwritten, ``vs`` (n - 1, n) is work space."""
    n = B.shape[0]
    top = 0.0
    for c in range(n - 1):
        size = 0.0
        for i in range(n):
            size += B[i, c] * B[i, c]
        top = max(top, math.sqrt(size))
    for c in range(n - 1):
        norm = 0.0
        for i in range(c, n):
            norm += B[i, c] * B[i, c]
        norm = math.sqrt(norm)
        if norm <= 1e-12 * top or top == 0.0:
            out[:] = 0.0
            return
        alpha = -norm if B[c, c] >= 0 else norm
        for i in range(n):
            vs[c, i] = 0.0
        vs[c, c] = B[c, c] - alpha
        for i in range(c + 1, n):
            vs[c, i] = B[i, c]
        vnorm = 0.0
        for i in range(c, n):
            vnorm += vs[c, i] * vs[c, i]
        vnorm = math.sqrt(vnorm)
        for i in range(c, n):
            vs[c, i] /= vnorm
        for j in range(c, n - 1):  # B <- (I - 2 v v^T) B
            dot = 0.0
            for i in range(c, n):
                dot += vs[c, i] * B[i, j]
            for i in range(c, n):
                B[i, j] -= 2.0 * vs[c, i] * dot
        if abs(B[c, c]) <= 1e-12 * top:
            out[:] = 0.0
            return
    for i in range(n):  # Q e_n = H_0 ... H_{n-2} e_n
        out[i] = 0.0
    out[n - 1] = 1.0
    for c in range(n - 2, -1, -1):
        dot = 0.0
        for i in range(c, n):
            dot += vs[c, i] * out[i]
        for i in range(c, n):
            out[i] -= 2.0 * vs[c, i] * dot


@njit(cache=True)
def subset_normals(A: NDArray, subsets: NDArray) -> NDArray:
    """Unit normals (N, S, n) of the columns ``subsets`` (S, n - 1) of each ``A``
    (N, n, m); zero where they are dependent."""
    N, n, _ = A.shape
    S = subsets.shape[0]
    out = np.zeros((N, S, n))
    for p in range(N):
        B = np.empty((n, n - 1))
        vs = np.empty((n - 1, n))
        for s in range(S):
            for c in range(n - 1):
                for i in range(n):
                    B[i, c] = A[p, i, subsets[s, c]]
            column_normal(B, vs, out[p, s])
    return out
