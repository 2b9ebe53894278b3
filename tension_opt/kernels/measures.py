"""The three measures of the certificate over a batch, compiled.

The reference is :func:`tension_opt.certificate.measures_reference` (the module
docstring of :mod:`tension_opt.certificate` defines the measures). Measuring a small
batch takes some twenty numpy operations, as long as a small DAQP solve, and every
solve measures at least twice (the backend's certificate, then the solution's); this
kernel measures each pose in one pass. Sums run in another order than numpy's, so the
two agree to rounding; NaN propagates as in numpy (a NaN anywhere in a pose's terms
makes its measure NaN, and a pose without a finite solution gets NaN measures).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["batch_measures", "nan_max", "pose_measures"]


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
        The scaled batch (:class:`tension_opt.scaled.ScaledBatch`), the solutions and
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
