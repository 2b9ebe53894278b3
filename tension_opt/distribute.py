"""The main entry point: :func:`distribute` tensions over a batch of poses."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend, RawResult
from tension_opt.backends.registry import (
    AUTO_ORDER,
    available_backends,
    choose_backend,
    get_backend,
)
from tension_opt.backends.settings import check_options
from tension_opt.errors import InvalidInputError
from tension_opt.problems import Objective, StandardForm, TensionProblem, as_problem
from tension_opt.robot import CableRobot, as_float_array
from tension_opt.solution import FEASIBILITY_TOL, Status, TensionSolution, status_array

__all__ = ["FEASIBILITY_TOL", "distribute", "solution_of"]


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
        ``"auto"`` (the fastest exact backend that supports the problem; poses it
        cannot settle, ``solver_error``, go to the next able backend of
        :data:`~tension_opt.backends.registry.AUTO_ORDER`, recorded in
        ``extras["fallback"]`` as ``{backend: [poses]}``), ``"closed_form"``,
        ``"cvxpy"``, ``"cvxpy:CLARABEL"``, ``"qpsolvers:daqp"``, ``"scipy:highs"``, ...;
        see :func:`tension_opt.available_backends`.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).
    previous : array_like, shape (m,) or (N, m), optional
        For smoothed or rate-limited problems. Shape (N, m): the previous tensions of
        each pose, solved independently. Shape (m,) or None: the poses are a sequence,
        solved in order, each against the solution of the pose before (the first
        against ``previous``, or unsmoothed when None).
    **options
        Passed to the backend: ``accuracy`` (``"default"`` or ``"high"``), ``time_limit``
        (s), ``solver_options`` (a dict in the solver's own names), ``warm_start``,
        ``batch_size`` (:mod:`tension_opt.backends.settings`); anything else is an error.

    Returns
    -------
    TensionSolution
        Per-pose tensions (N, m), status, uniqueness, objective and residuals.
    """
    if not isinstance(robot, CableRobot):
        raise InvalidInputError(f"robot must be a CableRobot, got {type(robot).__name__}")
    check_options(options)
    problem = as_problem(objective)
    p = robot.as_poses(poses)
    t0 = time.perf_counter()
    A = robot.structure_matrices(p)
    b = robot.required_wrench(p, wrench)
    geometry_time = time.perf_counter() - t0
    prev = None if previous is None else as_float_array("previous", previous)
    sequential = problem.is_sequential and (prev is None or prev.ndim == 1)
    # For a sequence this is the shape of every smoothed pose, to choose and check with.
    form = problem.standard_form_from(robot, A, b, np.zeros(robot.m) if sequential else prev)
    chosen = choose_backend(backend, form)
    if form.N == 0:  # an empty batch is an empty solution, whatever the backend
        empty = RawResult(np.empty((0, robot.m)), status_array(0), np.zeros(0, dtype=int))
        return solution_of(form, empty, chosen, setup_time=geometry_time)
    auto = isinstance(backend, str) and backend == "auto"
    if sequential:
        raw, form = _solve_sequence(chosen, problem, robot, A, b, prev, options, auto)
    else:
        raw = _solve(chosen, form, options, auto)
    return solution_of(form, raw, chosen, setup_time=geometry_time)


