"""The benchmark run: plan the matrix, run its cells, keep the rows.

The matrix is scenario x problem x backend x setting (accuracy, cold or warm start).
Each cell becomes one row of a tidy table. :func:`run` composes the parts:

- :mod:`benchmarks.plan`: the cells (:func:`plan`, :func:`default_suite`);
- :mod:`benchmarks.runner`: one cell solved in chunks and measured (:func:`run_cell`);
- :mod:`benchmarks.isolation`: each cell in a forked worker with a hard time limit;
- :mod:`benchmarks.distributed`: cells in chunks on a process pool or a Dask cluster
  (``executor=``; ``python -m benchmarks run --executor processes:2`` or
  ``--executor dask:tcp://host:8786``);
- :mod:`benchmarks.store`: the rows in an SQLite database, one transaction per chunk of
  cells (concurrent runs and kills lose nothing and keep nothing torn), exported to
  ``results.csv`` and ``traces.npz`` after the run. Each run is recorded with a key of
  its invocation (the cells and the time limit) and stamps its rows with its id and the
  time each was measured; a run resumes an *interrupted* run of the same invocation on
  this machine (skipping the cells it stored) and otherwise measures every cell, so the
  results that came with a clone are never taken for this machine's (they stay as the
  labelled reference of the report until measured again).

The names of those modules that callers use are importable from here too.
"""

from __future__ import annotations

import math
import time
from collections.abc import Generator, Sequence
from typing import Any

import pandas as pd

from benchmarks import metrics
from benchmarks.distributed import (
    CHUNK_CELLS,
    CellChunk,
    chunk_cells,
    chunk_results,
    executor_machines,
    open_executor,
    run_chunk,
)
from benchmarks.isolation import GRACE, run_isolated
from benchmarks.plan import (
    ALL_SETTINGS,
    DEFAULT_SUITE,
    FAST_BACKENDS,
    KEY,
    Cell,
    Setting,
    SuiteRule,
    default_suite,
    plan,
    select,
    supports_warm_start,
)
from benchmarks.runner import (
    JUMP_FRACTION,
    MAX_CHUNKS,
    MAX_TRACE_POSES,
    MIN_CHUNK,
    REFERENCE_BACKENDS,
    TIME_LIMIT,
    TIMING_COLUMNS,
    TRACE_BACKENDS,
    CellResult,
    References,
    base_row,
    keeps_trace,
    reference_solution,
    run_cell,
    trace_backends,
)
from benchmarks.store import (
    CONSOLIDATE_EVERY,
    DATABASE_FILE,
    JOURNAL_FILE,
    RESULTS_DIR,
    RESULTS_FILE,
    TRACES_FILE,
    ResultsStore,
    StoreError,
    invocation_key,
    machine_label,
    utc_now,
)
from tension_opt.workspace.executors import Executor

__all__ = [
    "ALL_SETTINGS",
    "CHUNK_CELLS",
    "CONSOLIDATE_EVERY",
    "DATABASE_FILE",
    "DEFAULT_SUITE",
    "FAST_BACKENDS",
    "GRACE",
    "JOURNAL_FILE",
    "JUMP_FRACTION",
    "KEY",
    "MAX_CHUNKS",
    "MAX_TRACE_POSES",
    "MIN_CHUNK",
    "REFERENCE_BACKENDS",
    "RESULTS_DIR",
    "RESULTS_FILE",
    "TIME_LIMIT",
    "TIMING_COLUMNS",
    "TRACES_FILE",
    "TRACE_BACKENDS",
    "Cell",
    "CellChunk",
    "CellResult",
    "ResultsStore",
    "Setting",
    "StoreError",
    "SuiteRule",
    "base_row",
    "chunk_cells",
    "default_suite",
    "executor_machines",
    "invocation_key",
    "machine_label",
    "plan",
    "reference_solution",
    "run",
    "run_cell",
    "run_chunk",
    "select",
    "summary",
    "supports_warm_start",
]

Results = Generator[tuple[Cell, CellResult], None, None]


