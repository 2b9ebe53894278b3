"""Markdown report and PNG plots of a results table.

:func:`write_report` turns the stored table (and traces) into ``README.md`` beside
the results, with the machine and library versions, the settings, a headline table,
then per scenario tables (success, time ratio, iterations, accuracy, smoothness, sag)
with one-line captions, and the plots ``traces_<scenario>.png``,
``time_per_pose.png``, ``performance_profile.png`` and ``smoothness.png``.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from numpy.typing import NDArray

from benchmarks import metrics
from benchmarks.plan import ALL_SETTINGS
from benchmarks.report_tables import (
    backend_style,
    certified_summary,
    provenance,
    reference_comparison,
    solved_cells,
)
from benchmarks.runner import (
    JUMP_FRACTION,
    MAX_CHUNKS,
    MIN_CHUNK,
    REFERENCE_BACKENDS,
    TIME_LIMIT,
)
from benchmarks.scenarios import PROBLEMS, RATE_FRACTION, SCENARIOS, SMOOTHING
from benchmarks.store import RESULTS_DIR, ResultsStore

REPORT_FILE = "README.md"
BASE_SETTING = ALL_SETTINGS[0].label
LIBRARIES = ("numpy", "scipy", "pandas", "cvxpy", "qpsolvers", "clarabel", "daqp", "highspy",
             "osqp", "piqp", "proxsuite", "quadprog", "scs", "matplotlib", "tension-opt")
_SHORT_STATUS = {"unsupported": "unsup.", "not_installed": "n/i", "not_available": "n/a",
                 "error": "error", "time_limit": "time"}


# ------------------------------------------------------------------ helpers
def machine_info() -> list[tuple[str, str]]:
    """(name, value) pairs: OS, CPU, core count, Python and library versions."""
    rows = [("OS", platform.platform()), ("CPU", platform.processor() or platform.machine()),
            ("cores", str(os.cpu_count())), ("Python", sys.version.split()[0])]
    for lib in LIBRARIES:
        try:
            rows.append((lib, metadata.version(lib)))
        except metadata.PackageNotFoundError:
            rows.append((lib, "not installed"))
    return rows


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return "-"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.2e}"
        return f"{v:.{digits}g}"
    return str(value).replace("|", "/")


def markdown_table(frame: pd.DataFrame, index: bool = True, digits: int = 3) -> str:
    """A pipe table of ``frame`` (index as the first column if ``index``)."""
    data = frame.reset_index() if index else frame
    header = [str(c) for c in data.columns]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in data.itertuples(index=False):
        lines.append("| " + " | ".join(_fmt(v, digits) for v in row) + " |")
    return "\n".join(lines)


def _cell_text(frame: pd.DataFrame, value: str, digits: int = 3) -> pd.DataFrame:
    """Problem x backend text table of ``value``; non-ok cells show their status."""
    text = frame.apply(lambda r: _fmt(r[value], digits) if r["status"] in ("ok", "time_limit")
                       else _SHORT_STATUS.get(r["status"], r["status"]), axis=1)
    table = frame.assign(_text=text).pivot_table(index="problem", columns="backend",
                                                 values="_text", aggfunc="first")
    order = [p for p in PROBLEMS if p in table.index] + [p for p in table.index
                                                          if p not in PROBLEMS]
    return table.reindex(order).fillna("")


def _backend_order(frame: pd.DataFrame) -> list[str]:
    seen = list(dict.fromkeys(frame["backend"]))
    return sorted(seen, key=lambda b: (b != "closed_form", b.split(":")[0], b))


def with_time_ratio(frame: pd.DataFrame) -> pd.DataFrame:
    """Add ``time_ratio``: median time per pose over the best of the same instance."""
    out = frame.copy()
    if "time_us_median" not in out:
        out["time_ratio"] = np.nan
        return out
    ok = out["status"] == "ok"
    t = out["time_us_median"].where(ok)
    best = t.groupby([out["scenario"], out["problem"], out["setting"]]).transform("min")
    out["time_ratio"] = t / best
    return out


def backend_summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per backend and setting over the cells of ``frame``: certified success, time,
    accuracy (:func:`benchmarks.report_tables.certified_summary`)."""
    return certified_summary(frame)


