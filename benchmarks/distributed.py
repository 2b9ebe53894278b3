"""Running cells through an executor: a local process pool or a Dask cluster.

The cells go in chunks of one scenario (:func:`chunk_cells`, :class:`CellChunk`) to
the executor's workers, which run them with :func:`run_chunk`; :func:`chunk_results`
gives the results back in order as the chunks return. The table is the same as an
in-process run apart from the timing columns and, on other hosts, ``machine``.
A worker of a pool or cluster cannot be killed per cell, so the time limit is only
the soft one of :func:`~benchmarks.runner.run_cell`.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable, Generator, Iterator, Sequence
from concurrent.futures import BrokenExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from benchmarks import store
from benchmarks.plan import Cell, Setting
from benchmarks.runner import TIME_LIMIT, CellResult, References, base_row, run_cell, short_message
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from tension_opt.workspace.executors import DaskExecutor, Executor, get_executor

__all__ = [
    "CHUNK_CELLS",
    "CellChunk",
    "chunk_cells",
    "chunk_results",
    "executor_machines",
    "open_executor",
    "run_chunk",
]

#: Largest number of cells sent to an executor's worker as one task.
CHUNK_CELLS = 4


@dataclass(frozen=True)
class _Pickled:
    """An object serialised with cloudpickle (a scenario or problem holding lambdas)."""

    data: bytes


@dataclass(frozen=True)
class CellChunk:
    """Cells of one scenario as sent to a worker (see :func:`run_chunk`).

    Scenarios and problems of the registries travel by name and are rebuilt by the
    worker (their poses are seeded, so identical everywhere); others travel pickled.

    Attributes
    ----------
    scenario : str or object
        Name in :data:`~benchmarks.scenarios.SCENARIOS`, or the scenario itself.
    cells : tuple of (problem, backend, setting)
        Problem by name in :data:`~benchmarks.scenarios.PROBLEMS`, or itself.
    time_limit : float
        Soft budget of each cell (s).
    """

    scenario: Any
    cells: tuple[tuple[Any, str, Setting], ...]
    time_limit: float = TIME_LIMIT

    @classmethod
    def of(cls, cells: Sequence[Cell], time_limit: float = TIME_LIMIT) -> CellChunk:
        """The chunk of ``cells``, which must share one scenario."""
        scenarios = {id(c.scenario) for c in cells}
        if len(scenarios) != 1:
            raise ValueError("the cells of a chunk must share one scenario")
        portable: dict[int, Any] = {}
        return cls(_portable(cells[0].scenario, SCENARIOS, portable),
                   tuple((_portable(c.problem, PROBLEMS, portable), c.backend, c.setting)
                         for c in cells), time_limit)


def _portable(obj: Any, registry: dict[str, Any], memo: dict[int, Any]) -> Any:
    """``obj``'s registry name, else ``obj`` if it pickles, else its cloudpickle."""
    if id(obj) in memo:
        return memo[id(obj)]
    name: str = obj.name
    if registry.get(name) is obj:
        memo[id(obj)] = name
        return name
    try:
        pickle.dumps(obj)
        memo[id(obj)] = obj
    except Exception as exc:  # lambdas, local functions
        try:
            import cloudpickle
        except ImportError:
            raise ValueError(
                f"{type(obj).__name__} {name!r} cannot be sent to worker processes ({exc}); "
                "register it in benchmarks.scenarios or install cloudpickle "
                '(pip install "tension-opt[dask]")') from exc
        memo[id(obj)] = _Pickled(cloudpickle.dumps(obj))
    return memo[id(obj)]


def _resolve(ref: Any, registry: dict[str, Any], memo: dict[int, Any]) -> Any:
    if id(ref) not in memo:
        if isinstance(ref, str):
            memo[id(ref)] = registry[ref]
        elif isinstance(ref, _Pickled):
            memo[id(ref)] = pickle.loads(ref.data)
        else:
            memo[id(ref)] = ref
    return memo[id(ref)]


