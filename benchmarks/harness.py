"""Runner of the benchmark matrix and its results store.

The matrix is scenario x problem x backend x setting (accuracy, cold or warm start).
Each cell solves the scenario's poses in chunks, measures them (:func:`run_cell`) and
becomes one row of a tidy table. A cell that cannot run (solver not installed, problem
not expressible, function missing, exception, time limit) becomes a row with that
status; the run goes on.

Rows are kept in ``results.csv`` (and the tension traces of short trajectories in
``traces.npz``), rewritten through a temporary file and an atomic rename after every
cell: an interrupted run loses at most the cell in progress, and a new run skips the
cells already in the file unless told to redo them.

With an executor (:func:`run` with ``executor=``; ``python -m benchmarks run --executor
processes:2`` or ``--executor dask:tcp://host:8786``), the cells are sent in chunks to a
local process pool or a Dask cluster (see :mod:`tension_opt.executors`); the table is the
same as an in-process run apart from the timing columns and, on other hosts, ``machine``.
"""

from __future__ import annotations

import json
import math
import multiprocessing as mp
import os
import pickle
import platform
import sys
import time
import warnings
from collections.abc import Collection, Iterable, Iterator, Sequence
from concurrent.futures import BrokenExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

import tension_opt
from benchmarks import metrics
from benchmarks.scenarios import PROBLEMS, SCENARIOS, NotAvailableError, ProblemSpec, Scenario
from benchmarks.scenarios import applicable as _applicable
from tension_opt import BackendNotAvailableError, UnsupportedProblemError
from tension_opt.executors import DaskExecutor, Executor, get_executor

RESULTS_DIR = Path(__file__).resolve().parent / "results"
RESULTS_FILE = "results.csv"
TRACES_FILE = "traces.npz"
JOURNAL_FILE = "results.journal.jsonl"
#: Seconds between merges of the journal into the results table during a run.
CONSOLIDATE_EVERY = 30.0
KEY = ("scenario", "problem", "backend", "setting")

#: Per-pose times are measured on chunks: at most this many chunks per cell.
MAX_CHUNKS = 20
#: Smallest chunk: batches are how the library is meant to be called, and a chunk of one
#: pose would time the per-call overhead rather than the solve.
MIN_CHUNK = 50
#: Traces are stored for trajectories up to this many poses.
MAX_TRACE_POSES = 200
#: Backends fast enough for the 10^4-pose scenario in the default suite.
FAST_BACKENDS = ("closed_form", "qpsolvers:daqp")
#: Reference of the objective gap: the exact closed form, else this one at high accuracy.
REFERENCE_BACKENDS = ("closed_form", "cvxpy:CLARABEL")
#: Backends whose traces are kept (all backends when none of them is in a run).
TRACE_BACKENDS = (*REFERENCE_BACKENDS, "qpsolvers:clarabel")
#: Jump threshold of the smoothness metrics, as a fraction of the platform weight.
JUMP_FRACTION = 0.1
#: Default time limit of one cell (s).
TIME_LIMIT = 10.0
#: Extra seconds before an isolated cell that overran its time limit is killed.
GRACE = 5.0
#: Largest number of cells sent to an executor's worker as one task.
CHUNK_CELLS = 4
#: Columns that hold measured times (they differ from run to run); all others are
#: reproducible, whichever executor ran the cell.
TIMING_COLUMNS = ("setup_us_median", "setup_us_p95", "solve_us_median", "solve_us_p95",
                  "time_us_median", "time_us_p95", "wall_time_s")


# ------------------------------------------------------------------ the matrix
@dataclass(frozen=True)
class Setting:
    """Solver setting of a cell: accuracy (``"default"`` or ``"high"``) and warm start."""

    accuracy: str = "default"
    warm_start: bool = False

    @property
    def label(self) -> str:
        """E.g. ``"default/cold"``."""
        return f"{self.accuracy}/{'warm' if self.warm_start else 'cold'}"

    @classmethod
    def parse(cls, text: str) -> list[Setting]:
        """Settings from ``"default"`` (cold and warm), ``"high/warm"``, ``"high/cold"`` ..."""
        accuracy, _, start = text.partition("/")
        if accuracy not in ("default", "high"):
            raise ValueError(f"accuracy must be 'default' or 'high', got {accuracy!r}")
        if start in ("", "any"):
            return [cls(accuracy, False), cls(accuracy, True)]
        if start not in ("cold", "warm"):
            raise ValueError(f"start must be 'cold' or 'warm', got {start!r}")
        return [cls(accuracy, start == "warm")]


