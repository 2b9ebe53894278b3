"""The main entry point: :func:`distribute` tensions over a batch of poses."""

from __future__ import annotations

import operator
import re
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import fields, is_dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import MAX_ERRORS, Backend, RawResult, SequenceRun
from tension_opt.backends.registry import (
    AUTO_ORDER,
    available_backends,
    choose_backend,
    get_backend,
)
from tension_opt.backends.settings import check_options
from tension_opt.checks import as_finite, as_float_array
from tension_opt.errors import InvalidInputError
from tension_opt.fused import CertifiedBatch, certified_plan
from tension_opt.problems import Objective, StandardForm, TensionProblem, as_problem
from tension_opt.robot import CableRobot
from tension_opt.solution import FEASIBILITY_TOL, Status, TensionSolution, status_array

__all__ = ["CHUNK_SIZE", "FEASIBILITY_TOL", "distribute", "solution_of"]

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
    chunk_size : int, optional
        Poses per chunk (default :data:`CHUNK_SIZE`). A larger batch is solved chunk
        by chunk (geometry, problem and backend), so its memory is that of its
        results plus one chunk's work; the results are those of one call on the whole
        batch (a sequence carries on from one chunk to the next), save that
        ``solution.form`` is None (the problems of every pose would outweigh the
        tensions; :meth:`TensionProblem.standard_form` rebuilds those of any poses).
        Independent poses on the compiled closed form take one compiled pass per chunk
        (:mod:`tension_opt.fused`; sums in another order: objective and residual to
        rounding). Invalid input in a later chunk raises when that chunk is reached.
    **options
        Passed to the backend: ``accuracy`` (``"default"`` or ``"high"``), ``time_limit``
        (s), ``solver_options`` (a dict in the solver's own names), ``warm_start``,
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
    size = CHUNK_SIZE if chunk_size is None else _whole_positive("chunk_size", chunk_size)
    problem = as_problem(objective)
    p = robot.as_poses(poses)
    prev = None if previous is None else as_float_array("previous", previous)
    if len(p) <= size:
        return _distribute_batch(robot, p, problem, backend, wrench, prev, options)[0]
    return _distribute_chunks(robot, p, problem, backend, wrench, prev, options, size)


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
                       size: int) -> TensionSolution:
    """:func:`distribute` of validated poses ``p`` (N, n) in chunks of at most ``size``
    poses.

    Inputs with one row per pose (wrench, bounds, reference, independent previous
    tensions) are cut with the poses; a sequence goes on from the last optimal tension
    of the chunk before. Pose numbers in errors and extras count over the whole batch.
    """
    N, m = len(p), robot.m
    w_rows = _pose_rows("wrench", None if wrench is None else as_finite("wrench", wrench),
                        N, robot.dof, scalar=False)
    chained = problem.is_sequential and (prev is None or prev.ndim == 1)
    prev_rows = _pose_rows("previous", prev if problem.is_sequential and not chained
                           else None, N, m)
    per_pose = {name: cut for name in ("t_min", "t_max", "reference")
                if (cut := _pose_rows(name, getattr(problem, name), N, m)) is not None}
    count = -(-N // size)  # chunks of equal length (to one pose), none of a few poses
    slices = [slice(k * N // count, (k + 1) * N // count) for k in range(count)]

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
            raise _renumbered(error, poses) from None

    rows = any(np.ndim(getattr(problem, name)) == 2 for name in per_pose)  # bounds per pose
    plan = None if rows else certified_plan(robot, problem, backend)
    if plan is not None:
        batch = CertifiedBatch(plan, p, None if w_rows is None else w_rows(slice(None)))
        return _certified_chunks(batch, slices, lambda poses: solve(poses, None)[0], problem)
    joined = _Joined(N)
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
    _in_order(slices[1:], lambda sl: solve(sl, None)[0], workers,
              lambda sl, sol: joined.add(sol, sl))
    return joined.solution(problem)


def _certified_chunks(batch: CertifiedBatch, slices: list[slice],
                      solve: Callable[[NDArray | slice], TensionSolution],
                      problem: TensionProblem) -> TensionSolution:
    """A batch of independent poses on the compiled closed form, each chunk in one
    compiled pass (:mod:`tension_opt.fused`), side by side in threads; ``solve`` answers
    the poses the kernel leaves (the path of a chunk, on those poses alone)."""
    def run(sl: slice) -> tuple[NDArray | slice | None, TensionSolution | None, float]:
        t0 = time.perf_counter()
        left = batch.solve(sl)
        elapsed = time.perf_counter() - t0
        if left is None:
            return None, None, elapsed
        sol = solve(left)
        batch.put(left, sol)
        return left, sol, elapsed

    extras: dict[str, Any] = {}
    times = [0.0, 0.0]  # setup, solve

    def join(sl: slice, done: tuple[NDArray | slice | None, TensionSolution | None, float]
             ) -> None:
        left, sol, elapsed = done
        times[1] += elapsed
        if left is not None and sol is not None:
            _merge_extras(extras, sol.extras, left)
            times[0] += sol.setup_time
            times[1] += sol.solve_time

    _in_order(slices, run, chunk_threads(), join)
    return batch.solution(problem, extras, *times)


def _in_order(parts: list[slice], run: Callable[[slice], Any], workers: int,
              join: Callable[[slice, Any], None]) -> None:
    """``join(part, run(part))`` for each part in order, ``run`` on up to ``workers``
    threads at once (at most that many parts in flight: bounded memory). The first
    error in the order of the parts is raised, and the parts not started are dropped."""
    if workers < 2 or len(parts) < 2:
        for part in parts:
            join(part, run(part))
        return
    with ThreadPoolExecutor(workers) as pool:
        pending: deque[tuple[slice, Future[Any]]] = deque()
        try:
            for part in parts:
                pending.append((part, pool.submit(run, part)))
                if len(pending) >= workers:
                    done, future = pending.popleft()
                    join(done, future.result())
            while pending:
                done, future = pending.popleft()
                join(done, future.result())
        finally:
            for _, future in pending:
                future.cancel()


def chunk_threads() -> int:
    """Threads that run the chunks of a large closed-form batch side by side: numba's
    configured thread count (``NUMBA_NUM_THREADS``, one per core by default), read
    without starting its threading layer."""
    import numba

    return max(1, int(numba.config.NUMBA_NUM_THREADS))


def _whole_positive(name: str, value: object) -> int:
    """``value`` as a whole number >= 1, or the package's error naming ``name``."""
    try:
        if isinstance(value, bool | np.bool_):
            raise TypeError(name)
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidInputError(f"{name} must be a whole number >= 1, got {value!r}") from None
    if number < 1:
        raise InvalidInputError(f"{name} must be a whole number >= 1, got {number}")
    return number


def _pose_rows(name: str, value: ArrayLike | None, N: int, k: int, scalar: bool = True
               ) -> Callable[[slice], Any] | None:
    """How to cut ``value`` (one row per pose, or one for every pose) to chunks of poses:
    a function of the chunk's slice, None for None.

    Raises
    ------
    InvalidInputError
        If ``value`` has neither shape (k,) nor (N, k) (nor is a number, with ``scalar``).
    """
    if value is None:
        return None
    shape = np.shape(value)
    try:
        fits = np.broadcast_shapes(shape, (N, k)) == (N, k) and (scalar or len(shape) > 0)
    except ValueError:
        fits = False
    if not fits:
        allowed = "be a scalar or have shape" if scalar else "have shape"
        raise InvalidInputError(f"{name} must {allowed} ({k},) or ({N}, {k}), got {shape}")
    if len(shape) == 2 and shape[0] == N:
        rows = np.asarray(value)
        return lambda sl: rows[sl]
    return lambda sl: value


_POSE_NUMBER = re.compile(r"\bpose (\d+)\b")


def _in_batch(poses: slice | NDArray, k: int) -> int:
    """The number in the batch of pose ``k`` of some of its poses (a chunk's slice, or
    their indices)."""
    if isinstance(poses, slice):
        return k + (poses.start or 0)
    return int(poses[k]) if 0 <= k < len(poses) else k


def _renumbered(error: InvalidInputError, poses: slice | NDArray) -> InvalidInputError:
    """``error`` of some poses of the batch (a chunk's slice, or their indices), its pose
    numbers counted over the whole batch."""
    text = _POSE_NUMBER.sub(lambda hit: f"pose {_in_batch(poses, int(hit.group(1)))}",
                            str(error))
    return error if text == str(error) else type(error)(text)


class _Joined:
    """The fields of a :class:`TensionSolution` put together from its chunks.

    Per-pose arrays (first axis over the chunk's poses, also inside a dataclass field
    such as the multipliers) are written into arrays allocated for the whole batch at
    the first chunk; times add up; extras are merged (:func:`_merge_extras`); any other
    field keeps the first chunk's value. A per-pose field that some chunk lacks (e.g.
    iteration counts) is None for the batch.
    """

    def __init__(self, N: int) -> None:
        self.N = N
        self.fields: dict[str, Any] = {}
        self.parts: dict[str, tuple[type, list[str]]] = {}  # dataclass fields' members

    def add(self, sol: TensionSolution, sl: slice) -> None:
        """Take the solution of the poses ``sl`` of the batch."""
        n, first = sl.stop - sl.start, not self.fields
        for f in fields(sol):
            value = getattr(sol, f.name)
            if f.name in ("setup_time", "solve_time"):
                self.fields[f.name] = self.fields.get(f.name, 0.0) + value
            elif f.name == "extras":
                _merge_extras(self.fields.setdefault("extras", {}), value, sl)
            else:
                if first:
                    self.fields[f.name] = self._start(f.name, value, n)
                self._write(f.name, value, sl)

    def _start(self, name: str, value: Any, n: int) -> Any:
        if _rows_of(value, n):
            return np.empty((self.N, *value.shape[1:]), value.dtype)
        if is_dataclass(value) and not isinstance(value, type):
            members = [f.name for f in fields(value)]
            if members and all(_rows_of(getattr(value, k), n) for k in members):
                self.parts[name] = (type(value), members)
                return {k: self._start(k, getattr(value, k), n) for k in members}
        return value

    def _write(self, name: str, value: Any, sl: slice, into: dict[str, Any] | None = None
               ) -> None:
        into = self.fields if into is None else into
        target = into.get(name)
        if name in self.parts and into is self.fields and target is not None:
            if value is None:
                into[name] = None
            else:
                for k in self.parts[name][1]:
                    self._write(k, getattr(value, k), sl, target)
                if any(v is None for v in target.values()):
                    into[name] = None
        elif isinstance(target, np.ndarray) and target.shape[0] == self.N:
            fits = _rows_of(value, sl.stop - sl.start) and value.shape[1:] == target.shape[1:]
            if fits:
                target[sl] = value
            else:
                into[name] = None

    def solution(self, problem: TensionProblem) -> TensionSolution:
        """The solution of the whole batch (no form: see :func:`distribute`)."""
        out = dict(self.fields, problem=problem, form=None)
        for name, (cls, _members) in self.parts.items():
            if out[name] is not None:
                out[name] = cls(**out[name])
        return TensionSolution(**out)


def _rows_of(value: Any, n: int) -> bool:
    """Whether ``value`` is an array with one row per pose of a chunk of ``n``."""
    return isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == n


def _merge_extras(total: dict[str, Any], part: dict[str, Any], where: slice | NDArray
                  ) -> None:
    """Add the extras of some poses (a chunk's slice, or their indices in the batch) to
    the batch's ``total``: per-pose errors and fallbacks renumbered, messages joined,
    anything else kept from the first chunk that has it."""
    for key, value in part.items():
        if key == "errors":
            errors = total.setdefault("errors", {})
            for pose, message in value.items():
                if len(errors) < MAX_ERRORS:
                    errors[_in_batch(where, pose) if isinstance(pose, int) else pose] = message
        elif key == "fallback":
            for name, poses in value.items():
                total.setdefault("fallback", {}).setdefault(name, []).extend(
                    _in_batch(where, k) for k in poses)
        elif key not in total:
            total[key] = value
        elif isinstance(value, str) and value not in str(total[key]).split("; "):
            total[key] = f"{total[key]}; {value}"


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
        solver = backend if backend.unsupported(form) is None else choose_backend("auto", form)
        raw = _solve(solver, form, options, auto or solver is not backend)
        tensions[k], status[k] = raw.tensions[0], raw.status[0]
        for name in raw.extras.get("fallback", {}):
            extras.setdefault("fallback", {}).setdefault(name, []).append(k)
        if raw.extras.get("errors"):
            extras.setdefault("errors", {})[k] = next(iter(raw.extras["errors"].values()))
        if "accuracy_target" in raw.extras:  # the whole sequence is judged at the target
            extras["accuracy_target"] = raw.extras["accuracy_target"]
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
    if any(np.ndim(x) > 1 for x in (problem.t_min, problem.t_max, problem.reference)):
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
