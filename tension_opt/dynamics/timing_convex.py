"""The time-optimal timing as one convex program (Verscheure et al. 2009), by Clarabel.

Over the squared path speeds ``x_k = s'^2``, path accelerations ``u_k = s''`` and one
tension vector ``T_j`` for each check ``j`` of a grid point ``k = o(j)``
(:class:`~tension_opt.dynamics.intervals.StageChecks`: the grid points, the ends of the
intervals, points inside them), at once::

    minimise    sum_k 2 ds_k / (sqrt(x_k) + sqrt(x_{k+1}))
    subject to  x_{k+1} = x_k + 2 ds_k u_k,   x_0 = x_K = 0,   x_k >= 0,
                A_j T_j = (a_j + 2 d_j b_j) u_k + b_j x_k + c_j,   t_min <= T_j <= t_max,
                x_k + 2 d_j u_k <= x_max,j,   |(V_j + 2 d_j C_j) u_k + C_j x_k| <= a_max

the same constraints as the reachability scheme of :mod:`tension_opt.dynamics.timing`
(:class:`~tension_opt.dynamics.stage_lp.StageLP`), so both give the same timing. The
objective is convex (the inverse of a concave function); with ``r_k <= sqrt(x_k)``
(``r_k^2 <= x_k``) and ``t_k >= 1 / (r_k + r_{k+1})`` as second-order cones it is a
second-order cone program, built here as Clarabel's sparse data (no modelling layer:
the build takes milliseconds, and the solver's time limit bounds the rest).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from tension_opt.backends.settings import quiet_solvers
from tension_opt.dynamics.deadline import Deadline, OutOfTime
from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.stage_lp import check_limits
from tension_opt.dynamics.stage_rows import StageRows

__all__ = ["ACTIVE_ROOM", "CUTS", "convex_rows_timing", "convex_timing", "timing_cone_program"]

#: Rows of the cutting-plane program first taken: within this of binding at the
#: reference timing, relative to ``1 + |b|`` (unit rows, :func:`convex_rows_timing`).
ACTIVE_ROOM = 1e-2
#: Most programs :func:`convex_rows_timing` solves.
CUTS = 12


class _Rows:
    """Rows ``A z + s = b`` of one cone, appended block by block (COO triplets)."""

    def __init__(self) -> None:
        self.count = self.last = 0
        self.r: list[NDArray] = []
        self.c: list[NDArray] = []
        self.v: list[NDArray] = []
        self.b: list[NDArray] = []

    def add(self, rows: NDArray, cols: NDArray, vals: NDArray, rhs: NDArray) -> None:
        """A block of ``len(rhs)`` rows; ``rows`` index into it."""
        self.last = self.count
        self.b.append(np.asarray(rhs, dtype=float))
        self.count += len(rhs)
        self.more(rows, cols, vals)

    def more(self, rows: NDArray, cols: NDArray, vals: NDArray) -> None:
        """More entries in the last block's rows."""
        self.r.append(np.asarray(rows) + self.last)
        self.c.append(np.asarray(cols))
        self.v.append(np.asarray(vals, dtype=float))


def _equalities(checks: StageChecks, sigma: NDArray, iu: int, ix: int, itau: int
                ) -> _Rows:
    """Equilibrium of every check, the path's kinematics and rest at both ends."""
    pts, K, own = checks.points, checks.K, checks.owner
    J, n, m = pts.A.shape
    eq = _Rows()
    row = np.arange(J * n).reshape(J, n)
    tau = itau + np.arange(J * m).reshape(J, m)
    eq.add(np.repeat(row, m, axis=1).ravel(), np.tile(tau, (1, n)).ravel(),
           pts.A.reshape(J, n * m).ravel(), (pts.c / sigma[:, None]).ravel())
    eq.more(row.ravel(), np.repeat(iu + own, n), (-checks.wrench_u() / sigma[:, None]).ravel())
    eq.more(row.ravel(), np.repeat(ix + own, n), (-pts.b / sigma[:, None]).ravel())
    ds = np.diff(checks.grid)
    k = np.arange(K - 1)
    eq.add(np.concatenate([k, k, k]), np.concatenate([ix + k + 1, ix + k, iu + k]),
           np.concatenate([np.ones(K - 1), -np.ones(K - 1), -2.0 * ds]), np.zeros(K - 1))
    eq.add(np.array([0, 1]), np.array([ix, ix + K - 1]), np.ones(2), np.zeros(2))
    return eq


