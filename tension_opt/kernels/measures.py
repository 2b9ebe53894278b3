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

__all__ = ["batch_measures"]


@njit(cache=True, inline="always")
def _worst(a: float, b: float) -> float:
    """The larger of two values, NaN if either is NaN (as numpy's maximum)."""
    if math.isnan(a) or math.isnan(b):
        return np.nan
    return a if a >= b else b


@njit(cache=True, nogil=True, error_model="numpy")
def batch_measures(P: NDArray, c: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray,
                   h: NDArray, lb: NDArray, ub: NDArray, x: NDArray, y: NDArray,
                   mu: NDArray, z: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Primal residual, dual residual and relative duality gap of scaled solutions.

    A hot numerical kernel: one pass per pose over its bounds, equations and rows, kept
    in one loop so that nothing is allocated per pose.

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
    N, n, k = Aeq.shape
    g = G.shape[1]
    primal = np.empty(N)
    dual = np.empty(N)
    relative = np.empty(N)
    station = np.empty(k)
    for p in range(N):
        solved = True
        for i in range(k):
            if not math.isfinite(x[p, i]):
                solved = False
        if not solved:
            primal[p] = dual[p] = relative[p] = np.nan
            continue
        worst = 0.0
        gap = 0.0
        objective = 0.0
        for i in range(k):
            xi = x[p, i]
            lo, hi = lb[p, i], ub[p, i]
            if math.isfinite(lo):
                worst = _worst(worst, lo - xi)
            if math.isfinite(hi):
                worst = _worst(worst, xi - hi)
            grad = P[p, i] * xi + c[p, i]
            zi = z[p, i]  # in its cone: >= 0 needs a finite upper bound, <= 0 a lower
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
            objective += (0.5 * P[p, i] * xi + c[p, i]) * xi
        for r in range(n):
            row = -beq[p, r]
            yr = y[p, r]
            for i in range(k):
                row += Aeq[p, r, i] * x[p, i]
                station[i] += Aeq[p, r, i] * yr
            worst = _worst(worst, abs(row))
            gap += beq[p, r] * yr
        for r in range(g):
            row = -h[p, r]
            mr = mu[p, r]
            if mr < 0.0:
                mr = 0.0
            for i in range(k):
                row += G[p, r, i] * x[p, i]
                station[i] += G[p, r, i] * mr
            worst = _worst(worst, row)
            gap += h[p, r] * mr
        stationarity = 0.0
        for i in range(k):
            stationarity = _worst(stationarity, abs(station[i]))
        primal[p] = worst
        dual[p] = stationarity
        relative[p] = abs(gap) / _worst(1.0, abs(objective))
    return primal, dual, relative