def _pick_trace_backend(rows: pd.DataFrame) -> pd.DataFrame:
    """One ok row per problem, preferring the reference backends."""
    rank = {b: i for i, b in enumerate((*REFERENCE_BACKENDS, "qpsolvers:clarabel"))}
    ok = rows[(rows["status"] == "ok") & (rows["setting"] == BASE_SETTING)].copy()
    ok["_rank"] = ok["backend"].map(lambda b: rank.get(b, len(rank)))
    ok = ok.sort_values(["_rank", "success_rate"], ascending=[True, False])
    return ok.drop_duplicates("problem").set_index("problem")


def smoothness_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Per problem of a trajectory scenario: smoothness of the preferred backend's path."""
    picked = _pick_trace_backend(frame)
    if picked.empty or "total_variation" not in picked:
        return pd.DataFrame()
    cols = {"backend": "backend", "success_rate": "success", "total_variation": "TV (N)",
            "max_step": "max step (N)", "max_second_diff": "max 2nd diff (N)", "jumps": "jumps",
            "non_unique_on_path": "non-unique"}
    table = picked[list(cols)].rename(columns=cols)
    order = [p for p in PROBLEMS if p in table.index]
    return table.reindex(order)


def sag_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Per problem: catenary columns (thesis convention) of the preferred backend."""
    picked = _pick_trace_backend(frame)
    if picked.empty or "sag_max_mm" not in picked:
        return pd.DataFrame()
    cols = {"catenary_length_mean": "mean L (m)", "sag_max_mm": "max L-Le (mm)",
            "sag_mean_mm": "mean L-Le (mm)", "catenary_iterations_mean": "cat. iter. mean",
            "catenary_iterations_max": "cat. iter. max",
            "thesis_residual_max": "thesis residual (N)"}
    table = picked[list(cols)].rename(columns=cols)
    return table.reindex([p for p in PROBLEMS if p in table.index])


def headline(frame: pd.DataFrame, scenario: str = "thesis_trajectory",
             problems: Sequence[str] = ("min_sum", "min_norm", "smoothed", "joint_smoothing")
             ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Headline tables of the study's trajectory.

    Returns
    -------
    smooth : DataFrame
        Per problem: total variation and largest step of the tensions (N).
    times : DataFrame
        Median time per pose (us), problem x backend, at the base setting.
    """
    rows = frame[(frame["scenario"] == scenario) & frame["problem"].isin(problems)]
    if rows.empty:
        return pd.DataFrame(), pd.DataFrame()
    smooth = smoothness_table(rows)
    smooth = smooth[[c for c in ("backend", "TV (N)", "max step (N)", "jumps")
                     if c in smooth]]
    base = rows[rows["setting"] == BASE_SETTING]
    times = _cell_text(base, "time_us_median")
    times = times[[b for b in _backend_order(base) if b in times.columns]]
    return smooth, times.T


# -------------------------------------------------------------------- plots
def _finish(fig: Figure, path: Path | None, dpi: int) -> Figure:
    """Save and close ``fig`` when a path is given; return it."""
    if path is not None:
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
    return fig


