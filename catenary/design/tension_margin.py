"""The tension margin of a batch of poses and its derivatives, as one sparse LP.

For a pose with structure matrix ``A`` (n, m), required wrench ``b`` and tension bounds
``t_lo <= T <= t_up`` (per winch), the margin is

    s* = max s   subject to   A T = b,   t_lo + s d <= T <= t_up - s d,

with ``d`` a positive half-range per cable (by default ``(t_up - t_lo) / 2``): the
largest fraction of it that the tensions can keep from both bounds. ``s* = 1`` puts
every cable in the middle of its range; the pose is wrench-feasible exactly where
``s* >= 0``; below zero, ``-s*`` is how far (in half-ranges) the bounds would have to
widen. Unlike a feasibility flag it moves smoothly with the design, across the lower
bounds as across the upper ones, and it stays defined where the bounds cross
(``t_lo > t_up``: then ``s* < 0``).

The poses' LPs are independent, so they are solved as one block-diagonal LP by HiGHS
(the sum of the margins is maximised, which maximises each). Its multipliers give the
derivatives of each ``s*`` by the envelope theorem: by a matrix entry through
``-marginal * (row's change at the optimum)``, by a bound through its row's marginal.
They are those of the optimal pair HiGHS returns; where an LP has several, they can
differ from the derivative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog
from scipy.sparse import coo_matrix

__all__ = ["TensionMargins", "tension_margins"]

FloatArray = NDArray[np.float64]

#: Seconds HiGHS may take on one batch.
TIME_LIMIT = 60.0


@dataclass(frozen=True, eq=False)
class TensionMargins:
    """Margins of a batch and the multipliers that differentiate them.

    Attributes
    ----------
    margin : ndarray, shape (N,)
        ``s*`` (dimensionless); NaN where not solved.
    tensions : ndarray, shape (N, m)
        The optimal tensions (N).
    d_matrix : ndarray, shape (N, n)
        ``y`` with ``d s* = y' (dA) T`` for a change ``dA`` of the structure matrix.
    d_upper, d_lower : ndarray, shape (N, m)
        ``d s* / d t_up`` and ``d s* / d t_lo`` at fixed half-ranges (1/N);
        ``d s* / d b = -d_matrix``.
    d_half : ndarray, shape (N, m)
        ``d s* / d d`` (1/N).
    solved : ndarray of bool, shape (N,)
    """

    margin: FloatArray
    tensions: FloatArray
    d_matrix: FloatArray
    d_upper: FloatArray
    d_lower: FloatArray
    d_half: FloatArray
    solved: NDArray[np.bool_]


def _block_lp(A: FloatArray, b: FloatArray, t_min: FloatArray, t_up: FloatArray,
              half: FloatArray
              ) -> tuple[FloatArray, coo_matrix, FloatArray, coo_matrix, FloatArray]:
    """The block-diagonal LP of the poses: ``c``, ``A_ub``, ``b_ub``, ``A_eq``, ``b_eq``
    over the variables ``[T_k (m), s_k]`` of each pose ``k``."""
    N, n, m = A.shape
    v = m + 1
    c = np.zeros(N * v)
    c[m::v] = -1.0
    k = np.arange(N)
    # Equalities: row k*n + r, columns k*v + i.
    eq_rows = (k[:, None, None] * n + np.arange(n)[None, :, None]).repeat(m, axis=2)
    eq_cols = (k[:, None, None] * v + np.arange(m)[None, None, :]).repeat(n, axis=1)
    A_eq = coo_matrix((A.ravel(), (eq_rows.ravel(), eq_cols.ravel())), shape=(N * n, N * v))
    # Inequalities, 2m per pose: -T_i + d_i s <= -t_min_i, then T_i + d_i s <= t_up_i.
    rows = k[:, None] * 2 * m + np.arange(2 * m)[None, :]                      # (N, 2m)
    t_cols = k[:, None] * v + np.tile(np.arange(m), 2)[None, :]
    s_cols = np.broadcast_to((k * v + m)[:, None], rows.shape)
    t_vals = np.broadcast_to(np.concatenate([-np.ones(m), np.ones(m)]), rows.shape)
    s_vals = np.concatenate([half, half], axis=1)
    A_ub = coo_matrix((np.concatenate([t_vals.ravel(), s_vals.ravel()]),
                       (np.concatenate([rows.ravel(), rows.ravel()]),
                        np.concatenate([t_cols.ravel(), s_cols.ravel()]))),
                      shape=(N * 2 * m, N * v))
    b_ub = np.concatenate([-t_min, t_up], axis=1).ravel()
    return c, A_ub, b_ub, A_eq, b.ravel()


def _solve(A: FloatArray, b: FloatArray, t_min: FloatArray, t_up: FloatArray,
           half: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """Solution and marginals (equalities, inequalities) of the batch's LP, or None."""
    c, A_ub, b_ub, A_eq, b_eq = _block_lp(A, b, t_min, t_up, half)
    res = linprog(c, A_ub=A_ub.tocsr(), b_ub=b_ub, A_eq=A_eq.tocsr(), b_eq=b_eq,
                  bounds=(None, None), method="highs",
                  options={"time_limit": TIME_LIMIT, "presolve": True})
    if res.status != 0 or res.x is None:
        return None
    return res.x, res.eqlin.marginals, res.ineqlin.marginals


def tension_margins(A: FloatArray, b: FloatArray, t_lo: FloatArray, t_up: FloatArray,
                    half: FloatArray | None = None) -> TensionMargins:
    """Tension margins (module notes) of poses with structure matrices ``A`` (N, n, m)
    and required wrenches ``b`` (N, n) (N, N m), bounds ``t_lo`` and ``t_up`` (N, m) (N)
    and half-ranges ``half`` (N, m) (N, > 0; default ``(t_up - t_lo) / 2``).

    The batch is one LP; if it fails (a pose whose ``A`` cannot hold ``b`` at all), the
    poses are solved one by one and those that fail get NaN and ``solved`` False.
    """
    N, n, m = A.shape
    half = 0.5 * (t_up - t_lo) if half is None else np.broadcast_to(half, (N, m))
    margin = np.full(N, np.nan)
    tensions = np.full((N, m), np.nan)
    d_matrix = np.zeros((N, n))
    d_upper, d_lower, d_half = (np.zeros((N, m)) for _ in range(3))
    solved = np.zeros(N, dtype=bool)
    groups = [np.arange(N)]
    got = _solve(A, b, t_lo, t_up, half) if N else None
    if got is None and N:
        groups = [np.array([k]) for k in range(N)]  # rare: find the poses that fail
    for idx in groups:
        if got is None or len(groups) > 1:
            got = _solve(A[idx], b[idx], t_lo[idx], t_up[idx], half[idx])
            if got is None:
                continue
        x, eq, ub = got
        x = x.reshape(len(idx), m + 1)
        eq = eq.reshape(len(idx), n)
        ub = ub.reshape(len(idx), 2, m)
        s = x[:, m]
        margin[idx], tensions[idx], solved[idx] = s, x[:, :m], True
        # s = -objective: d s = -sum(marginal * (d right side - d row . x)). A matrix
        # change dA moves the equality rows' left side by dA T: d s = eq . (dA T).
        d_matrix[idx] = eq
        lo, up = ub[:, 0], ub[:, 1]
        d_upper[idx] = -up                      # right side of T + d s <= t_up
        d_lower[idx] = lo                       # right side -t_lo of -T + d s <= -t_lo
        d_half[idx] = (lo + up) * s[:, None]    # the coefficient d of s in both rows
    return TensionMargins(margin, tensions, d_matrix, d_upper, d_lower, d_half, solved)
