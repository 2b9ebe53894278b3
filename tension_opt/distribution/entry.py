"""The main entry point: :func:`distribute` tensions over a batch of poses."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend, RawResult, SequenceRun
from tension_opt.backends.registry import (
    AUTO_ORDER,
    available_backends,
    choose_backend,
    get_backend,
)
from tension_opt.backends.settings import check_options
from tension_opt.checks import as_finite, as_float_array, whole_positive
from tension_opt.distribution.certified import CertifiedBatch, certified_plan
from tension_opt.distribution.chunks import (
    CERTIFIED_TASK,
    Joined,
    certified_chunks,
    chunk_threads,
    in_order,
    pose_rows,
    renumbered,
    slices_of,
)
from tension_opt.distribution.solution import TensionSolution, reusable, solution_of
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import Objective, StandardForm, TensionProblem, as_problem
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.tolerances import accuracy_target

__all__ = ["CHUNK_SIZE", "distribute"]

#: Poses per chunk of a large batch (:func:`distribute`). The closed form's
#: two-dimensional enumeration (eight cables, six degrees of freedom) holds about
#: 30 kB per pose while it runs, so a chunk needs about 120 MB whatever the batch
#: (larger chunks are no faster: their temporaries fall out of the caches).
CHUNK_SIZE = 4096


def distribute(
    robot: CableRobot,
    poses: ArrayLike,
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str | Backend = "auto",
    wrench: ArrayLike | None = None,
    previous: ArrayLike | None = None,
    *,
    chunk_size: int | None = None,
    out: TensionSolution | None = None,
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
        :class:`~tension_opt.problem.form.TensionProblem` (weights, bounds, smoothing ...).
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
    chunk_size : int, optional
        Poses per chunk (default :data:`CHUNK_SIZE`). A larger batch is solved chunk
        by chunk (geometry, problem and backend), so its memory is that of its
        results plus one chunk's work; the results are those of one call on the whole
        batch (a sequence carries on from one chunk to the next), save that
        ``solution.form`` is None (the problems of every pose would outweigh the
        tensions; :meth:`TensionProblem.standard_form` rebuilds those of any poses).
        Independent poses on the compiled closed form take one compiled pass per chunk
        (:mod:`tension_opt.distribution.certified`; sums in another order: objective and residual to
        rounding), in tasks of :data:`~tension_opt.distribution.chunks.CERTIFIED_TASK` poses unless
        ``chunk_size`` is given. Invalid input in a later chunk raises there.
    out : TensionSolution, optional
        An earlier result on as many poses of the same robot and problem, whose arrays
        take this call's results (no page faults of fresh memory: 10^6 study poses in
        about 0.7x the time). Not for calls running at the same time.
    **options
        ``accuracy`` (``"default"``, ``"high"`` or a number: the certificate's target,
        the closed form's too), ``time_limit`` (s per solver call: a pose, or cvxpy's
        ``batch_size`` poses), ``solver_options`` (the solver's own names), ``warm_start``,
        ``batch_size`` (:mod:`tension_opt.backends.settings`); anything else is an error.
        A warm start does not cross from one chunk to the next.

    Returns
    -------
    TensionSolution
        Per-pose tensions (N, m), status, uniqueness, objective and residuals.
    """
    if not isinstance(robot, CableRobot):
        raise InvalidInputError(f"robot must be a CableRobot, got {type(robot).__name__}")
    check_options(options)
    size = CHUNK_SIZE if chunk_size is None else whole_positive("chunk_size", chunk_size)
    problem = as_problem(objective)
    p = robot.as_poses(poses)
    prev = None if previous is None else as_float_array("previous", previous)
    if out is not None:
        inputs = (p, wrench, prev, problem.t_min, problem.t_max, problem.reference)
        out = reusable(out, len(p), robot.m, inputs)
    if len(p) <= size:
        sol = _distribute_batch(robot, p, problem, backend, wrench, prev, options)[0]
    else:
        task = CERTIFIED_TASK if chunk_size is None else size
        sol = _distribute_chunks(robot, p, problem, backend, wrench, prev, options, size,
                                 task, out)
    return sol if out is None else sol.written_into(out)