def plot_traces(scenario: str, traces: dict[tuple[str, ...], NDArray], frame: pd.DataFrame,
                path: Path | None = None) -> Figure | None:
    """Tension traces along a trajectory, one panel per problem; None if there are none.

    With ``path`` the figure is saved there and closed; without, it is returned open.
    """
    picked = _pick_trace_backend(frame[frame["scenario"] == scenario])
    panels = [(p, r["backend"]) for p, r in picked.iterrows()
              if (scenario, p, r["backend"], BASE_SETTING) in traces]
    panels.sort(key=lambda pb: list(PROBLEMS).index(pb[0]) if pb[0] in PROBLEMS else 99)
    if not panels:
        return None
    cols = 4 if len(panels) > 4 else len(panels)
    rows = int(np.ceil(len(panels) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.3 * rows), squeeze=False,
                             sharex=True)
    for ax, (problem, backend) in zip(axes.flat, panels, strict=False):
        T = traces[(scenario, problem, backend, BASE_SETTING)]
        lines = ax.plot(np.arange(len(T)), T / 1e3, lw=1.2)
        ax.set_title(f"{problem} ({backend})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    fig.legend(lines, [f"cable {i + 1}" for i in range(len(lines))], loc="upper right",
               fontsize=7, ncol=min(len(lines), 8))
    for ax in axes[:, 0]:
        ax.set_ylabel("tension (kN)", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("pose", fontsize=8)
    fig.suptitle(f"{scenario}: cable tensions along the path", fontsize=10)
    fig.tight_layout()
    return _finish(fig, path, dpi=72)


def plot_time_per_pose(frame: pd.DataFrame, path: Path | None = None) -> Figure | None:
    """Median time per pose of every ok cell at the base setting, per backend (log scale).

    With ``path`` the figure is saved there and closed; without, it is returned open.
    """
    ok = frame[(frame["status"] == "ok") & (frame["setting"] == BASE_SETTING)]
    if ok.empty:
        return None
    backends = _backend_order(ok)
    scenarios = list(dict.fromkeys(ok["scenario"]))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.45 * len(backends) + 2), 4.2))
    for j, sc in enumerate(scenarios):
        sub = ok[ok["scenario"] == sc]
        x = np.array([backends.index(b) for b in sub["backend"]], dtype=float)
        x += (j - (len(scenarios) - 1) / 2) * 0.12
        ax.scatter(x, sub["time_us_median"], s=12, label=sc, alpha=0.8)
    ax.set_yscale("log")
    ax.set_xticks(range(len(backends)))
    ax.set_xticklabels(backends, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("median time per pose (us)")
    ax.grid(alpha=0.3, which="both", axis="y")
    ax.legend(fontsize=7)
    ax.set_title(f"time per pose, each dot a problem ({BASE_SETTING})", fontsize=10)
    fig.tight_layout()
    return _finish(fig, path, dpi=90)


def plot_performance_profile(frame: pd.DataFrame, path: Path | None = None) -> Figure | None:
    """Performance profile of the median time per pose (Dolan-More), at the base setting.

    With ``path`` the figure is saved there and closed; without, it is returned open.

    Instances are the (scenario, problem) pairs that every backend in the table ran;
    a cell that is not ok there (unsupported, failed), or that certifies fewer poses
    than the best backend of the instance, counts as never solved. Each solver has its
    colour and each backend family its line style (:func:`backend_style`).
    """
    base = frame[(frame["setting"] == BASE_SETTING) & (frame["status"] != "not_installed")]
    # Only cells that certified as many poses as the best backend count as solved.
    ranked = with_time_ratio(base.assign(status=base["status"].where(
        solved_cells(base), "uncertified")))
    if ranked["time_ratio"].notna().sum() == 0:
        return None
    index = ["scenario", "problem"]
    present = ranked.pivot_table(index=index, columns="backend", values="status",
                                 aggfunc="first").notna().all(axis=1)
    wide = ranked.pivot_table(index=index, columns="backend", values="time_ratio",
                              aggfunc="first", dropna=False)
    wide = wide[present.reindex(wide.index).fillna(False).to_numpy(dtype=bool)]
    finite = wide.to_numpy()[np.isfinite(wide.to_numpy())]
    if wide.empty or finite.size == 0:
        return None
    taus = np.logspace(0, np.log10(max(2.0, float(finite.max()) * 1.1)), 200)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for backend in _backend_order(ranked):
        if backend in wide:
            ax.step(taus, metrics.performance_profile(wide[backend].to_numpy(), taus),
                    where="post", label=backend, **{"linewidth": 1.2, **backend_style(backend)})
    ax.set_xscale("log")
    ax.set_xlabel("time per pose / best time per pose of the instance")
    ax.set_ylabel("fraction of instances")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6, ncol=2)
    ax.set_title(f"performance profile over {len(wide)} scenario x problem instances "
                 f"({BASE_SETTING})", fontsize=10)
    fig.tight_layout()
    return _finish(fig, path, dpi=90)


def plot_smoothness(frame: pd.DataFrame, path: Path | None = None) -> Figure | None:
    """Bars of total variation and largest step per problem, per trajectory scenario.

    With ``path`` the figure is saved there and closed; without, it is returned open.
    """
    scenarios = [s for s in dict.fromkeys(frame["scenario"])
                 if s in SCENARIOS and SCENARIOS[s].trajectory]
    tables = [(s, smoothness_table(frame[frame["scenario"] == s])) for s in scenarios]
    tables = [(s, t) for s, t in tables if not t.empty]
    if not tables:
        return None
    fig, axes = plt.subplots(len(tables), 2, figsize=(10, 2.6 * len(tables)), squeeze=False)
    for (scenario, table), row in zip(tables, axes, strict=True):
        for ax, col in zip(row, ("TV (N)", "max step (N)"), strict=True):
            ax.bar(table.index, table[col].astype(float) / 1e3, color="tab:blue")
            ax.set_title(f"{scenario}: {col.replace(' (N)', '')} (kN)", fontsize=9)
            ax.tick_params(axis="x", rotation=45, labelsize=7)
            ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return _finish(fig, path, dpi=90)


