"""Results store of the benchmark: one tidy table and the tension traces, safe to interrupt.

Rows are kept in ``results.csv`` (and the tension traces of short trajectories in
``traces.npz``). Each finished cell is first appended to a journal flushed to disk;
:meth:`ResultsStore.consolidate` merges the journal into the table through temporary
files and atomic renames, so an interrupted run loses at most the cell in progress,
and a new run skips the cells already stored by this machine (:func:`machine_label`).
"""

from __future__ import annotations

import json
import os
import platform
import sys
from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from benchmarks.plan import KEY

__all__ = [
    "CONSOLIDATE_EVERY",
    "JOURNAL_FILE",
    "RESULTS_DIR",
    "RESULTS_FILE",
    "TRACES_FILE",
    "Key",
    "ResultsStore",
    "machine_label",
]

RESULTS_DIR = Path(__file__).resolve().parent / "results"
RESULTS_FILE = "results.csv"
TRACES_FILE = "traces.npz"
JOURNAL_FILE = "results.journal.jsonl"
#: Seconds between merges of the journal into the results table during a run.
CONSOLIDATE_EVERY = 30.0

Key = tuple[str, ...]


def machine_label() -> str:
    """Host, CPU, core count and Python of this machine: rows are reused only on it."""
    return (f"{platform.node()} / {platform.processor() or platform.machine()} / "
            f"{os.cpu_count()} cores / Python {sys.version.split()[0]}")


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
        """Add one cell's row (and trace, (N, m) in N) to the journal, flushed to disk."""
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