def _solve(backend: Backend, form: StandardForm, options: dict[str, Any],
           auto: bool) -> RawResult:
    """``backend.solve``; with ``auto``, poses it reports ``SOLVER_ERROR`` (a pose its
    method does not cover, such as a rank-deficient structure matrix in the closed
    form) are solved again by the next able backend of ``AUTO_ORDER``."""
    raw = backend.solve(form, **options)
    if not auto or not (raw.status == Status.SOLVER_ERROR).any():
        return raw
    order = list(AUTO_ORDER)
    later = order[order.index(backend.name) + 1:] if backend.name in order else order
    installed = set(available_backends())
    for name in later:
        failed = np.flatnonzero(raw.status == Status.SOLVER_ERROR)
        if not len(failed):
            break
        other = get_backend(name) if name in installed else None
        sub = form.subset(failed)
        if other is None or other.unsupported(sub) is not None:
            continue
        again = other.solve(sub, **options)
        raw.tensions[failed], raw.status[failed] = again.tensions, again.status
        if raw.unique is not None:
            raw.unique[failed] = True if again.unique is None else again.unique
        if raw.iterations is not None:
            raw.iterations[failed] = 0 if again.iterations is None else again.iterations
        if raw.infeasibility is not None:
            raw.infeasibility[failed] = (np.nan if again.infeasibility is None
                                         else again.infeasibility)
        raw.setup_time += again.setup_time
        raw.solve_time += again.solve_time
        answered = failed[again.status != Status.SOLVER_ERROR]
        if len(answered):
            raw.extras.setdefault("fallback", {})[name] = answered.tolist()
    return raw


def solution_of(form: StandardForm, raw: RawResult, backend: Backend,
                setup_time: float = 0.0) -> TensionSolution:
    """The :class:`TensionSolution` of a backend's raw result on ``form``.

    ``setup_time`` (s) is added to the backend's own (e.g. the geometry's).
    """
    return TensionSolution.from_form(
        form, raw.tensions, raw.status, backend=backend.name, solver=backend.solver,
        solver_version=backend.version, unique=raw.unique, iterations=raw.iterations,
        infeasibility=raw.infeasibility, setup_time=raw.setup_time + setup_time,
        solve_time=raw.solve_time, extras=raw.extras)


def _solve_sequence(backend: Backend, problem: TensionProblem, robot: CableRobot, A: NDArray,
                    b: NDArray, previous: NDArray | None, options: dict[str, Any],
                    auto: bool = False) -> tuple[RawResult, StandardForm]:
    """Solve poses in order, each smoothed against the previous solution.

    The chain is sequential by nature (pose k needs the answer of pose k - 1). Returns
    the raw result and the stacked form of the problems solved.
    """
    N, _, m = A.shape
    unsmoothed = problem.with_(smoothing=0.0, rate_limit=None)
    tensions = np.full((N, m), np.nan)
    status = status_array(N, Status.NOT_RUN)
    iterations: NDArray | None = np.zeros(N, dtype=int)
    unique = np.ones(N, dtype=bool)
    forms: list[StandardForm] = []
    extras: dict[str, Any] = {}
    setup = solve = 0.0
    last = previous
    for k in range(N):
        if last is None or not np.isfinite(last).all():
            form = unsmoothed.standard_form_from(robot, A[k:k + 1], b[k:k + 1])
        else:
            form = problem.standard_form_from(robot, A[k:k + 1], b[k:k + 1], last)
        forms.append(form)
        # A pose with no previous solution is unsmoothed (an LP for min-sum), which a
        # QP-only backend hands to the automatic choice.
        solver = backend if backend.unsupported(form) is None else choose_backend("auto", form)
        raw = _solve(solver, form, options, auto or solver is not backend)
        tensions[k], status[k] = raw.tensions[0], raw.status[0]
        for name in raw.extras.get("fallback", {}):
            extras.setdefault("fallback", {}).setdefault(name, []).append(k)
        if raw.extras.get("errors"):
            extras.setdefault("errors", {})[k] = next(iter(raw.extras["errors"].values()))
        unique[k] = True if raw.unique is None else raw.unique[0]
        if iterations is not None and raw.iterations is not None:
            iterations[k] = raw.iterations[0]
        else:
            iterations = None
        setup += raw.setup_time
        solve += raw.solve_time
        if status[k] == Status.OPTIMAL:
            last = tensions[k]
    stacked = StandardForm.stack(forms)
    # Every pose is judged by the smoothed problem, the first one included.
    stacked = replace(stacked, problem=problem)
    return RawResult(tensions, status, iterations, setup, solve, unique,
                     extras=extras), stacked
