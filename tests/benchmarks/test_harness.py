"""Benchmark runner: resumption after an interrupt, missing solvers, time limits, report."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks import harness, report
from benchmarks import store as store_module
from benchmarks.__main__ import main
from benchmarks.scenarios import PROBLEMS, SCENARIOS, Scenario, pick_and_place
from tension_opt import presets

TINY = Scenario("tiny_path", "first six poses of the study's path", presets.algae_harvester,
                lambda r: pick_and_place()[:6], trajectory=True, sag=True)
PROBS = [PROBLEMS[p] for p in ("min_sum", "min_norm", "pinv")]
SETTINGS = [harness.Setting("default"), harness.Setting("high")]
# Columns that do not depend on timing.
STABLE = ["scenario", "problem", "backend", "setting", "status", "success_rate",
          "objective_mean", "objective_gap_max", "total_variation", "max_step", "jumps",
          "sag_max_mm", "iterations_mean"]


def _cells(backends: list[str] | None = None) -> list[harness.Cell]:
    return harness.plan([TINY], PROBS, backends or ["closed_form"], SETTINGS)


def _sorted(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[STABLE].sort_values(list(harness.KEY)).reset_index(drop=True)


def test_resumes_after_interrupt(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cells = _cells()
    assert len(cells) == 6
    full = harness.run(cells, harness.ResultsStore(tmp_path / "full"), progress=False,
                       isolate=False)
    assert len(full) == 6 and (full["status"] == "ok").all()
    # min_sum along the first six poses (raise at (-3,-4), then two line steps).
    assert full["total_variation"].min() > 0

    real = harness.run_cell
    calls: list[tuple[str, ...]] = []

    def interrupted(cell, references, time_limit=harness.TIME_LIMIT):  # type: ignore[no-untyped-def]
        if len(calls) == 3:
            raise KeyboardInterrupt
        calls.append(cell.key)
        return real(cell, references, time_limit)

    store = harness.ResultsStore(tmp_path / "resumed")
    monkeypatch.setattr(harness, "run_cell", interrupted)
    with pytest.raises(KeyboardInterrupt):
        harness.run(cells, store, progress=False, isolate=False)
    assert len(store.load()) == 3
    assert not list((tmp_path / "resumed").glob("*.tmp*"))

    calls.clear()

    def counting(cell, references, time_limit=harness.TIME_LIMIT):  # type: ignore[no-untyped-def]
        calls.append(cell.key)
        return real(cell, references, time_limit)

    monkeypatch.setattr(harness, "run_cell", counting)
    resumed = harness.run(cells, store, progress=False, isolate=False)
    assert len(calls) == 3  # only the cells not stored
    assert set(calls).isdisjoint(set(_sorted(store.load()).index))
    pd.testing.assert_frame_equal(_sorted(resumed), _sorted(full))
    pd.testing.assert_frame_equal(_sorted(store.load()), _sorted(full), check_dtype=False)

    calls.clear()
    harness.run(cells[:2], store, progress=False, isolate=False, redo=True)
    assert len(calls) == 2 and len(store.load()) == 6


def test_missing_solver_becomes_a_row(tmp_path: Path) -> None:
    cells = harness.plan([TINY], PROBS[:1], ["qpsolvers:no_such_solver", "nowhere:x",
                                             "closed_form"], SETTINGS[:1])
    frame = harness.run(cells, harness.ResultsStore(tmp_path), progress=False, isolate=False)
    status = dict(zip(frame["backend"], frame["status"], strict=True))
    assert status == {"qpsolvers:no_such_solver": "not_installed", "nowhere:x": "not_installed",
                      "closed_form": "ok"}
    ok = frame[frame["backend"] == "closed_form"].iloc[0]
    assert ok["success_rate"] == 1.0
    assert ok["objective_gap_max"] == pytest.approx(0.0, abs=1e-12)
    assert ok["residual_max"] < 1e-6
    assert ok["iterations_mean"] == 0.0
    assert "install" in frame.loc[frame["backend"] == "nowhere:x", "message"].iloc[0]


def test_unsupported_and_missing_function(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    # As if not written yet:
    monkeypatch.setitem(sys.modules, "tension_opt.dynamics.trajectory", None)
    cells = [harness.Cell(TINY, PROBLEMS["joint_smoothing"], "cvxpy:CLARABEL",
                          harness.Setting()),
             harness.Cell(SCENARIOS["cogiro_random"], PROBLEMS["min_max"], "closed_form",
                          harness.Setting())]
    frame = harness.run(cells, harness.ResultsStore(tmp_path), progress=False, isolate=False)
    assert list(frame["status"]) == ["not_available", "unsupported"]


def test_hard_time_limit_kills_a_hanging_cell(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    real = harness.run_cell
    hang = ("tiny_path", "min_norm", "closed_form", "default/cold")

    def hanging(cell, references, time_limit=harness.TIME_LIMIT):  # type: ignore[no-untyped-def]
        if cell.key == hang:
            time.sleep(60)
        return real(cell, references, time_limit)

    monkeypatch.setattr(harness, "run_cell", hanging)
    monkeypatch.setattr(harness, "GRACE", 0.5)
    start = time.perf_counter()
    frame = harness.run(_cells()[:4], harness.ResultsStore(tmp_path), progress=False,
                        time_limit=0.5, isolate=True)
    assert time.perf_counter() - start < 15
    status = {tuple(r[:4]): r[4] for r in frame[[*harness.KEY, "status"]].itertuples(index=False)}
    assert status.pop(hang) == "time_limit"
    assert set(status.values()) == {"ok"} and len(status) == 3


def test_report_and_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    harness.run(_cells(), harness.ResultsStore(tmp_path), progress=False, isolate=False)
    traces = harness.ResultsStore(tmp_path).load_traces()
    key = ("tiny_path", "min_sum", "closed_form", "default/cold")
    assert traces[key].shape == (6, 4)
    assert np.isfinite(traces[key]).all()
    path = report.write_report(tmp_path)
    text = path.read_text()
    assert "## tiny_path" in text and "| numpy |" in text
    assert (tmp_path / "time_per_pose.png").stat().st_size > 1000
    assert main(["list"]) == 0
    assert "thesis_trajectory" in capsys.readouterr().out


def test_default_suite_cuts_only_unchosen_dimensions() -> None:
    cells = harness.plan([SCENARIOS["thesis_long"], SCENARIOS["cogiro_random"]],
                         [PROBLEMS["min_sum"]], ["closed_form", "cvxpy:CLARABEL"],
                         harness.ALL_SETTINGS)
    assert len(cells) == 2 * (2 + 4)  # closed_form cannot warm start, CLARABEL can
    kept = {c.key for c in harness.default_suite(cells)}
    assert kept == {("thesis_long", "min_sum", "closed_form", "default/cold")}
    kept = {c.key for c in harness.default_suite(cells, chosen=["scenario"])}
    assert kept == {("thesis_long", "min_sum", "closed_form", "default/cold"),
                    ("cogiro_random", "min_sum", "closed_form", "default/cold"),
                    ("cogiro_random", "min_sum", "cvxpy:CLARABEL", "default/cold")}
    assert len(harness.default_suite(cells, chosen=["scenario", "backend", "settings"])) == 12


def test_rows_measured_on_another_machine_are_run_again(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    cells = _cells()[:2]
    store = harness.ResultsStore(tmp_path)
    harness.run(cells, store, progress=False, isolate=False)
    assert store.done() == {c.key for c in cells}
    monkeypatch.setattr(store_module, "machine_label", lambda: "another host / cpu / 2 cores")
    assert store.done() == set()  # a fresh clone's stored rows are not its own
    frame = harness.run(cells, store, progress=False, isolate=False)
    assert (frame["machine"] == "another host / cpu / 2 cores").all()
    assert store.done() == {c.key for c in cells}
