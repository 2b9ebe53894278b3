"""The certificate over a batch, compiled: its three measures and its cheap dual solve.

Measures.

The reference is :func:`tension_opt.certify.certificate.measures_reference` (the module
docstring of :mod:`tension_opt.certify.certificate` defines the measures). Measuring a small
batch takes some twenty numpy operations, as long as a small DAQP solve, and every
solve measures at least twice (the backend's certificate, then the solution's); this
kernel measures each pose in one pass. Sums run in another order than numpy's, so the
two agree to rounding; NaN propagates as in numpy (a NaN anywhere in a pose's terms
makes its measure NaN, and a pose without a finite solution gets NaN measures).
Multipliers. The reference is
:func:`tension_opt.certify.certificate.estimate_multipliers_reference` (the
fit itself is described there): per pose, a weighted least-squares fit of
stationarity in the multipliers of the equations and rows, ``z`` eliminated in closed
form. numpy solves it with a batched LAPACK call on (N, r, r) arrays built by several
broadcasts, which takes longer than the closed form it certifies; this kernel builds
and solves each pose's small system in place (Gaussian elimination with partial
pivoting, as LAPACK's ``gesv`` does for matrices this small), so both agree to
rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["batch_estimate", "batch_measures", "nan_max", "pose_estimate",
           "pose_measures", "solve_small"]


@njit(cache=True, inline="always")
def nan_max(a: float, b: float) -> float:
    """The larger of two values, NaN if either is NaN (as numpy's maximum)."""
    if math.isnan(a) or math.isnan(b):
        return np.nan
    return a if a >= b else b


@njit(cache=True, error_model="numpy", inline="always")
def pose_measures(P: NDArray, c: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray,
                  h: NDArray, lb: NDArray, ub: NDArray, x: NDArray, y: NDArray,
                  mu: NDArray, z: NDArray, station: NDArray) -> tuple[float, float, float]:
    """Primal residual, dual residual and relative duality gap of one scaled pose
    (the arrays of :func:`batch_measures` at one pose; ``station`` (k,) work space),
    in one pass over its bounds, equations and rows; NaN for a solution ``x`` that
    is not finite."""
    n, k = Aeq.shape
    g = G.shape[0]
    solved = True
    for i in range(k):
        solved = solved and math.isfinite(x[i])
    worst = 0.0
    gap = 0.0
    objective = 0.0
    for i in range(k):
        xi = x[i]
        lo, hi = lb[i], ub[i]
        if math.isfinite(lo):
            worst = nan_max(worst, lo - xi)
        if math.isfinite(hi):
            worst = nan_max(worst, xi - hi)
        grad = P[i] * xi + c[i]
        zi = z[i]  # in its cone: >= 0 needs a finite upper bound, <= 0 a lower
        if zi > 0.0 and not math.isfinite(hi):
            zi = 0.0
        elif zi < 0.0 and not math.isfinite(lo):
            zi = 0.0
        station[i] = grad + zi
        gap += grad * xi
        if zi > 0.0:
            gap += hi * zi
        elif zi < 0.0:
            gap += lo * zi
        elif math.isnan(zi):
            gap = np.nan
        objective += (0.5 * P[i] * xi + c[i]) * xi
    for r in range(n):
        row = -beq[r]
        yr = y[r]
        for i in range(k):
            row += Aeq[r, i] * x[i]
            station[i] += Aeq[r, i] * yr
        worst = nan_max(worst, abs(row))
        gap += beq[r] * yr
    for r in range(g):
        row = -h[r]
        mr = mu[r]
        if mr < 0.0:
            mr = 0.0
        for i in range(k):
            row += G[r, i] * x[i]
            station[i] += G[r, i] * mr
        worst = nan_max(worst, row)
        gap += h[r] * mr
    stationarity = 0.0
    for i in range(k):
        stationarity = nan_max(stationarity, abs(station[i]))
    relative = abs(gap) / nan_max(1.0, abs(objective))
    if not solved:
        worst = stationarity = relative = np.nan
    # One return (see tension_opt.kernels): the arrays' reference counts pruned.
    return worst, stationarity, relative


@njit(cache=True, nogil=True, error_model="numpy")
def batch_measures(P: NDArray, c: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray,
                   h: NDArray, lb: NDArray, ub: NDArray, x: NDArray, y: NDArray,
                   mu: NDArray, z: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Primal residual, dual residual and relative duality gap of scaled solutions
    (:func:`pose_measures` per pose; nothing allocated per pose).

    Parameters
    ----------
    P, c, lb, ub, x, z : ndarray, shape (N, k)
    Aeq : ndarray, shape (N, n, k)
    beq, y : ndarray, shape (N, n)
    G : ndarray, shape (N, g, k)
    h, mu : ndarray, shape (N, g)
        The scaled batch (:class:`tension_opt.certify.scaling.ScaledBatch`), the solutions and
        the multipliers as given (put in their cones here).

    Returns
    -------
    primal, dual, gap : ndarray, shape (N,)
    """
    N, _, k = Aeq.shape
    primal = np.empty(N)
    dual = np.empty(N)
    relative = np.empty(N)
    station = np.empty(k)
    for p in range(N):
        primal[p], dual[p], relative[p] = pose_measures(
            P[p], c[p], Aeq[p], beq[p], G[p], h[p], lb[p], ub[p], x[p], y[p], mu[p], z[p],
            station)
    return primal, dual, relative

#: Largest finite double (``np.nan_to_num``'s stand-in for an infinite multiplier).
_HUGE = np.finfo(np.float64).max


@njit(cache=True, error_model="numpy", inline="always")
def solve_small(H: NDArray, u: NDArray) -> bool:
    """Solve ``H v = u`` in place (``u`` becomes ``v``; ``H`` is overwritten) by
    Gaussian elimination with partial pivoting; False for a zero pivot."""
    r = H.shape[0]
    ok = True
    for col in range(r):
        pivot = col
        for row in range(col + 1, r):
            if abs(H[row, col]) > abs(H[pivot, col]):
                pivot = row
        if H[pivot, col] == 0.0 or not math.isfinite(H[pivot, col]):
            ok = False
            break
        if pivot != col:
            for j in range(r):
                H[col, j], H[pivot, j] = H[pivot, j], H[col, j]
            u[col], u[pivot] = u[pivot], u[col]
        for row in range(col + 1, r):
            factor = H[row, col] / H[col, col]
            if factor != 0.0:
                for j in range(col, r):
                    H[row, j] -= factor * H[col, j]
                u[row] -= factor * u[col]
    for col in range(r - 1 if ok else -1, -1, -1):
        total = u[col]
        for j in range(col + 1, r):
            total -= H[col, j] * u[j]
        u[col] = total / H[col, col]
    # One return (see tension_opt.kernels): the arrays' reference counts pruned.
    return ok


@njit(cache=True, error_model="numpy", inline="always")
def pose_estimate(P: NDArray, c: NDArray, Aeq: NDArray, G: NDArray, h: NDArray,
                  lb: NDArray, ub: NDArray, x: NDArray, ridge: float, y: NDArray,
                  mu: NDArray, z: NDArray, B: NDArray, H: NDArray, u: NDArray,
                  grad: NDArray, shrink: NDArray) -> bool:
    """Multipliers ``y`` (n,), ``mu`` (g,), ``z`` (k,) of one solved scaled pose (the
    arrays of :func:`batch_estimate` at one pose), written; its normal equations built
    and solved in place in the work arrays ``B`` (k, n + g), ``H`` (n + g, n + g),
    ``u`` (n + g,), ``grad`` and ``shrink`` (k,). False (and NaN multipliers) where
    the system is singular."""
    n, k = Aeq.shape
    g = G.shape[0]
    r = n + g
    for i in range(k):
        grad[i] = P[i] * x[i] + c[i]
        near = min(abs(x[i] - lb[i]), abs(ub[i] - x[i]))
        shrink[i] = 1.0 / (1.0 + near * near)  # 0 where there is no bound
        for j in range(n):
            B[i, j] = Aeq[j, i]
        for j in range(g):
            B[i, n + j] = G[j, i]
    # The normal equations, each entry summed over i in order; i outermost, so that the
    # entries' sums run side by side.
    for a in range(r):
        u[a] = 0.0
        for b in range(a, r):
            H[a, b] = 0.0
    for i in range(k):
        weight = 1.0 - shrink[i]
        for a in range(r):
            Bw = B[i, a] * weight
            u[a] -= Bw * grad[i]
            for b in range(a, r):
                H[a, b] += Bw * B[i, b]
    top = 0.0
    for a in range(r):
        for b in range(a + 1, r):
            H[b, a] = H[a, b]
        top = max(top, abs(H[a, a]))
    top = max(top, 1.0)
    for a in range(r):
        extra = 0.0
        if a >= n:
            slack = 0.0
            for i in range(k):
                slack += G[a - n, i] * x[i]
            slack = min(abs(h[a - n] - slack), 1e6)
            extra = slack * slack
        H[a, a] += extra + ridge * top
    ok = solve_small(H, u)
    for j in range(n):
        y[j] = u[j] if ok else np.nan
    for j in range(g):
        mu[j] = u[n + j] if ok else np.nan
    for i in range(k):
        total = grad[i]
        for a in range(r):
            total += B[i, a] * u[a]
        zi = -total * shrink[i]
        if math.isnan(zi):
            zi = 0.0
        elif math.isinf(zi):
            zi = _HUGE if zi > 0 else -_HUGE
        z[i] = zi if ok else np.nan
    return ok


@njit(cache=True, nogil=True, error_model="numpy")
def batch_estimate(P: NDArray, c: NDArray, Aeq: NDArray, G: NDArray, h: NDArray,
                   lb: NDArray, ub: NDArray, x: NDArray, ridge: float
                   ) -> tuple[NDArray, NDArray, NDArray]:
    """Multipliers ``y`` (N, n), ``mu`` (N, g), ``z`` (N, k) of solved scaled poses
    (:func:`pose_estimate` per pose, without the (N, k, n + g) temporaries of the
    numpy reference).

    Parameters
    ----------
    P, c, lb, ub, x : ndarray, shape (N, k)
    Aeq : ndarray, shape (N, n, k)
    G : ndarray, shape (N, g, k)
    h : ndarray, shape (N, g)
        The scaled batch and its solutions (every row finite).
    ridge : float
        Ridge of the fit, relative to the largest diagonal entry (at least 1).

    Returns
    -------
    y, mu, z : ndarray
        NaN rows where the system is singular.
    """
    N, n, k = Aeq.shape
    g = G.shape[1]
    r = n + g
    y = np.empty((N, n))
    mu = np.empty((N, g))
    z = np.empty((N, k))
    B = np.empty((k, r))
    H = np.empty((r, r))
    u = np.empty(r)
    grad = np.empty(k)
    shrink = np.empty(k)
    for p in range(N):
        pose_estimate(P[p], c[p], Aeq[p], G[p], h[p], lb[p], ub[p], x[p], ridge, y[p], mu[p],
                      z[p], B, H, u, grad, shrink)
    return y, mu, z