def _inequalities(checks: StageChecks, limits: tuple[NDArray, NDArray, NDArray, NDArray],
                  a_max: NDArray, cols: tuple[int, int, int, int]) -> _Rows:
    """``x >= 0``, ``r >= 0``, the tension bounds, speed and acceleration limits."""
    sigma, lb, ub, x_max = limits
    iu, ix, itau, ir = cols
    pts, K, own = checks.points, checks.K, checks.owner
    J, _, m = pts.A.shape
    le = _Rows()
    k = np.arange(K)
    le.add(np.arange(2 * K), np.concatenate([ix + k, ir + k]), -np.ones(2 * K), np.zeros(2 * K))
    tau = itau + np.arange(J * m)
    low = (lb / sigma[:, None]).ravel()
    le.add(np.arange(J * m), tau, -np.ones(J * m), -low)
    high = (ub / sigma[:, None]).ravel()
    fin = np.flatnonzero(np.isfinite(high))
    le.add(np.arange(fin.size), tau[fin], np.ones(fin.size), high[fin])
    sp_ = np.flatnonzero(np.isfinite(x_max))  # x + 2 d u <= x_max
    r = np.arange(sp_.size)
    le.add(np.concatenate([r, r]), np.concatenate([ix + own[sp_], iu + own[sp_]]),
           np.concatenate([np.ones(sp_.size), 2.0 * checks.offset[sp_]]), x_max[sp_])
    limited = np.flatnonzero(np.isfinite(a_max))
    if limited.size:  # |(V + 2 d C) u + C x| <= a_max
        vu, C = checks.accel_u()[:, limited].ravel(), pts.C[:, limited].ravel()
        o = np.repeat(own, limited.size)
        r = np.arange(o.size)
        bound = np.tile(a_max[limited], J)
        for sign in (1.0, -1.0):
            le.add(np.concatenate([r, r]), np.concatenate([iu + o, ix + o]),
                   sign * np.concatenate([vu, C]), bound)
    return le


def _cones(K: int, ix: int, ir: int, it: int) -> _Rows:
    """``r_k^2 <= x_k`` as ``(x_k + 1, 2 r_k, x_k - 1)`` and ``t_k (r_k + r_{k+1}) >= 1``
    as ``(t_k + w, 2, t_k - w)``, ``w = r_k + r_{k+1}``, each in a cone of size 3."""
    soc = _Rows()
    k = np.arange(K)
    base = 3 * k
    soc.add(np.concatenate([base, base + 1, base + 2]), np.concatenate([ix + k, ir + k, ix + k]),
            np.concatenate([-np.ones(K), -2.0 * np.ones(K), -np.ones(K)]),
            np.tile([1.0, 0.0, -1.0], K))
    k = np.arange(K - 1)
    base = 3 * k
    rows = np.concatenate([base, base, base, base + 2, base + 2, base + 2])
    cols = np.concatenate([it + k, ir + k, ir + k + 1, it + k, ir + k, ir + k + 1])
    one = np.ones(K - 1)
    soc.add(rows, cols, np.concatenate([-one, -one, -one, -one, one, one]),
            np.tile([0.0, 2.0, 0.0], K - 1))
    return soc


def timing_cone_program(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float
                        ) -> tuple[sp.csc_matrix, NDArray, list[int], int]:
    """Clarabel's data of the timing program: ``A`` (rows, z), ``b``, the sizes of the
    zero, non-negative and (each 3) second-order cones as ``[zero, nonneg, socs]``, and
    the number of variables ``z = (u, x, T / sigma, r, t)``."""
    K = checks.K
    J, _, m = checks.points.A.shape
    limits = check_limits(checks, v_max, slack)
    iu, ix, itau = 0, K, 2 * K
    ir = itau + J * m
    it = ir + K
    nz = it + K - 1
    A, b, counts = _stack([_equalities(checks, limits[0], iu, ix, itau),
                           _inequalities(checks, limits, a_max, (iu, ix, itau, ir)),
                           _cones(K, ix, ir, it)], nz)
    return A, b, [counts[0], counts[1], 2 * K - 1], nz


def _solve_cones(A: sp.csc_matrix, b: NDArray, sizes: list[int], grid: NDArray,
                 deadline: Deadline) -> tuple[NDArray, NDArray, str]:
    """Clarabel on the data of a timing program whose variables start ``(u, x)`` and end
    with the ``K - 1`` epigraph variables ``t``: ``x, u`` and an outcome."""
    import clarabel

    K = grid.size
    nz = A.shape[1]
    q = np.zeros(nz)
    q[nz - (K - 1):] = 2.0 * np.diff(grid)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    if deadline.limited:
        settings.time_limit = deadline.remaining()
    cones = [clarabel.ZeroConeT(sizes[0]), clarabel.NonnegativeConeT(sizes[1])]
    cones += [clarabel.SecondOrderConeT(3)] * sizes[2]
    deadline.check()
    with quiet_solvers():
        solution = clarabel.DefaultSolver(sp.csc_matrix((nz, nz)), q, A, b, cones,
                                          settings).solve()
    status = str(solution.status)
    if status == "MaxTime":
        raise OutOfTime
    outcome = {"Solved": "optimal", "AlmostSolved": "optimal",
               "PrimalInfeasible": "infeasible", "AlmostPrimalInfeasible": "infeasible",
               "DualInfeasible": "unbounded",
               "AlmostDualInfeasible": "unbounded"}.get(status, "error")
    if outcome != "optimal":
        return np.full(K, np.nan), np.full(K, np.nan), outcome
    z = np.asarray(solution.x)
    u = z[:K].copy()
    u[-1] = u[-2]  # at rest at the end: the arrival's s''
    return np.maximum(z[K:2 * K], 0.0), u, outcome


