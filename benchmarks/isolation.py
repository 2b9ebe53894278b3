"""Process isolation of cells: a forked worker with a hard time limit.

:func:`run_isolated` runs cells one at a time in a forked worker process. A cell
still running :data:`GRACE` seconds after its time limit, or one that kills its
process (a crashing solver), becomes a ``"time_limit"`` or ``"error"`` row; the
worker is then replaced and the run goes on.
"""

from __future__ import annotations

import multiprocessing as mp
import sys
from collections.abc import Callable, Generator, Sequence
from typing import Any

from benchmarks.plan import Cell
from benchmarks.runner import CellResult, References, base_row, run_cell, short_message
from tension_opt.warmup import DISTRIBUTION_FAMILIES

#: The kernel families a cell runs: tension distribution. The sag columns
#: (:func:`benchmarks.metrics.thesis_sag`) take the catenary's numpy reference, about
#: 1.5 s over the default suite against 40 s of compiling its kernels.
CELL_FAMILIES: tuple[str, ...] = DISTRIBUTION_FAMILIES

__all__ = ["CELL_FAMILIES", "GRACE", "CellRunner", "Worker", "load_compiled_kernels",
           "run_isolated"]

#: Extra seconds before an isolated cell that overran its time limit is killed.
GRACE = 5.0

#: What a worker calls per cell: ``run(cell, references, time_limit)`` (see run_cell).
CellRunner = Callable[[Cell, References, float], CellResult]


class Worker:
    """A forked process that runs cells one at a time and can be killed at a deadline.

    The process inherits ``cells`` and ``run`` (and everything else in memory) when
    forked, so only indices travel through the pipe; it keeps the reference cache
    between cells.

    Parameters
    ----------
    cells : sequence of Cell
    time_limit : float
        Budget of each cell (s), passed to ``run``.
    run : callable
        Runs one cell (default :func:`~benchmarks.runner.run_cell`).
    """

    def __init__(self, cells: Sequence[Cell], time_limit: float,
                 run: CellRunner = run_cell) -> None:
        ctx = mp.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_loop,
                                   args=(child, cells, time_limit, run, self.conn), daemon=True)
        self.process.start()
        child.close()

    def run(self, index: int, deadline: float) -> tuple[str, Any]:
        """``("ok", CellResult)``, ``("timeout", None)``, ``("interrupt", None)`` or
        ``("crash", message)``; the worker is unusable after anything but ``"ok"``."""
        self.conn.send(index)
        if not self.conn.poll(deadline):
            return "timeout", None
        try:
            return self.conn.recv()
        except EOFError:
            return "crash", f"worker process died (exit code {self.process.exitcode})"

    def close(self, kill: bool = False) -> None:
        """Stop the process: politely, or at once with ``kill``."""
        if self.process.is_alive():
            if kill:
                self.process.kill()
            else:
                try:
                    self.conn.send(None)
                except OSError:
                    self.process.kill()
        self.process.join(5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


def _worker_loop(conn: Any, cells: Sequence[Cell], time_limit: float, run: CellRunner,
                 parent_end: Any) -> None:
    # The fork inherited the parent's end of the pipe: closed here, a parent that dies
    # (even by SIGKILL) ends the pipe, and this worker with it instead of an orphan.
    parent_end.close()
    references: References = {}
    while True:
        try:
            index = conn.recv()
        except (EOFError, OSError):
            return
        if index is None:
            return
        try:
            conn.send(("ok", run(cells[index], references, time_limit)))
        except KeyboardInterrupt:
            conn.send(("interrupt", None))
            return
        except BaseException as exc:  # run_cell turns exceptions into rows; this is a bug
            conn.send(("crash", f"{type(exc).__name__}: {short_message(exc)}"))
            return


def load_compiled_kernels(names: Sequence[str] | None = None) -> None:
    """Load the compiled kernels of the warm-up families ``names`` (default: every one of
    :data:`tension_opt.warmup.FAMILIES`, the installed plugins' too) into this process,
    once (compiling them first where numba's disk cache is empty: tens of seconds; the
    main job runs ``python -m tension_opt warmup``'s parallel compile before).

    Forked workers inherit them; a worker that had to compile them itself would spend
    a cell's time limit on it. The families run serial kernels only, so no threading
    layer starts in the parent (one that did would not survive the fork: see
    :mod:`tension_opt.kernels.launch`).
    """
    from tension_opt import warmup

    wanted = [n for n in (names or warmup.every_family()) if n not in _LOADED]
    if wanted:
        warmup.warm(wanted, jobs=1, progress=False)
        _LOADED.update(wanted)


_LOADED: set[str] = set()


def run_isolated(cells: Sequence[Cell], time_limit: float, grace: float = GRACE,
                 run: CellRunner = run_cell) -> Generator[tuple[Cell, CellResult], None, None]:
    """(cell, result) pairs of ``cells`` in order, each run in a forked worker process.

    Parameters
    ----------
    cells : sequence of Cell
    time_limit : float
        Budget of each cell (s); a cell still running ``time_limit + grace`` seconds
        after it started is killed and becomes a ``"time_limit"`` row.
    grace : float
        Seconds allowed past the budget (s).
    run : callable
        Runs one cell in the worker (default :func:`~benchmarks.runner.run_cell`).

    Yields
    ------
    (Cell, CellResult)
        One per cell; a crashed worker gives an ``"error"`` row.

    Raises
    ------
    KeyboardInterrupt
        If the worker was interrupted; the worker is killed when the generator is
        closed early or fails.
    """
    worker: Worker | None = None
    load_compiled_kernels(CELL_FAMILIES)
    try:
        for index, cell in enumerate(cells):
            worker = worker or Worker(cells, time_limit, run)
            outcome, payload = worker.run(index, time_limit + grace)
            if outcome == "interrupt":
                raise KeyboardInterrupt
            if outcome == "ok":
                yield cell, payload
                continue
            worker.close(kill=True)
            worker = None
            row = base_row(cell)
            if outcome == "timeout":
                row.update(status="time_limit", message=f"killed after {time_limit + grace:g} s")
            else:
                row.update(status="error", message=str(payload))
            yield cell, CellResult(row)
    finally:
        if worker is not None:
            worker.close(kill=sys.exc_info()[0] is not None)
