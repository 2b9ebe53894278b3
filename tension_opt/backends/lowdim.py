"""Exact, vectorised minimisation over one- and two-dimensional affine sets.

Tensions are written ``T = T0 + Z z`` with ``z`` in R^k (k = 1 or 2): the null-space
parameterisation of a redundant robot (``Z`` spans the null space of ``A``) or the
optimal face of an LP. Bounds ``lb <= T <= ub`` become half-planes in ``z``; the
optimum of a convex diagonal quadratic or of a linear cost is found by enumerating
its few possible locations (free minimum, minimum on each bounding line, vertices)
for all poses at once. There is no iteration and no tolerance beyond rounding. The
capacity margin uses the bound lines and the minimum of a maximum of lines too.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["FEAS_TOL", "FLAT_TOL", "bound_lines", "infeasibility_1d", "interval", "lp_2d",
           "min_of_max_lines", "qp_2d", "widen"]

# Relative tolerance on feasibility tests and on flat (tied) directions.
FEAS_TOL = 1e-9
FLAT_TOL = 1e-9


def interval(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray, scale: NDArray
             ) -> tuple[NDArray, NDArray]:
    """Interval ``[lo, hi]`` of ``t`` with ``lb <= T0 + t n <= ub``.

    Parameters
    ----------
    T0, n, lb, ub : ndarray, shape (N, m)
    scale : ndarray, shape (N,)
        Typical tension, for the tolerance on cables that do not move with ``t``.

    Returns
    -------
    lo, hi : ndarray, shape (N,)
        ``lo > hi`` where the set is empty.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (lb - T0) / n
        b = (ub - T0) / n
    moving = np.abs(n) > 1e-14 * np.abs(n).max(axis=1, keepdims=True)
    low = np.where(moving, np.where(n > 0, a, b), -np.inf)
    high = np.where(moving, np.where(n > 0, b, a), np.inf)
    low = np.where(np.isnan(low), -np.inf, low)
    high = np.where(np.isnan(high), np.inf, high)
    lo, hi = low.max(axis=1), high.min(axis=1)
    # A cable that does not move with t must already be within its bounds.
    tol = FEAS_TOL * scale[:, None]
    stuck_bad = (~moving & ((T0 < lb - tol) | (T0 > ub + tol))).any(axis=1)
    lo = np.where(stuck_bad, np.inf, lo)
    hi = np.where(stuck_bad, -np.inf, hi)
    return lo, hi


def widen(lo: NDArray, hi: NDArray, n: NDArray, scale: NDArray) -> tuple[NDArray, NDArray]:
    """Accept intervals empty by rounding only: ``lo - hi`` below tolerance becomes a point."""
    slack = FEAS_TOL * scale / np.linalg.norm(n, axis=1)
    tight = (lo > hi) & (lo - hi <= slack)
    with np.errstate(invalid="ignore"):
        mid = 0.5 * (lo + hi)
    return np.where(tight, mid, lo), np.where(tight, mid, hi)


def infeasibility_1d(T0: NDArray, n: NDArray, lb: NDArray, ub: NDArray) -> NDArray:
    """Smallest largest bound violation (N) over the line ``T0 + t n``, shape (N,)."""
    slopes = np.concatenate([-n, n], axis=1)
    intercepts = np.concatenate([lb - T0, T0 - ub], axis=1)
    finite = np.isfinite(intercepts)
    slopes = np.where(finite, slopes, 0.0)
    intercepts = np.where(finite, intercepts, -np.inf)
    inf = np.full(len(T0), np.inf)
    _, value = min_of_max_lines(slopes, intercepts, -inf, inf)
    return np.maximum(value, 0.0)


def _feasible_2d(points: NDArray, normals: NDArray, beta: NDArray, finite: NDArray,
                 scale: NDArray) -> NDArray:
    """Which candidate points (N, P, 2) satisfy every finite line, shape (N, P)."""
    lhs = np.einsum("nlk,npk->npl", normals, points)
    slack = FEAS_TOL * scale[:, None, None] * (1.0 + np.linalg.norm(normals, axis=2)[:, None, :])
    ok = (lhs <= beta[:, None, :] + slack) | ~finite[:, None, :]
    return ok.all(axis=2) & np.isfinite(points).all(axis=2)


def _vertices_2d(normals: NDArray, beta: NDArray, finite: NDArray) -> NDArray:
    """All pairwise intersections of the bounding lines, shape (N, P, 2)."""
    L = normals.shape[1]
    i, j = np.triu_indices(L, k=1)
    a1, a2 = normals[:, i], normals[:, j]
    det = a1[..., 0] * a2[..., 1] - a1[..., 1] * a2[..., 0]
    b1, b2 = beta[:, i], beta[:, j]
    with np.errstate(divide="ignore", invalid="ignore"):
        z0 = (b1 * a2[..., 1] - b2 * a1[..., 1]) / det
        z1 = (a1[..., 0] * b2 - a2[..., 0] * b1) / det
    both = finite[:, i] & finite[:, j] & (np.abs(det) > 1e-14)
    z = np.stack([z0, z1], axis=-1)
    return np.where(both[..., None], z, np.nan)


