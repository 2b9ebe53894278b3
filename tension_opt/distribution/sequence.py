"""A smoothed or rate-limited sequence of poses, solved in order: each pose against the
answer of the pose before.

Runs of poses go through the backend's compiled loop where it has one
(:meth:`~tension_opt.backends.base.Backend.solve_sequence`: the compiled closed form,
qpsolvers), any other pose through :func:`~tension_opt.backends.registry.solve_routed`
on its own form; the forms solved are stacked in pose order, every pose judged by the
smoothed problem.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import Backend, RawResult, SequenceRun
from tension_opt.backends.registry import route, solve_routed
from tension_opt.problem.form import StandardForm, TensionProblem
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.tolerances import accuracy_target

__all__ = ["solve_sequence"]


def solve_sequence(backend: Backend, problem: TensionProblem, robot: CableRobot, A: NDArray,
                    b: NDArray, previous: NDArray | None, options: dict[str, Any],
                    auto: bool = False) -> tuple[RawResult, StandardForm]:
    """Solve poses in order, each smoothed against the previous solution.

    The chain is sequential by nature (pose k needs the answer of pose k - 1). Runs of
    poses go through the backend's compiled loop where it has one
    (:meth:`Backend.solve_sequence`, the compiled closed form and qpsolvers: each pose
    as its own form would be solved), any other pose through the backend on its own
    form. Returns the raw
    result and the stacked form of the problems solved.
    """
    N, _, m = A.shape
    unsmoothed = problem.with_(smoothing=0.0, rate_limit=None)
    tensions = np.full((N, m), np.nan)
    status = status_array(N, Status.NOT_RUN)
    iterations: NDArray | None = np.zeros(N, dtype=int)
    unique = np.ones(N, dtype=bool)
    infeasibility = np.full(N, np.nan)
    forms: dict[int, StandardForm] = {}  # the poses solved on their own forms
    used = np.full((N, m), np.nan)  # what each pose was smoothed against (NaN: nothing)
    # The whole sequence is judged at the call's target (every backend's certificate
    # and the closed form's judgement use the same one).
    target = accuracy_target(options.get("accuracy"))
    extras: dict[str, Any] = {}
    setup = solve = 0.0
    last = previous
    base = _compiled_sequence(backend, problem, unsmoothed, robot, A, b, previous, options)
    rates = _rates(problem, m)
    k = 0
    while k < N:
        if base is not None:
            held = np.full(m, np.nan) if last is None else np.array(last, dtype=float)
            t0 = time.perf_counter()
            run = SequenceRun(tensions, status, unique, infeasibility, iterations, extras)
            stop = backend.solve_sequence(base, problem.smoothing, rates, held, k, run,
                                          options)
            iterations = run.iterations  # None once a solver reports none
            solve += time.perf_counter() - t0
            _smoothed_against(used, tensions, status, k, stop, last)
            last = held if np.isfinite(held).all() else last
            if stop >= N:
                break
            k = stop
        if last is None or not np.isfinite(last).all():
            form = unsmoothed.standard_form_from(robot, A[k:k + 1], b[k:k + 1])
        else:
            form = problem.standard_form_from(robot, A[k:k + 1], b[k:k + 1], last)
        forms[k] = form
        # A pose with no previous solution is unsmoothed (an LP for min-sum), which a
        # QP-only backend hands to the automatic choice.
        raw = solve_routed(route(backend, form, hand_over=True, fallback=auto), form, options)
        tensions[k], status[k] = raw.tensions[0], raw.status[0]
        for name in raw.extras.get("fallback", {}):
            extras.setdefault("fallback", {}).setdefault(name, []).append(k)
        if raw.extras.get("errors"):
            extras.setdefault("errors", {})[k] = next(iter(raw.extras["errors"].values()))
        unique[k] = True if raw.unique is None else raw.unique[0]
        if raw.infeasibility is not None:
            infeasibility[k] = raw.infeasibility[0]
        if iterations is not None and raw.iterations is not None:
            iterations[k] = raw.iterations[0]
        else:
            iterations = None
        setup += raw.setup_time
        solve += raw.solve_time
        if status[k] == Status.OPTIMAL:
            last = tensions[k]
        k += 1
    stacked = _stacked_sequence(problem, robot, base, forms, used, A, b)
    return RawResult(tensions, status, iterations, setup, solve, unique, infeasibility,
                     extras=extras, accuracy_target=target), stacked


def _compiled_sequence(backend: Backend, problem: TensionProblem, unsmoothed: TensionProblem,
                       robot: CableRobot, A: NDArray, b: NDArray, previous: NDArray | None,
                       options: dict[str, Any]) -> StandardForm | None:
    """The unsmoothed forms of every pose, where the backend runs the sequence in a
    loop (:meth:`Backend.solve_sequence`: the compiled closed form, qpsolvers),
    else None (also for previous tensions that are not m finite numbers: the
    pose-by-pose path names the error)."""
    if previous is not None and not (np.shape(previous) == (robot.m,)
                                     and np.isfinite(previous).all()):
        return None
    if any(x is not None and np.ndim(x) > 1
           for x in (problem.t_min, problem.t_max, problem.reference)):
        return None  # rows per pose: each pose's own form
    # The loop takes the poses the backend takes once smoothed (a QP-only solver the
    # smoothed ones; the unsmoothed ones go to the pose-by-pose path, which chooses).
    smoothed = problem.standard_form_from(robot, A[:1], b[:1], np.zeros(robot.m))
    if backend.unsupported(smoothed) or not backend.runs_sequences(options, smoothed, len(A)):
        return None
    base = unsmoothed.standard_form_from(robot, A, b)
    if base.minmax is not None or base.G is not None:
        return None
    return base


def _rates(problem: TensionProblem, m: int) -> NDArray:
    """Rate limit per cable (N), ``inf`` where there is none, shape (m,)."""
    if problem.rate_limit is None:
        return np.full(m, np.inf)
    return np.broadcast_to(np.asarray(problem.rate_limit, dtype=float), (m,))


def _smoothed_against(used: NDArray, tensions: NDArray, status: NDArray, start: int,
                      stop: int, last: NDArray | None) -> None:
    """Write into ``used`` what poses ``start .. stop - 1`` of a compiled run were
    smoothed against: the tensions of the last optimal pose before each, else ``last``
    (NaN where there is none)."""
    if stop <= start:
        return
    index = np.arange(start, stop)
    optimal = np.where(status[start:stop] == Status.OPTIMAL, index, -1)
    before = np.concatenate([[-1], np.maximum.accumulate(optimal)[:-1]])
    first = np.full(used.shape[1], np.nan) if last is None else last
    used[start:stop] = np.where((before >= 0)[:, None], tensions[np.maximum(before, 0)],
                                first)


def _stacked_sequence(problem: TensionProblem, robot: CableRobot, base: StandardForm | None,
                      forms: dict[int, StandardForm], used: NDArray, A: NDArray,
                      b: NDArray) -> StandardForm:
    """The forms of a solved sequence in pose order, judged by the smoothed problem:
    the own forms of the poses solved one by one, and the forms the compiled runs
    solved (smoothed against ``used``, unsmoothed where it is NaN)."""
    parts, order = [forms[k] for k in sorted(forms)], [np.array(sorted(forms), dtype=int)]
    if base is not None:
        compiled = np.setdiff1d(np.arange(len(A)), order[0])
        smoothed = compiled[np.isfinite(used[compiled]).all(axis=1)]
        plain = np.setdiff1d(compiled, smoothed)
        if len(smoothed):
            parts.append(problem.standard_form_from(robot, A[smoothed], b[smoothed],
                                                    used[smoothed]))
        if len(plain):
            parts.append(base.subset(plain))
        order += [smoothed, plain]
    stacked = StandardForm.stack(parts).subset(np.argsort(np.concatenate(order),
                                                          kind="stable"))
    # Every pose is judged by the smoothed problem, the first one included.
    return replace(stacked, problem=problem)
