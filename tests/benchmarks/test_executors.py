"""Benchmark matrix on executors: a process pool and a Dask cluster give the in-process table."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from benchmarks import harness
from benchmarks.cli import build_parser, main
from benchmarks.scenarios import PROBLEMS, Scenario, pick_and_place
from tension_opt import presets
from tension_opt.workspace.executors import DaskExecutor

TINY = Scenario("tiny_path", "first six poses of the study's path (not registered: lambdas)",
                presets.algae_harvester, lambda r: pick_and_place()[:6], trajectory=True)


def _stable(frame: pd.DataFrame, machine: bool = True) -> pd.DataFrame:
    """Every column but the timing ones, sorted by the key."""
    drop = [*harness.TIMING_COLUMNS, *([] if machine else ["machine"])]
    cols = [c for c in frame.columns if c not in drop]
    return frame[sorted(cols)].sort_values(list(harness.KEY)).reset_index(drop=True)


def _assert_same_table(frame: pd.DataFrame, expected: pd.DataFrame) -> None:
    # Same library, same poses, same order of operations: equal to the last bit. The
    # machine column too, as every worker runs on this host.
    pd.testing.assert_frame_equal(_stable(frame), _stable(expected), check_exact=True)


def _assert_same_traces(store: harness.ResultsStore, reference: harness.ResultsStore) -> None:
    traces, expected = store.load_traces(), reference.load_traces()
    assert traces.keys() == expected.keys() and len(traces) == 4  # closed_form on the path
    for key, trace in expected.items():
        np.testing.assert_array_equal(traces[key], trace)


def test_chunks_keep_order_scenarios_and_problem_groups(cells: list[harness.Cell]) -> None:
    chunks = harness.chunk_cells(cells, 3)
    assert [c for chunk in chunks for c in chunk] == cells
    for chunk in chunks:
        assert len(chunk) <= 3 and len({id(c.scenario) for c in chunk}) == 1
    # Each (scenario, problem) pair has 2 cells: never split over chunks.
    owner = {(c.scenario.name, c.problem.name): i for i, ch in enumerate(chunks) for c in ch}
    assert all(owner[(c.scenario.name, c.problem.name)] == i
               for i, ch in enumerate(chunks) for c in ch)
    assert [len(c) for c in harness.chunk_cells(cells, 1)] == [1] * len(cells)
    with pytest.raises(ValueError):
        harness.chunk_cells(cells, 0)
    # Registered scenarios and problems travel by name.
    payload = harness.CellChunk.of(chunks[0])
    assert payload.scenario == "thesis_snapshots" and payload.cells[0][0] == "min_sum"


def test_process_pool_gives_the_same_table_and_measures_again(cells: list[harness.Cell],
        tmp_path: Path, expected: pd.DataFrame, reference: harness.ResultsStore) -> None:
    store = harness.ResultsStore(tmp_path)
    frame = harness.run(cells, store, progress=False, executor="processes:2", chunk_size=3)
    _assert_same_table(frame, expected)
    _assert_same_table(store.load(), reference.load())
    _assert_same_traces(store, reference)
    # A finished run is not resumed: a second run measures every cell again, in a run of
    # its own, with the same reproducible columns.
    again = harness.run(cells, store, progress=False, executor="processes:2")
    pd.testing.assert_frame_equal(again, store.load())
    assert again["run"].nunique() == 1 and set(again["run"]).isdisjoint(set(frame["run"]))
    pd.testing.assert_frame_equal(_stable(again), _stable(frame), check_dtype=False,
                                  rtol=1e-5)  # the CSV keeps 6 significant digits
    assert not store.journal_path.exists()


def test_unregistered_scenario_goes_to_a_pool_pickled(tmp_path: Path) -> None:
    cells = harness.plan([TINY], [PROBLEMS["min_sum"], PROBLEMS["smoothed"]], ["closed_form"],
                         [harness.Setting()])
    here = harness.run(cells, harness.ResultsStore(tmp_path / "here"), progress=False,
                       isolate=False)
    pooled = harness.run(cells, harness.ResultsStore(tmp_path / "pool"), progress=False,
                         executor="processes:2")
    _assert_same_table(pooled, here)


def test_interrupted_executor_run_keeps_finished_chunks(cells: list[harness.Cell], tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    cells = cells[:8]
    real = harness.run_chunk
    chunks: list[int] = []

    def interrupted(chunk: harness.CellChunk) -> list[harness.CellResult]:
        if len(chunks) == 2:
            raise KeyboardInterrupt
        chunks.append(len(chunk.cells))
        return real(chunk)

    store = harness.ResultsStore(tmp_path)
    monkeypatch.setattr(harness, "run_chunk", interrupted)
    with pytest.raises(KeyboardInterrupt):
        harness.run(cells, store, progress=False, executor="inprocess", chunk_size=2)
    assert len(store.load()) == sum(chunks) == 4

    def counting(chunk: harness.CellChunk) -> list[harness.CellResult]:
        chunks.append(len(chunk.cells))
        return real(chunk)

    chunks.clear()
    monkeypatch.setattr(harness, "run_chunk", counting)
    frame = harness.run(cells, store, progress=False, executor="inprocess", chunk_size=2)
    assert sum(chunks) == 4 and len(frame) == 8


def test_failed_chunk_becomes_error_rows_and_the_run_goes_on(cells: list[harness.Cell],
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = harness.run_chunk
    calls: list[str] = []

    def failing(chunk: harness.CellChunk) -> list[harness.CellResult]:
        calls.append(chunk.cells[0][0])
        if len(calls) == 1:
            raise RuntimeError("worker lost")
        return real(chunk)

    monkeypatch.setattr(harness, "run_chunk", failing)
    frame = harness.run(cells[:6], harness.ResultsStore(tmp_path), progress=False,
                        executor="inprocess", chunk_size=2)
    assert list(frame["status"]) == ["error"] * 2 + ["ok"] * 4
    assert frame["message"].iloc[0] == "worker failed: RuntimeError: worker lost"
    assert len(calls) == 3  # every chunk ran once: the failure did not resend the rest


def test_dask_cluster_gives_the_same_table_and_measures_again(cells: list[harness.Cell],
        tmp_path: Path, expected: pd.DataFrame, reference: harness.ResultsStore,
        dask_client: Any) -> None:
    store = harness.ResultsStore(tmp_path)
    frame = harness.run(cells, store, progress=False, executor=dask_client)
    _assert_same_table(frame, expected)
    _assert_same_table(store.load(), reference.load())
    _assert_same_traces(store, reference)
    # Rows carry the label computed on the worker (all on this host here).
    labels = set(dask_client.run(harness.machine_label).values())
    assert set(frame["machine"]) <= labels
    assert harness.executor_machines(DaskExecutor(dask_client)) >= labels
    assert dask_client.status == "running"  # a client passed in is left open
    again = harness.run(cells, store, progress=False, executor=dask_client)
    pd.testing.assert_frame_equal(again, store.load())
    assert set(again["run"]).isdisjoint(set(frame["run"]))  # measured again
    pd.testing.assert_frame_equal(_stable(again), _stable(frame), check_dtype=False,
                                  rtol=1e-5)


def test_rows_of_cluster_machines_count_as_done(cells: list[harness.Cell], tmp_path: Path) -> None:
    store = harness.ResultsStore(tmp_path)
    run, resumed = store.start_run("an invocation", 2)
    assert not resumed
    worker = "worker-7 / x86_64 / 64 cores"
    store.append({**harness.base_row(cells[0]), "machine": worker, "run": run})
    # A row that came from elsewhere (no run of this database) never counts.
    store.append({**harness.base_row(cells[1]), "machine": worker})
    assert store.done() == set()
    assert store.done({worker}) == {cells[0].key} == store.done(run=run)
    assert store.start_run("an invocation", 2) == (run, True)  # interrupted: resumed
    store.finish_run(run)
    assert store.start_run("an invocation", 2)[1] is False  # finished: a new run


def test_command_line_executor_option(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    parser = build_parser()
    assert parser.parse_args(["run", "--executor", "processes:2"]).executor == "processes:2"
    assert parser.parse_args(["run"]).executor is None
    args = parser.parse_args(["--executor", "dask:tcp://10.0.0.1:8786", "run"])
    assert args.suite_executor == "dask:tcp://10.0.0.1:8786" and args.executor is None

    argv = ["--results", str(tmp_path), "run", "--scenario", "thesis_snapshots", "--problem",
            "min_sum", "--backend", "closed_form", "--settings", "default/cold", "--no-report",
            "--no-progress"]
    assert main([*argv, "--executor", "inprocess"]) == 0
    assert "1 cells in the selection" in capsys.readouterr().out
    assert len(harness.ResultsStore(tmp_path).load()) == 1

    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--executor", "dask"])
    assert exit_info.value.code == 2
    assert "DASK_SCHEDULER_ADDRESS" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*argv, "--executor", "threads"])
    assert "unknown executor 'threads'" in capsys.readouterr().err

    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # as if not installed
    with pytest.raises(SystemExit) as exit_info:
        main(["--executor", "dask:tcp://127.0.0.1:1", "--results", str(tmp_path)])
    assert exit_info.value.code == 2
    assert 'pip install "tension-opt[dask]"' in capsys.readouterr().err
