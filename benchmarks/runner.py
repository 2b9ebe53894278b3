"""Running one cell of the matrix: solve its poses in chunks, measure, make its row.

:func:`run_cell` solves a cell's poses chunk by chunk (per-pose times are measured on
chunks), compares the objectives with a reference backend, adds smoothness and sag
metrics, and returns one row. A cell that cannot run (solver not installed, problem
not expressible, function missing, exception, time limit) becomes a row with that
status; it never raises.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

import tension_opt
from benchmarks import metrics, store
from benchmarks.plan import ALL_SETTINGS, Cell
from benchmarks.scenarios import NotAvailableError, ProblemSpec, Scenario
from tension_opt import BackendNotAvailableError, UnsupportedProblemError

__all__ = [
    "JUMP_FRACTION",
    "MAX_CHUNKS",
    "MAX_TRACE_POSES",
    "MIN_CHUNK",
    "REFERENCE_BACKENDS",
    "TIME_LIMIT",
    "TIMING_COLUMNS",
    "TRACE_BACKENDS",
    "CellResult",
    "Reference",
    "References",
    "base_row",
    "keeps_trace",
    "reference_solution",
    "run_cell",
    "short_message",
    "trace_backends",
]

#: Per-pose times are measured on chunks: at most this many chunks per cell.
MAX_CHUNKS = 20
#: Smallest chunk: batches are how the library is meant to be called, and a chunk of one
#: pose would time the per-call overhead rather than the solve.
MIN_CHUNK = 50
#: Traces are stored for trajectories up to this many poses.
MAX_TRACE_POSES = 200
#: Reference of the objective gap: the exact closed form, else this one at high accuracy.
REFERENCE_BACKENDS = ("closed_form", "cvxpy:CLARABEL")
#: Backends whose traces are kept (all backends when none of them is in a run).
TRACE_BACKENDS = (*REFERENCE_BACKENDS, "qpsolvers:clarabel")
#: Jump threshold of the smoothness metrics, as a fraction of the platform weight.
JUMP_FRACTION = 0.1
#: Default time limit of one cell (s).
TIME_LIMIT = 10.0
#: Columns that differ from run to run: measured times, and the run that stored the row
#: and when (stamped by :func:`benchmarks.harness.run`); all others are reproducible,
#: whichever executor ran the cell.
TIMING_COLUMNS = ("setup_us_median", "setup_us_p95", "solve_us_median", "solve_us_p95",
                  "time_us_median", "time_us_p95", "wall_time_s", "certified_us", "run",
                  "measured_at")



@dataclass(frozen=True)
class Reference:
    """The exact optimum of a cell's poses: objective (N,) and tensions (N, m) (N), NaN
    where the reference backend did not certify the pose; ``slack`` is its own accuracy
    (0 for the closed form, the high target for an iterative reference)."""

    objective: NDArray
    tensions: NDArray
    slack: float = 0.0


#: Cache of references by (scenario, problem) name; None: no reference.
References = dict[tuple[str, str], Reference | None]


@dataclass
class CellResult:
    """Row of one cell and, for short trajectories, its tensions (N, m) (N)."""

    row: dict[str, Any]
    trace: NDArray | None = None


def base_row(cell: Cell) -> dict[str, Any]:
    """The identity columns of a cell's row (status ``"ok"``, this machine)."""
    sc = cell.scenario
    return {
        "machine": store.machine_label(),
        "scenario": sc.name, "problem": cell.problem.name, "backend": cell.backend,
        "setting": cell.setting.label, "accuracy": cell.setting.accuracy,
        "warm_start": cell.setting.warm_start, "status": "ok", "message": "",
        "robot": sc.robot.name, "n_poses": sc.N, "m": sc.robot.m,
    }


def short_message(exc: BaseException, limit: int = 160) -> str:
    """The exception's text on one line, cut to ``limit`` characters."""
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def trace_backends(cells: Sequence[Cell]) -> set[str]:
    """Backends whose traces a run keeps: :data:`TRACE_BACKENDS`, else every one."""
    return set(TRACE_BACKENDS) & {c.backend for c in cells} or {c.backend for c in cells}


def keeps_trace(cell: Cell, backends: set[str]) -> bool:
    """Whether a run keeping traces of ``backends`` stores this cell's trace."""
    return cell.setting == ALL_SETTINGS[0] and cell.backend in backends


