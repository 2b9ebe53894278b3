"""The main entry point: :func:`distribute` tensions over a batch of poses."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend, RawResult
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.backends.registry import route, solve_routed
from tension_opt.backends.settings import check_options
from tension_opt.checks import as_finite, as_float_array, whole_positive
from tension_opt.distribution.certified import (
    CertifiedBatch,
    CertifiedPlan,
    certified_plan,
    plan_of,
)
from tension_opt.distribution.chunks import (
    CERTIFIED_TASK,
    Joined,
    certified_chunks,
    chunk_slices,
    chunk_threads,
    in_order,
    pose_rows,
    renumbered,
)
from tension_opt.distribution.sequence import solve_sequence
from tension_opt.distribution.solution import TensionSolution, reusable, solution_of
from tension_opt.errors import InvalidInputError
from tension_opt.kernels import launch
from tension_opt.problem.form import Objective, TensionProblem, as_problem
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array

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
        Poses per chunk (default :data:`CHUNK_SIZE`). A larger batch is solved chunk by
        chunk (geometry, problem and backend): its memory is its results plus one
        chunk's work; the results are those of one call on the whole batch (a sequence
        carries on from one chunk to the next), but ``solution.form`` is None
        (:meth:`TensionProblem.standard_form` rebuilds those of any poses). Independent
        poses on the compiled closed form take one compiled pass per chunk
        (:mod:`tension_opt.distribution.certified`; objective and residual to rounding),
        in tasks of :data:`~tension_opt.distribution.chunks.CERTIFIED_TASK` poses unless
        ``chunk_size`` is given (without it, from 16 poses in one task, the form kept).
        Invalid input in a later chunk raises there.
    out : TensionSolution, optional
        An earlier result on as many poses of the same robot and problem, whose arrays
        take this call's results (no page faults of fresh memory: 10^6 study poses in
        about 0.7x the time). Not for calls running at the same time.
    **options
        ``accuracy`` (``"default"``, ``"high"`` or a number: the certificate's target, the
        closed form's too), ``time_limit`` (s per solver call, a pose or cvxpy's ``batch_size``
        poses: 10 s unless given, None for none; a pose it stops reads ``max_iter``),
        ``solver_options`` (the solver's own names), ``warm_start`` (not across chunks),
        ``batch_size`` (:mod:`tension_opt.backends.settings`); anything else is an error.

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
        out = reusable(out, len(p), robot.m,
                       (p, wrench, prev, problem.t_min, problem.t_max, problem.reference))
    if len(p) <= size:
        sol = _distribute_batch(robot, p, problem, backend, wrench, prev, options, chunk_size
                                is None and prev is None and len(p) >= launch.COMPILED_MIN)[0]
    else:
        sol = _distribute_chunks(robot, p, problem, backend, wrench, prev, options, size,
                                 CERTIFIED_TASK if chunk_size is None else size, out)
    return sol if out is None else sol.written_into(out)


def _distribute_batch(robot: CableRobot, p: NDArray, problem: TensionProblem,
                      backend: str | Backend, wrench: ArrayLike | None,
                      prev: NDArray | None, options: dict[str, Any],
                      certified: bool = False) -> tuple[TensionSolution, NDArray | None]:
    """:func:`distribute` of validated poses ``p`` (N, n) in one piece; also, for a
    sequence, the tensions the pose after it is smoothed against (its last optimal
    ones, else ``prev``). ``certified``: through the certified compiled pass where it
    applies (:func:`_certified_whole`)."""
    t0 = time.perf_counter()
    A, b = robot.equilibrium(p, wrench)
    geometry_time = time.perf_counter() - t0
    sequential = problem.is_sequential and (prev is None or prev.ndim == 1)
    # For a sequence this is the shape of every smoothed pose, to choose and check with.
    form = problem.standard_form_from(robot, A, b, np.zeros(robot.m) if sequential else prev)
    way = route(backend, form)
    chosen = way.backend
    if form.N == 0:  # an empty batch is an empty solution, whatever the backend
        empty = RawResult(np.empty((0, robot.m)), status_array(0), np.zeros(0, dtype=int))
        return solution_of(form, empty, chosen, setup_time=geometry_time), prev
    last = None
    if sequential:
        raw, form = solve_sequence(chosen, problem, robot, A, b, prev, options,
                                    way.fallback)
        # As the sequence itself goes on: from the solver's optimal poses.
        solved = np.flatnonzero(raw.status == Status.OPTIMAL)
        last = raw.tensions[solved[-1]].copy() if len(solved) else prev
    else:
        plan = None if not (certified and isinstance(chosen, ClosedFormBackend)
                            ) or problem.has_pose_rows else plan_of(
            robot, problem, chosen, form, options.get("accuracy"))
        if plan is not None:
            return _certified_whole(robot, p, problem, backend, wrench, options, plan,
                                    form), last
        raw = solve_routed(way, form, options)
    return solution_of(form, raw, chosen, setup_time=geometry_time), last


def _certified_whole(robot: CableRobot, p: NDArray, problem: TensionProblem,
                     backend: str | Backend, wrench: ArrayLike | None,
                     options: dict[str, Any], plan: CertifiedPlan, form: Any
                     ) -> TensionSolution:
    """A batch of one chunk of independent poses on the compiled closed form (from
    :data:`~tension_opt.kernels.launch.COMPILED_MIN` poses: a rule on the call alone)
    through the certified compiled pass in one task, its ``form`` kept as any batch of
    one chunk keeps it: the same statuses, tensions, multipliers and certificate as the
    chunk path, the objective and residuals to rounding, several times faster on a
    point robot of four cables (whose poses the pass takes 16 at a time). The poses the
    pass leaves go through the chunk path."""
    w_rows = pose_rows("wrench", None if wrench is None else as_finite("wrench", wrench),
                       len(p), robot.dof, scalar=False)

    def leftovers(poses: slice | NDArray) -> TensionSolution:
        try:
            return _distribute_batch(robot, p[poses], problem, backend,
                                     None if w_rows is None else w_rows(poses), None,
                                     options)[0]
        except InvalidInputError as error:
            raise renumbered(error, poses) from None

    batch = CertifiedBatch(plan, p, None if w_rows is None else w_rows(slice(None)), None)
    return replace(certified_chunks(batch, len(p), CHUNK_SIZE, 1, leftovers, problem),
                   form=form)


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
    slices = chunk_slices(N, size)

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

    plan = None if problem.has_pose_rows else certified_plan(robot, problem, backend,
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