def run(
    cells: Sequence[Cell],
    store: ResultsStore | None = None,
    redo: bool = False,
    time_limit: float = TIME_LIMIT,
    progress: bool = True,
    isolate: bool = True,
    executor: str | Executor | Any | None = None,
    chunk_size: int | None = None,
) -> pd.DataFrame:
    """Run the cells (those an interrupted run left, when resuming); return the table.

    Parameters
    ----------
    cells : sequence of Cell
        From :func:`plan`.
    store : ResultsStore, optional
        Default: ``benchmarks/results``.
    redo : bool
        Start afresh even where an interrupted run of the same invocation (cells and
        time limit) on this machine could be resumed (its stored cells skipped); rows
        of finished runs, or imported with a clone, are always measured again.
    time_limit : float
        Budget of each cell (s). It is passed to the solvers and checked between chunks
        of poses; with ``isolate`` and no executor, a cell still running :data:`GRACE`
        seconds after its budget is killed and stored with status ``"time_limit"``.
        With an executor the limit is only this soft one: a worker of a pool or of a
        Dask cluster cannot be killed per cell, so a solver that hangs inside one call
        holds its worker until it returns.
    progress : bool
        Show a tqdm progress bar over cells.
    isolate : bool
        Without an executor: run the cells in a forked worker process (hard time limit,
        survives a crashing solver). False runs them in this process. Ignored with an
        executor.
    executor : str, Executor or dask.distributed.Client, optional
        Where the cells run (see :func:`tension_opt.workspace.executors.get_executor`):
        ``"inprocess"``, ``"processes[:N]"``, ``"dask[:ADDRESS]"``, an executor or a
        Dask client. The cells go in chunks of at most ``chunk_size`` cells of one
        scenario; the rows of a chunk are stored in one transaction as it comes back,
        in order, so an interrupted run keeps every chunk returned before. Rows carry
        the machine of the worker that ran them. An executor named by a string is
        closed at the end; one passed in is left open.
        None (default): in this process, as described under ``isolate``.
    chunk_size : int, optional
        Cells per chunk sent to the executor (default: up to :data:`CHUNK_CELLS`, fewer
        when there are not two chunks per worker).

    Returns
    -------
    DataFrame
        The stored table after the run (all rows, not only these cells), also exported
        to ``results.csv`` and ``traces.npz`` (and every :data:`CONSOLIDATE_EVERY`
        seconds during the run).

    Raises
    ------
    KeyboardInterrupt
        If interrupted; every cell finished before is stored.
    concurrent.futures.BrokenExecutor
        If a worker of the process pool died (every pending chunk fails then, so the
        culprit is unknown); the rows returned before are stored. With Dask, a chunk
        whose workers keep dying becomes ``"error"`` rows and the run goes on.
    StoreError
        If the store cannot be read or written (the message names the file and the fix).
    """
    store = store or ResultsStore()
    keep = trace_backends(cells)
    run_id, todo = _begin(cells, store, redo, time_limit)
    if executor is not None:
        frame = _on_executor(executor, todo, store, keep, progress, run_id, time_limit,
                             chunk_size)
    else:
        if isolate:
            results = run_isolated(todo, time_limit, GRACE, run=run_cell)
        else:
            results = _in_process(todo, time_limit)
        frame = _collect(todo, results, store, keep, progress, run_id)
    store.finish_run(run_id)
    return frame


def _on_executor(executor: str | Executor | Any, todo: list[Cell], store: ResultsStore,
                 keep: set[str], progress: bool, run_id: str, time_limit: float,
                 chunk_size: int | None) -> pd.DataFrame:
    """The cells ``todo`` in chunks on ``executor``, stored as chunks come back."""
    with open_executor(executor) as runner:
        size = _chunk_size(len(todo), runner.workers) if chunk_size is None else chunk_size
        results = chunk_results(runner, todo, time_limit, size, work=run_chunk)
        sizes = [len(chunk) for chunk in chunk_cells(todo, size)]
        return _collect(todo, results, store, keep, progress, run_id, sizes)