def run_cell(cell: Cell, references: References, time_limit: float = TIME_LIMIT) -> CellResult:
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
    row = base_row(cell)
    try:
        tension_opt.get_backend(cell.backend)
        info, out = _solve_chunked(cell, time_limit)
    except BackendNotAvailableError as exc:
        return CellResult({**row, "status": "not_installed", "message": short_message(exc)})
    except UnsupportedProblemError as exc:
        return CellResult({**row, "status": "unsupported", "message": short_message(exc)})
    except NotAvailableError as exc:
        return CellResult({**row, "status": "not_available", "message": short_message(exc)})
    except Exception as exc:
        return CellResult({**row, "status": "error",
                           "message": f"{type(exc).__name__}: {short_message(exc)}"})
    try:
        reference = reference_solution(cell.scenario, cell.problem, references)
        row.update(_measure(cell, info, out, reference))
    except Exception as exc:
        return CellResult({**row, "status": "error",
                           "message": f"metrics: {type(exc).__name__}: {short_message(exc)}"})
    keep = cell.scenario.trajectory and cell.scenario.N <= MAX_TRACE_POSES
    return CellResult(row, out["tensions"] if keep else None)


def reference_solution(scenario: Scenario, problem: ProblemSpec,
                       cache: References) -> Reference | None:
    """The exact optimum per pose, or None: closed form, else CLARABEL at high accuracy.

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
            cache[key] = Reference(np.where(sol.success, sol.objective, np.nan),
                                   np.where(sol.success[:, None], sol.tensions, np.nan),
                                   0.0 if backend == "closed_form" else sol.accuracy)
            break
    return cache[key]


# ------------------------------------------------------------------ solving
def _options(cell: Cell, time_limit: float) -> dict[str, Any]:
    options: dict[str, Any] = {"accuracy": cell.setting.accuracy, "time_limit": time_limit}
    if cell.setting.warm_start:
        options["warm_start"] = True
    return options


def _chunks(cell: Cell) -> list[NDArray]:
    """Pose indices of each chunk: the whole path for joint smoothing."""
    N = cell.scenario.N
    if cell.problem.joint:
        return [np.arange(N)]
    return np.array_split(np.arange(N), max(1, min(MAX_CHUNKS, N // MIN_CHUNK)))


def _solve_chunked(cell: Cell, time_limit: float) -> tuple[dict[str, Any], dict[str, NDArray]]:
    """Solve the cell's poses chunk by chunk; raise the library's errors unchanged."""
    sc, pr = cell.scenario, cell.problem
    N, m = sc.N, sc.robot.m
    out = {
        "tensions": np.full((N, m), np.nan), "success": np.zeros(N, dtype=bool),
        "unique": np.ones(N, dtype=bool), "objective": np.full(N, np.nan),
        "residual": np.full(N, np.nan), "bound_violation": np.full(N, np.nan),
        "iterations": np.full(N, np.nan), "primal_residual": np.full(N, np.nan),
        "dual_residual": np.full(N, np.nan), "duality_gap": np.full(N, np.nan),
    }
    times: dict[str, list[float]] = {"setup": [], "solve": [], "sizes": []}
    info: dict[str, Any] = {"solver": "", "solver_version": "", "timed_out": False,
                            "iterations_reported": True, "statuses": {}, "accuracy": np.nan,
                            "notes": set()}
    previous: NDArray | None = None
    # One backend instance for all chunks (joint smoothing takes the name).
    backend = cell.backend if pr.joint else tension_opt.get_backend(cell.backend)
    start = time.perf_counter()
    for idx in _chunks(cell):
        remaining = time_limit - (time.perf_counter() - start)
        if remaining <= 0:
            info["timed_out"] = True
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = pr.solve(sc.robot, sc.poses[idx], backend, previous=previous,
                           **_options(cell, remaining))
        _record(sol, idx, out, info, times)
        if pr.sequential:
            finite = np.flatnonzero(np.isfinite(sol.tensions).all(axis=1))
            previous = sol.tensions[finite[-1]] if len(finite) else previous
    info["wall_time"] = time.perf_counter() - start
    info["setup"], info["solve"] = np.array(times["setup"]), np.array(times["solve"])
    info["sizes"] = np.array(times["sizes"], dtype=float)
    return info, out


def _record(sol: tension_opt.TensionSolution, idx: NDArray, out: dict[str, NDArray],
            info: dict[str, Any], times: dict[str, list[float]]) -> None:
    """Copy one chunk's solution into the cell's arrays and counters."""
    info["solver"], info["solver_version"] = sol.solver, sol.solver_version
    info["accuracy"] = sol.accuracy
    if sol.extras.get("accuracy"):
        info["notes"].add(str(sol.extras["accuracy"]))
    times["setup"].append(sol.setup_time)
    times["solve"].append(sol.solve_time)
    times["sizes"].append(len(idx))
    for name in ("tensions", "success", "unique", "objective", "residual", "bound_violation",
                 "primal_residual", "dual_residual", "duality_gap"):
        out[name][idx] = getattr(sol, name)
    if sol.iterations is None:
        info["iterations_reported"] = False
    else:
        out["iterations"][idx] = sol.iterations
    for s in sol.status:
        info["statuses"][str(s)] = info["statuses"].get(str(s), 0) + 1


# ---------------------------------------------------------------- measuring
def _nanstat(values: NDArray, fn: Any) -> float:
    v = values[np.isfinite(values)]
    return float(fn(v)) if v.size else float("nan")


def _measure(cell: Cell, info: dict[str, Any], out: dict[str, NDArray],
             reference: Reference | None) -> dict[str, Any]:
    """Metric columns of a solved cell."""
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
    row.update(_certificate_columns(cell, info, out, reference))
    if reference is not None:
        gap = metrics.relative_gap(np.where(ok, out["objective"], np.nan), reference.objective)
        row["objective_gap_max"] = _nanstat(gap, np.max)
    if info["iterations_reported"]:
        row["iterations_mean"] = _nanstat(out["iterations"], np.mean)
        row["iterations_max"] = _nanstat(out["iterations"], np.max)
    row.update(_timing(info))
    solved = int(ok.sum())
    row["certified_us"] = (1e6 * (info["setup"].sum() + info["solve"].sum()) / solved
                           if solved else float("nan"))
    if sc.trajectory:
        threshold = JUMP_FRACTION * sc.robot.weight
        row.update(metrics.smoothness(out["tensions"], threshold))
        row["jump_threshold"] = threshold
        row["non_unique_on_path"] = bool(row["n_non_unique"] > 0)
    if sc.sag:
        row.update(metrics.thesis_sag(sc.robot, sc.poses, out["tensions"]))
    if info["timed_out"]:
        row["status"] = "time_limit"
        row["message"] = f"stopped after {int(info['sizes'].sum())} of {N} poses"
    elif info["notes"]:
        row["message"] = short_message(RuntimeError("; ".join(sorted(info["notes"]))))
    return row


def _certificate_columns(cell: Cell, info: dict[str, Any], out: dict[str, NDArray],
                         reference: Reference | None) -> dict[str, Any]:
    """The certificate's measures over the poses with an answer (largest and shifted
    geometric mean), and the answers labelled optimal against the exact optimum: their
    largest objective excess and how many exceed the target (wrong "optimal")."""
    answered = np.isfinite(out["tensions"]).all(axis=1)
    row: dict[str, Any] = {"accuracy_target": info["accuracy"]}
    for name in ("primal_residual", "dual_residual", "duality_gap"):
        values = out[name][answered & np.isfinite(out[name])]
        row[f"{name}_max"] = float(values.max()) if values.size else float("nan")
        row[f"{name}_sgm"] = (metrics.shifted_geometric_mean(values, metrics.RESIDUAL_SHIFT)
                              if values.size else float("nan"))
    row["objective_excess_max"] = float("nan")
    row["wrong_optimal"] = 0
    ok = out["success"]
    if reference is None or cell.problem.sequential or not ok.any():
        return row
    compared = ok & np.isfinite(reference.tensions).all(axis=1)
    if not compared.any():
        return row
    form = cell.problem.build(cell.scenario.robot).standard_form(
        cell.scenario.robot, cell.scenario.poses[compared])
    excess = metrics.objective_excess(form, out["tensions"][compared],
                                      reference.tensions[compared])
    row["objective_excess_max"] = float(np.nanmax(excess))
    row["wrong_optimal"] = int((excess > info["accuracy"] + reference.slack).sum())
    return row


def _timing(info: dict[str, Any]) -> dict[str, float]:
    """Per-pose setup, solve and total times over the chunks (us), chunk size, wall time."""
    sizes = info["sizes"]
    per_pose = {"setup": info["setup"] / np.maximum(sizes, 1),
                "solve": info["solve"] / np.maximum(sizes, 1)}
    per_pose["time"] = per_pose["setup"] + per_pose["solve"]
    row: dict[str, float] = {}
    for name, samples in per_pose.items():
        med, p95 = metrics.percentiles(1e6 * samples)
        row[f"{name}_us_median"], row[f"{name}_us_p95"] = med, p95
    row["chunk_size"] = float(np.median(sizes)) if sizes.size else float("nan")
    row["wall_time_s"] = info["wall_time"]
    return row
