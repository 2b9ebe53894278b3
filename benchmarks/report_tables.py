"""The report's tables of certified results, its provenance lines and its plot styles.

Success is certified success: a pose counts when its certificate (primal residual, dual
residual and duality gap of the scaled problem, :mod:`tension_opt.certify.certificate`) meets
the cell's accuracy target. The tables follow qpbenchmark: per solver and setting, the
success rate, the time ratio as a shifted geometric mean over the cells (a cell that
certifies fewer poses than the best backend of the same instance counts as a failure,
at the slowest time), the shifted geometric means of the three measures, the cost of a
certified answer (a cell's time over its certified poses), and the answers labelled
optimal that the exact optimum shows wrong.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from benchmarks import metrics

__all__ = [
    "FAMILY_STYLES",
    "INSTANCE",
    "backend_style",
    "certified_summary",
    "provenance",
    "reference_comparison",
    "solved_cells",
]

#: Columns of an instance: the cells of one instance are comparable across backends.
INSTANCE = ("scenario", "problem", "setting")
#: Line style of each backend family in the plots (the colour says the solver).
FAMILY_STYLES = {"closed_form": "-", "cvxpy": "--", "qpsolvers": "-", "scipy": ":"}
#: Solvers in the order of their colours (tab10); others follow.
_SOLVER_ORDER = ("closed_form", "clarabel", "daqp", "highs", "osqp", "piqp", "proxqp",
                 "quadprog", "scs", "scipy", "ecos")


def backend_style(backend: str) -> dict[str, Any]:
    """Matplotlib line keywords of a backend: the solver's colour, the family's style
    (cvxpy dashed, scipy dotted, qpsolvers and the closed form solid; markers tell the
    qpsolvers family from the closed form)."""
    family, _, solver = backend.partition(":")
    solver = (solver or family).lower()
    index = _SOLVER_ORDER.index(solver) if solver in _SOLVER_ORDER else (
        len(_SOLVER_ORDER) + sum(map(ord, solver)))
    colour = "black" if family == "closed_form" else f"C{index % 10}"
    style: dict[str, Any] = {"color": colour, "linestyle": FAMILY_STYLES.get(family, "-.")}
    if family == "qpsolvers":
        style.update(marker="o", markevery=0.1, markersize=3)
    if family == "closed_form":
        style["linewidth"] = 2.0
    return style


def _column(frame: pd.DataFrame, name: str) -> pd.Series:
    """A numeric column, NaN where the table (an older one) lacks it."""
    if name in frame:
        return pd.to_numeric(frame[name], errors="coerce")
    return pd.Series(np.nan, index=frame.index, dtype=float)


def solved_cells(frame: pd.DataFrame) -> pd.Series:
    """Whether each cell certified as many poses as the best backend of its instance."""
    success = _column(frame, "success_rate").where(frame["status"] == "ok")
    best = success.groupby([frame[c] for c in INSTANCE]).transform("max")
    return (success >= best - 1e-12) & success.notna()


def certified_summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per backend and setting over the cells of ``frame`` (see the module docstring).

    Columns: ``cells ok``, ``success`` (mean share of poses certified over the cells
    that ran), ``time ratio (sgm)`` (shift 10 us), ``certified us (sgm)`` (cost of a
    certified answer, shift 10 us), ``primal res.``, ``dual res.``, ``gap`` (shifted
    geometric means of each cell's, shift 1e-15), ``wrong optimal`` (poses labelled
    optimal whose objective exceeds the exact optimum by more than the target),
    ``max excess`` (the largest such excess), ``iterations`` (mean) and
    ``max residual (N)``.
    """
    ran = frame[frame["status"].isin(["ok", "time_limit"])]
    if ran.empty:
        return pd.DataFrame()
    attempted = frame[frame["status"].isin(["ok", "time_limit", "error"])].copy()
    solved = solved_cells(attempted)
    attempted["t"] = _column(attempted, "time_us_median").where(solved)
    attempted["c"] = _column(attempted, "certified_us").where(solved)
    ratios = {setting: _ratio(attempted[attempted["setting"] == setting], "t")
              for setting in attempted["setting"].unique()}
    rows = []
    for (backend, setting), group in ran.groupby(["backend", "setting"], sort=False):
        mine = attempted["setting"] == setting
        rows.append({
            "backend": backend, "setting": setting,
            "cells ok": int((group["status"] == "ok").sum()),
            "success": float(_column(group, "success_rate").mean()),
            "time ratio (sgm)": float(ratios.get(setting, pd.Series(dtype=float)).get(
                backend, np.nan)),
            "certified us (sgm)": _sgm(attempted[mine & (attempted["backend"] == backend)]["c"],
                                       attempted[mine]["c"]),
            **{label: _residual(group, f"{name}_sgm") for label, name in (
                ("primal res.", "primal_residual"), ("dual res.", "dual_residual"),
                ("gap", "duality_gap"))},
            "wrong optimal": int(_column(group, "wrong_optimal").fillna(0).sum()),
            "max excess": float(_column(group, "objective_excess_max").max()),
            "iterations": float(_column(group, "iterations_mean").mean()),
            "max residual (N)": float(_column(group, "residual_max").max()),
        })
    table = pd.DataFrame(rows).set_index(["backend", "setting"])
    return table.sort_values(["setting", "time ratio (sgm)"])


