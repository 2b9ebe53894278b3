"""The sign-constrained refit of a certificate's multipliers, compiled: one pose.

The cheap dual solve (:func:`tension_opt.kernels.certificate.pose_estimate`) fits
stationarity without the multipliers' cones; where its fit leaves a primal-feasible
pose uncertified, :func:`tension_opt.certify.certificate.certify` refits that pose's
multipliers by a bounded least-squares problem (each multiplier in its cone) and keeps
the fit where it measures better. The reference is that numpy code
(:func:`tension_opt.certify.certificate._refit`, scipy's ``lsq_linear`` with the
``"bvls"`` method); this kernel builds the same problem and solves it by an active-set
method (Lawson and Hanson's, with bounds on both sides as in Stark and Parker's BVLS),
each subproblem by a Householder QR of its free columns. The problem's matrix has full
column rank whenever the structure matrix does, so its solution is unique and both
agree to the solvers' tolerance; a subproblem that is numerically singular returns
False, and the caller leaves the pose to the numpy path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.affine import column_norm, reflect
from tension_opt.kernels.certificate import nan_max, pose_measures

__all__ = ["batch_refit", "bounded_lstsq", "pose_refit", "refit_work_size"]

#: Active-set steps per variable (scipy's ``lsq_linear`` default for ``"bvls"``: 50 per
#: variable, as the reference passes it).
STEPS_PER_VARIABLE = 50
#: Relative size of a QR pivot below which a subproblem counts as singular.
SINGULAR = 1e-13
#: Cap of the complementarity charges (as the reference's).
CHARGE_CAP = 1e6


@njit(cache=True)
def refit_work_size(n: int, g: int, k: int) -> int:
    """Floats of work space :func:`pose_refit` needs for ``n`` equations, ``g`` rows
    and ``k`` variables."""
    R, C = 2 * k + g, n + g + k
    return 2 * R * C + 4 * R + 9 * C


@njit(cache=True, error_model="numpy")
def _least_squares(M: NDArray, rhs: NDArray, free: NDArray, f: int, Q: NDArray,
                   b: NDArray, out: NDArray) -> bool:
    """Least-squares solution over the ``f`` columns ``free[:f]`` of ``M`` (R, C),
    written to ``out[:f]``, by a Householder QR in ``Q`` (f rows of R) and ``b`` (R,);
    False where a pivot is below :data:`SINGULAR` times the largest column."""
    R = M.shape[0]
    largest = 0.0
    for jj in range(f):
        col = 0.0
        for i in range(R):
            v = M[i, int(free[jj])]
            Q[jj * R + i] = v
            col += v * v
        largest = max(largest, math.sqrt(col))
    for i in range(R):
        b[i] = rhs[i]
    for k in range(f):
        norm = column_norm(Q, k * R, k, R)
        if not (norm > SINGULAR * largest):
            return False
        alpha, beta = reflect(Q, R, k, f, norm)
        o = k * R
        dot = 0.0
        for i in range(k, R):
            dot += Q[o + i] * b[i]
        dot *= beta
        for i in range(k, R):
            b[i] -= dot * Q[o + i]
        Q[o + k] = alpha  # R's diagonal; the reflector is no longer needed
    for k in range(f - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, f):
            s -= Q[j * R + k] * out[j]
        out[k] = s / Q[k * R + k]
    return True


@njit(cache=True, error_model="numpy")
def _most_inward(M: NDArray, rhs: NDArray, lo: NDArray, hi: NDArray, u: NDArray,
                 fixed: NDArray, tried: NDArray, resid: NDArray) -> tuple[int, float]:
    """The fixed variable whose gradient points furthest into its interval (not one
    freed and fixed at once before), and how far; ``(-1, 0)`` for none. ``resid`` (R,)
    work space."""
    R, C = M.shape
    for i in range(R):
        total = -rhs[i]
        for j in range(C):
            total += M[i, j] * u[j]
        resid[i] = total
    freed, pull = -1, 0.0
    for j in range(C):
        w = 0.0
        for i in range(R):
            w -= M[i, j] * resid[i]
        if fixed[j] != 0.0 and tried[j] == 0.0 and lo[j] < hi[j]:
            inward = w if lo[j] == 0.0 else -w
            if inward > pull:
                freed, pull = j, inward
    return freed, pull


@njit(cache=True, error_model="numpy")
def bounded_lstsq(M: NDArray, rhs: NDArray, lo: NDArray, hi: NDArray, u: NDArray,
                  work: NDArray, max_steps: int) -> bool:
    """``u`` (C,) minimising ``||M u - rhs||`` within ``lo <= u <= hi``, where every
    variable's bounds hold 0 (each is free, or has 0 as a bound); written in place.

    An active-set method: the variables fixed at a bound (at 0) start all fixed; each
    round frees the fixed one whose gradient points most into its interval, solves
    the free variables' least squares, and steps back to the last feasible point where
    that solution leaves the bounds, fixing the variables it stops at. Returns False
    where a subproblem is numerically singular (``u`` is then not the solution).
    ``work`` holds :func:`refit_work_size`'s floats; at most ``max_steps`` solves.
    """
    R, C = M.shape
    Q = work[:R * C]
    b = work[R * C:R * C + R]
    resid = work[R * C + R:R * C + 2 * R]
    s = work[R * C + 2 * R:R * C + 2 * R + C]
    fixed = work[R * C + 2 * R + C:R * C + 2 * R + 2 * C]  # 1.0: fixed at its bound, 0
    tried = work[R * C + 2 * R + 2 * C:R * C + 2 * R + 3 * C]  # freed and fixed at once
    free = work[R * C + 2 * R + 3 * C:R * C + 2 * R + 4 * C]  # the free columns, as floats
    for j in range(C):
        u[j] = 0.0
        fixed[j] = 0.0 if (lo[j] == -np.inf and hi[j] == np.inf) else 1.0
        tried[j] = 0.0
    steps, freed = 0, -1
    size = 0.0  # |M| |rhs|: the scale of the gradient's rounding
    for j in range(C):
        col = 0.0
        for i in range(R):
            col += abs(M[i, j]) * abs(rhs[i])
        size = max(size, col)
    tol = 1e-13 * size
    while steps < max_steps:
        first = True
        # Solve on the free set; where the solution leaves the bounds, step back to the
        # last feasible point and fix the variables met there.
        while steps < max_steps:
            steps += 1
            f = 0
            for j in range(C):
                if fixed[j] == 0.0:
                    free[f] = j
                    f += 1
            if f == 0:
                break
            if not _least_squares(M, rhs, free, f, Q, b, s):
                return False
            alpha, block = 1.0, -1
            for jj in range(f):
                j = int(free[jj])
                step = 1.0
                if s[jj] < lo[j]:
                    step = (lo[j] - u[j]) / (s[jj] - u[j])
                elif s[jj] > hi[j]:
                    step = (hi[j] - u[j]) / (s[jj] - u[j])
                if step < alpha:
                    alpha, block = step, j
            for jj in range(f):
                j = int(free[jj])
                u[j] += alpha * (s[jj] - u[j])
            if alpha >= 1.0:
                break
            for jj in range(f):  # the blocking variable, and any other the step met
                j = int(free[jj])
                if j == block or ((s[jj] < lo[j] or s[jj] > hi[j]) and (
                        abs(u[j]) <= 1e-12 * abs(s[jj]) or u[j] < lo[j] or u[j] > hi[j])):
                    u[j], fixed[j] = 0.0, 1.0
                    if j == freed and first:  # rounding: it would be freed forever
                        tried[j] = 1.0
            first = False
        freed, pull = _most_inward(M, rhs, lo, hi, u, fixed, tried, resid)
        # None where every such pull is within rounding of the data (|M| |rhs|).
        if freed < 0 or pull <= tol:
            break
        fixed[freed] = 0.0
    return True


@njit(cache=True, error_model="numpy")
def pose_refit(P: NDArray, c: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray,
               h: NDArray, lb: NDArray, ub: NDArray, x: NDArray, y: NDArray, mu: NDArray,
               z: NDArray, measured: tuple[float, float, float], station: NDArray,
               work: NDArray) -> tuple[float, float, float, int]:
    """The refit of one scaled pose's multipliers ``y`` (n,), ``mu`` (g,), ``z`` (k,)
    (the reference's problem: stationarity rows, then each row multiplier charged by
    its row's slack and each bound multiplier by its distance to its nearer bound, each
    multiplier in its cone), kept in place where its dual residual and gap measure
    better than ``measured`` (the three measures of the multipliers given).

    Returns the three measures of the multipliers kept and 1 if the fit was kept, 0 if
    not, -1 where a subproblem was singular (the pose is left to the numpy path).
    """
    n, k = Aeq.shape
    g = G.shape[0]
    R, C = 2 * k + g, n + g + k
    size = R * C
    M = work[:size].reshape((R, C))
    rhs = work[size:size + R]
    lo = work[size + R:size + R + C]
    hi = work[size + R + C:size + R + 2 * C]
    u = work[size + R + 2 * C:size + R + 3 * C]
    rest = work[size + R + 3 * C:]
    M[:, :] = 0.0
    for i in range(k):
        to_lb, to_ub = abs(x[i] - lb[i]), abs(ub[i] - x[i])  # inf where there is none
        near = min(to_lb, to_ub)
        charge = near if math.isfinite(near * near) else 0.0
        for r in range(n):
            M[i, r] = Aeq[r, i]
        for r in range(g):
            M[i, n + r] = G[r, i]
        M[i, n + g + i] = 1.0
        M[k + g + i, n + g + i] = min(charge, CHARGE_CAP)
        rhs[i] = -(P[i] * x[i] + c[i])
        # z_i is the multiplier of its nearer bound (either, where equidistant).
        lower = math.isfinite(lb[i]) and x[i] - lb[i] <= ub[i] - x[i]
        upper = math.isfinite(ub[i]) and ub[i] - x[i] <= x[i] - lb[i]
        lo[n + g + i] = -np.inf if lower else 0.0
        hi[n + g + i] = np.inf if upper else 0.0
    for r in range(g):
        row = 0.0
        for i in range(k):
            row += G[r, i] * x[i]
        M[k + r, n + r] = min(abs(h[r] - row), CHARGE_CAP)
        lo[n + r], hi[n + r] = 0.0, np.inf
    for r in range(n):
        lo[r], hi[r] = -np.inf, np.inf
    for i in range(k, R):
        rhs[i] = 0.0
    # A variable pinned to 0 (no bound on the side its cone allows) stays out: its
    # column's bounds are both 0, which the active set keeps fixed.
    if not bounded_lstsq(M, rhs, lo, hi, u, rest, STEPS_PER_VARIABLE * C):
        return measured[0], measured[1], measured[2], -1
    fit_y, fit_mu, fit_z = rest[:n], rest[n:n + g], rest[n + g:n + g + k]
    for r in range(n):
        fit_y[r] = u[r]
    for r in range(g):
        fit_mu[r] = u[n + r]
    for i in range(k):
        fit_z[i] = u[n + g + i]
    first, second, third = pose_measures(P, c, Aeq, beq, G, h, lb, ub, x, fit_y, fit_mu,
                                         fit_z, station)
    if not nan_max(second, third) < nan_max(measured[1], measured[2]):
        return measured[0], measured[1], measured[2], 0
    for r in range(n):
        y[r] = fit_y[r]
    for r in range(g):
        mu[r] = fit_mu[r]
    for i in range(k):
        z[i] = fit_z[i]
    return first, second, third, 1


@njit(cache=True, nogil=True, error_model="numpy")
def batch_refit(P: NDArray, c: NDArray, Aeq: NDArray, beq: NDArray, G: NDArray,
                h: NDArray, lb: NDArray, ub: NDArray, x: NDArray, y: NDArray, mu: NDArray,
                z: NDArray, measured: NDArray) -> NDArray:
    """:func:`pose_refit` of every pose of a scaled batch (the arrays of
    :func:`tension_opt.kernels.certificate.batch_measures`, all writable): ``y``,
    ``mu``, ``z`` refitted in place where the fit measures better than ``measured``
    (N, 3), whose rows become the kept multipliers' measures. Returns each pose's
    :func:`pose_refit` verdict (N,): 1 kept, 0 not, -1 singular."""
    N, n, k = Aeq.shape
    g = G.shape[1]
    work = np.empty(refit_work_size(n, g, k))
    station = np.empty(k)
    kept = np.empty(N, dtype=np.int64)
    for p in range(N):
        first, second, third, kept[p] = pose_refit(
            P[p], c[p], Aeq[p], beq[p], G[p], h[p], lb[p], ub[p], x[p], y[p], mu[p], z[p],
            (measured[p, 0], measured[p, 1], measured[p, 2]), station, work)
        measured[p, 0], measured[p, 1], measured[p, 2] = first, second, third
    return kept
