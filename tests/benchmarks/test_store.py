"""Benchmark results store: concurrent runs, kills, unreadable files, honest exit codes.

The store is an SQLite database beside ``results.csv``; these tests start real processes
(writers of this file run as a script, and ``python -m benchmarks run``) and check that
row counts are exact and no row is torn.
"""

from __future__ import annotations

import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from benchmarks import harness
from benchmarks.cli import main
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from benchmarks.store import ResultsStore, StoreError

# The runs in subprocesses load the kernels from numba's disk cache, filled here first:
# their timeouts are for the runs, not for a cold compilation.
pytestmark = pytest.mark.usefixtures("compiled_kernels")

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / "benchmarks" / "results"
TRIALS = 3
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


# ------------------------------------------------------------------ writer processes
def _row(selection: str, chunk: int, index: int, pad: int) -> dict[str, Any]:
    """A fake row whose every field can be checked after the fact."""
    return {"machine": "writer", "scenario": selection, "problem": f"p{chunk}",
            "backend": f"b{index}", "setting": "default/cold", "status": "ok", "message": "",
            "chunk": chunk, "index": index, "value": chunk + index / 1000,
            "payload": f"{selection}/{chunk}/{index}/" + "x" * pad}


def _write(directories: str, selection: str, chunks: int, size: int, pad: int,
           export_every: int) -> None:
    """Into each of the ``|``-separated directories, once its file ``go`` exists: append
    ``chunks`` chunks of ``size`` rows, one transaction each, printing each commit."""
    trace = np.arange(12.0).reshape(3, 4)
    for directory in directories.split("|"):
        print("ready", flush=True)
        while not (Path(directory) / "go").exists():  # start with the other writer
            time.sleep(0.001)
        store = ResultsStore(directory)
        for chunk in range(chunks):
            store.append_many([(_row(selection, chunk, i, pad), trace) for i in range(size)])
            print(chunk, flush=True)
            if export_every and (chunk + 1) % export_every == 0:
                store.export()  # what used to lose rows: a merge while another run appends
        store.export()
        print("done", flush=True)