def _ratio(frame: pd.DataFrame, column: str) -> pd.Series:
    """Shifted geometric mean of ``column`` per backend over the instances, relative to
    the best; failures (NaN) count as the slowest time."""
    return metrics.relative_shifted_geometric_means(frame, column, instance=INSTANCE)


def _sgm(values: pd.Series, everyone: pd.Series) -> float:
    """Shifted geometric mean (10 us) of one backend's costs; failures count as the
    slowest cost of any backend."""
    known = everyone.to_numpy(dtype=float)
    if values.empty or not np.isfinite(known).any():
        return float("nan")
    fill = float(np.nanmax(known))
    return metrics.shifted_geometric_mean(values.fillna(fill).to_numpy(dtype=float))


def _residual(group: pd.DataFrame, column: str) -> float:
    values = _column(group, column).dropna().to_numpy()
    if not values.size:
        return float("nan")
    return metrics.shifted_geometric_mean(values, metrics.RESIDUAL_SHIFT)


def provenance(frame: pd.DataFrame, runs: pd.DataFrame) -> list[str]:
    """Markdown lines saying where and when the rows were measured: per run of this
    results database, and for rows that came from elsewhere (a committed reference)."""
    if frame.empty:
        return []
    run = frame["run"].astype(object).where(frame["run"].notna(), "") if "run" in frame else (
        pd.Series("", index=frame.index))
    when = frame["measured_at"] if "measured_at" in frame else pd.Series(
        np.nan, index=frame.index)
    local = set(runs["id"]) if not runs.empty else set()
    lines = ["| rows | measured by | on | when (UTC) |", "|---|---|---|---|"]
    for (label, machine), group in frame.assign(_run=run).groupby(["_run", "machine"],
                                                                    sort=False):
        dates = when[group.index].dropna().astype(str)
        span = f"{dates.min()} .. {dates.max()}" if len(dates) else "not recorded"
        who = (f"run {label} (this results database)" if label in local
               else f"reference run {label}" if label else "reference (imported)")
        lines.append(f"| {len(group)} | {who} | {machine} | {span} |")
    if any(r not in local for r in run):
        lines += ["", "Reference rows came with the results: they were measured where "
                  "and when the table says, by a run of another results database (a "
                  "machine label alike to this one's does not make them this machine's). "
                  "A plain `python -m benchmarks` measures every cell it runs again; the "
                  "table keeps the reference only for cells not measured here."]
    return lines


def reference_comparison(frame: pd.DataFrame, reference: pd.DataFrame, runs: pd.DataFrame
                         ) -> pd.DataFrame:
    """Per backend: the median time per pose of the rows measured by ``runs`` (this
    results database's) over the reference's, and both success rates, on the cells
    measured in both."""
    if reference.empty or frame.empty or runs.empty or "run" not in frame:
        return pd.DataFrame()
    key = ["scenario", "problem", "backend", "setting"]
    mine = frame[frame["run"].isin(set(runs["id"]))]
    both = mine.merge(reference, on=key, suffixes=("", "_ref"))
    both = both[(both["status"] == "ok") & (both["status_ref"] == "ok")]
    if both.empty:
        return pd.DataFrame()
    ratio = _column(both, "time_us_median") / _column(both, "time_us_median_ref")
    table = pd.DataFrame({"backend": both["backend"], "time / reference": ratio,
                          "success": _column(both, "success_rate"),
                          "success (reference)": _column(both, "success_rate_ref")})
    return table.groupby("backend").agg({"time / reference": "median", "success": "mean",
                                         "success (reference)": "mean"})
