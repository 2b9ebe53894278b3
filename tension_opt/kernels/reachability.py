"""TOPP-RA's reachability passes, compiled: two-variable LPs over each grid point's rows.

The twin of :mod:`tension_opt.dynamics.reachability` (its HiGHS passes over
:class:`~tension_opt.dynamics.stage_lp.StageLP`, the reference these kernels are tested
against). Here every grid point's constraints are rows ``a . (u, x) <= b`` in the path
acceleration ``u`` and squared speed ``x`` alone (the wrench-feasible sets by their
facets: :mod:`tension_opt.dynamics.stage_rows`), unit ``a``, and each LP has two
variables: Seidel's incremental algorithm (the optimum of the rows so far; a row it
violates puts the new optimum on that row's line, a one-dimensional LP over the rows
before it), deterministic, in the rows' order.

Rows of grid point ``k`` are ``rows[start[k]:start[k + 1]]``; ``x`` of grid point ``k``
is also at most ``x_top[k]`` (its own velocity limits). The passes run over a range of
grid points, so that a caller can look at the clock between calls.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["BIG", "INFEASIBLE", "OPTIMAL", "UNBOUNDED", "backward_pass", "forward_pass", "lp2",
           "stage_feasible"]

#: The box ``|u|, x <= BIG`` that keeps every LP bounded; an optimum on it is unbounded.
BIG = 1e15
#: Feasibility tolerance of a row, relative to ``1 + |b|`` (rows have unit normals).
ROW_TOL = 1e-9
#: Outcomes.
OPTIMAL, INFEASIBLE, UNBOUNDED = 0, 1, 2


@njit(cache=True, inline="always")
def _row(rows: NDArray, rhs: NDArray, first: int, extra: NDArray, n_extra: int, j: int
         ) -> tuple[float, float, float]:
    """Constraint ``j`` of an LP: the extra rows first, then ``rows[first:]``."""
    if j < n_extra:
        return extra[j, 0], extra[j, 1], extra[j, 2]
    i = first + j - n_extra
    return rows[i, 0], rows[i, 1], rhs[i]


@njit(cache=True, error_model="numpy")
def _line_lp(rows: NDArray, rhs: NDArray, first: int, extra: NDArray, n_extra: int,
             j: int, c0: float, c1: float, box: NDArray, v0: float, v1: float
             ) -> tuple[bool, float, float]:
    """Minimise ``c . z`` on the line of constraint ``j`` within the box and the
    constraints before it: (feasible, u, x)."""
    a0, a1, b = _row(rows, rhs, first, extra, n_extra, j)
    norm2 = a0 * a0 + a1 * a1
    if norm2 == 0.0:
        return False, v0, v1
    p0, p1 = a0 * b / norm2, a1 * b / norm2
    d0, d1 = -a1, a0
    lo, hi = -np.inf, np.inf
    for axis in range(2):  # box[0] <= u <= box[1], box[2] <= x <= box[3]
        p, d = (p0, d0) if axis == 0 else (p1, d1)
        blo, bhi = box[2 * axis], box[2 * axis + 1]
        if abs(d) > 1e-15:
            t1, t2 = (blo - p) / d, (bhi - p) / d
            lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
        elif p < blo - ROW_TOL * (1.0 + abs(blo)) or p > bhi + ROW_TOL * (1.0 + abs(bhi)):
            return False, v0, v1
    for i in range(j):
        e0, e1, eb = _row(rows, rhs, first, extra, n_extra, i)
        ad = e0 * d0 + e1 * d1
        room = eb - (e0 * p0 + e1 * p1)
        if abs(ad) > 1e-12:
            if ad > 0:
                hi = min(hi, room / ad)
            else:
                lo = max(lo, room / ad)
        elif room < -ROW_TOL * (1.0 + abs(eb)):
            return False, v0, v1
    if lo > hi:
        if lo - hi > ROW_TOL * (1.0 + abs(lo) + abs(hi)):
            return False, v0, v1
        lo = hi = 0.5 * (lo + hi)
    slope = c0 * d0 + c1 * d1
    if slope > 1e-14:
        t = lo
    elif slope < -1e-14:
        t = hi
    else:  # flat: the point of the line closest to the last optimum
        t = min(max((v0 - p0) * d0 + (v1 - p1) * d1, lo), hi)
    return True, p0 + t * d0, p1 + t * d1


@njit(cache=True, error_model="numpy")
def lp2(rows: NDArray, rhs: NDArray, first: int, last: int, extra: NDArray, n_extra: int,
        c0: float, c1: float, box: NDArray) -> tuple[int, float, float]:
    """Minimise ``c0 u + c1 x`` over ``rows[first:last] . (u, x) <= rhs``, the first
    ``n_extra`` rows ``(a0, a1, b)`` of ``extra`` (taken first) and ``box`` (u_lo, u_hi,
    x_lo, x_hi), rows of unit normal: (outcome, u, x)."""
    if box[0] > box[1] or box[2] > box[3]:
        return INFEASIBLE, 0.0, 0.0
    v0 = box[0] if c0 > 0 else (box[1] if c0 < 0 else min(max(0.0, box[0]), box[1]))
    v1 = box[2] if c1 > 0 else (box[3] if c1 < 0 else min(max(0.0, box[2]), box[3]))
    for j in range(n_extra + last - first):
        a0, a1, b = _row(rows, rhs, first, extra, n_extra, j)
        if a0 * v0 + a1 * v1 <= b + ROW_TOL * (1.0 + abs(b)):
            continue
        ok, v0, v1 = _line_lp(rows, rhs, first, extra, n_extra, j, c0, c1, box, v0, v1)
        if not ok:
            return INFEASIBLE, v0, v1
    return OPTIMAL, v0, v1


@njit(cache=True, error_model="numpy")
def _next_rows(extra: NDArray, step: float, lo: float, hi: float) -> int:
    """``lo <= x + step u <= hi`` as unit rows in ``extra``; how many."""
    norm = math.sqrt(step * step + 1.0)
    n = 0
    if hi < np.inf:
        extra[n, 0], extra[n, 1], extra[n, 2] = step / norm, 1.0 / norm, hi / norm
        n += 1
    if lo > -np.inf:
        extra[n, 0], extra[n, 1], extra[n, 2] = -step / norm, -1.0 / norm, -lo / norm
        n += 1
    return n


@njit(cache=True, error_model="numpy")
def backward_pass(rows: NDArray, rhs: NDArray, start: NDArray, x_top: NDArray,
                  grid: NDArray, sets: NDArray, k_from: int, k_to: int) -> tuple[int, int]:
    """The controllable sets ``sets[k] = (K_lo, K_hi)`` (inf: unbounded) for
    ``k = k_from, k_from - 1, ..., k_to`` (``sets[k_from + 1]`` known; at the last grid
    point pass ``k_from = K - 1``: at rest). Returns (the point where a set is empty,
    or -1; its outcome)."""
    K = grid.size
    extra = np.empty((2, 3))
    box = np.empty(4)
    for k in range(k_from, k_to - 1, -1):
        box[0], box[1] = -BIG, BIG
        box[2], box[3] = 0.0, min(x_top[k], BIG)
        if k == K - 1:
            box[3] = 0.0
            n = 0
        else:
            hi = sets[k + 1, 1]
            n = _next_rows(extra, 2.0 * (grid[k + 1] - grid[k]), sets[k + 1, 0],
                           hi if hi < BIG else np.inf)
        out, _, lo = lp2(rows, rhs, start[k], start[k + 1], extra, n, 0.0, 1.0, box)
        if out != OPTIMAL:
            return k, out
        out, u_top, top = lp2(rows, rhs, start[k], start[k + 1], extra, n, 0.0, -1.0, box)
        if out != OPTIMAL:
            return k, out
        sets[k, 0] = max(lo, 0.0)
        # On the box: nothing but the box bounds it.
        on_box = max(top, abs(u_top)) >= BIG * (1.0 - 1e-9)
        sets[k, 1] = np.inf if on_box else top
    return -1, OPTIMAL


@njit(cache=True, error_model="numpy")
def _largest_u(rows: NDArray, rhs: NDArray, first: int, last: int, x: float, step: float,
               lo: float, hi: float) -> tuple[float, float]:
    """The interval of ``u`` the rows leave at ``x`` with ``lo <= x + step u <= hi``."""
    u_lo, u_hi = (lo - x) / step, (hi - x) / step
    for i in range(first, last):
        a0, room = rows[i, 0], rhs[i] - rows[i, 1] * x
        if a0 > 1e-15:
            u_hi = min(u_hi, room / a0)
        elif a0 < -1e-15:
            u_lo = max(u_lo, room / a0)
        elif room < -ROW_TOL * (1.0 + abs(rhs[i])):
            return np.inf, -np.inf
    slack = ROW_TOL * (1.0 + abs(u_lo) + abs(u_hi))
    if u_lo > u_hi and u_lo - u_hi <= slack:
        u_lo = u_hi
    return u_lo, u_hi


@njit(cache=True, error_model="numpy")
def forward_pass(rows: NDArray, rhs: NDArray, start: NDArray, grid: NDArray,
                 sets: NDArray, top: NDArray, x: NDArray, u: NDArray, k_from: int,
                 k_to: int, retries: int, backoff: float) -> tuple[int, int]:
    """Greedy forward pass over ``k = k_from .. k_to - 1``: the largest ``u_k`` that
    keeps ``x_{k+1}`` in ``[sets[k + 1, 0], top[k + 1]]``, ``x[k]`` given (lowered by
    ``backoff`` up to ``retries`` times where rounding left it just outside). Returns
    the point where no ``u`` is feasible (or none bounds it), or -1, and the outcome."""
    for k in range(k_from, k_to):
        step = 2.0 * (grid[k + 1] - grid[k])
        lo, hi = sets[k + 1, 0], top[k + 1]
        u_lo, u_hi = _largest_u(rows, rhs, start[k], start[k + 1], x[k], step, lo, hi)
        tries = 0
        while u_lo > u_hi and x[k] > 0.0 and tries < retries:
            x[k] *= 1.0 - backoff
            u_lo, u_hi = _largest_u(rows, rhs, start[k], start[k + 1], x[k], step, lo, hi)
            tries += 1
        if u_lo > u_hi:
            return k, INFEASIBLE
        if not u_hi < np.inf:
            return k, UNBOUNDED
        x[k + 1] = min(max(x[k] + step * u_hi, lo), hi)
        u[k] = (x[k + 1] - x[k]) / step
    return -1, OPTIMAL


@njit(cache=True, error_model="numpy")
def stage_feasible(rows: NDArray, rhs: NDArray, start: NDArray, x_top: NDArray) -> NDArray:
    """Whether any ``(u, x >= 0)`` meets each grid point's rows, shape (K,) of bool."""
    K = start.size - 1
    out = np.zeros(K, np.bool_)
    extra = np.empty((2, 3))
    box = np.empty(4)
    for k in range(K):
        box[0], box[1], box[2], box[3] = -BIG, BIG, 0.0, min(x_top[k], BIG)
        out[k] = lp2(rows, rhs, start[k], start[k + 1], extra, 0, 0.0, 1.0, box)[0] == OPTIMAL
    return out