def run_chunk(chunk: CellChunk) -> list[CellResult]:
    """Run the cells of a chunk with :func:`~benchmarks.runner.run_cell`, in order.

    This is the function an executor maps over the chunks. It runs on the worker, so the
    rows carry the worker's :func:`~benchmarks.store.machine_label`; the chunk's cells
    share one cache of reference objectives.

    Returns
    -------
    list of CellResult
        One per cell of the chunk.
    """
    memo: dict[int, Any] = {}
    scenario = _resolve(chunk.scenario, SCENARIOS, memo)
    references: References = {}
    return [run_cell(Cell(scenario, _resolve(problem, PROBLEMS, memo), backend, setting),
                     references, chunk.time_limit)
            for problem, backend, setting in chunk.cells]


def chunk_cells(cells: Sequence[Cell], size: int) -> list[list[Cell]]:
    """Split ``cells`` into consecutive chunks of at most ``size`` cells of one scenario.

    The cells of one (scenario, problem) stay in one chunk when they fit (they share the
    reference solve); the order of the cells is kept.
    """
    if size < 1:
        raise ValueError(f"chunk size must be >= 1; got {size}")
    groups: list[list[Cell]] = []
    for cell in cells:
        last = groups[-1][-1] if groups else None
        if (last is not None and last.scenario is cell.scenario
                and last.problem is cell.problem):
            groups[-1].append(cell)
        else:
            groups.append([cell])
    chunks: list[list[Cell]] = []
    for group in groups:
        for start in range(0, len(group), size):
            piece = group[start:start + size]
            if (chunks and start == 0 and chunks[-1][0].scenario is piece[0].scenario
                    and len(chunks[-1]) + len(piece) <= size):
                chunks[-1].extend(piece)
            else:
                chunks.append(piece)
    return chunks


def executor_machines(executor: Executor) -> set[str]:
    """Machine labels of an executor's workers and of this machine.

    A process pool runs here; a Dask cluster is asked for the label of every worker.
    """
    machines = {store.machine_label()}
    if isinstance(executor, DaskExecutor):
        machines |= {str(v) for v in executor.client.run(store.machine_label).values()}
    return machines


@contextmanager
def open_executor(executor: str | Executor | Any) -> Iterator[Executor]:
    """The executor of a spec (see :func:`tension_opt.workspace.executors.get_executor`).

    One named by a string is closed on exit; one passed in (an executor or a Dask
    client) is left open.
    """
    runner = get_executor(executor)
    try:
        yield runner
    finally:
        if isinstance(executor, str):
            runner.close()


def chunk_results(
    runner: Executor,
    cells: Sequence[Cell],
    time_limit: float = TIME_LIMIT,
    chunk_size: int | None = None,
    work: Callable[[CellChunk], list[CellResult]] = run_chunk,
) -> Generator[tuple[Cell, CellResult], None, None]:
    """Run ``cells`` on ``runner`` in chunks; (cell, result) pairs in order as chunks return.

    Parameters
    ----------
    runner : Executor
    cells : sequence of Cell
    time_limit : float
        Soft budget of each cell (s).
    chunk_size : int, optional
        Cells per chunk (default: up to :data:`CHUNK_CELLS`, fewer when there are not
        two chunks per worker).
    work : callable
        What the executor maps over the chunks (default :func:`run_chunk`).

    Yields
    ------
    (Cell, CellResult)
        A chunk that failed on its worker (a lost connection ...) gives ``"error"``
        rows; the next chunks go on.

    Raises
    ------
    KeyboardInterrupt, concurrent.futures.BrokenExecutor
        Unchanged (a dead pool worker fails every pending chunk).
    """
    if chunk_size is None:
        chunk_size = max(1, min(CHUNK_CELLS, math.ceil(len(cells) / (2 * runner.workers))))
    chunks = chunk_cells(cells, chunk_size)
    results = iter(runner.map(work, [CellChunk.of(c, time_limit) for c in chunks]))
    for chunk in chunks:
        try:
            returned = next(results)
        except (KeyboardInterrupt, BrokenExecutor):
            raise
        except Exception as exc:  # a worker died, a lost connection ...
            message = f"worker failed: {type(exc).__name__}: {short_message(exc)}"
            returned = [CellResult({**base_row(c), "status": "error", "message": message})
                              for c in chunk]
            # The executor's results go on with the next chunk after a failure.
        yield from zip(chunk, returned, strict=True)