def _distribute_batch(robot: CableRobot, p: NDArray, problem: TensionProblem,
                      backend: str | Backend, wrench: ArrayLike | None,
                      prev: NDArray | None, options: dict[str, Any]
                      ) -> tuple[TensionSolution, NDArray | None]:
    """:func:`distribute` of validated poses ``p`` (N, n) in one piece; also, for a
    sequence, the tensions the pose after it is smoothed against (its last optimal
    ones, else ``prev``)."""
    t0 = time.perf_counter()
    A, b = robot.equilibrium(p, wrench)
    geometry_time = time.perf_counter() - t0
    sequential = problem.is_sequential and (prev is None or prev.ndim == 1)
    # For a sequence this is the shape of every smoothed pose, to choose and check with.
    form = problem.standard_form_from(robot, A, b, np.zeros(robot.m) if sequential else prev)
    chosen = choose_backend(backend, form)
    if form.N == 0:  # an empty batch is an empty solution, whatever the backend
        empty = RawResult(np.empty((0, robot.m)), status_array(0), np.zeros(0, dtype=int))
        return solution_of(form, empty, chosen, setup_time=geometry_time), prev
    auto = isinstance(backend, str) and backend == "auto"
    last = None
    if sequential:
        raw, form = _solve_sequence(chosen, problem, robot, A, b, prev, options, auto)
        # As the sequence itself goes on: from the solver's optimal poses.
        solved = np.flatnonzero(raw.status == Status.OPTIMAL)
        last = raw.tensions[solved[-1]].copy() if len(solved) else prev
    else:
        raw = _solve(chosen, form, options, auto)
    return solution_of(form, raw, chosen, setup_time=geometry_time), last


def _distribute_chunks(robot: CableRobot, p: NDArray, problem: TensionProblem,
                       backend: str | Backend, wrench: ArrayLike | None,
                       prev: NDArray | None, options: dict[str, Any],
                       size: int, task: int, out: TensionSolution | None
                       ) -> TensionSolution:
    """:func:`distribute` of validated poses ``p`` (N, n) in chunks of at most ``size``
    poses (tasks of ``task`` poses on the certified compiled pass, into the arrays of
    ``out`` where given).

    Inputs with one row per pose (wrench, bounds, reference, independent previous
    tensions) are cut with the poses; a sequence goes on from the last optimal tension
    of the chunk before. Pose numbers in errors and extras count over the whole batch.
    """
    N, m = len(p), robot.m
    w_rows = pose_rows("wrench", None if wrench is None else as_finite("wrench", wrench),
                       N, robot.dof, scalar=False)
    chained = problem.is_sequential and (prev is None or prev.ndim == 1)
    prev_rows = pose_rows("previous", prev if problem.is_sequential and not chained
                          else None, N, m)
    per_pose = {name: cut for name in ("t_min", "t_max", "reference")
                if (cut := pose_rows(name, getattr(problem, name), N, m)) is not None}
    slices = slices_of(N, size)

    def solve(poses: slice | NDArray, last: NDArray | None
              ) -> tuple[TensionSolution, NDArray | None]:
        part = problem.with_(**{name: cut(poses) for name, cut in per_pose.items()}
                             ) if per_pose else problem
        try:
            return _distribute_batch(
                robot, p[poses], part, backend, None if w_rows is None else w_rows(poses),
                last if chained else (None if prev_rows is None else prev_rows(poses)),
                options)
        except InvalidInputError as error:
            raise renumbered(error, poses) from None

    rows = any(np.ndim(getattr(problem, name)) == 2 for name in per_pose)  # bounds per pose
    plan = None if rows else certified_plan(robot, problem, backend,
                                                options.get("accuracy"))
    if plan is not None:
        batch = CertifiedBatch(plan, p, None if w_rows is None else w_rows(slice(None)),
                               out)
        return certified_chunks(batch, task, size, chunk_threads(),
                                lambda poses: solve(poses, None)[0], problem)
    joined = Joined(N)
    sol, last = solve(slices[0], prev)
    joined.add(sol, slices[0])
    workers = chunk_threads()
    if chained or workers < 2 or sol.backend != "closed_form":
        for sl in slices[1:]:
            sol, after = solve(sl, last)
            joined.add(sol, sl)
            last = after if chained else None
        return joined.solution(problem)
    # Independent poses on the compiled closed form: its kernels release the GIL, so
    # chunks run side by side in threads, joined in order (the serial loop's result).
    in_order(slices[1:], lambda sl: solve(sl, None)[0], workers,
             lambda sl, sol: joined.add(sol, sl))
    return joined.solution(problem)


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


def _solve_sequence(backend: Backend, problem: TensionProblem, robot: CableRobot, A: NDArray,
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
    extras: dict[str, Any] = {"accuracy_target": accuracy_target(options.get("accuracy"))}
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
        solver = backend if backend.unsupported(form) is None else choose_backend("auto", form)
        raw = _solve(solver, form, options, auto or solver is not backend)
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
                     extras=extras), stacked


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
    if backend.unsupported(smoothed) or not backend.runs_sequences(options, smoothed):
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