def _writer(directories: list[Path], selection: str, chunks: int, size: int, pad: int = 10,
            export_every: int = 0) -> subprocess.Popen[str]:
    command = [sys.executable, __file__, "|".join(map(str, directories)), selection,
               str(chunks), str(size), str(pad), str(export_every)]
    return subprocess.Popen(command, cwd=ROOT, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _lines_until(process: subprocess.Popen[str], last: str) -> list[str]:
    """Lines the process prints up to ``last`` (included)."""
    assert process.stdout is not None
    lines = []
    while not lines or lines[-1] != last:
        line = process.stdout.readline()
        assert line, f"the writer stopped: {process.communicate()[1]}"
        lines.append(line.strip())
    return lines


def _assert_whole(frame: pd.DataFrame, pad: int, size: int) -> None:
    """Every row equal to what was written; chunks all there or absent."""
    for row in frame.to_dict("records"):
        expected = _row(row["scenario"], int(row["chunk"]), int(row["index"]), pad)
        assert {k: row[k] for k in expected} == expected
    counts = frame.groupby(["scenario", "chunk"]).size()
    assert (counts == size).all(), counts[counts != size]


# ------------------------------------------------------------------ concurrency
def test_two_writers_at_once_lose_nothing(tmp_path: Path) -> None:
    trials = [tmp_path / str(trial) for trial in range(TRIALS)]
    writers = [_writer(trials, name, chunks=30, size=10, export_every=6)
               for name in ("alpha", "beta")]
    for directory in trials:
        for writer in writers:
            _lines_until(writer, "ready")
        directory.mkdir()
        (directory / "go").touch()
        for writer in writers:
            assert _lines_until(writer, "done") == [*map(str, range(30)), "done"]
        store = ResultsStore(directory)
        frame = store.load()
        assert len(frame) == 2 * 30 * 10
        _assert_whole(frame, pad=10, size=10)
        assert len(store.load_traces()) == 600
        # The last export holds every row too, and reads back whole.
        exported = pd.read_csv(store.results_path)
        assert len(exported) == 600 and exported["payload"].str.endswith("x" * 10).all()
        assert not list(directory.glob("*.tmp"))
    for writer in writers:
        assert writer.wait(timeout=60) == 0


def _selection(problems: list[str], backends: list[str]) -> list[str]:
    return ["--scenario", "thesis_snapshots", "thesis_trajectory", "--problem", *problems,
            "--backend", *backends, "--settings", "default/cold"]


def _cells(problems: list[str], backends: list[str]) -> set[tuple[str, ...]]:
    cells = harness.plan([SCENARIOS["thesis_snapshots"], SCENARIOS["thesis_trajectory"]],
                         [PROBLEMS[p] for p in problems], backends, [harness.Setting()])
    return {c.key for c in cells}


def _benchmarks(*args: str) -> subprocess.Popen[str]:
    """``python -m benchmarks ARGS`` in a session of its own (killed with its workers)."""
    return subprocess.Popen([sys.executable, "-m", "benchmarks", *args], cwd=ROOT, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def test_two_command_line_runs_at_once_lose_nothing(tmp_path: Path) -> None:
    # One trial here (each takes seconds); the writers above make three.
    selections = [(["min_sum", "min_norm", "pinv"], ["closed_form", "qpsolvers:daqp"]),
                  (["min_sum", "min_norm", "pinv"], ["scipy:highs", "cvxpy:CLARABEL"])]
    expected = set().union(*(_cells(*s) for s in selections))
    # A generous per-cell budget: a loaded machine must not turn a cell into time_limit.
    runs = [_benchmarks("run", *_selection(*s), "--results", str(tmp_path), "--no-progress",
                        "--time-limit", "120") for s in selections]
    for run in runs:
        _, err = run.communicate(timeout=300)
        assert run.returncode == 0, err
    frame = ResultsStore(tmp_path).load()
    assert len(frame) == len(expected) == 24
    assert {tuple(r) for r in frame[list(harness.KEY)].itertuples(index=False)} == expected
    assert frame["status"].isin(["ok", "unsupported"]).all()
    # The exported table holds every row and reads back whole; so does the report.
    fresh = tmp_path / "copy"
    fresh.mkdir()
    (fresh / "results.csv").write_bytes((tmp_path / "results.csv").read_bytes())
    assert len(ResultsStore(fresh).load()) == 24
    report = (tmp_path / "README.md").read_text()
    assert all(f"| {backend} |" in report for s in selections for backend in s[1])


# ------------------------------------------------------------------ kills
@pytest.mark.parametrize("trial", range(TRIALS))
def test_a_writer_killed_mid_chunk_leaves_whole_chunks(tmp_path: Path, trial: int) -> None:
    # Large chunks: the writer spends most of its time inside a transaction.
    size, pad = 400, 2000
    (tmp_path / "go").touch()
    writer = _writer([tmp_path], "kill", chunks=10_000, size=size, pad=pad)
    committed = _lines_until(writer, "1")[1:]
    time.sleep(random.uniform(0.0, 0.2))
    os.kill(writer.pid, signal.SIGKILL)
    writer.wait(timeout=60)
    store = ResultsStore(tmp_path)
    frame = store.load()
    assert len(frame) >= len(committed) * size and len(frame) % size == 0
    _assert_whole(frame, pad, size)
    with sqlite3.connect(store.database_path) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    # The store goes on: one more chunk, then an export of every row.
    store.append_many([(_row("after", 0, i, pad), None) for i in range(size)])
    assert len(store.export()) == len(frame) + size


def test_a_killed_run_resumes_with_exact_rows(tmp_path: Path) -> None:
    problems, backends = ["min_sum", "min_norm", "pinv"], ["closed_form", "scipy:highs",
                                                           "cvxpy:CLARABEL"]
    args = ["run", *_selection(problems, backends), "--results", str(tmp_path),
            "--no-progress", "--no-report"]
    run = _benchmarks(*args)
    store = ResultsStore(tmp_path)
    deadline = time.monotonic() + 120
    while not (store.database_path.exists() and len(ResultsStore(tmp_path).load()) >= 3):
        assert time.monotonic() < deadline and run.poll() is None
        time.sleep(0.05)
    os.killpg(run.pid, signal.SIGKILL)  # the run and its forked cell worker, at once
    run.wait(timeout=60)
    stored = ResultsStore(tmp_path).load()
    assert 3 <= len(stored) < 18 and stored["status"].isin(["ok", "unsupported"]).all()
    rerun = _benchmarks(*args)
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    frame = ResultsStore(tmp_path).load()
    assert len(frame) == 18 and not frame.duplicated(list(harness.KEY)).any()
    assert "18 cells in the selection, 18 rows stored" in out


# ------------------------------------------------------------------ import, upsert
def test_a_fresh_clone_imports_the_committed_csv_once(tmp_path: Path) -> None:
    for name in ("results.csv", "traces.npz"):
        (tmp_path / name).write_bytes((COMMITTED / name).read_bytes())
    store = ResultsStore(tmp_path)
    committed = pd.read_csv(COMMITTED / "results.csv", keep_default_na=False,
                            na_values=["", "nan", "NaN"])
    frame = store.load()
    assert store.database_path.exists() and len(frame) == len(committed)
    assert list(frame.columns) == list(committed.columns)
    with np.load(COMMITTED / "traces.npz") as data:
        traces = store.load_traces()
        assert len(traces) == len(data.files)
        for name in data.files:
            np.testing.assert_array_equal(traces[tuple(name.split("|"))], data[name])
    # The export gives the committed files back, byte for byte (and leaves them alone).
    dates = [(tmp_path / name).stat().st_mtime_ns for name in ("results.csv", "traces.npz")]
    store.export()
    for name, date in zip(("results.csv", "traces.npz"), dates, strict=True):
        assert (tmp_path / name).read_bytes() == (COMMITTED / name).read_bytes()
        assert (tmp_path / name).stat().st_mtime_ns == date
    # A row stored now stays: the CSV is not imported again over it.
    row = {**frame.iloc[0].to_dict(), "status": "error", "message": "measured again"}
    store.append(row)
    assert ResultsStore(tmp_path).load().iloc[0]["message"] == "measured again"


def test_a_changed_csv_is_merged_and_a_redo_replaces_in_place(tmp_path: Path) -> None:
    store = ResultsStore(tmp_path)
    store.append_many([(_row("s", 0, i, 1), None) for i in range(3)])
    store.export()
    # Measured again (--redo): one row per key, in its place, the latest values.
    store.append({**_row("s", 0, 1, 1), "value": -1.0})
    frame = ResultsStore(tmp_path).load()
    assert list(frame["index"]) == [0, 1, 2] and list(frame["value"]) == [0.0, -1.0, 0.002]
    # A CSV changed behind the database's back (a pull) is imported, its rows winning.
    store.export()
    table = pd.read_csv(store.results_path)
    table.loc[0, "status"] = "pulled"
    table.to_csv(store.results_path, index=False)
    assert list(ResultsStore(tmp_path).load()["status"]) == ["pulled", "ok", "ok"]


def test_a_journal_of_earlier_versions_is_imported(tmp_path: Path) -> None:
    lines = [json.dumps({"row": _row("j", 0, i, 1), "trace": [[1.0, 2.0]] if i else None})
             for i in range(2)]
    (tmp_path / "results.journal.jsonl").write_text("\n".join(lines) + '\n{"row": {"scen')
    store = ResultsStore(tmp_path)
    assert len(store.load()) == 2 and list(store.load_traces()) == [("j", "p0", "b1",
                                                                    "default/cold")]
    assert not store.journal_path.exists()


# ------------------------------------------------------------------ unreadable stores
def _committed_csv() -> bytes:
    return (COMMITTED / "results.csv").read_bytes()


@pytest.mark.parametrize("content", [
    pytest.param(_committed_csv()[: len(_committed_csv()) // 2], id="cut-in-half"),
    pytest.param(_committed_csv()[:1000] + b'x,"unterminated\n', id="cut-in-a-quoted-field"),
    pytest.param(_committed_csv().split(b"\n", 3)[0] + b"\n" + b"thesis,min_sum\n",
                 id="short-last-line"),
    pytest.param(bytes(random.Random(0).randrange(256) for _ in range(4000)), id="binary"),
    pytest.param(b"<html>not a table</html>\n", id="text"),
    pytest.param(b"", id="empty"),
])
def test_an_unreadable_csv_is_a_named_error(tmp_path: Path, content: bytes) -> None:
    (tmp_path / "results.csv").write_bytes(content)
    with pytest.raises(StoreError, match=r"results\.csv is not a readable results table") as info:
        ResultsStore(tmp_path).load()
    assert str(tmp_path / "results.csv") in str(info.value) and "delete it" in str(info.value)


def test_a_torn_csv_beside_a_database_is_an_error_not_a_row(tmp_path: Path) -> None:
    store = ResultsStore(tmp_path)
    store.append_many([(_row("s", 0, i, 1), None) for i in range(4)])
    store.export()
    data = store.results_path.read_bytes()
    store.results_path.write_bytes(data[: len(data) - 20])  # the last line cut
    with pytest.raises(StoreError, match="the database keeps the rows"):
        ResultsStore(tmp_path).load()
    store.results_path.unlink()  # the advised fix: the rows are written again
    assert len(ResultsStore(tmp_path).export()) == 4
    assert len(pd.read_csv(store.results_path)) == 4


def test_a_corrupt_database_is_a_named_error(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    store = ResultsStore(tmp_path)
    store.append(_row("s", 0, 0, 1))
    store.export()
    store.database_path.write_bytes(b"garbage" * 1000)
    with pytest.raises(StoreError, match="is not a readable results database") as info:
        ResultsStore(tmp_path).load()
    assert f"delete {store.database_path}" in str(info.value)
    args = ["run", "--scenario", "thesis_snapshots", "--problem", "min_sum", "--backend",
            "closed_form", "--settings", "default/cold", "--results", str(tmp_path),
            "--no-progress", "--no-report"]
    assert main(args) == 1
    assert str(store.database_path) in capsys.readouterr().err
    for suffix in ("", "-wal", "-shm"):  # the advised fix: rebuilt from the CSV
        Path(f"{store.database_path}{suffix}").unlink(missing_ok=True)
    assert main(args) == 0
    assert len(ResultsStore(tmp_path).load()) == 2


def _stored(directory: Path, rows: int = 6) -> ResultsStore:
    """A store of ``rows`` rows, exported, its write-ahead log folded into the file."""
    store = ResultsStore(directory)
    store.append_many([(_row("s", 0, i, 40), None) for i in range(rows)])
    store.export()
    with sqlite3.connect(store.database_path) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return store


def test_a_damaged_row_is_reported_as_corruption(tmp_path: Path) -> None:
    """Bytes of a stored row overwritten (text that is not UTF-8): the database is
    damaged, not the directory unwritable; the message names the file and the way
    out and does not quote the damaged row."""
    store = _stored(tmp_path)
    data = bytearray(store.database_path.read_bytes())
    at = data.index(b"s/0/3/xxxx")
    data[at + 6:at + 12] = b"\xff\xfe\xfd\xfc\xfb\xfa"
    store.database_path.write_bytes(bytes(data))
    with pytest.raises(StoreError) as info:
        ResultsStore(tmp_path).load()
    message = str(info.value)
    assert str(store.database_path) in message
    assert "damaged" in message and "move it aside" in message
    assert "writable" not in message and "locked" not in message
    assert "payload" not in message and "xxxx" not in message  # the row is not quoted
    # The way out: moved aside, the database is rebuilt from the exported table.
    store.database_path.rename(tmp_path / "damaged.sqlite")
    assert len(ResultsStore(tmp_path).load()) == 6


def test_a_database_locked_by_another_process_is_reported_as_locked(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    store = _stored(tmp_path)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sqlite3, sys, time\n"
         "c = sqlite3.connect(sys.argv[1], isolation_level=None)\n"
         "c.execute('BEGIN IMMEDIATE'); print('held', flush=True); time.sleep(60)",
         str(store.database_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        monkeypatch.setattr("benchmarks.store.BUSY_TIMEOUT", 0.3)
        with pytest.raises(StoreError) as info:
            ResultsStore(tmp_path).append(_row("s", 1, 0, 1))
    finally:
        holder.kill()
        holder.wait()
    message = str(info.value)
    assert str(store.database_path) in message and "locked" in message
    assert "another run" in message and "wait" in message and "stop it" in message
    assert "damaged" not in message and "writable" not in message
    ResultsStore(tmp_path).append(_row("s", 1, 0, 1))  # the lock gone, the write goes in
    assert len(ResultsStore(tmp_path).load()) == 7


def _assert_permissions(message: str, path: Path) -> None:
    assert str(path) in message and "not writable" in message and "--results" in message
    assert "damaged" not in message and "locked" not in message


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                    reason="running as root: file permissions are not enforced, so a "
                           "read-only directory cannot be made; "
                           "test_an_unwritable_database_simulated covers the message")
def test_a_read_only_directory_is_reported_as_permissions(tmp_path: Path) -> None:
    store = _stored(tmp_path)
    for path in (store.database_path, tmp_path):
        path.chmod(0o555 if path.is_dir() else 0o444)
    try:
        with pytest.raises(StoreError) as info:
            ResultsStore(tmp_path).append(_row("s", 1, 0, 1))
    finally:
        for path in (store.database_path, tmp_path):
            path.chmod(0o755 if path.is_dir() else 0o644)
    _assert_permissions(str(info.value), store.database_path)


def test_an_unwritable_database_simulated(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """SQLite's own refusal to write (a connection opened read-only stands in for a
    directory or file without write permission), and the system's refusal to write
    an exported file: both are permission problems, named as such."""
    store = _stored(tmp_path)
    connect = sqlite3.connect

    def read_only(path: Any, *args: Any, **kwargs: Any) -> sqlite3.Connection:
        return connect(f"file:{path}?mode=ro", *args, uri=True, **kwargs)

    with monkeypatch.context() as patched:
        patched.setattr(sqlite3, "connect", read_only)
        with pytest.raises(StoreError) as info:
            ResultsStore(tmp_path).append(_row("s", 1, 0, 1))
    _assert_permissions(str(info.value), store.database_path)

    def refused(path: Path, *args: Any, **kwargs: Any) -> str:
        raise PermissionError(13, "Permission denied", str(path))

    store.append(_row("s", 1, 0, 1))  # a new row: the table is written again
    monkeypatch.setattr("benchmarks.store.replace_file", refused)
    with pytest.raises(StoreError) as info:
        ResultsStore(tmp_path).export()
    _assert_permissions(str(info.value), store.results_path)


# ------------------------------------------------------------------ exit codes
def _untouched(directory: Path) -> dict[str, bytes]:
    (directory / "README.md").write_text("report\n")
    (directory / "results.csv").write_bytes(_committed_csv())
    return {p.name: p.read_bytes() for p in directory.iterdir()}


def test_a_backend_not_installed_exits_2_before_the_run(tmp_path: Path) -> None:
    before = _untouched(tmp_path)
    done = subprocess.run([sys.executable, "-m", "benchmarks", "run", "--backend", "gurobi",
                           "--results", str(tmp_path), "--no-progress"], cwd=ROOT, env=ENV,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    assert "unknown backend 'gurobi'; installed backends: closed_form" in done.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # nothing stored


@pytest.mark.parametrize("args", [
    ["--backend", "closed_form", "qpsolvers:no_such_solver"],
    ["--backend", "closed_form:suffix"],
    ["--scenario", "no_such_scenario"],
    ["--problem", "no_such_problem"],
    ["--settings", "ultra"],
])
def test_what_cannot_run_exits_2_before_the_run(tmp_path: Path, args: list[str],
                                               capsys: pytest.CaptureFixture[str]) -> None:
    before = _untouched(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["run", *args, "--results", str(tmp_path), "--no-progress"])
    assert info.value.code == 2
    assert args[-1].split(":")[-1] in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


if __name__ == "__main__":  # a writer process of the tests above
    _directories, _selection_name, *_numbers = sys.argv[1:]
    _write(_directories, _selection_name, *map(int, _numbers))
