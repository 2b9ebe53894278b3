"""A large batch in chunks: per-pose inputs cut with the poses, chunks run side by
side in threads and joined in order, pose numbers renumbered over the whole batch.

:func:`tension_opt.distribute` solves a batch larger than its chunk size chunk by chunk
(its memory is that of the results plus one chunk's work); this module holds the
machinery that does not depend on what a chunk is solved by.
"""

from __future__ import annotations

import re
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import MAX_ERRORS
from tension_opt.checks import whole_positive
from tension_opt.distribution.certified import CertifiedBatch
from tension_opt.distribution.solution import TensionSolution
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import TensionProblem

__all__ = ["CERTIFIED_TASK", "Joined", "certified_chunks", "chunk_slices", "chunk_threads",
           "in_batch", "in_order", "merge_extras", "pose_rows", "renumbered"]

#: Poses per task of a batch on the certified compiled pass (:func:`certified_chunks`)
#: where the caller gives no chunk size: a task is one kernel call writing into the
#: batch's own result arrays, with no work arrays of its own, so its size bounds no
#: memory (the poses it leaves are solved a chunk at a time). Measured on 10^6 poses of
#: the study robot, two threads, fresh result arrays: tasks of 4096 poses 90-106
#: ns/pose, of 65536 poses 52-69 ns/pose (one thread: the same for both).
CERTIFIED_TASK = 65536


def chunk_slices(count: int, chunk_size: int) -> list[slice]:
    """``range(count)`` cut into the fewest consecutive slices of at most ``chunk_size``,
    of equal length to one (none for no poses): the one slicer of batches, for
    :func:`~tension_opt.distribute`'s chunks and the executors' alike.

    Raises
    ------
    InvalidInputError
        If ``chunk_size`` is not a whole number >= 1 (an int, not a bool).
    """
    size = whole_positive("chunk_size", chunk_size)
    parts = -(-count // size)
    return [slice(k * count // parts, (k + 1) * count // parts) for k in range(parts)]


def certified_chunks(batch: CertifiedBatch, task: int, size: int, workers: int,
                     solve: Callable[[NDArray | slice], TensionSolution],
                     problem: TensionProblem) -> TensionSolution:
    """A batch of independent poses on the compiled closed form, in tasks of at most
    ``task`` poses, each one compiled pass (:mod:`tension_opt.distribution.certified`), on up to
    ``workers`` threads; ``solve`` answers the poses the kernel leaves (the path of a
    chunk, on at most ``size`` of those poses at a time)."""
    Done = list[tuple[NDArray | slice, TensionSolution]]

    def run(sl: slice) -> tuple[Done, float]:
        t0 = time.perf_counter()
        left = batch.solve(sl)
        elapsed = time.perf_counter() - t0
        done: Done = []
        for piece in ([] if left is None else _pieces(left, size)):
            sol = solve(piece)
            batch.put(piece, sol)
            done.append((piece, sol))
        return done, elapsed

    extras: dict[str, Any] = {}
    times = [0.0, 0.0]  # setup, solve

    def join(sl: slice, result: tuple[Done, float]) -> None:
        done, elapsed = result
        times[1] += elapsed
        for piece, sol in done:
            merge_extras(extras, sol.extras, piece)
            times[0] += sol.setup_time
            times[1] += sol.solve_time

    in_order(chunk_slices(batch.N, task), run, workers, join)
    return batch.solution(problem, extras, *times)


def _pieces(poses: NDArray | slice, size: int) -> list[NDArray | slice]:
    """Some poses of a batch (a slice, or their indices) in pieces of at most ``size``."""
    if isinstance(poses, slice):
        return [slice(poses.start + part.start, poses.start + part.stop)
                for part in chunk_slices(poses.stop - poses.start, size)]
    return [poses[k:k + size] for k in range(0, len(poses), size)]


def in_order(parts: list[slice], run: Callable[[slice], Any], workers: int,
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
    from tension_opt.kernels.launch import configured_threads

    return max(1, int(configured_threads()))


def pose_rows(name: str, value: ArrayLike | None, N: int, k: int, scalar: bool = True
              ) -> Callable[[slice | NDArray], Any] | None:
    """How to cut ``value`` (one row per pose, or one for every pose) to chunks of poses:
    a function of the chunk's poses (its slice, or their indices), None for None.

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


def in_batch(poses: slice | NDArray, k: int) -> int:
    """The number in the batch of pose ``k`` of some of its poses (a chunk's slice, or
    their indices)."""
    if isinstance(poses, slice):
        return k + (poses.start or 0)
    return int(poses[k]) if 0 <= k < len(poses) else k


def renumbered(error: InvalidInputError, poses: slice | NDArray) -> InvalidInputError:
    """``error`` of some poses of the batch (a chunk's slice, or their indices), its pose
    numbers counted over the whole batch."""
    text = _POSE_NUMBER.sub(lambda hit: f"pose {in_batch(poses, int(hit.group(1)))}",
                            str(error))
    return error if text == str(error) else type(error)(text)


class Joined:
    """The fields of a :class:`TensionSolution` put together from its chunks.

    Per-pose arrays (first axis over the chunk's poses, also inside a dataclass field
    such as the multipliers) are written into arrays allocated for the whole batch at
    the first chunk; times add up; extras are merged (:func:`merge_extras`); any other
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
                merge_extras(self.fields.setdefault("extras", {}), value, sl)
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


def merge_extras(total: dict[str, Any], part: dict[str, Any], where: slice | NDArray
                 ) -> None:
    """Add the extras of some poses (a chunk's slice, or their indices in the batch) to
    the batch's ``total``: per-pose errors and fallbacks renumbered, messages joined,
    anything else kept from the first chunk that has it."""
    for key, value in part.items():
        if key == "errors":
            errors = total.setdefault("errors", {})
            for pose, message in value.items():
                if len(errors) < MAX_ERRORS:
                    errors[in_batch(where, pose) if isinstance(pose, int) else pose] = message
        elif key == "fallback":
            for name, poses in value.items():
                total.setdefault("fallback", {}).setdefault(name, []).extend(
                    in_batch(where, k) for k in poses)
        elif key not in total:
            total[key] = value
        elif isinstance(value, str) and value not in str(total[key]).split("; "):
            total[key] = f"{total[key]}; {value}"
