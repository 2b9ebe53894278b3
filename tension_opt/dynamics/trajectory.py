"""Tension distribution along trajectories: pointwise, smoothed, rate-limited, joint.

Pointwise, penalty-smoothed and rate-limited distributions are :func:`distribute` with
the right :class:`~tension_opt.problem.form.TensionProblem`; :func:`smooth_jointly` solves
the whole path as one sparse QP::

    minimise   sum_k f(T_k) + weight * sum_k ||T_k - T_{k-1}||^2
    subject to A_k T_k = b_k,  t_min <= T_k <= t_max   for every pose k
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import note_error
from tension_opt.backends.registry import get_backend
from tension_opt.backends.settings import check_options, quiet_solvers, solver_options
from tension_opt.certify.scaling import reference_tension
from tension_opt.distribution.entry import distribute
from tension_opt.distribution.solution import TensionSolution
from tension_opt.errors import (
    BackendNotAvailableError,
    InvalidInputError,
    UnsupportedProblemError,
)
from tension_opt.problem.form import StandardForm, as_problem
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array

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
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity (N, N m).
    **options
        ``accuracy``, ``time_limit`` and ``solver_options`` as for
        :func:`~tension_opt.distribute`.

    Returns
    -------
    TensionSolution
        With the same status for every pose (the path is solved as a whole); a solver's
        exception is kept in ``extras["errors"]``.
    """
    problem = as_problem(objective)
    if problem.objective == "min_max" or problem.is_sequential:
        raise UnsupportedProblemError(
            "smooth_jointly takes min_sum, min_norm, pinv or centered without its own smoothing")
    if not isinstance(weight, int | float | np.integer | np.floating) or isinstance(
            weight, bool) or not np.isfinite(weight) or weight < 0:
        raise InvalidInputError(f"weight must be a finite number >= 0, got {weight!r}")
    if not isinstance(backend, str):
        raise InvalidInputError(f"backend must be a name such as 'qpsolvers:clarabel' or "
                                f"'cvxpy:CLARABEL', got {backend!r}")
    check_options(options)
    t0 = time.perf_counter()
    form = problem.standard_form(robot, robot.as_poses(poses), wrench)
    N, m = form.N, form.m
    family, _, solver = backend.partition(":")
    extras: dict[str, Any] = {"weight": weight}
    x, status, iterations = None, Status.OPTIMAL, None
    setup = elapsed = 0.0
    if N:
        s, path = _path_qp(form, float(weight))
        setup = time.perf_counter() - t0
        t0 = time.perf_counter()
        x, status, iterations = _solve_path(family, solver, path, options, extras)
        elapsed = time.perf_counter() - t0
        if x is not None:
            x = x.reshape(N, m) * s
    T = np.full((N, m), np.nan) if x is None else x
    extras["path_iterations"] = iterations
    sol = TensionSolution.from_form(
        form, T, status_array(N, status), backend=f"joint:{backend}",
        solver=solver or backend, iterations=None if iterations is None
        else np.full(N, iterations), setup_time=setup, solve_time=elapsed, extras=extras,
        accuracy=options.get("accuracy"), optimality=False)  # optimal as a path, not per pose
    if not sol.success.all():  # the path is one problem: one inaccurate pose taints it all
        sol.status[sol.success] = Status.INACCURATE
    return sol


def _path_qp(form: StandardForm, weight: float) -> tuple[float, tuple[Any, ...]]:
    """The path QP in scaled units ``x = T / s``: ``(s, (P, q, Aeq, beq, lb, ub))``.

    ``s`` is the median typical tension; the objective is divided by its largest
    Hessian entry (or cost), so a weight of 1e10 poses the solver a well-scaled problem.
    """
    N, m = form.N, form.m
    s = float(np.median(reference_tension(form)))
    top = max(float(form.q.max(initial=0.0)), 2.0 * weight)
    cost = float(np.abs(form.c).max(initial=0.0))
    sigma = s**2 * top if top > 0 else s * (cost if cost > 0 else 1.0)
    diff = sp.diags([np.ones(N - 1), -np.ones(N - 1)], [0, 1], shape=(N - 1, N))
    D = sp.kron(diff, sp.identity(m), format="csc")
    P = sp.diags(form.q.ravel() * s**2 / sigma) + 2.0 * weight * s**2 / sigma * (D.T @ D)
    Aeq = sp.block_diag(list(form.A), format="csc")
    return s, (sp.csc_matrix(P), form.c.ravel() * s / sigma, Aeq, form.b.ravel() / s,
               form.lb.ravel() / s, form.ub.ravel() / s)


