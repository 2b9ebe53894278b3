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

__all__ = ["GRACE", "CellRunner", "Worker", "load_compiled_kernels", "run_isolated"]

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


def load_compiled_kernels() -> None:
    """Load the compiled kernels of the plain calls into this process, once (compiling
    them first where numba's disk cache is empty: tens of seconds).

    Forked workers inherit them; a worker that had to compile them itself would spend
    a cell's time limit on it. The calls run the serial kernels only, so no threading
    layer starts in the parent (one that did would not survive the fork: see
    :mod:`tension_opt.kernels.launch`).
    """
    if _LOADED:
        return
    import numpy as np

    import catenary
    import tension_opt as to
    from tension_opt.distribution.entry import CHUNK_SIZE

    available = set(to.available_backends())
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        home = robot.default_home()
        # The closed form takes min-max with one null-space dimension only.
        for objective in ("min_sum", "min_norm", "min_max")[:3 if robot.m - robot.dof == 1
                                                            else 2]:
            to.distribute(robot, home, objective, "closed_form")
            to.Distributor(robot, objective)(home)
        # A batch of more than one chunk: the certified pass of tension_opt.distribution.certified.
        many = np.repeat(home[None], CHUNK_SIZE + 1, axis=0)
        to.distribute(robot, many, "min_sum", "closed_form")
        # A smoothed sequence's compiled loops (one compilation serves every robot).
        smoothed = to.TensionProblem("min_sum", smoothing=1e-3)
        to.distribute(robot, np.stack([home, home]), smoothed, "closed_form")
        catenary.inverse_kinematics(robot, home, model="thesis")
        # The generic backends' scaling and certificate kernels (and DAQP's C path).
        generic: list[str] = [b for b in ("scipy:highs", "qpsolvers:daqp") if b in available]
        for backend in generic:
            to.distribute(robot, home, "min_sum", backend)
        if "qpsolvers:daqp" in available:
            to.Distributor(robot, "min_norm", "qpsolvers:daqp")(home)
            to.distribute(robot, np.stack([home, home]), smoothed, "qpsolvers:daqp")
        # The other qpsolvers' sequence loop (its compiled QP and verdict).
        other = [b for b in ("qpsolvers:piqp", "qpsolvers:osqp", "qpsolvers:clarabel")
                 if b in available][:1]
        for backend in other:
            to.distribute(robot, np.stack([home, home]), smoothed, backend)
    for end in ("B", "A"):
        catenary.solve_length(10.0, -2.0, 500.0, 2.0, EA=1e6, end=end)
        # Vectors with numbers for w and EA: the kernel's variant for a robot's cables.
        catenary.solve_length(np.array([10.0]), np.array([-2.0]), np.array([500.0]), 2.0,
                              EA=1e6, end=end)
    catenary.solve_forces(10.0, -2.0, 10.5, 2.0, EA=1e6)
    _LOADED.append(True)


_LOADED: list[bool] = []


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
    load_compiled_kernels()
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