def convex_timing(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float = 0.0,
                  deadline: Deadline | None = None) -> tuple[NDArray, NDArray, str]:
    """Solve the convex timing program of ``checks`` with Clarabel, over the tensions.

    Parameters
    ----------
    checks : StageChecks
    v_max, a_max : ndarray, shape (n,)
        Velocity and acceleration limits (inf: none).
    slack : float
        Keep the tensions this fraction of their tension scale inside their bounds.
    deadline : Deadline, optional
        Clarabel gets the time left as its limit;
        :class:`~tension_opt.dynamics.deadline.OutOfTime` once it has passed.

    Returns
    -------
    x, u : ndarray, shape (K,)
        Squared path speed and path acceleration at the grid points (``u`` at the last
        point, at rest, the arrival's).
    outcome : {"optimal", "infeasible", "unbounded", "error"}
        ``"optimal"`` also for Clarabel's nearly solved (residuals a few times its
        tolerance of 1e-8): the timing makes the answer exact and checks it along the
        path.
    """
    A, b, sizes, _ = timing_cone_program(checks, v_max, a_max, slack)
    return _solve_cones(A, b, sizes, checks.grid, deadline or Deadline())


def _stack(blocks: list[_Rows], nz: int) -> tuple[sp.csc_matrix, NDArray, list[int]]:
    """The blocks' rows one after the other: ``A``, ``b`` and each block's row count."""
    rows, cols, vals, rhs, offset = [], [], [], [], 0
    for block in blocks:
        rows += [r + offset for r in block.r]
        cols += block.c
        vals += block.v
        rhs += block.b
        offset += block.count
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(offset, nz))
    return A, np.concatenate(rhs), [block.count for block in blocks]


def _rows_program(rows: StageRows, active: NDArray, grid: NDArray
                  ) -> tuple[sp.csc_matrix, NDArray, list[int]]:
    """The timing program over ``(u, x, r, t)`` with the rows ``active`` of ``rows``."""
    K = grid.size
    iu, ix, ir, it = 0, K, 2 * K, 3 * K
    owner = np.repeat(np.arange(K), np.diff(rows.start))[active]
    eq = _Rows()
    k = np.arange(K - 1)
    eq.add(np.concatenate([k, k, k]), np.concatenate([ix + k + 1, ix + k, iu + k]),
           np.concatenate([np.ones(K - 1), -np.ones(K - 1), -2.0 * np.diff(grid)]),
           np.zeros(K - 1))
    eq.add(np.array([0, 1]), np.array([ix, ix + K - 1]), np.ones(2), np.zeros(2))
    le = _Rows()
    r = np.arange(owner.size)
    le.add(np.concatenate([r, r]), np.concatenate([iu + owner, ix + owner]),
           np.concatenate([rows.rows[active, 0], rows.rows[active, 1]]), rows.rhs[active])
    k = np.arange(K)
    le.add(np.arange(2 * K), np.concatenate([ix + k, ir + k]), -np.ones(2 * K),
           np.zeros(2 * K))
    A, b, counts = _stack([eq, le, _cones(K, ix, ir, it)], it + K - 1)
    return A, b, [counts[0], counts[1], 2 * K - 1]


def convex_rows_timing(rows: StageRows, grid: NDArray, x_ref: NDArray, u_ref: NDArray,
                       deadline: Deadline | None = None) -> tuple[NDArray, NDArray, str]:
    """:func:`convex_timing` over the checks' rows in ``(u, x)``
    (:mod:`tension_opt.dynamics.stage_rows`) instead of their tensions, with cutting
    planes: first the rows within :data:`ACTIVE_ROOM` of binding at a feasible timing
    ``x_ref, u_ref`` (the reachability passes'), then, up to :data:`CUTS` times, every
    row the answer violates, until it violates none (it is then the optimum over all
    rows: a program over fewer rows is a relaxation of it)."""
    deadline = deadline or Deadline()
    owner = np.repeat(np.arange(grid.size), np.diff(rows.start))
    tol = 1e-9 * (1.0 + np.abs(rows.rhs))

    def room(x: NDArray, u: NDArray) -> NDArray:
        return rows.rhs - rows.rows[:, 0] * u[owner] - rows.rows[:, 1] * x[owner]

    active = room(x_ref, u_ref) <= ACTIVE_ROOM * (1.0 + np.abs(rows.rhs))
    for _ in range(CUTS):
        A, b, sizes = _rows_program(rows, active, grid)
        x, u, outcome = _solve_cones(A, b, sizes, grid, deadline)
        if outcome != "optimal":
            return x, u, outcome
        cut = ~active & (room(x, u) < -tol)
        if not cut.any():
            return x, u, outcome
        active |= cut
    return x, u, "error"
