"""The main entry point: :func:`distribute` tensions over a batch of poses."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend, RawResult
from tension_opt.backends.registry import choose_backend
from tension_opt.problems import Objective, TensionProblem, as_problem
from tension_opt.robot import CableRobot
from tension_opt.solution import STATUS_DTYPE, Status, TensionSolution, status_array

#: Relative tolerance (of the typical tension) on equilibrium and bounds of a solution.
FEASIBILITY_TOL = 1e-6



def distribute(
    robot: CableRobot,
    poses: ArrayLike,
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str | Backend = "auto",
    wrench: ArrayLike | None = None,
    previous: ArrayLike | None = None,
    **options: Any,
) -> TensionSolution:
    """Distribute cable tensions over a batch of poses.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
        Platform poses (see :mod:`tension_opt.robot` for the coordinates).
    objective : str or TensionProblem
        ``"min_sum"``, ``"min_norm"``, ``"pinv"``, ``"min_max"``, ``"centered"`` or a
        :class:`~tension_opt.problems.TensionProblem` (weights, bounds, smoothing ...).
    backend : str or Backend
        ``"auto"`` (the fastest exact backend that supports the problem),
        ``"closed_form"``, ``"cvxpy"``, ``"cvxpy:CLARABEL"``, ``"qpsolvers:daqp"``,
        ``"scipy:highs"``, ...; see :func:`tension_opt.available_backends`.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).
    previous : array_like, shape (m,) or (N, m), optional
        For smoothed or rate-limited problems. Shape (N, m): the previous tensions of
        each pose, solved independently. Shape (m,) or None: the poses are a sequence,
        solved in order, each against the solution of the pose before (the first
        against ``previous``, or unsmoothed when None).
    **options
        Passed to the backend (e.g. ``accuracy="high"``, ``time_limit``).

    Returns
    -------
    TensionSolution
        Per-pose tensions (N, m), status, uniqueness, objective and residuals.
    """
    problem = as_problem(objective)
    p = robot.as_poses(poses)
    t0 = time.perf_counter()
    A = robot.structure_matrices(p)
    b = robot.required_wrench(p, wrench)
    geometry_time = time.perf_counter() - t0
    prev = None if previous is None else np.asarray(previous, dtype=float)
    sequential = problem.is_sequential and (prev is None or prev.ndim == 1)
    # For a sequence this is the shape of every smoothed pose, to choose and check with.
    form = problem.standard_form_from(robot, A, b, np.zeros(robot.m) if sequential else prev)
    chosen = choose_backend(backend, form)
    prevs: NDArray | None
    if sequential:
        raw, lb, ub, prevs = _solve_sequence(chosen, problem, robot, A, b, prev, options)
    else:
        raw = chosen.solve(form, **options)
        lb, ub, prevs = form.lb, form.ub, form.previous
    raw.setup_time += geometry_time
    return finish(raw, problem, chosen, A, b, lb, ub, prevs)


def _solve_sequence(backend: Backend, problem: TensionProblem, robot: CableRobot, A: NDArray,
                    b: NDArray, previous: NDArray | None, options: dict[str, Any]
                    ) -> tuple[RawResult, NDArray, NDArray, NDArray]:
    """Solve poses in order, each smoothed against the previous solution.

    The chain is sequential by nature (pose k needs the answer of pose k - 1).
    """
    N, _, m = A.shape
    unsmoothed = problem.with_(smoothing=0.0, rate_limit=None)
    tensions = np.full((N, m), np.nan)
    status = status_array(N, Status.NOT_RUN)
    iterations: NDArray | None = np.zeros(N, dtype=int)
    unique = np.ones(N, dtype=bool)
    lbs, ubs, prevs = np.empty((N, m)), np.empty((N, m)), np.full((N, m), np.nan)
    setup = solve = 0.0
    last = previous
    for k in range(N):
        if last is None or not np.isfinite(last).all():
            form = unsmoothed.standard_form_from(robot, A[k:k + 1], b[k:k + 1])
        else:
            form = problem.standard_form_from(robot, A[k:k + 1], b[k:k + 1], last)
            prevs[k] = last
        # A pose with no previous solution is unsmoothed (an LP for min-sum), which a
        # QP-only backend hands to the automatic choice.
        solver = backend if backend.unsupported(form) is None else choose_backend("auto", form)
        raw = solver.solve(form, **options)
        tensions[k], status[k] = raw.tensions[0], raw.status[0]
        unique[k] = True if raw.unique is None else raw.unique[0]
        if iterations is not None and raw.iterations is not None:
            iterations[k] = raw.iterations[0]
        else:
            iterations = None
        lbs[k], ubs[k] = form.lb[0], form.ub[0]
        setup += raw.setup_time
        solve += raw.solve_time
        if status[k] == Status.OPTIMAL:
            last = tensions[k]
    result = RawResult(tensions, status, iterations, setup, solve, unique)
    return result, lbs, ubs, prevs


def finish(raw: RawResult, problem: TensionProblem, backend: Backend, A: NDArray, b: NDArray,
           lb: NDArray, ub: NDArray, previous: NDArray | None) -> TensionSolution:
    """Turn a backend's raw result into a :class:`TensionSolution` with its diagnostics."""
    T = np.asarray(raw.tensions, dtype=float)
    status = np.asarray(raw.status, dtype=STATUS_DTYPE)
    solved = (status == Status.OPTIMAL) | (status == Status.INACCURATE)
    T[~solved] = np.nan
    residual = np.linalg.norm(np.einsum("nij,nj->ni", A, T) - b, axis=1)
    violation = np.maximum(np.nanmax(np.maximum(lb - T, T - ub), axis=1, initial=0.0), 0.0)
    violation[~solved] = np.nan
    # A solver's "optimal" is checked where it is cheap: equilibrium and bounds must hold
    # to FEASIBILITY_TOL of the typical tension, or the pose is reported inaccurate.
    scale = np.maximum(np.linalg.norm(b, axis=1),
                       np.where(np.isfinite(lb), np.abs(lb), 0.0).max(axis=1))
    loose = solved & ((residual > FEASIBILITY_TOL * scale)
                      | (violation > FEASIBILITY_TOL * scale))
    status[loose] = Status.INACCURATE
    prev = None if previous is None else np.where(np.isfinite(previous), previous, T)
    objective = problem.evaluate(T, lb, ub, prev)
    unique = np.ones(len(T), dtype=bool) if raw.unique is None else np.asarray(raw.unique)
    infeas = raw.infeasibility if raw.infeasibility is not None else np.full(len(T), np.nan)
    return TensionSolution(
        tensions=T, status=status, unique=unique, objective=objective, residual=residual,
        bound_violation=violation, iterations=raw.iterations, infeasibility=infeas,
        setup_time=raw.setup_time, solve_time=raw.solve_time, backend=backend.name,
        solver=backend.solver, solver_version=backend.version, problem=problem,
        extras=raw.extras,
    )
