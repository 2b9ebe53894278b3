"""How each pose is nondimensionalised for the solvers, compiled.

The reference is :meth:`tension_opt.problem.form.StandardForm.scaling` (see
:mod:`tension_opt.problem.form` for the scaling itself): the reference tension of a pose,
its equilibrium rows' factors, the size of its objective. In numpy it takes some
thirty small array operations, longer than a small DAQP solve; this kernel does it in
one pass per pose, with the same guards (norms measured without overflow, a finite
stand-in where the reference tension overflows, the row floor and the upper-bound
share), so both agree to rounding.

:func:`pose_scaling` is one pose (also used by the real-time DAQP path,
:mod:`tension_opt.kernels.dense_qp`); :func:`batch_scaling` runs it over a batch;
:func:`pose_scaled` writes one pose's whole scaled problem (the certified closed form,
:mod:`tension_opt.kernels.certified`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["batch_scaling", "pose_scaled", "pose_scaling", "safe_norm_of"]


@njit(cache=True, error_model="numpy", inline="always")
def safe_norm_of(x: NDArray) -> float:
    """Euclidean norm of a vector without overflow or underflow of the squares (the
    entries are divided by the largest magnitude first); inf or NaN for a non-finite
    entry, as :func:`tension_opt.problem.affine.safe_norm`."""
    top = 0.0
    for v in x:
        a = abs(v)
        if not a <= top:  # NaN propagates
            top = a
    norm = top
    if top != 0.0 and math.isfinite(top):
        total = 0.0
        for v in x:
            r = v / top
            total += r * r
        norm = top * math.sqrt(total)
    if x.size < 0:  # never: x read after the branch (see tension_opt.kernels)
        norm = np.nan
    return norm


@njit(cache=True, error_model="numpy", inline="always")
def pose_scaling(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
                 vmax: float, ub_share: float, row_floor: float, rows: NDArray
                 ) -> tuple[float, float, bool]:
    """Scaling of one pose, as :meth:`~tension_opt.problem.form.StandardForm.scaling`.

    Parameters
    ----------
    A : ndarray, shape (n, m)
    b : ndarray, shape (n,)
    lb, ub, q, c : ndarray, shape (m,)
        Bounds (N), Hessian diagonal and cost of the form.
    vmax : float
        Largest min-max weight (0 without a min-max term).
    ub_share, row_floor : float
        :data:`~tension_opt.problem.form.UB_SHARE`, :data:`~tension_opt.problem.form.ROW_FLOOR`.
    rows : ndarray, shape (n,)
        Written: the factors of the equilibrium rows.

    Returns
    -------
    tuple
        ``(tension, top, quadratic)``: the reference tension (N), the objective's
        largest Hessian entry or cost, and whether the objective is quadratic.
    """
    n, m = A.shape
    col = 0.0
    for j in range(m):
        col = max(col, safe_norm_of(A[:, j]))
    top_lb = 0.0
    top_ub = 0.0
    for i in range(m):
        if math.isfinite(lb[i]):
            top_lb = max(top_lb, abs(lb[i]))
        if math.isfinite(ub[i]):
            top_ub = max(top_ub, abs(ub[i]))
    s = max(max(safe_norm_of(b) / max(col, 1e-300), top_lb), 1e-12)
    if not math.isfinite(s):  # a wrench near 1e300 N: a finite stand-in
        big = 0.0
        for k in range(n):
            big = max(big, abs(b[k]))
        s = max(max(big, top_lb), 1e-12)
    s = max(s, ub_share * top_ub)
    longest = 0.0
    for k in range(n):
        norm = 0.0
        for i in range(m):
            norm += A[k, i] * A[k, i]
        rows[k] = math.sqrt(norm)  # inf where the squares overflow, as numpy's norm
        longest = max(longest, rows[k])
    floor = row_floor * longest
    for k in range(n):
        size = max(rows[k], floor)
        rows[k] = 1.0 / size if size > 0.0 and math.isfinite(size) else 1.0
    quadratic = 0.0
    linear = 0.0
    for i in range(m):
        quadratic = max(quadratic, q[i])
        linear = max(linear, abs(c[i]))
    if vmax > 0.0:
        linear = max(linear, vmax)
    square = quadratic > 0.0
    if (A.size | b.size | lb.size | ub.size | q.size | c.size | rows.size) < 0:
        s = np.nan  # never: the arrays read after the branches (tension_opt.kernels)
    return s, quadratic if square else (linear if linear > 0.0 else 1.0), square


@njit(cache=True, error_model="numpy", inline="always")
def pose_scaled(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
                v: NDArray, vmax: float, ub_share: float, row_floor: float, rows: NDArray,
                P: NDArray, cs: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray, h: NDArray,
                lbs: NDArray, ubs: NDArray, again: bool) -> float:
    """The scaled, lifted problem of one pose, as :func:`tension_opt.certify.scaling.scaled_batch`
    writes it (its numpy reference), from the pose's form (``A`` (n, m), ``b`` (n,),
    ``lb``, ``ub``, ``q``, ``c`` (m,)).

    Parameters
    ----------
    v : ndarray, shape (m,)
        Min-max weights (read only with a min-max term).
    vmax : float
        Largest min-max weight, 0 without a min-max term (:func:`pose_scaling`).
    ub_share, row_floor : float
        As :func:`pose_scaling`.
    rows : ndarray, shape (n,)
        Written: the factors of the equilibrium rows.
    P, cs, lbs, ubs : ndarray, shape (k,)
    Aeq : ndarray, shape (n, k)
    beq : ndarray, shape (n,)
    G : ndarray, shape (g, k)
    h : ndarray, shape (g,)
        Written: the scaled problem, ``k = m + 1`` and ``g = m`` with a min-max term
        (its epigraph variable and rows), else ``k = m`` and ``g = 0``.
    again : bool
        Whether these arrays hold the scaled problem of another pose with the same
        ``q``, ``c``, ``v`` and bounds: what does not depend on the pose (``P``, a
        linear ``cs``, the epigraph's rows and bounds) is then left as it is.

    Returns
    -------
    float
        The reference tension ``s`` (N): ``T = s x``.
    """
    n, m = A.shape
    s, top, quadratic = pose_scaling(A, b, lb, ub, q, c, vmax, ub_share, row_floor, rows)
    per_s = s if quadratic else 1.0  # a QP's linear term also shrinks by s
    # (Loops that run only where needed, rather than branches: see tension_opt.kernels.)
    for i in range(m):
        lbs[i] = lb[i] / s
        ubs[i] = ub[i] / s
    for i in range(0 if again else m):
        P[i] = q[i] / top
    for i in range(0 if again and not quadratic else m):
        cs[i] = c[i] / top / per_s
    for r in range(n):
        for i in range(m):
            Aeq[r, i] = A[r, i] * rows[r]
        beq[r] = b[r] * rows[r] / s
    # The epigraph variable t >= (v_i / vmax) x_i of a min-max term and its m rows.
    unit = vmax if vmax > 0.0 else 1.0
    for j in range(m, P.shape[0]):
        cs[j] = unit / top / per_s
    for j in range(P.shape[0] if again else m, P.shape[0]):
        P[j], lbs[j], ubs[j] = 0.0, -np.inf, np.inf
        for r in range(n):
            Aeq[r, j] = 0.0
    for r in range(0 if again else G.shape[0]):
        for i in range(m):
            G[r, i] = 0.0
        G[r, r], G[r, m], h[r] = v[r] / unit, -1.0, 0.0
    return s


@njit(cache=True, nogil=True, error_model="numpy")
def batch_scaling(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
                  vmax: float, ub_share: float, row_floor: float
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """:func:`pose_scaling` of every pose of a batch (A (N, n, m), b (N, n), the rest
    (N, m)); returns ``tension`` (N,), ``rows`` (N, n), ``top`` (N,), ``quadratic``
    (N,)."""
    N, n, _ = A.shape
    tension = np.empty(N)
    rows = np.empty((N, n))
    top = np.empty(N)
    quadratic = np.empty(N, dtype=np.bool_)
    for p in range(N):
        tension[p], top[p], quadratic[p] = pose_scaling(A[p], b[p], lb[p], ub[p], q[p], c[p],
                                                        vmax, ub_share, row_floor, rows[p])
    return tension, rows, top, quadratic