def qp_2d(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
          scale: NDArray) -> tuple[NDArray, NDArray]:
    """Minimise ``1/2 sum q T^2 + c.T`` over ``T = T0 + Z z`` within bounds; strictly convex.

    Parameters
    ----------
    T0 : ndarray, shape (N, m)
    Z : ndarray, shape (N, m, 2)
    lb, ub, q, c : ndarray, shape (N, m)
        ``Z^T diag(q) Z`` must be positive definite.
    scale : ndarray, shape (N,)

    Returns
    -------
    z : ndarray, shape (N, 2)
        NaN where the polygon is empty.
    feasible : ndarray of bool, shape (N,)
    """
    H = np.einsum("nmi,nm,nmj->nij", Z, q, Z)
    g = np.einsum("nmi,nm->ni", Z, q * T0 + c)
    Hinv = np.linalg.inv(H)
    z_free = -np.einsum("nij,nj->ni", Hinv, g)
    normals, beta, finite = bound_lines(T0, Z, lb, ub)
    # Minimum on each line a.z = beta: z_free + Hinv a (beta - a.z_free) / (a^T Hinv a).
    Ha = np.einsum("nij,nlj->nli", Hinv, normals)
    with np.errstate(divide="ignore", invalid="ignore"):
        step = (beta - np.einsum("nli,ni->nl", normals, z_free)) / np.einsum(
            "nli,nli->nl", normals, Ha)
    on_lines = z_free[:, None, :] + Ha * step[..., None]
    on_lines = np.where(finite[..., None], on_lines, np.nan)
    points = np.concatenate(
        [z_free[:, None, :], on_lines, _vertices_2d(normals, beta, finite)], axis=1)
    ok = _feasible_2d(points, normals, beta, finite, scale)
    value = 0.5 * np.einsum("npi,nij,npj->np", points, H, points) + np.einsum(
        "npi,ni->np", points, g)
    value = np.where(ok, value, np.inf)
    best = np.argmin(value, axis=1)
    rows = np.arange(len(T0))
    feasible = np.asarray(ok.any(axis=1))
    z = np.where(feasible[:, None], points[rows, best], np.nan)
    return z, feasible