# ------------------------------------------------------------------- report
def _settings_lines() -> list[str]:
    return [
        f"- Cell time limit: {TIME_LIMIT:g} s by default (checked between chunks and "
        "passed to the solver as `time_limit`).",
        f"- Time per pose: each cell solves its poses in at most {MAX_CHUNKS} chunks "
        f"of at least {MIN_CHUNK} poses (one chunk for shorter scenarios); "
        "a chunk's setup + solve time (as the library reports it) divided by its number of "
        "poses is one sample; median and 95th percentile over the chunks. Sequential problems "
        "are solved pose by pose inside a chunk; joint smoothing is one chunk (one sample).",
        "- Time ratio: median time per pose over the best backend of the same scenario x "
        "problem x setting; summaries use the shifted geometric mean (shift 10 us) of the "
        "median time per pose over the cells a backend can express (errors and time-outs "
        "count as the slowest time), relative to the best.",
        "- Success: the share of a cell's poses labelled optimal, which means certified: "
        "primal residual, dual residual and duality gap of the scaled problem (tensions "
        "over a reference tension, equilibrium rows over their norms, objective of order "
        "one) all within the accuracy target (default 1e-7, high 1e-10), from the solver's "
        "own multipliers where it gives them (`tension_opt.certify.certificate`).",
        "- Certified summary (qpbenchmark style): time ratio and certified cost count a "
        "cell that certifies fewer poses than the best backend of its instance as a "
        "failure (at the slowest time); `certified us` is a cell's time over its certified "
        "poses; residuals and gap are shifted geometric means (shift 1e-15) of each cell's.",
        "- Objective gap: largest `|f - f_ref| / max(|f_ref|, 1)` over the poses, against "
        f"{' or '.join(REFERENCE_BACKENDS)} (high accuracy), whichever applies first; "
        "`wrong optimal` counts poses labelled optimal whose objective exceeds that "
        "exact optimum by more than the target on the scaled problem (`max excess`).",
        f"- Smoothing weight {SMOOTHING:g} (1/N); rate limit {RATE_FRACTION:g} m g per step; "
        f"jumps: steps where some tension changes by more than {JUMP_FRACTION:g} m g.",
        "- Centred problem on the study's robot (no upper bound): t_max = 4 m g.",
        "- Sag (study's convention): inextensible catenary per cable with the distributed "
        "tension imposed at the drawing point; `thesis residual` is the force imbalance of "
        "the catenary end forces at the platform, i.e. the error against a coupled model.",
    ]


