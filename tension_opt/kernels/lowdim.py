"""Compiled minimisation over one- and two-dimensional affine sets ``T = T0 + Z z``,
one pose: the kernels of :mod:`tension_opt.backends.lowdim` (the reference), with the
same candidates, tolerances and tie-breaks.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["FEAS_TOL", "FLAT_TOL", "infeasibility_1d", "interval", "lowdim_work", "lp_2d",
           "qp_2d", "solve_1d"]

FEAS_TOL = 1e-9
FLAT_TOL = 1e-9
#: Problem kinds of the kernels (``StandardForm.kind``).
LP, QP, MINMAX = 0, 1, 2


@njit(cache=True)
def lowdim_work(m: int) -> int:
    """Floats of work space the kernels of this module need for ``m`` cables (the
    two-dimensional enumeration's lines, vertices and candidates, with room for the
    tie-break's nested QP)."""
    lines = 2 * m
    return 4 * lines * lines + 16 * lines + 16


@njit(cache=True, error_model="numpy")
def clip(x: float, lo: float, hi: float) -> float:
    """``numpy.clip`` of one number (``hi`` where ``lo > hi``)."""
    return min(max(x, lo), hi)


@njit(cache=True, error_model="numpy")
def interval(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray, scale: float
             ) -> tuple[float, float]:
    """``[lo, hi]`` of ``t`` with ``lb <= T0 + t n <= ub`` (``lo > hi``: empty)."""
    nmax = 0.0
    for i in range(n.size):
        nmax = max(nmax, abs(n[i]))
    lo, hi = -np.inf, np.inf
    tol = FEAS_TOL * scale
    stuck_bad = False
    for i in range(n.size):
        if abs(n[i]) > 1e-14 * nmax:
            a = (lb[i] - T0[i]) / n[i]
            b = (ub[i] - T0[i]) / n[i]
            low, high = (a, b) if n[i] > 0 else (b, a)
            if math.isnan(low):
                low = -np.inf
            if math.isnan(high):
                high = np.inf
            lo, hi = max(lo, low), min(hi, high)
        elif T0[i] < lb[i] - tol or T0[i] > ub[i] + tol:
            stuck_bad = True
    if stuck_bad:
        return np.inf, -np.inf
    return lo, hi


@njit(cache=True, error_model="numpy")
def infeasibility_1d(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray, work: NDArray
                     ) -> float:
    """Smallest largest bound violation (N) over the line ``T0 + t n`` (``work``: 4 m
    floats)."""
    m = T0.size
    slopes = work[:2 * m]
    intercepts = work[2 * m:4 * m]
    for i in range(m):
        slopes[i], intercepts[i] = -n[i], lb[i] - T0[i]
        slopes[m + i], intercepts[m + i] = n[i], T0[i] - ub[i]
    for j in range(2 * m):
        if not math.isfinite(intercepts[j]):
            slopes[j], intercepts[j] = 0.0, -np.inf
    _, value = min_of_max_lines(slopes, intercepts, -np.inf, np.inf)
    return max(value, 0.0)


@njit(cache=True, error_model="numpy")
def _dot(a: NDArray, b: NDArray) -> float:
    s = 0.0
    for i in range(a.size):
        s += a[i] * b[i]
    return s


@njit(cache=True, error_model="numpy")
def _minmax_t(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray, v: NDArray, lo: float,
              hi: float, scale: float, work: NDArray) -> tuple[float, bool]:
    """Min-max on the line: the minimum-norm point of the optimal interval, and whether
    the optimum is unique (``work``: 3 m floats)."""
    m = T0.size
    slopes, intercepts, cap = work[:m], work[m:2 * m], work[2 * m:3 * m]
    for i in range(m):
        slopes[i], intercepts[i] = v[i] * n[i], v[i] * T0[i]
    t, fstar = min_of_max_lines(slopes, intercepts, lo, hi)
    tol = FEAS_TOL * (abs(fstar) + scale)
    for i in range(m):
        cap[i] = min(ub[i], (fstar + tol) / v[i])
    olo, ohi = interval(T0, n, lb, cap, scale)
    olo, ohi = max(olo, lo), min(ohi, hi)
    nmax = 0.0
    for i in range(m):
        nmax = max(nmax, abs(n[i]))
    width_ok = ohi - olo > 10.0 * tol / max(nmax, 1e-300)
    t_norm = clip(-_dot(T0, n), olo, ohi)
    if width_ok and math.isfinite(t_norm):
        t = t_norm
    return t, not width_ok


@njit(cache=True, error_model="numpy")
def solve_1d(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
             v: NDArray, kind: int, scale: float, T: NDArray, work: NDArray
             ) -> tuple[int, bool, float]:
    """One pose, null space of dimension 1 (``n`` a unit vector): tensions written to
    ``T``; returns ``(code, unique, infeasibility)`` with code 0 optimal, 1 infeasible,
    2 unbounded (:meth:`ClosedFormBackend._solve_1d`). ``work``: 4 m floats."""
    lo, hi = interval(T0, n, lb, ub, scale)
    slack = FEAS_TOL * scale / math.sqrt(_dot(n, n))
    if lo > hi and lo - hi <= slack:
        lo = hi = 0.5 * (lo + hi)
    if not lo <= hi:
        T[:] = np.nan
        return 1, True, infeasibility_1d(T0, n, lb, ub, work)
    unique = True
    if kind == QP:
        curvature = 0.0
        grad = 0.0
        for i in range(T0.size):
            curvature += q[i] * n[i] * n[i]
            grad += (q[i] * T0[i] + c[i]) * n[i]
        t = clip(-grad / curvature, lo, hi)
    elif kind == LP:
        slope = _dot(c, n)
        flat = abs(slope) <= FLAT_TOL * math.sqrt(_dot(c, c))
        t = lo if slope > 0 else hi
        if flat:
            t = clip(-_dot(T0, n), lo, hi)
        unique = not flat or lo == hi
    else:
        t, unique = _minmax_t(T0, n, lb, ub, v, lo, hi, scale, work)
    if not math.isfinite(t):
        T[:] = np.nan
        return 2, unique, np.nan
    for i in range(T0.size):
        T[i] = T0[i] + t * n[i]
    return 0, unique, np.nan


@njit(cache=True, error_model="numpy")
def _lines(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, work: NDArray
           ) -> tuple[NDArray, NDArray, NDArray]:
    """Bounds as half-planes ``a_l . z <= beta_l`` (:func:`tension_opt.problem.affine.bound_lines`),
    and 1.0 where a line is present (a finite bound), in ``work`` (8 m floats)."""
    m = T0.size
    normals = work[:4 * m].reshape((2 * m, 2))
    beta = work[4 * m:6 * m]
    present = work[6 * m:8 * m]
    for i in range(m):
        normals[i, 0], normals[i, 1] = -Z[i, 0], -Z[i, 1]
        normals[m + i, 0], normals[m + i, 1] = Z[i, 0], Z[i, 1]
        beta[i], beta[m + i] = T0[i] - lb[i], ub[i] - T0[i]
    for j in range(2 * m):
        present[j] = 1.0 if math.isfinite(beta[j]) else 0.0
        if present[j] == 0.0:
            beta[j] = 0.0
    return normals, beta, present


@njit(cache=True, error_model="numpy")
def _vertices(normals: NDArray, beta: NDArray, present: NDArray, work: NDArray) -> NDArray:
    """Pairwise intersections of the lines (upper-triangle order), NaN where absent,
    in ``work`` (``L (L - 1)`` floats for ``L`` lines)."""
    L = beta.size
    out = work[:L * (L - 1)].reshape((L * (L - 1) // 2, 2))
    k = 0
    for i in range(L):
        for j in range(i + 1, L):
            out[k, 0], out[k, 1] = _crossing(normals, beta, present, i, j)
            k += 1
    return out


@njit(cache=True, error_model="numpy", inline="always")
def _crossing(normals: NDArray, beta: NDArray, present: NDArray, i: int, j: int
              ) -> tuple[float, float]:
    """Where lines ``i`` and ``j`` cross; NaN where one is absent or they are parallel."""
    a1x, a1y, a2x, a2y = normals[i, 0], normals[i, 1], normals[j, 0], normals[j, 1]
    det = a1x * a2y - a1y * a2x
    x = y = np.nan
    if present[i] != 0.0 and present[j] != 0.0 and abs(det) > 1e-14:
        x = (beta[i] * a2y - beta[j] * a1y) / det
        y = (a1x * beta[j] - a2x * beta[i]) / det
    if (normals.size | beta.size | present.size) < 0:  # never: read last (tension_opt.kernels)
        x = np.nan
    return x, y


@njit(cache=True, error_model="numpy")
def _slacks(normals: NDArray, beta: NDArray, present: NDArray, scale: float,
            out: NDArray) -> NDArray:
    """Right-hand sides with the reference's slack, ``+inf`` for absent lines, written
    to ``out`` (one per line)."""
    for j in range(beta.size):
        a0, a1 = normals[j, 0], normals[j, 1]
        out[j] = (beta[j] + FEAS_TOL * scale * (1.0 + math.sqrt(a0 * a0 + a1 * a1))
                  if present[j] != 0.0 else np.inf)
    return out


@njit(cache=True, error_model="numpy")
def _feasible(z0: float, z1: float, normals: NDArray, limits: NDArray) -> bool:
    """Whether the point satisfies every line within its limit (:func:`_slacks`)."""
    if not (math.isfinite(z0) and math.isfinite(z1)):
        return False
    for j in range(limits.size):
        if not normals[j, 0] * z0 + normals[j, 1] * z1 <= limits[j]:
            return False
    return True


@njit(cache=True, error_model="numpy", inline="always")
def _within(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, scale: float, z0: float,
            z1: float) -> bool:
    """:func:`_feasible` of the point against the lines of :func:`_lines` with the
    limits of :func:`_slacks`, the same arithmetic, without writing the lines."""
    inside = math.isfinite(z0) and math.isfinite(z1)
    for i in range(T0.size):
        a0, a1 = -Z[i, 0], -Z[i, 1]
        slack = FEAS_TOL * scale * (1.0 + math.sqrt(a0 * a0 + a1 * a1))
        low, high = T0[i] - lb[i], ub[i] - T0[i]
        if math.isfinite(low) and not a0 * z0 + a1 * z1 <= low + slack:
            inside = False
        if math.isfinite(high) and not Z[i, 0] * z0 + Z[i, 1] * z1 <= high + slack:
            inside = False
    if (T0.size | Z.size | lb.size | ub.size) < 0:  # never: read last (tension_opt.kernels)
        inside = False
    return inside


@njit(cache=True, error_model="numpy")
def qp_2d(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
          scale: float, work: NDArray) -> tuple[float, float, bool]:
    """Strictly convex QP on a polygon: ``(z0, z1, feasible)`` (:func:`lowdim.qp_2d`);
    ``work`` as :func:`lowdim_work`."""
    h00 = h01 = h11 = g0 = g1 = 0.0
    for i in range(T0.size):
        h00 += Z[i, 0] * q[i] * Z[i, 0]
        h01 += Z[i, 0] * q[i] * Z[i, 1]
        h11 += Z[i, 1] * q[i] * Z[i, 1]
        r = q[i] * T0[i] + c[i]
        g0 += Z[i, 0] * r
        g1 += Z[i, 1] * r
    det = h00 * h11 - h01 * h01
    i00, i01, i11 = h11 / det, -h01 / det, h00 / det
    f0, f1 = -(i00 * g0 + i01 * g1), -(i01 * g0 + i11 * g1)
    if _within(T0, Z, lb, ub, scale, f0, f1):  # the global minimum: no candidate beats it
        return f0, f1, True
    normals, beta, present = _lines(T0, Z, lb, ub, work)
    L = beta.size
    limits = _slacks(normals, beta, present, scale, work[4 * L:5 * L])
    # The candidates of the reference in its order (the minimum on each line, then the
    # lines' crossings), the first feasible one of least value kept. A crossing of lines
    # i and j is worth at least the larger of the two lines' minima, so one whose bound
    # cannot beat the best so far is skipped unseen: the same answer, bit for bit, from
    # a few crossings instead of all.
    points = work[5 * L:7 * L].reshape((L, 2))
    floor = work[7 * L:8 * L]  # each line's minimum value (inf for an absent line)
    finite = True
    for j in range(L):
        points[j, 0] = points[j, 1] = np.nan
        floor[j] = np.inf
        if present[j] != 0.0:
            a0, a1 = normals[j, 0], normals[j, 1]
            ha0, ha1 = i00 * a0 + i01 * a1, i01 * a0 + i11 * a1
            step = (beta[j] - (a0 * f0 + a1 * f1)) / (a0 * ha0 + a1 * ha1)
            x, y = f0 + ha0 * step, f1 + ha1 * step
            points[j, 0], points[j, 1] = x, y
            floor[j] = 0.5 * (h00 * x * x + 2.0 * h01 * x * y + h11 * y * y) + g0 * x + g1 * y
            finite = finite and math.isfinite(floor[j])
    best = np.inf
    z0 = z1 = np.nan
    for j in range(L):
        if (floor[j] < best or math.isnan(z0)) and _feasible(points[j, 0], points[j, 1],
                                                             normals, limits):
            best, z0, z1 = floor[j], points[j, 0], points[j, 1]
    for i in range(L):
        for j in range(i + 1, L):
            bound = max(floor[i], floor[j])
            if finite and bound - best > 1e-9 * (abs(bound) + abs(best)) \
                    and not math.isnan(z0):
                continue  # cannot be of less value (rounding allowed for); where a
                # line's value is not finite, no bound: every crossing, in order
            x, y = _crossing(normals, beta, present, i, j)
            if _feasible(x, y, normals, limits):  # (False for a NaN crossing)
                value = 0.5 * (h00 * x * x + 2.0 * h01 * x * y + h11 * y * y) + g0 * x + g1 * y
                if value < best or math.isnan(z0):
                    best, z0, z1 = value, x, y
    return z0, z1, not math.isnan(z0)


@njit(cache=True, error_model="numpy")
def lp_2d(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, c: NDArray, scale: float,
          work: NDArray) -> tuple[float, float, bool, bool]:
    """LP on a polygon, ties broken to minimum 2-norm: ``(z0, z1, feasible, unique)``
    (:func:`lowdim.lp_2d`); ``work`` as :func:`lowdim_work`."""
    m = T0.size
    normals, beta, present = _lines(T0, Z, lb, ub, work)
    L = beta.size
    limits = _slacks(normals, beta, present, scale, work[4 * L:5 * L])
    P = L * (L - 1) // 2
    cost = work[5 * L:5 * L + P]
    verts = _vertices(normals, beta, present, work[5 * L + P:5 * L + 3 * P])
    rest = work[5 * L + 3 * P:]
    gz0, gz1 = _dot(Z[:, 0], c), _dot(Z[:, 1], c)
    best, arg = np.inf, -1
    for p in range(P):
        cost[p] = np.inf
        if _feasible(verts[p, 0], verts[p, 1], normals, limits):
            cost[p] = verts[p, 0] * gz0 + verts[p, 1] * gz1
            if arg < 0 or cost[p] < best:
                best, arg = cost[p], p
    if not math.isfinite(best):
        return np.nan, np.nan, False, True
    c_norm = math.sqrt(_dot(c, c))
    zz = 0.0
    col0 = col1 = 0.0
    for i in range(m):
        zz += Z[i, 0] * Z[i, 0] + Z[i, 1] * Z[i, 1]
        col0 += Z[i, 0] * Z[i, 0]
        col1 += Z[i, 1] * Z[i, 1]
    flat = math.sqrt(gz0 * gz0 + gz1 * gz1) <= FLAT_TOL * c_norm * math.sqrt(zz)
    tol = FEAS_TOL * abs(best) + FEAS_TOL * scale * c_norm
    lo0 = lo1 = np.inf
    hi0 = hi1 = -np.inf
    for p in range(P):
        if cost[p] <= best + tol:
            lo0, hi0 = min(lo0, verts[p, 0]), max(hi0, verts[p, 0])
            lo1, hi1 = min(lo1, verts[p, 1]), max(hi1, verts[p, 1])
    znorm = math.sqrt(max(col0, col1))
    multi = max((hi0 - lo0) * znorm, (hi1 - lo1) * znorm) > FEAS_TOL * scale * 10.0
    z0, z1 = verts[arg, 0], verts[arg, 1]
    if flat:
        ones, zeros = rest[:m], rest[m:2 * m]
        ones[:] = 1.0
        zeros[:] = 0.0
        z0, z1, _ = qp_2d(T0, Z, lb, ub, ones, zeros, scale, rest[2 * m:])
    elif multi:
        z0, z1 = _edge_min_norm(T0, Z, verts, cost, best + tol, z0, z1)
    return z0, z1, True, not flat and not multi


@njit(cache=True, error_model="numpy")
def _edge_min_norm(T0: NDArray, Z: NDArray, verts: NDArray, cost: NDArray, cut: float,
                   z0: float, z1: float) -> tuple[float, float]:
    """Minimum-norm point of the segment from the chosen optimal vertex to the optimal
    vertex farthest from it."""
    far, far_d = -1, -1.0
    for p in range(verts.shape[0]):
        d = 0.0
        if cost[p] <= cut:
            d = math.hypot(verts[p, 0] - z0, verts[p, 1] - z1)
        if d > far_d:
            far, far_d = p, d
    b0, b1 = verts[far, 0], verts[far, 1]
    num = den = 0.0
    for i in range(T0.size):
        ta = T0[i] + Z[i, 0] * z0 + Z[i, 1] * z1
        dt = Z[i, 0] * (b0 - z0) + Z[i, 1] * (b1 - z1)
        num += ta * dt
        den += dt * dt
    s = clip(-num / den, 0.0, 1.0)
    return z0 + s * (b0 - z0), z1 + s * (b1 - z1)


@njit(cache=True, error_model="numpy")
def min_of_max_lines(slopes: NDArray, intercepts: NDArray, lo: float, hi: float
                     ) -> tuple[float, float]:
    """Minimise ``max_j (slopes_j t + intercepts_j)`` over ``t`` in ``[lo, hi]``:
    ``(t, value)``; lines with intercept ``-inf`` are ignored (one pose of
    :func:`tension_opt.problem.affine.min_of_max_lines`, same choices)."""
    J = slopes.size
    best_v = -np.inf
    best_t = np.nan
    has_pair = any_rising = any_falling = False
    for i in range(J):
        if not math.isfinite(intercepts[i]):
            continue
        if slopes[i] > 0:
            any_rising = True
        elif slopes[i] < 0:
            any_falling = True
    for i in range(J):
        if not (slopes[i] > 0 and math.isfinite(intercepts[i])):
            continue
        for j in range(J):
            if not (slopes[j] < 0 and math.isfinite(intercepts[j])):
                continue
            t_cross = (intercepts[j] - intercepts[i]) / (slopes[i] - slopes[j])
            v = slopes[i] * t_cross + intercepts[i]
            if not has_pair or v > best_v:
                best_v, best_t = v, t_cross
                has_pair = True
    if has_pair:
        t_free = best_t
    elif any_rising:
        t_free = -np.inf
    elif any_falling:
        t_free = np.inf
    else:
        t_free = 0.0
    t = min(max(t_free, lo), hi)
    value = -np.inf
    for j in range(J):
        if not math.isfinite(intercepts[j]):
            continue
        line = intercepts[j] if slopes[j] == 0 else slopes[j] * t + intercepts[j]
        if line > value or math.isnan(line):
            value = line
    return t, value