ALL_SETTINGS = (Setting("default", False), Setting("default", True), Setting("high", False),
                Setting("high", True))


@dataclass(frozen=True)
class Cell:
    """One cell of the matrix."""

    scenario: Scenario
    problem: ProblemSpec
    backend: str
    setting: Setting

    @property
    def key(self) -> tuple[str, str, str, str]:
        """(scenario, problem, backend, setting label): the row's identity in the store."""
        return (self.scenario.name, self.problem.name, self.backend, self.setting.label)


def supports_warm_start(backend: str) -> bool:
    """Whether an installed backend can warm start (False if it is not installed)."""
    try:
        return bool(tension_opt.get_backend(backend).warm_start)
    except Exception:
        return False


def plan(
    scenarios: Iterable[Scenario] | None = None,
    problems: Iterable[ProblemSpec] | None = None,
    backends: Sequence[str] | None = None,
    settings: Sequence[Setting] = ALL_SETTINGS,
) -> list[Cell]:
    """Every cell of the matrix, in a stable order.

    Parameters
    ----------
    scenarios, problems : iterables, optional
        Default: all of :data:`~benchmarks.scenarios.SCENARIOS` / ``PROBLEMS``.
        Sequential problems are posed on trajectories only.
    backends : sequence of str, optional
        Default: :func:`tension_opt.available_backends`. Names not installed are kept
        and become ``not_installed`` rows.
    settings : sequence of Setting
        Warm-start settings are kept only for backends that support warm starts.
    """
    scenarios = list(SCENARIOS.values() if scenarios is None else scenarios)
    problems = list(PROBLEMS.values() if problems is None else problems)
    backends = list(tension_opt.available_backends() if backends is None else backends)
    warm = {b: supports_warm_start(b) for b in backends}
    return [Cell(sc, pr, be, s)
            for sc in scenarios for pr in problems if _applicable(sc, pr)
            for be in backends for s in settings if warm[be] or not s.warm_start]


@dataclass(frozen=True)
class SuiteRule:
    """What the default suite keeps of a scenario's cells.

    Attributes
    ----------
    settings : tuple of str
        Setting labels kept.
    backends : tuple of str, optional
        Backends kept (None: all).
    joint : bool
        Whether joint smoothing is kept.
    enabled : bool
        False: the scenario runs only when asked for by name (or with ``--full``).
    """

    settings: tuple[str, ...] = ("default/cold",)
    backends: tuple[str, ...] | None = None
    joint: bool = True
    enabled: bool = True


#: The default suite (``python -m benchmarks``): modest, within a few minutes on 2 cores.
#: Scenarios not listed here are kept whole; ``--full`` keeps everything.
DEFAULT_SUITE: dict[str, SuiteRule] = {
    "thesis_snapshots": SuiteRule(("default/cold", "high/cold")),
    "thesis_trajectory": SuiteRule(("default/cold", "default/warm", "high/cold")),
    "thesis_random": SuiteRule(),
    "cogiro_trajectory": SuiteRule(),
    "cogiro_random": SuiteRule(enabled=False),
    "thesis_long": SuiteRule(backends=FAST_BACKENDS, joint=False),
}


def default_suite(cells: Iterable[Cell], chosen: Collection[str] = ()) -> list[Cell]:
    """The cells of ``cells`` that the default suite runs (see :data:`DEFAULT_SUITE`).

    Parameters
    ----------
    cells : iterable of Cell
    chosen : collection of str
        Dimensions the user chose explicitly, among ``"scenario"``, ``"backend"`` and
        ``"settings"``: the suite's rules do not cut those (a disabled scenario runs when
        named, a backend or setting runs when asked for).
    """
    kept = []
    for cell in cells:
        rule = DEFAULT_SUITE.get(cell.scenario.name)
        if rule is not None and (
            (not rule.enabled and "scenario" not in chosen)
            or ("settings" not in chosen and cell.setting.label not in rule.settings)
            or ("backend" not in chosen and rule.backends is not None
                and cell.backend not in rule.backends)
            or (cell.problem.joint and not rule.joint and "backend" not in chosen)
        ):
            continue
        kept.append(cell)
    return kept