def lp_2d(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray, c: NDArray, scale: NDArray
          ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Minimise ``c.T`` over ``T = T0 + Z z`` within bounds, ties broken to minimum 2-norm.

    Returns
    -------
    z : ndarray, shape (N, 2)
    feasible : ndarray of bool, shape (N,)
    unique : ndarray of bool, shape (N,)
    bounded : ndarray of bool, shape (N,)
    """
    N = len(T0)
    rows = np.arange(N)
    normals, beta, finite = bound_lines(T0, Z, lb, ub)
    vertices = _vertices_2d(normals, beta, finite)
    ok = _feasible_2d(vertices, normals, beta, finite, scale)
    gz = np.einsum("nmi,nm->ni", Z, c)  # cost gradient in z
    cost = np.einsum("npi,ni->np", vertices, gz)
    cost = np.where(ok, cost, np.inf)
    best = cost.min(axis=1)
    feasible = np.isfinite(best)
    # Bounded iff no feasible recession direction decreases the cost; for T >= lb with
    # positive costs this always holds, so test only directions along the lines.
    flat = np.linalg.norm(gz, axis=1) <= FLAT_TOL * np.linalg.norm(c, axis=1) * np.sqrt(
        np.einsum("nmi,nmi->n", Z, Z))
    tol = FEAS_TOL * np.abs(best) + FEAS_TOL * scale * np.linalg.norm(c, axis=1)
    optimal = ok & (cost <= (best + tol)[:, None])
    # Distinct optimal vertices: the spread of their coordinates.
    opt_pts = np.where(optimal[..., None], vertices, np.nan)
    hi_pts = np.where(optimal[..., None], vertices, -np.inf).max(axis=1)
    lo_pts = np.where(optimal[..., None], vertices, np.inf).min(axis=1)
    spread = np.where(optimal.any(axis=1)[:, None], hi_pts - lo_pts, 0.0)
    znorm = np.linalg.norm(Z, axis=1).max(axis=1)
    multi = (spread * znorm[:, None]).max(axis=1) > FEAS_TOL * scale * 10
    unique = feasible & ~flat & ~multi
    # Unique: the single optimal vertex.
    z = np.where(feasible[:, None], vertices[rows, np.argmin(cost, axis=1)], np.nan)
    # Tied along an edge: the point of the segment between the extreme optimal vertices
    # closest to the origin in T (minimum 2-norm); flat cost: minimum norm on the polygon.
    edge = feasible & ~flat & multi
    if edge.any():
        e = np.flatnonzero(edge)
        pts = opt_pts[e]
        d = np.nan_to_num(pts - z[e][:, None, :])
        far = np.argmax(np.linalg.norm(d, axis=2), axis=1)
        z_a, z_b = z[e], pts[np.arange(len(e)), far]
        Ta = T0[e] + np.einsum("nmi,ni->nm", Z[e], z_a)
        dT = np.einsum("nmi,ni->nm", Z[e], z_b - z_a)
        s = np.clip(-np.einsum("nm,nm->n", Ta, dT) / np.einsum("nm,nm->n", dT, dT), 0.0, 1.0)
        z[e] = z_a + s[:, None] * (z_b - z_a)
    whole = feasible & flat
    if whole.any():
        w = np.flatnonzero(whole)
        zw, _ = qp_2d(T0[w], Z[w], lb[w], ub[w], np.ones_like(T0[w]), np.zeros_like(T0[w]),
                      scale[w])
        z[w] = zw
    return z, feasible, unique, np.ones(N, dtype=bool)


def bound_lines(T0: NDArray, Z: NDArray, lb: NDArray, ub: NDArray
                ) -> tuple[NDArray, NDArray, NDArray]:
    """Bounds ``lb <= T0 + Z z <= ub`` as half-spaces ``a_l . z <= beta_l`` in ``z``.

    Parameters
    ----------
    T0, lb, ub : ndarray, shape (N, m)
        ``lb`` / ``ub`` may be infinite (no half-space).
    Z : ndarray, shape (N, m, d)

    Returns
    -------
    normals : ndarray, shape (N, 2m, d)
        ``-Z`` rows (lower bounds), then ``Z`` rows (upper bounds).
    beta : ndarray, shape (N, 2m)
        ``T0 - lb``, then ``ub - T0``; 0 where the bound is absent.
    present : ndarray of bool, shape (N, 2m)
        Which half-spaces exist (finite bound).
    """
    normals = np.concatenate([-Z, Z], axis=1)
    with np.errstate(invalid="ignore"):
        beta = np.concatenate([T0 - lb, ub - T0], axis=1)
    present = np.isfinite(beta)
    return normals, np.where(present, beta, 0.0), present


def min_of_max_lines(slopes: NDArray, intercepts: NDArray, lo: NDArray, hi: NDArray
                     ) -> tuple[NDArray, NDArray]:
    """Minimise ``f(t) = max_j (slopes_j t + intercepts_j)`` over ``t`` in ``[lo, hi]``.

    ``f`` is convex; its free minimum is where the highest crossing of a rising and a
    falling line lies (in one dimension two lines decide the minimum), and the minimum
    over the interval is that point clipped to it.

    Parameters
    ----------
    slopes, intercepts : ndarray, shape (N, J)
        Lines with intercept ``-inf`` are ignored; lines of slope 0 are constant.
    lo, hi : ndarray, shape (N,)
        May be infinite; ``t`` is then infinite where ``f`` keeps falling, and the
        value is that of the highest constant line (``-inf`` without one).

    Returns
    -------
    t, value : ndarray, shape (N,)
    """
    rising = (slopes > 0) & np.isfinite(intercepts)
    falling = (slopes < 0) & np.isfinite(intercepts)
    a_i, a_j = slopes[:, :, None], slopes[:, None, :]
    b_i, b_j = intercepts[:, :, None], intercepts[:, None, :]
    pair = rising[:, :, None] & falling[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cross = (b_j - b_i) / (a_i - a_j)  # meaningful where pair
        v_cross = np.where(pair, a_i * t_cross + b_i, -np.inf)
    best = np.argmax(v_cross.reshape(len(lo), -1), axis=1)
    rows = np.arange(len(lo))
    has_pair = rising.any(axis=1) & falling.any(axis=1)
    t_free = np.where(has_pair, t_cross.reshape(len(lo), -1)[rows, best],
                      np.where(rising.any(axis=1), -np.inf,
                               np.where(falling.any(axis=1), np.inf, 0.0)))
    t = np.clip(t_free, lo, hi)
    with np.errstate(invalid="ignore"):
        # A constant line keeps its value at an infinite t (0 * inf would be NaN).
        lines = np.where(slopes == 0, intercepts, slopes * t[:, None] + intercepts)
        value = np.where(np.isfinite(intercepts), lines, -np.inf).max(axis=1)
    return t, value
