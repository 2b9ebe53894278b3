"""The time-optimal timing as one convex program (Verscheure et al. 2009), through cvxpy.

Over the squared path speeds ``x_k = s'^2``, path accelerations ``u_k = s''`` and the
tensions ``T_k`` of every grid point at once::

    minimise    sum_k 2 ds_k / (sqrt(x_k) + sqrt(x_{k+1}))
    subject to  x_{k+1} = x_k + 2 ds_k u_k,   x_0 = x_K = 0,   0 <= x_k <= x_max,k
                A_k T_k = a_k u_k + b_k x_k + c_k,   t_min <= T_k <= t_max,
                |V_k u_k + C_k x_k| <= a_max

the same constraints as the reachability scheme of :mod:`tension_opt.dynamics.timing`
(:class:`~tension_opt.dynamics.stage_lp.StageLP`),
so both give the same timing. The objective is convex (the inverse of a concave
function), a second-order cone program for Clarabel.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from tension_opt.backends.base import quiet_solvers
from tension_opt.dynamics.path import PathStages
from tension_opt.dynamics.stage_lp import StageLP

__all__ = ["convex_timing"]


def _block_rows(values: NDArray) -> sp.csr_matrix:
    """Sparse (K n, K) matrix with column k holding ``values[k]`` (n,) in rows k n..."""
    K, n = values.shape
    rows = np.arange(K * n)
    return sp.csr_matrix((values.ravel(), (rows, np.repeat(np.arange(K), n))),
                         shape=(K * n, K))


def convex_timing(stages: PathStages, v_max: NDArray, a_max: NDArray, slack: float = 0.0,
                  solver: str = "CLARABEL") -> tuple[NDArray, NDArray, str]:
    """Solve the convex timing program of ``stages``.

    Parameters
    ----------
    stages : PathStages
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

    limits = StageLP(stages, v_max, a_max, slack)  # the same scaling and bounds
    K, _, m = stages.A.shape
    sig = limits.sigma
    ds = np.diff(stages.s)
    x, u = cp.Variable(K), cp.Variable(K)
    tau = cp.Variable(K * m)
    A_blk = sp.block_diag(list(stages.A), format="csr")
    constraints = [
        A_blk @ tau - _block_rows(stages.a / sig[:, None]) @ u
        - _block_rows(stages.b / sig[:, None]) @ x == (stages.c / sig[:, None]).ravel(),
        x[1:] == x[:-1] + 2 * cp.multiply(ds, u[:-1]),
        x[0] == 0, x[K - 1] == 0, x >= 0,
    ]
    finite_x = np.isfinite(limits.x_max)
    if finite_x.any():
        constraints.append(x[np.flatnonzero(finite_x)] <= limits.x_max[finite_x])
    lb, ub = (limits.lb / sig[:, None]).ravel(), (limits.ub / sig[:, None]).ravel()
    constraints.append(tau >= lb)
    if np.isfinite(ub).any():
        constraints.append(tau[np.flatnonzero(np.isfinite(ub))] <= ub[np.isfinite(ub)])
    for j in np.flatnonzero(np.isfinite(a_max)):
        acc = cp.multiply(stages.V[:, j], u) + cp.multiply(stages.C[:, j], x)
        constraints += [acc <= a_max[j], acc >= -a_max[j]]
    duration = cp.sum(cp.multiply(2 * ds, cp.inv_pos(cp.sqrt(x[:-1]) + cp.sqrt(x[1:]))))
    problem = cp.Problem(cp.Minimize(duration), constraints)
    try:
        with quiet_solvers():
            problem.solve(solver=solver)
    except cp.error.SolverError:
        return np.full(K, np.nan), np.full(K, np.nan), "error"
    outcome = {"optimal": "optimal", "infeasible": "infeasible",
               "unbounded": "unbounded"}.get(str(problem.status), "error")
    if outcome != "optimal" or x.value is None:
        return np.full(K, np.nan), np.full(K, np.nan), outcome
    return np.maximum(np.asarray(x.value), 0.0), np.asarray(u.value), outcome