# --------------------------------------------------------------------- a cell
@dataclass
class CellResult:
    """Row of one cell and, for short trajectories, its tensions (N, m) (N)."""

    row: dict[str, Any]
    trace: NDArray | None = None


def machine_label() -> str:
    """Host, CPU, core count and Python of this machine: rows are reused only on it."""
    return (f"{platform.node()} / {platform.processor() or platform.machine()} / "
            f"{os.cpu_count()} cores / Python {sys.version.split()[0]}")


def _base_row(cell: Cell) -> dict[str, Any]:
    sc = cell.scenario
    return {
        "machine": machine_label(),
        "scenario": sc.name, "problem": cell.problem.name, "backend": cell.backend,
        "setting": cell.setting.label, "accuracy": cell.setting.accuracy,
        "warm_start": cell.setting.warm_start, "status": "ok", "message": "",
        "robot": sc.robot.name, "n_poses": sc.N, "m": sc.robot.m,
    }


def _options(cell: Cell, time_limit: float) -> dict[str, Any]:
    options: dict[str, Any] = {"accuracy": cell.setting.accuracy, "time_limit": time_limit}
    if cell.setting.warm_start:
        options["warm_start"] = True
    return options


def _solve_chunked(cell: Cell, time_limit: float) -> tuple[dict[str, Any], dict[str, NDArray]]:
    """Solve the cell's poses chunk by chunk; raise the library's errors unchanged."""
    sc, pr = cell.scenario, cell.problem
    N, m = sc.N, sc.robot.m
    chunks = [np.arange(N)] if pr.joint else np.array_split(
        np.arange(N), max(1, min(MAX_CHUNKS, N // MIN_CHUNK)))
    out = {
        "tensions": np.full((N, m), np.nan), "success": np.zeros(N, dtype=bool),
        "unique": np.ones(N, dtype=bool), "objective": np.full(N, np.nan),
        "residual": np.full(N, np.nan), "bound_violation": np.full(N, np.nan),
        "iterations": np.full(N, np.nan),
    }
    setup, solve, sizes = [], [], []
    info: dict[str, Any] = {"solver": "", "solver_version": "", "timed_out": False,
                            "iterations_reported": True, "statuses": {}}
    previous: NDArray | None = None
    # One backend instance for all chunks (joint smoothing takes the name).
    backend = cell.backend if pr.joint else tension_opt.get_backend(cell.backend)
    start = time.perf_counter()
    for idx in chunks:
        remaining = time_limit - (time.perf_counter() - start)
        if remaining <= 0:
            info["timed_out"] = True
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = pr.solve(sc.robot, sc.poses[idx], backend, previous=previous,
                           **_options(cell, remaining))
        info["solver"], info["solver_version"] = sol.solver, sol.solver_version
        setup.append(sol.setup_time)
        solve.append(sol.solve_time)
        sizes.append(len(idx))
        out["tensions"][idx] = sol.tensions
        out["success"][idx] = sol.success
        out["unique"][idx] = sol.unique
        out["objective"][idx] = sol.objective
        out["residual"][idx] = sol.residual
        out["bound_violation"][idx] = sol.bound_violation
        if sol.iterations is None:
            info["iterations_reported"] = False
        else:
            out["iterations"][idx] = sol.iterations
        for s in sol.status:
            info["statuses"][str(s)] = info["statuses"].get(str(s), 0) + 1
        if pr.sequential:
            finite = np.flatnonzero(np.isfinite(sol.tensions).all(axis=1))
            previous = sol.tensions[finite[-1]] if len(finite) else previous
    info["wall_time"] = time.perf_counter() - start
    info["setup"], info["solve"], info["sizes"] = (np.array(setup), np.array(solve),
                                                   np.array(sizes, dtype=float))
    return info, out


def reference_solution(scenario: Scenario, problem: ProblemSpec,
                       cache: dict[tuple[str, str], NDArray | None]) -> NDArray | None:
    """Reference objective per pose, shape (N,), or None: closed form, else CLARABEL (high).

    Cached in ``cache`` under (scenario, problem).
    """
    key = (scenario.name, problem.name)
    if key not in cache:
        cache[key] = None
        for backend in REFERENCE_BACKENDS:
            options: dict[str, Any] = ({"accuracy": "high"} if backend != "closed_form"
                                       else {})
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sol = problem.solve(scenario.robot, scenario.poses, backend, **options)
            except Exception:
                continue
            cache[key] = np.where(sol.success, sol.objective, np.nan)
            break
    return cache[key]


def _nanstat(values: NDArray, fn: Any) -> float:
    v = values[np.isfinite(values)]
    return float(fn(v)) if v.size else float("nan")


def _measure(cell: Cell, info: dict[str, Any], out: dict[str, NDArray],
             reference: NDArray | None) -> dict[str, Any]:
    sc = cell.scenario
    N = sc.N
    ok = out["success"]
    row: dict[str, Any] = {
        "solver": info["solver"], "solver_version": info["solver_version"],
        "statuses": ";".join(f"{k}:{v}" for k, v in sorted(info["statuses"].items())),
        "success_rate": float(ok.mean()) if N else float("nan"),
        "n_non_unique": int((~out["unique"] & ok).sum()),
        "objective_mean": _nanstat(np.where(ok, out["objective"], np.nan), np.mean),
        "objective_gap_max": float("nan"),
        "residual_max": _nanstat(np.where(ok, out["residual"], np.nan), np.max),
        "bound_violation_max": _nanstat(np.where(ok, out["bound_violation"], np.nan), np.max),
        "iterations_mean": float("nan"), "iterations_max": float("nan"),
    }
    if reference is not None:
        gap = metrics.relative_gap(np.where(ok, out["objective"], np.nan), reference)
        row["objective_gap_max"] = _nanstat(gap, np.max)
    if info["iterations_reported"]:
        row["iterations_mean"] = _nanstat(out["iterations"], np.mean)
        row["iterations_max"] = _nanstat(out["iterations"], np.max)
    sizes = info["sizes"]
    per_pose = {"setup": info["setup"] / np.maximum(sizes, 1),
                "solve": info["solve"] / np.maximum(sizes, 1)}
    per_pose["time"] = per_pose["setup"] + per_pose["solve"]
    for name, samples in per_pose.items():
        med, p95 = metrics.percentiles(1e6 * samples)
        row[f"{name}_us_median"], row[f"{name}_us_p95"] = med, p95
    row["chunk_size"] = float(np.median(sizes)) if sizes.size else float("nan")
    row["wall_time_s"] = info["wall_time"]
    if sc.trajectory:
        threshold = JUMP_FRACTION * sc.robot.weight
        row.update(metrics.smoothness(out["tensions"], threshold))
        row["jump_threshold"] = threshold
        row["non_unique_on_path"] = bool(row["n_non_unique"] > 0)
    if sc.sag:
        row.update(metrics.thesis_sag(sc.robot, sc.poses, out["tensions"]))
    if info["timed_out"]:
        row["status"] = "time_limit"
        row["message"] = f"stopped after {int(sizes.sum())} of {N} poses"
    return row


def run_cell(cell: Cell, references: dict[tuple[str, str], NDArray | None],
             time_limit: float = TIME_LIMIT) -> CellResult:
    """Run one cell; every failure becomes the row's status, never an exception.

    Parameters
    ----------
    cell : Cell
    references : dict
        Cache of reference objectives (see :func:`reference_solution`).
    time_limit : float
        Time budget of the cell (s); checked between chunks and passed to the solver.

    Returns
    -------
    CellResult
        ``row["status"]`` is ``"ok"``, ``"time_limit"``, ``"not_installed"``,
        ``"unsupported"``, ``"not_available"`` or ``"error"`` (with ``message``).
    """
    row = _base_row(cell)
    try:
        tension_opt.get_backend(cell.backend)
        info, out = _solve_chunked(cell, time_limit)
    except BackendNotAvailableError as exc:
        return CellResult({**row, "status": "not_installed", "message": _short(exc)})
    except UnsupportedProblemError as exc:
        return CellResult({**row, "status": "unsupported", "message": _short(exc)})
    except NotAvailableError as exc:
        return CellResult({**row, "status": "not_available", "message": _short(exc)})
    except Exception as exc:
        return CellResult({**row, "status": "error",
                           "message": f"{type(exc).__name__}: {_short(exc)}"})
    try:
        reference = reference_solution(cell.scenario, cell.problem, references)
        row.update(_measure(cell, info, out, reference))
    except Exception as exc:
        return CellResult({**row, "status": "error",
                           "message": f"metrics: {type(exc).__name__}: {_short(exc)}"})
    keep = cell.scenario.trajectory and cell.scenario.N <= MAX_TRACE_POSES
    return CellResult(row, out["tensions"] if keep else None)


def _short(exc: BaseException, limit: int = 160) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


# --------------------------------------------------------------------- store
Key = tuple[str, ...]


class ResultsStore:
    """Results table and tension traces of one directory, safe against interruption.

    Each finished cell is appended (and flushed to disk) as one JSON line to a journal,
    ``results.journal.jsonl``; :meth:`consolidate` merges the journal into
    ``results.csv`` and ``traces.npz``, each written to a temporary file and renamed,
    then removes the journal. Reading merges both, the journal winning, and ignores a
    torn last line, so an interrupted run loses at most the cell in progress.

    Parameters
    ----------
    directory : path
        Created when first written.
    """

    def __init__(self, directory: str | os.PathLike[str] = RESULTS_DIR) -> None:
        self.directory = Path(directory)
        self.results_path = self.directory / RESULTS_FILE
        self.traces_path = self.directory / TRACES_FILE
        self.journal_path = self.directory / JOURNAL_FILE

    # reading
    def read(self) -> tuple[dict[Key, dict[str, Any]], dict[Key, NDArray]]:
        """Rows and traces by key (scenario, problem, backend, setting), in stored order."""
        rows: dict[Key, dict[str, Any]] = {}
        traces: dict[Key, NDArray] = {}
        if self.results_path.exists():
            frame = pd.read_csv(self.results_path, keep_default_na=False,
                                na_values=["", "nan", "NaN"])
            for row in frame.to_dict("records"):
                rows[_key(row)] = row
        if self.traces_path.exists():
            with np.load(self.traces_path) as data:
                traces.update({tuple(k.split("|")): data[k] for k in data.files})
        if self.journal_path.exists():
            for line in self.journal_path.read_text().splitlines():
                try:
                    entry = json.loads(line)
                except json.JSONDecodeError:  # torn write of an interrupted run
                    continue
                key = _key(entry["row"])
                rows.pop(key, None)
                rows[key] = entry["row"]
                if entry.get("trace") is not None:
                    traces[key] = np.asarray(entry["trace"], dtype=float)
        return rows, traces

    def load(self) -> pd.DataFrame:
        """The stored table (empty, with the key columns, if there is none)."""
        rows, _ = self.read()
        return _frame(rows)

    def load_traces(self) -> dict[Key, NDArray]:
        """Stored traces by key, each of shape (N, m) (N)."""
        return self.read()[1]

    def done(self, machines: Collection[str] | None = None) -> set[Key]:
        """Keys of the rows stored by this machine (rows measured elsewhere are re-run).

        Parameters
        ----------
        machines : collection of str, optional
            Machine labels (see :func:`machine_label`) whose rows count as done, e.g. the
            workers of a cluster. Default: this machine only.
        """
        here = {machine_label()} if machines is None else set(machines)
        return {key for key, row in self.read()[0].items() if row.get("machine") in here}

    # writing
    def append(self, row: dict[str, Any], trace: NDArray | None = None) -> None:
        """Add one cell's row (and trace) to the journal, flushed to disk."""
        self.directory.mkdir(parents=True, exist_ok=True)
        entry = {"row": row, "trace": None if trace is None else np.round(trace, 3).tolist()}
        with open(self.journal_path, "a") as f:
            f.write(json.dumps(entry, default=_json_default) + "\n")
            f.flush()
            os.fsync(f.fileno())

    def consolidate(self) -> pd.DataFrame:
        """Merge the journal into the table and the traces; return the table."""
        rows, traces = self.read()
        frame = _frame(rows)
        if not rows and not self.journal_path.exists():
            return frame
        self.directory.mkdir(parents=True, exist_ok=True)
        if traces:
            tmp = self.traces_path.with_name(self.traces_path.name + ".tmp.npz")
            # Any: a dict unpacked into **kwds would otherwise have to fit allow_pickle too.
            arrays: dict[str, Any] = {"|".join(k): v.astype(np.float32)
                                      for k, v in traces.items()}
            np.savez_compressed(tmp, **arrays)
            os.replace(tmp, self.traces_path)
        tmp = self.results_path.with_suffix(".csv.tmp")
        frame.to_csv(tmp, index=False, float_format="%.6g")
        os.replace(tmp, self.results_path)
        self.journal_path.unlink(missing_ok=True)
        return frame


def _key(row: dict[str, Any]) -> Key:
    return tuple(str(row[k]) for k in KEY)


def _frame(rows: dict[Key, dict[str, Any]]) -> pd.DataFrame:
    if not rows:
        return pd.DataFrame(columns=list(KEY))
    frame = pd.DataFrame(list(rows.values()))
    for col in ("message", "statuses", "solver", "solver_version"):
        if col in frame:
            frame[col] = frame[col].astype(object).where(frame[col].notna(), "").astype(str)
    return frame


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot store {type(value).__name__} in the results")


# ----------------------------------------------------------------------- run
class _Worker:
    """A forked process that runs cells one at a time and can be killed at a deadline.

    The process inherits ``cells`` (and everything else in memory) when forked, so only
    indices travel through the pipe; it keeps the reference cache between cells.
    """

    def __init__(self, cells: Sequence[Cell], time_limit: float) -> None:
        ctx = mp.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_loop, args=(child, cells, time_limit),
                                   daemon=True)
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


def _worker_loop(conn: Any, cells: Sequence[Cell], time_limit: float) -> None:
    references: dict[tuple[str, str], NDArray | None] = {}
    while True:
        index = conn.recv()
        if index is None:
            return
        try:
            conn.send(("ok", run_cell(cells[index], references, time_limit)))
        except KeyboardInterrupt:
            conn.send(("interrupt", None))
            return
        except BaseException as exc:  # run_cell turns exceptions into rows; this is a bug
            conn.send(("crash", f"{type(exc).__name__}: {_short(exc)}"))
            return


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
    """Run the cells not yet in the store and return the whole stored table.

    Parameters
    ----------
    cells : sequence of Cell
        From :func:`plan`.
    store : ResultsStore, optional
        Default: ``benchmarks/results``.
    redo : bool
        Run the cells again even if they are stored (their rows are replaced).
    time_limit : float
        Budget of each cell (s). It is passed to the solvers and checked between chunks
        of poses; with ``isolate`` and no executor, a cell still running :data:`GRACE`
        seconds after its budget is killed and stored with status ``"time_limit"``.
        With an executor the limit is only this soft one: a worker of a pool or of a
        Dask cluster cannot be killed per cell, so a solver that hangs inside one call
        holds its worker until it returns.
    progress : bool
        Show a tqdm progress bar (over cells; with an executor it advances per chunk).
    isolate : bool
        Without an executor: run the cells in a forked worker process (hard time limit,
        survives a crashing solver). False runs them in this process. Ignored with an
        executor.
    executor : str, Executor or dask.distributed.Client, optional
        Where the cells run (see :func:`tension_opt.executors.get_executor`):
        ``"inprocess"``, ``"processes[:N]"``, ``"dask[:ADDRESS]"``, an executor or a
        Dask client. The cells go in chunks of at most ``chunk_size`` cells of one
        scenario; the rows are stored as the chunks come back, in order, so an
        interrupted run keeps every chunk returned before. Rows carry the machine of
        the worker that ran them, and rows of the cluster's machines count as done. An
        executor named by a string is closed at the end; one passed in is left open.
        None (default): in this process, as described under ``isolate``.
    chunk_size : int, optional
        Cells per chunk sent to the executor (default: up to :data:`CHUNK_CELLS`, fewer
        when there are not two chunks per worker).

    Returns
    -------
    DataFrame
        The stored table after the run (all rows, not only these cells).

    Raises
    ------
    KeyboardInterrupt
        If interrupted; every cell finished before is stored.
    concurrent.futures.BrokenExecutor
        If a worker of the process pool died (every pending chunk fails then, so the
        culprit is unknown); the rows returned before are stored. With Dask, a chunk
        whose workers keep dying becomes ``"error"`` rows and the run goes on.
    """
    store = store or ResultsStore()
    if executor is not None:
        return _run_on(cells, store, redo, time_limit, progress, executor, chunk_size)
    done = set() if redo else store.done()
    todo = [c for c in cells if c.key not in done]
    keep = _trace_backends(cells)
    references: dict[tuple[str, str], NDArray | None] = {}
    worker: _Worker | None = None
    saved = time.perf_counter()
    bar = _progress(todo, progress)
    try:
        for i, cell in enumerate(bar):
            if progress:
                bar.set_postfix_str("/".join(cell.key), refresh=False)
            if not isolate:
                result = run_cell(cell, references, time_limit)
            else:
                worker = worker or _Worker(todo, time_limit)
                outcome, payload = worker.run(i, time_limit + GRACE)
                if outcome == "interrupt":
                    raise KeyboardInterrupt
                if outcome == "ok":
                    result = payload
                else:
                    worker.close(kill=True)
                    worker = None
                    row = _base_row(cell)
                    if outcome == "timeout":
                        row.update(status="time_limit",
                                   message=f"killed after {time_limit + GRACE:g} s")
                    else:
                        row.update(status="error", message=str(payload))
                    result = CellResult(row)
            _store(store, cell, result, keep)
            if time.perf_counter() - saved > CONSOLIDATE_EVERY:
                store.consolidate()
                saved = time.perf_counter()
    finally:
        if worker is not None:
            worker.close(kill=sys.exc_info()[0] is not None)
    return store.consolidate()


def _trace_backends(cells: Sequence[Cell]) -> set[str]:
    return set(TRACE_BACKENDS) & {c.backend for c in cells} or {c.backend for c in cells}


def _store(store: ResultsStore, cell: Cell, result: CellResult, keep: set[str]) -> None:
    trace = (result.trace if cell.setting == ALL_SETTINGS[0] and cell.backend in keep
             else None)
    store.append(result.row, trace)


# ------------------------------------------------------------ on an executor
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
    """Run the cells of a chunk with :func:`run_cell`, in order; one result per cell.

    This is the function an executor maps over the chunks. It runs on the worker, so the
    rows carry the worker's :func:`machine_label`; the chunk's cells share one cache of
    reference objectives.
    """
    memo: dict[int, Any] = {}
    scenario = _resolve(chunk.scenario, SCENARIOS, memo)
    references: dict[tuple[str, str], NDArray | None] = {}
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
    machines = {machine_label()}
    if isinstance(executor, DaskExecutor):
        machines |= {str(v) for v in executor.client.run(machine_label).values()}
    return machines


def _run_on(cells: Sequence[Cell], store: ResultsStore, redo: bool, time_limit: float,
            progress: bool, executor: str | Executor | Any, chunk_size: int | None,
            ) -> pd.DataFrame:
    """:func:`run` through an executor."""
    owned = isinstance(executor, str)
    runner = get_executor(executor)
    try:
        done = set() if redo else store.done(executor_machines(runner))
        todo = [c for c in cells if c.key not in done]
        if chunk_size is None:
            chunk_size = max(1, min(CHUNK_CELLS, math.ceil(len(todo) / (2 * runner.workers))))
        chunks = chunk_cells(todo, chunk_size)
        payloads = [CellChunk.of(c, time_limit) for c in chunks]
        keep = _trace_backends(cells)
        saved = time.perf_counter()
        bar = _progress_bar(len(todo), progress)
        index = 0
        results: Iterator[list[CellResult]] = iter(runner.map(run_chunk, payloads))
        try:
            while index < len(chunks):
                chunk = chunks[index]
                try:
                    chunk_results = next(results)
                except (KeyboardInterrupt, BrokenExecutor):
                    raise
                except Exception as exc:  # a worker died, a lost connection ...
                    message = f"worker failed: {type(exc).__name__}: {_short(exc)}"
                    chunk_results = [CellResult({**_base_row(c), "status": "error",
                                                 "message": message}) for c in chunk]
                    # The executor's results go on with the next chunk after a failure.
                for cell, result in zip(chunk, chunk_results, strict=True):
                    _store(store, cell, result, keep)
                index += 1
                if bar is not None:
                    bar.set_postfix_str("/".join(chunk[-1].key), refresh=False)
                    bar.update(len(chunk))
                if time.perf_counter() - saved > CONSOLIDATE_EVERY:
                    store.consolidate()
                    saved = time.perf_counter()
        finally:
            if bar is not None:
                bar.close()
    finally:
        if owned:
            runner.close()
    return store.consolidate()


def _progress_bar(total: int, enabled: bool) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="cell", dynamic_ncols=True)


def _progress(todo: list[Cell], enabled: bool) -> Any:
    if not enabled:
        return todo
    from tqdm import tqdm

    return tqdm(todo, unit="cell", dynamic_ncols=True)


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


def select(names: Sequence[str] | None, registry: dict[str, Any], what: str) -> list[Any]:
    """Items of ``registry`` by name (all if ``names`` is empty); unknown names raise."""
    if not names:
        return list(registry.values())
    unknown = [n for n in names if n not in registry]
    if unknown:
        raise ValueError(f"unknown {what} {unknown}; choose from {sorted(registry)}")
    return [registry[n] for n in names]