def _begin(cells: Sequence[Cell], store: ResultsStore, redo: bool, time_limit: float
           ) -> tuple[str, list[Cell]]:
    """Start (or, unless ``redo``, resume) the run of this invocation; its id and the
    cells it measures: all of them, or those the resumed run has not stored."""
    invocation = invocation_key([c.key for c in cells], time_limit=time_limit)
    run_id, resumed = store.start_run(invocation, len(cells), resume=not redo)
    done = store.done(run=run_id) if resumed else set()
    return run_id, [c for c in cells if c.key not in done]


def _chunk_size(cells: int, workers: int) -> int:
    """Cells per executor chunk: up to :data:`CHUNK_CELLS`, fewer when there are not two
    chunks per worker."""
    return max(1, min(CHUNK_CELLS, math.ceil(cells / (2 * workers))))


def _in_process(cells: Sequence[Cell], time_limit: float) -> Results:
    references: References = {}
    for cell in cells:
        yield cell, run_cell(cell, references, time_limit)


def _collect(todo: Sequence[Cell], results: Results, store: ResultsStore, keep: set[str],
             progress: bool, run_id: str, sizes: Sequence[int] = ()) -> pd.DataFrame:
    """Store the results chunk by chunk (with traces if kept), each row stamped with the
    run and the time it was stored; return the exported table.

    ``sizes`` are the lengths of the executor's chunks, each stored in one transaction;
    without them each cell is a chunk of its own.
    """
    bar = _progress_bar(len(todo), progress)
    saved = time.perf_counter()
    chunks = _chunks(results, sizes)
    try:
        for chunk in chunks:
            stamp = {"run": run_id, "measured_at": utc_now()}
            store.append_many([({**result.row, **stamp},
                                result.trace if keeps_trace(cell, keep) else None)
                               for cell, result in chunk])
            if bar is not None:
                bar.set_postfix_str("/".join(chunk[-1][0].key), refresh=False)
                bar.update(len(chunk))
            if time.perf_counter() - saved > CONSOLIDATE_EVERY:
                store.export()
                saved = time.perf_counter()
    finally:
        chunks.close()
        results.close()  # an isolated worker is killed if the run stops early
        if bar is not None:
            bar.close()
    return store.export()


def _chunks(results: Results, sizes: Sequence[int]) -> Generator[list[tuple[Cell, CellResult]],
                                                                 None, None]:
    """The results in consecutive lists of ``sizes[0]``, ``sizes[1]`` ... (then of one)."""
    lengths = iter(sizes)
    want = next(lengths, 1)
    chunk: list[tuple[Cell, CellResult]] = []
    for pair in results:
        chunk.append(pair)
        if len(chunk) >= want:
            yield chunk
            chunk, want = [], next(lengths, 1)


def _progress_bar(total: int, enabled: bool) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="cell", dynamic_ncols=True)


def summary(frame: pd.DataFrame, cells: Sequence[Cell], wall_time: float) -> str:
    """A few lines: cells run, statuses, and the fastest backend per scenario."""
    keys = {c.key for c in cells}
    mask = pd.Series([tuple(str(v) for v in r) in keys
                      for r in frame[list(KEY)].itertuples(index=False)], index=frame.index)
    sub = frame[mask.to_numpy()] if len(frame) else frame
    lines = [f"{len(sub)} cells in the selection, {len(frame)} rows stored; "
             f"this run took {wall_time:.1f} s"]
    if len(sub):
        counts = sub["status"].value_counts().to_dict()
        lines.append("status: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
        ok = sub[sub["status"] == "ok"]
        if "time_us_median" in ok:
            for scenario, group in ok.groupby("scenario", sort=False):
                ratios = metrics.relative_shifted_geometric_means(group, "time_us_median")
                if len(ratios):
                    best = ", ".join(f"{b} {r:.3g}" for b, r in list(ratios.items())[:3])
                    lines.append(f"{scenario}: time per pose relative to best: {best}")
    return "\n".join(lines)
