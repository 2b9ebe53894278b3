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
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import platform
import sys
import time
import warnings
from collections.abc import Collection, Iterable, Sequence
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
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sol = problem.solve(scenario.robot, scenario.poses, backend,
                                        **({"accuracy": "high"} if backend != "closed_form"
                                           else {}))
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

    def done(self) -> set[Key]:
        """Keys of the rows stored by this machine (rows measured elsewhere are re-run)."""
        here = machine_label()
        return {key for key, row in self.read()[0].items() if row.get("machine") == here}

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
            np.savez_compressed(tmp, **{"|".join(k): v.astype(np.float32)
                                        for k, v in traces.items()})
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
        Budget of each cell (s). It is passed to the solvers and checked between chunks;
        with ``isolate``, a cell still running :data:`GRACE` seconds after its budget
        is killed and stored with status ``"time_limit"``.
    progress : bool
        Show a tqdm progress bar.
    isolate : bool
        Run the cells in a forked worker process (hard time limit, survives a crashing
        solver). False runs them in this process.

    Returns
    -------
    DataFrame
        The stored table after the run (all rows, not only these cells).

    Raises
    ------
    KeyboardInterrupt
        If interrupted; every cell finished before is stored.
    """
    store = store or ResultsStore()
    done = set() if redo else store.done()
    todo = [c for c in cells if c.key not in done]
    keep = set(TRACE_BACKENDS) & {c.backend for c in cells} or {c.backend for c in cells}
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
            trace = (result.trace if cell.setting == ALL_SETTINGS[0] and cell.backend in keep
                     else None)
            store.append(result.row, trace)
            if time.perf_counter() - saved > CONSOLIDATE_EVERY:
                store.consolidate()
                saved = time.perf_counter()
    finally:
        if worker is not None:
            worker.close(kill=sys.exc_info()[0] is not None)
    return store.consolidate()


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