def build_markdown(frame: pd.DataFrame, figures: dict[str, str],
                   runs: pd.DataFrame | None = None,
                   reference: pd.DataFrame | None = None) -> str:
    """The report text for ``frame`` with the given figure files (name -> caption), the
    runs of its results database and the reference rows that came with the results."""
    lines = ["# Tension distribution benchmark", "",
             f"Generated {datetime.now(UTC):%Y-%m-%d %H:%M} UTC by `python -m benchmarks`. "
             f"{len(frame)} cells.", "", "## Machine and libraries", "",
             "| item | value |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in machine_info()]
    if "machine" in frame and not frame.empty:
        lines += ["", "## Where and when the rows were measured", "",
                  *provenance(frame, pd.DataFrame(columns=["id"]) if runs is None else runs)]
        compared = reference_comparison(
            frame, pd.DataFrame() if reference is None else reference,
            pd.DataFrame(columns=["id"]) if runs is None else runs)
        if not compared.empty:
            lines += ["", "This machine against the reference, on the cells measured in "
                      "both (median time ratio, mean success):", "",
                      markdown_table(compared)]
    lines += ["", "## Settings", "", *_settings_lines(), ""]
    if frame.empty:
        return "\n".join([*lines, "No results yet.", ""])
    counts = frame["status"].value_counts()
    lines += ["Cell status: " + ", ".join(f"{k} {v}" for k, v in counts.items()) + ".", ""]

    smooth, times = headline(frame)
    if not smooth.empty:
        lines += ["## Headline: the study's pick-and-place trajectory", "",
                  "Tension smoothness along the path (preferred backend per problem):", "",
                  markdown_table(smooth), "",
                  f"Median time per pose (us) per backend ({BASE_SETTING}):", "",
                  markdown_table(times), ""]

    lines += ["## Certified results over all scenarios", ""]
    for setting in dict.fromkeys(frame["setting"]):
        sub = frame[frame["setting"] == setting]
        table = backend_summary(sub)
        if not table.empty:
            lines += [f"**{setting}**: per backend over every scenario and problem "
                      "(success = share of poses certified; see Settings).", "",
                      markdown_table(table.reset_index(level="setting", drop=True)), ""]
    for name, caption in figures.items():
        if not name.startswith("traces_"):
            lines += [f"![{caption}]({name})", "", f"*{caption}*", ""]

    for scenario in dict.fromkeys(frame["scenario"]):
        lines += _scenario_section(frame[frame["scenario"] == scenario], scenario, figures)
    return "\n".join(lines)


def _scenario_section(rows: pd.DataFrame, scenario: str, figures: dict[str, str]) -> list[str]:
    sc = SCENARIOS.get(scenario)
    first = rows.iloc[0]
    lines = [f"## {scenario}", "",
             f"{sc.description if sc else ''} ({first['robot']}, {first['n_poses']} poses, "
             f"{first['m']} cables).", ""]
    base = rows[rows["setting"] == BASE_SETTING]
    order = [b for b in _backend_order(base)]
    for value, caption, digits in (
        ("success_rate", "Success rate (fraction of poses certified optimal); non-ok cells "
         "show their status", 3),
        ("time_ratio", "Time ratio: median time per pose over the best backend of the problem",
         3),
        ("iterations_mean", "Iterations per pose as the solver reports them ('-' where it does "
         "not; 0 for closed forms)", 3),
    ):
        table = _cell_text(with_time_ratio(base), value, digits)
        lines += [f"{caption} ({BASE_SETTING}):", "",
                  markdown_table(table[[b for b in order if b in table.columns]].T), ""]
    summary = backend_summary(rows)
    if not summary.empty:
        lines += ["Per backend and setting over this scenario's problems (certified "
                  "success, time, accuracy):", "", markdown_table(summary), ""]
    settings = with_time_ratio(rows[rows["status"] == "ok"])
    if settings["setting"].nunique() > 1:
        effect = settings.pivot_table(index="backend", columns="setting",
                                      values="time_us_median", aggfunc="median")
        lines += ["Median time per pose (us) by setting (median over problems):", "",
                  markdown_table(effect), ""]
    if sc is not None and sc.trajectory:
        table = smoothness_table(rows)
        if not table.empty:
            lines += ["Smoothness of the tensions along the path (preferred backend per "
                      "problem; TV = total variation):", "", markdown_table(table), ""]
    if sc is not None and sc.sag:
        table = sag_table(rows)
        if not table.empty:
            lines += ["Sag (study's convention): catenary length, difference to the straight "
                      "line, catenary iterations per cable and force residual:", "",
                      markdown_table(table), ""]
    name = f"traces_{scenario}.png"
    if name in figures:
        lines += [f"![{figures[name]}]({name})", "", f"*{figures[name]}*", ""]
    return lines


def write_report(directory: str | os.PathLike[str] = RESULTS_DIR) -> Path:
    """Write ``README.md`` and the PNG plots from the stored results in ``directory``.

    Returns
    -------
    Path
        The report file.
    """
    store = ResultsStore(directory)
    frame = store.load()
    traces = store.load_traces()
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    figures: dict[str, str] = {}
    if not frame.empty:
        if plot_time_per_pose(frame, out / "time_per_pose.png") is not None:
            figures["time_per_pose.png"] = "Median time per pose per backend (log scale)."
        if plot_performance_profile(frame, out / "performance_profile.png") is not None:
            figures["performance_profile.png"] = (
                "Performance profile: fraction of the instances every backend ran that a "
                "backend solves within a factor of the best time per pose (unsupported counts "
                "as unsolved).")
        if plot_smoothness(frame, out / "smoothness.png") is not None:
            figures["smoothness.png"] = "Total variation and largest step of the tensions."
        for scenario in dict.fromkeys(frame["scenario"]):
            name = f"traces_{scenario}.png"
            if plot_traces(scenario, traces, frame, out / name) is not None:
                figures[name] = f"Tensions along {scenario}, one panel per problem."
    path = out / REPORT_FILE
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(build_markdown(frame, figures, store.runs(), store.reference()))
    os.replace(tmp, path)
    return path