def _solve_path(family: str, solver: str, path: tuple[Any, ...], options: dict[str, Any],
                extras: dict[str, Any]) -> tuple[NDArray | None, Status, int | None]:
    """Solve the path QP; a solver's exception becomes ``SOLVER_ERROR`` with its message
    in ``extras["errors"]`` (options it rejects raise :class:`SolverError` first)."""
    if family == "qpsolvers":
        return _solve_path_qpsolvers(solver, path, options, extras)
    if family == "cvxpy":
        return _solve_path_cvxpy(solver, path, options, extras)
    raise UnsupportedProblemError(
        f"smooth_jointly runs on qpsolvers:SOLVER or cvxpy[:SOLVER], not {family!r}")


def _solve_path_qpsolvers(solver: str, path: tuple[Any, ...], options: dict[str, Any],
                          extras: dict[str, Any]) -> tuple[NDArray | None, Status, int | None]:
    import qpsolvers

    from tension_opt.backends.qpsolvers_backend import failure_status, iterations_of

    P, q, Aeq, beq, lb, ub = path
    name = solver or next((s for s in _SPARSE_SOLVERS if s in qpsolvers.available_solvers),
                          "")
    if not name:
        raise BackendNotAvailableError(
            f"smooth_jointly needs a sparse QP solver: pip install one of {_SPARSE_SOLVERS}")
    # A clear error if not installed, or if the solver rejects the options.
    get_backend(f"qpsolvers:{name}").check_solver_options(options)
    settings = solver_options(name, options.get("accuracy"), options.get("time_limit"),
                              options.get("solver_options"), per_pose=False)
    problem = qpsolvers.Problem(P, q, None, None, Aeq, beq, lb, ub)
    try:
        with quiet_solvers():
            sol = qpsolvers.solve_problem(problem, solver=name, **settings)
    except Exception as error:  # a solver's failure on the path
        note_error(extras, 0, error)
        return None, Status.SOLVER_ERROR, None
    iterations = iterations_of(sol.extras or {})
    if not sol.found or sol.x is None or not np.isfinite(sol.x).all():
        return None, failure_status(sol.extras or {}), iterations
    return sol.x, Status.OPTIMAL, iterations


def _solve_path_cvxpy(solver: str, path: tuple[Any, ...], options: dict[str, Any],
                      extras: dict[str, Any]) -> tuple[NDArray | None, Status, int | None]:
    import cvxpy as cp

    from tension_opt.backends.cvxpy_backend import LP_ONLY

    P, q, Aeq, beq, lb, ub = path
    name = (solver or "CLARABEL").upper()
    # A clear error if not installed, or if the solver rejects the options.
    get_backend(f"cvxpy:{name}").check_solver_options(options)
    if name in LP_ONLY:
        raise UnsupportedProblemError(f"cvxpy:{name} solves LPs only; a path QP needs a "
                                      "QP solver such as cvxpy:CLARABEL")
    settings = solver_options(name, options.get("accuracy"), options.get("time_limit"),
                              options.get("solver_options"), interface="cvxpy",
                              per_pose=False)
    x = cp.Variable(len(q))
    constraints = [Aeq @ x == beq]
    fin_lb, fin_ub = np.isfinite(lb), np.isfinite(ub)
    if fin_lb.any():
        constraints.append(x[np.flatnonzero(fin_lb)] >= lb[fin_lb])
    if fin_ub.any():
        constraints.append(x[np.flatnonzero(fin_ub)] <= ub[fin_ub])
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(x, cp.psd_wrap(P)) + q @ x), constraints)
    try:
        with quiet_solvers():
            prob.solve(solver=name, **settings)
    except Exception as error:  # a solver's failure on the path
        note_error(extras, 0, error)
        return None, Status.SOLVER_ERROR, None
    stats = prob.solver_stats
    iterations = None if stats is None else stats.num_iters
    status = _CVXPY_STATUS.get(str(prob.status), Status.SOLVER_ERROR)
    if status not in (Status.OPTIMAL, Status.INACCURATE) or x.value is None:
        return None, Status.SOLVER_ERROR if status == Status.INACCURATE else status, iterations
    return x.value, status, iterations


#: cvxpy's statuses of a path solve.
_CVXPY_STATUS = {"optimal": Status.OPTIMAL, "optimal_inaccurate": Status.INACCURATE,
                 "infeasible": Status.INFEASIBLE, "infeasible_inaccurate": Status.INFEASIBLE,
                 "unbounded": Status.UNBOUNDED, "unbounded_inaccurate": Status.UNBOUNDED,
                 "user_limit": Status.MAX_ITER}
