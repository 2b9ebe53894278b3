"""Tension distribution along trajectories: pointwise, smoothed, rate-limited, joint.

Pointwise, penalty-smoothed and rate-limited distributions are :func:`distribute` with
the right :class:`~tension_opt.problems.TensionProblem`; :func:`smooth_jointly` solves
the whole path as one sparse QP::

    minimise   sum_k f(T_k) + weight * sum_k ||T_k - T_{k-1}||^2
    subject to A_k T_k = b_k,  t_min <= T_k <= t_max   for every pose k
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.registry import get_backend
from tension_opt.backends.settings import solver_options
from tension_opt.distribute import distribute
from tension_opt.errors import InvalidInputError, UnsupportedProblemError
from tension_opt.problems import as_problem
from tension_opt.robot import CableRobot
from tension_opt.solution import Status, TensionSolution, status_array

__all__ = ["smooth_jointly", "solve_trajectory"]

#: qpsolvers solvers that take sparse matrices, tried in this order by default.
_SPARSE_SOLVERS = ("clarabel", "piqp", "proxqp", "osqp", "highs", "scs")


def solve_trajectory(robot: CableRobot, poses: ArrayLike, objective: Any = "min_sum",
                     mode: str = "pointwise", backend: str = "auto", *,
                     smoothing: float = 1e-3, rate_limit: float | None = None,
                     **options: Any) -> TensionSolution:
    """Distribute tensions along a path with one of the trajectory modes.

    Parameters
    ----------
    mode : {"pointwise", "penalty", "rate_limit", "joint"}
        ``pointwise``: each pose alone; ``penalty``: ``smoothing * ||T - T_prev||^2``
        against the previous pose's solution; ``rate_limit``: ``|T - T_prev| <=
        rate_limit``; ``joint``: one QP over the whole path (:func:`smooth_jointly`).
    """
    problem = as_problem(objective)
    if mode == "pointwise":
        return distribute(robot, poses, problem, backend, **options)
    if mode == "penalty":
        return distribute(robot, poses, problem.with_(smoothing=smoothing), backend, **options)
    if mode == "rate_limit":
        if rate_limit is None:
            raise InvalidInputError("mode 'rate_limit' needs rate_limit (N)")
        return distribute(robot, poses, problem.with_(rate_limit=rate_limit), backend,
                          **options)
    if mode == "joint":
        return smooth_jointly(robot, poses, problem, weight=smoothing,
                              backend="qpsolvers:clarabel" if backend == "auto" else backend,
                              **options)
    raise InvalidInputError(
        f"unknown mode {mode!r}; choose pointwise, penalty, rate_limit or joint")


def smooth_jointly(robot: CableRobot, poses: ArrayLike, objective: Any = "min_sum",
                   weight: float = 1e-3, backend: str = "qpsolvers:clarabel",
                   wrench: ArrayLike | None = None, **options: Any) -> TensionSolution:
    """Solve the tensions of a whole path at once, penalising change between poses.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n)
        Consecutive poses of the path.
    objective : str or TensionProblem
        Per-pose objective (``min_sum``, ``min_norm``, ``centered`` ...; not ``min_max``).
    weight : float
        Weight of ``||T_k - T_{k-1}||^2`` (1/N for min_sum, dimensionless for QPs).
    backend : str
        ``"qpsolvers:SOLVER"`` with a sparse-capable solver, or ``"cvxpy[:SOLVER]"``.

    Returns
    -------
    TensionSolution
        With the same status for every pose (the path is solved as a whole).
    """
    problem = as_problem(objective)
    if problem.objective == "min_max" or problem.is_sequential:
        raise UnsupportedProblemError(
            "smooth_jointly takes min_sum, min_norm, pinv or centered without its own smoothing")
    if weight < 0 or not np.isfinite(weight):
        raise InvalidInputError(f"weight must be >= 0, got {weight!r}")
    t0 = time.perf_counter()
    p = robot.as_poses(poses)
    form = problem.standard_form(robot, p, wrench)
    N, m = form.N, form.m
    s = float(np.median(form.scale()))
    sigma = s**2
    # Path QP in scaled units x = T / s, objective divided by s^2 (an LP cost becomes c / s).
    diff = sp.diags([np.ones(N - 1), -np.ones(N - 1)], [0, 1], shape=(N - 1, N))
    D = sp.kron(diff, sp.identity(m), format="csc")
    P = sp.diags(form.q.ravel() * s**2 / sigma) + 2.0 * weight * s**2 / sigma * (D.T @ D)
    P = sp.csc_matrix(P)
    q = form.c.ravel() * s / sigma
    Aeq = sp.block_diag(list(form.A), format="csc")
    beq = form.b.ravel() / s
    lb, ub = form.lb.ravel() / s, form.ub.ravel() / s
    setup = time.perf_counter() - t0
    family, _, solver = backend.partition(":")
    t0 = time.perf_counter()
    x, status, iterations = _solve_path(family, solver, P, q, Aeq, beq, lb, ub, options)
    elapsed = time.perf_counter() - t0
    T = np.full((N, m), np.nan) if x is None else x.reshape(N, m) * s
    sol = TensionSolution.from_form(
        form, T, status_array(N, status), backend=f"joint:{backend}",
        solver=solver or backend, iterations=None if iterations is None
        else np.full(N, iterations), setup_time=setup, solve_time=elapsed,
        extras={"path_iterations": iterations, "weight": weight})
    if not sol.success.all():  # the path is one problem: one inaccurate pose taints it all
        sol.status[sol.success] = Status.INACCURATE
    return sol


def _solve_path(family: str, solver: str, P: sp.csc_matrix, q: NDArray, Aeq: sp.csc_matrix,
                beq: NDArray, lb: NDArray, ub: NDArray, options: dict[str, Any]
                ) -> tuple[NDArray | None, Status, int | None]:
    if family == "qpsolvers":
        import qpsolvers

        from tension_opt.backends.qpsolvers_backend import iterations_of

        name = solver or next(s for s in _SPARSE_SOLVERS if s in qpsolvers.available_solvers)
        get_backend(f"qpsolvers:{name}")  # raises a clear error if not installed
        settings = solver_options(name, options.get("accuracy"), None,
                                  options.get("solver_options"), per_pose=False)
        lbv = np.where(np.isfinite(lb), lb, -np.inf)
        ubv = np.where(np.isfinite(ub), ub, np.inf)
        problem = qpsolvers.Problem(P, q, None, None, Aeq, beq, lbv, ubv)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sol = qpsolvers.solve_problem(problem, solver=name, **settings)
        except Exception:
            return None, Status.SOLVER_ERROR, None
        if not sol.found or sol.x is None:
            return None, Status.SOLVER_ERROR, None
        return sol.x, Status.OPTIMAL, iterations_of(sol.extras or {})
    if family == "cvxpy":
        import cvxpy as cp

        from tension_opt.backends.cvxpy_backend import LP_ONLY

        name = (solver or "CLARABEL").upper()
        get_backend(f"cvxpy:{name}")  # raises a clear error if not installed
        if name in LP_ONLY:
            raise UnsupportedProblemError(f"cvxpy:{name} solves LPs only; a path QP needs a "
                                          "QP solver such as cvxpy:CLARABEL")
        x = cp.Variable(len(q))
        constraints = [Aeq @ x == beq]
        fin_lb, fin_ub = np.isfinite(lb), np.isfinite(ub)
        if fin_lb.any():
            constraints.append(x[np.flatnonzero(fin_lb)] >= lb[fin_lb])
        if fin_ub.any():
            constraints.append(x[np.flatnonzero(fin_ub)] <= ub[fin_ub])
        prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(x, cp.psd_wrap(P)) + q @ x),
                          constraints)
        try:
            prob.solve(solver=name)
        except Exception:
            return None, Status.SOLVER_ERROR, None
        ok = prob.status == "optimal"
        stats = prob.solver_stats
        return (x.value if ok else None, Status.OPTIMAL if ok else Status.SOLVER_ERROR,
                None if stats is None else stats.num_iters)
    raise UnsupportedProblemError(
        f"smooth_jointly runs on qpsolvers:SOLVER or cvxpy[:SOLVER], not {family!r}")

