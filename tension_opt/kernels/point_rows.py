"""The facet rows of points along a path, compiled: one pass per point, no
intermediate arrays.

The twin of :func:`tension_opt.dynamics.point_rows.point_rows_reference` (a singular
value decomposition of every ``n - 1`` columns of the structure matrix, then the
facets' offsets and products as numpy arrays: the reference these kernels are tested
against). Here, for a structure matrix ``A`` (n, m) of full rank, a Householder QR of
``A^T = Q_1 R`` gives the null space ``N`` (m, m - n) of ``A`` in the last columns of
the full ``Q``. For a subset ``S`` of ``n - 1`` columns and its complement ``T``
(``m - n + 1`` columns), the normal ``c`` of the plane the columns ``S`` span has
``A^T c = y`` with ``y`` zero on ``S`` and, on ``T``, the normal of the columns of
``N_T`` (``y`` must lie in the row space of ``A``, orthogonal to ``N``): a small
problem of ``m - n + 1`` rows (a perpendicular, a cross product, or
:func:`tension_opt.kernels.facets.column_normal`). Then ``c = Y^T y`` with
``Y = Q_1 R^{-T}``: the products ``c . a_j = y_j`` need no product at all,
``c . v = y . (Y v)`` for the wrench's coefficients ``v`` (au, b, c) and
``|c|^2 = y . (Y Y^T y)``, with ``Y v`` and ``Y Y^T`` computed once per point. Subsets
whose columns are dependent (``y`` below ``1e-12``: the columns of ``N`` are unit
vectors) get zero rows, as in the reference; each pair of rows may come in the other
order (the sign of a normal).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.facets import column_normal

__all__ = ["point_rows_into"]


@njit(cache=True, error_model="numpy")
def _qr(X: NDArray, vs: NDArray, Q: NDArray) -> bool:
    """Householder QR of ``X`` (m, n), ``m >= n``: ``R`` in ``X``'s upper triangle, the
    full orthogonal factor in ``Q`` (m, m); ``vs`` (n, m) is work space. False where a
    diagonal of ``R`` is zero (``X`` of lower rank)."""
    m, n = X.shape
    for c in range(n):
        norm = 0.0
        for i in range(c, m):
            norm += X[i, c] * X[i, c]
        norm = math.sqrt(norm)
        if norm == 0.0:
            return False
        alpha = -norm if X[c, c] >= 0 else norm
        for i in range(m):
            vs[c, i] = 0.0
        vs[c, c] = X[c, c] - alpha
        for i in range(c + 1, m):
            vs[c, i] = X[i, c]
        vnorm = 0.0
        for i in range(c, m):
            vnorm += vs[c, i] * vs[c, i]
        vnorm = math.sqrt(vnorm)
        for i in range(c, m):
            vs[c, i] /= vnorm
        for j in range(c, n):  # X <- (I - 2 v v^T) X
            dot = 0.0
            for i in range(c, m):
                dot += vs[c, i] * X[i, j]
            for i in range(c, m):
                X[i, j] -= 2.0 * vs[c, i] * dot
    for i in range(m):  # Q = H_0 ... H_{n-1}, applied to the identity from the right end
        for j in range(m):
            Q[i, j] = 1.0 if i == j else 0.0
    for c in range(n - 1, -1, -1):
        for j in range(m):
            dot = 0.0
            for i in range(c, m):
                dot += vs[c, i] * Q[i, j]
            for i in range(c, m):
                Q[i, j] -= 2.0 * vs[c, i] * dot
    return True


@njit(cache=True, error_model="numpy", inline="always")
def _complement_normal(B: NDArray, vb: NDArray, y: NDArray) -> None:
    """Unit normal ``y`` (t,) of the columns of ``B`` (t, t - 1), rows of orthonormal
    columns: a perpendicular in two rows, a cross product in three (zero where it is
    below ``1e-12``: dependent columns), else
    :func:`~tension_opt.kernels.facets.column_normal`."""
    t = B.shape[0]
    if t == 2:
        size = math.hypot(B[0, 0], B[1, 0])
        if size <= 1e-12:
            y[0] = y[1] = 0.0
        else:
            y[0], y[1] = B[1, 0] / size, -B[0, 0] / size
    elif t == 3:
        y0 = B[1, 0] * B[2, 1] - B[2, 0] * B[1, 1]
        y1 = B[2, 0] * B[0, 1] - B[0, 0] * B[2, 1]
        y2 = B[0, 0] * B[1, 1] - B[1, 0] * B[0, 1]
        size = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
        if size <= 1e-12:
            y[0] = y[1] = y[2] = 0.0
        else:
            y[0], y[1], y[2] = y0 / size, y1 / size, y2 / size
    else:
        column_normal(B, vb, y)


@njit(cache=True, error_model="numpy")
def point_rows_into(
    A: NDArray,
    lb: NDArray,
    ub: NDArray,
    coef: NDArray,
    gap: NDArray,
    complements: NDArray,
    G: NDArray,
    g: NDArray,
    weight: NDArray,
    moved: NDArray,
) -> bool:
    """The facet rows of every point (module docstring), written.

    A hot numerical kernel: each point's factorisation, then its subsets, in one pass.

    Parameters
    ----------
    A : ndarray, shape (P, n, m)
        Structure matrices, each of full rank ``n <= m``.
    lb, ub : ndarray, shape (P, m)
        Tension bounds (N); ``ub`` may be ``+inf``.
    coef : ndarray, shape (P, n, 3)
        The wrench's coefficients of ``u``, ``x`` and 1 as columns.
    gap : ndarray, shape (P, m)
        How far each tension stays inside its bounds (N).
    complements : ndarray of int, shape (S, m - n + 1)
        The columns not in each subset of ``n - 1`` columns, in the reference's order of
        the subsets.
    G : ndarray, shape (P, 2 S, 2)
    g, weight, moved : ndarray, shape (P, 2 S)
        Written: rows ``G (u, x) <= g``, ``sum_j |c . a_j|`` and ``sum_j |c . a_j|
        gap_j``; row ``s + S`` is row ``s`` of the opposite normal.

    Returns
    -------
    bool
        False if a structure matrix is of lower rank (the rows are then not written).
    """
    P, n, m = A.shape
    S, t = complements.shape
    r = m - n
    X = np.empty((m, n))
    vs = np.empty((n, m))
    Q = np.empty((m, m))
    Yt = np.empty((n, m))  # Y^T = R^{-1} Q_1^T: c = Y^T y
    W = np.empty((m, 3))  # Y v for the wrench's coefficients v
    M = np.empty((m, m))  # Y Y^T: |c|^2 = y^T M y
    B = np.empty((t, r))
    vb = np.empty((max(r, 1), t))
    y = np.empty(t)
    length = np.empty(m)
    for p in range(P):
        for i in range(m):
            size = 0.0
            for k in range(n):
                X[i, k] = A[p, k, i]
                size += A[p, k, i] * A[p, k, i]
            length[i] = math.sqrt(size)
        if not _qr(X, vs, Q):
            return False
        for j in range(m):  # R Y^T = Q_1^T, by back substitution
            for e in range(n - 1, -1, -1):
                acc = Q[j, e]
                for k in range(e + 1, n):
                    acc -= X[e, k] * Yt[k, j]
                Yt[e, j] = acc / X[e, e]
        for i in range(m):
            for k in range(3):
                acc = 0.0
                for e in range(n):
                    acc += Yt[e, i] * coef[p, e, k]
                W[i, k] = acc
            for j in range(i + 1):
                acc = 0.0
                for e in range(n):
                    acc += Yt[e, i] * Yt[e, j]
                M[i, j] = M[j, i] = acc
        for s in range(S):
            for i in range(t):
                for e in range(r):
                    B[i, e] = Q[complements[s, i], n + e]
            _complement_normal(B, vb, y)
            norm2 = 0.0
            for i in range(t):
                for k in range(t):
                    norm2 += y[i] * M[complements[s, i], complements[s, k]] * y[k]
            up = down = size = slack = cu = cx = c1 = 0.0
            if norm2 > 0.0:
                inv = 1.0 / math.sqrt(norm2)
                for i in range(t):
                    j = complements[s, i]
                    cu += y[i] * W[j, 0]  # c . v over T (exact for every column)
                    cx += y[i] * W[j, 1]
                    c1 += y[i] * W[j, 2]
                    proj = y[i] * inv
                    if abs(proj) <= 1e-12 * max(length[j], 1e-300):
                        continue  # the plane's own column, to rounding
                    if proj > 0:
                        up += proj * ub[p, j]
                        down -= proj * lb[p, j]
                    else:
                        up += proj * lb[p, j]
                        down -= proj * ub[p, j]
                    size += abs(proj)
                    slack += abs(proj) * gap[p, j]
                cu, cx, c1 = cu * inv, cx * inv, c1 * inv
            G[p, s, 0], G[p, s, 1], g[p, s] = cu, cx, up - c1
            G[p, s + S, 0], G[p, s + S, 1], g[p, s + S] = -cu, -cx, down + c1
            weight[p, s] = weight[p, s + S] = size
            moved[p, s] = moved[p, s + S] = slack
    return True
