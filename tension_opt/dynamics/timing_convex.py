"""The time-optimal timing as one convex program (Verscheure et al. 2009), through cvxpy.

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
objective is convex (the inverse of a concave function), a second-order cone program
for Clarabel.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from tension_opt.backends.base import quiet_solvers
from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.stage_lp import check_limits

__all__ = ["convex_timing"]


def _owner_rows(values: NDArray, owner: NDArray, K: int) -> sp.csr_matrix:
    """Sparse (J n, K) matrix with ``values[j]`` (n,) in rows j n... of column ``owner[j]``."""
    J, n = values.shape
    return sp.csr_matrix((values.ravel(), (np.arange(J * n), np.repeat(owner, n))),
                         shape=(J * n, K))


def convex_timing(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float = 0.0,
                  solver: str = "CLARABEL") -> tuple[NDArray, NDArray, str]:
    """Solve the convex timing program of ``checks``.

    Parameters
    ----------
    checks : StageChecks
    v_max, a_max : ndarray, shape (n,)
        Velocity and acceleration limits (inf: none).
    slack : float
        Keep the tensions this fraction of a typical tension inside their bounds.
    solver : str
        A cvxpy conic solver.

    Returns
    -------
    x, u : ndarray, shape (K,)
        Squared path speed and path acceleration at the grid points.
    outcome : {"optimal", "infeasible", "unbounded", "error"}
    """
    import cvxpy as cp

    pts, K, own = checks.points, checks.K, checks.owner
    J, _, m = pts.A.shape
    sig, lb, ub, x_max = check_limits(checks, v_max, slack)
    ds = np.diff(checks.grid)
    x, u = cp.Variable(K), cp.Variable(K)
    tau = cp.Variable(J * m)
    A_blk = sp.block_diag(list(pts.A), format="csr")
    constraints = [
        A_blk @ tau - _owner_rows(checks.wrench_u() / sig[:, None], own, K) @ u
        - _owner_rows(pts.b / sig[:, None], own, K) @ x == (pts.c / sig[:, None]).ravel(),
        x[1:] == x[:-1] + 2 * cp.multiply(ds, u[:-1]),
        x[0] == 0, x[K - 1] == 0, x >= 0,
    ]
    speed = np.flatnonzero(np.isfinite(x_max))
    if len(speed):  # x + 2 d u <= x_max at each check
        rows = _owner_rows(np.ones((len(speed), 1)), own[speed], K)
        reach = _owner_rows(2.0 * checks.offset[speed, None], own[speed], K)
        constraints.append(rows @ x + reach @ u <= x_max[speed])
    lb, ub = (lb / sig[:, None]).ravel(), (ub / sig[:, None]).ravel()
    constraints.append(tau >= lb)
    if np.isfinite(ub).any():
        constraints.append(tau[np.flatnonzero(np.isfinite(ub))] <= ub[np.isfinite(ub)])
    limited = np.flatnonzero(np.isfinite(a_max))
    if len(limited):
        acc = (_owner_rows(checks.accel_u()[:, limited], own, K) @ u
               + _owner_rows(pts.C[:, limited], own, K) @ x)
        bound = np.tile(a_max[limited], J)
        constraints += [acc <= bound, acc >= -bound]
    duration = cp.sum(cp.multiply(2 * ds, cp.inv_pos(cp.sqrt(x[:-1]) + cp.sqrt(x[1:]))))
    problem = cp.Problem(cp.Minimize(duration), constraints)
    try:
        with quiet_solvers():
            problem.solve(solver=solver)
    except cp.error.SolverError:
        return np.full(K, np.nan), np.full(K, np.nan), "error"
    # A nearly solved program (Clarabel's AlmostSolved, residuals a few times its
    # tolerance of 1e-8) is taken: the timing checks its own answer along the path.
    outcome = {"optimal": "optimal", "optimal_inaccurate": "optimal",
               "infeasible": "infeasible",
               "unbounded": "unbounded"}.get(str(problem.status), "error")
    if outcome != "optimal" or x.value is None:
        return np.full(K, np.nan), np.full(K, np.nan), outcome
    u_value = np.array(u.value)
    u_value[-1] = u_value[-2]  # at rest at the end: the arrival's s''
    return np.maximum(np.asarray(x.value), 0.0), u_value, outcome
