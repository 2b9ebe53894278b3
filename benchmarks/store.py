"""Results store of the benchmark: an SQLite database, exported as a tidy table and traces.

Rows live in ``results.sqlite`` in the results directory (standard library
:mod:`sqlite3`, write-ahead log, so it needs a local file system). The committed
artefacts, ``results.csv`` and ``traces.npz``, are exports of it, each written to a
temporary file and renamed over the old one.

- Table ``results``: one row per cell, ``UNIQUE (scenario, problem, backend, setting)``
  (the scenario names a seeded pose set, the same on every machine); columns
  ``machine`` (who measured it), ``run`` (the run that measured it), ``row`` (the whole
  row as JSON, column order kept) and ``trace`` (tensions (N, m) as float32 ``.npy``
  bytes, or NULL).
- Table ``runs``: the runs made with this database: ``id`` (a random hex id, stamped on
  their rows with the time each was measured), ``invocation`` (a key of the cells and
  settings asked for, :func:`invocation_key`), ``machine``, ``started``, ``finished``
  (NULL while it runs, or if it was interrupted). A run resumes only an *interrupted*
  run of the *same invocation* on the *same machine* (:meth:`ResultsStore.start_run`):
  rows that came with the clone, or that a finished run left, are measured again, so a
  plain run always measures the machine it runs on.
- Writes: one ``BEGIN IMMEDIATE`` transaction per chunk of rows, an upsert on the key
  (a row measured again replaces the old one in place). Concurrent runs wait for each
  other's transaction (busy timeout :data:`BUSY_TIMEOUT`); a process killed at any
  instant leaves whole chunks only.
- Table ``meta``: the SHA-256 of the CSV and traces last imported or exported. A
  results directory with a CSV the database has not seen (a fresh clone, or a CSV
  changed since the last export) imports it, its rows winning; so does a journal
  ``results.journal.jsonl`` left by an interrupted run of earlier versions.

A store that cannot be read or written raises :class:`StoreError` naming the file, what
is wrong (a damaged database, a lock held by another run, a file or directory that
cannot be written) and the way out.
"""

from __future__ import annotations

import contextlib
import csv
import datetime
import hashlib
import io
import json
import os
import platform
import sqlite3
import sys
import threading
import time
import uuid
from collections.abc import Collection, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from benchmarks.plan import KEY
from benchmarks.store_files import (
    check_csv,
    database_problem,
    digest,
    error_text,
    parse_journal,
    replace_file,
    same_traces,
)

__all__ = [
    "BUSY_TIMEOUT",
    "CONSOLIDATE_EVERY",
    "DATABASE_FILE",
    "JOURNAL_FILE",
    "RESULTS_DIR",
    "RESULTS_FILE",
    "TRACES_FILE",
    "Entry",
    "Key",
    "ResultsStore",
    "StoreError",
    "invocation_key",
    "machine_label",
    "utc_now",
]

RESULTS_DIR = Path(__file__).resolve().parent / "results"
RESULTS_FILE = "results.csv"
TRACES_FILE = "traces.npz"
DATABASE_FILE = "results.sqlite"
#: Journal of earlier versions of the store; imported once if a run left one behind.
JOURNAL_FILE = "results.journal.jsonl"
#: Seconds between exports of the table during a run.
CONSOLIDATE_EVERY = 30.0
#: Seconds a write waits for another process's transaction before giving up.
BUSY_TIMEOUT = 600.0

Key = tuple[str, ...]
#: One cell's row and its trace (N, m) (N) or None.
Entry = tuple[dict[str, Any], NDArray | None]

_SCHEMA_VERSION = 2
_COLUMNS = ", ".join(KEY)
_SCHEMA = (
    f"""CREATE TABLE IF NOT EXISTS results (
        {", ".join(f"{k} TEXT NOT NULL" for k in KEY)},
        machine TEXT NOT NULL,
        row TEXT NOT NULL,
        trace BLOB,
        run TEXT,
        UNIQUE ({_COLUMNS}))""",
    "CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT)",
    """CREATE TABLE IF NOT EXISTS runs (id TEXT PRIMARY KEY, invocation TEXT NOT NULL,
        machine TEXT NOT NULL, started TEXT NOT NULL, finished TEXT, cells INTEGER)""",
    f"""CREATE TABLE IF NOT EXISTS reference (
        {", ".join(f"{k} TEXT NOT NULL" for k in KEY)}, row TEXT NOT NULL,
        UNIQUE ({_COLUMNS}))""",
)
# A row measured again replaces the old one in place; a row without a trace keeps the
# trace stored before.
_UPSERT = (f"INSERT INTO results ({_COLUMNS}, machine, run, row, trace) "
           f"VALUES ({', '.join('?' * (len(KEY) + 4))}) ON CONFLICT ({_COLUMNS}) DO UPDATE "
           "SET machine = excluded.machine, run = excluded.run, row = excluded.row, "
           "trace = COALESCE(excluded.trace, results.trace)")
_KEEP_REFERENCE = (f"INSERT INTO reference ({_COLUMNS}, row) VALUES "
                   f"({', '.join('?' * (len(KEY) + 1))}) ON CONFLICT ({_COLUMNS}) DO UPDATE "
                   "SET row = excluded.row")
_SET_TRACE = f"UPDATE results SET trace = ? WHERE ({_COLUMNS}) = ({', '.join('?' * len(KEY))})"
_SET_META = ("INSERT INTO meta (name, value) VALUES (?, ?) "
             "ON CONFLICT (name) DO UPDATE SET value = excluded.value")

#: Connection holding the write lock of a database in this thread (see
#: :meth:`ResultsStore.exclusive`), by (database path, thread).
_HELD: dict[tuple[str, int], sqlite3.Connection] = {}


class StoreError(RuntimeError):
    """The results store cannot be read or written; the message names the file and the fix."""


def machine_label() -> str:
    """Host, CPU, core count and Python of this machine (a label of where rows were
    measured; two virtual machines may share it, so rows are resumed by run, not by it)."""
    return (f"{platform.node()} / {platform.processor() or platform.machine()} / "
            f"{os.cpu_count()} cores / Python {sys.version.split()[0]}")


def utc_now() -> str:
    """The time now, UTC, to the second, ISO 8601 (e.g. ``2026-01-02T03:04:05Z``)."""
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def invocation_key(keys: Sequence[tuple[str, ...]], **settings: object) -> str:
    """A key of one invocation: its cell keys (in any order) and settings such as the
    time limit. Two runs with the same key are the same invocation (one may resume
    the other)."""
    text = json.dumps([sorted(map(list, keys)), sorted((k, repr(v)) for k, v in
                                                       settings.items())])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class ResultsStore:
    """Results table and tension traces of one directory, transactional.

    Rows are kept in ``results.sqlite``; :meth:`export` writes ``results.csv`` and
    ``traces.npz`` from it. See the module's documentation for the schema and the
    guarantees (concurrent runs, kills, imports of an existing CSV).

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
        self.database_path = self.directory / DATABASE_FILE
        self._synced = False

    # reading
    def read(self) -> tuple[dict[Key, dict[str, Any]], dict[Key, NDArray]]:
        """Rows and traces by key (scenario, problem, backend, setting), in stored order."""
        with self._reading() as conn:
            return ({}, {}) if conn is None else self._read_all(conn)

    def load(self) -> pd.DataFrame:
        """The stored table (empty, with the key columns, if there is none)."""
        with self._reading() as conn:
            texts = [] if conn is None else conn.execute(
                "SELECT row FROM results ORDER BY rowid").fetchall()
        rows = (self._decode_row(text) for (text,) in texts)
        return _frame({_key(row): row for row in rows})

    def load_traces(self) -> dict[Key, NDArray]:
        """Stored traces by key, each of shape (N, m) (N)."""
        with self._reading() as conn:
            found = [] if conn is None else conn.execute(
                f"SELECT {_COLUMNS}, trace FROM results WHERE trace IS NOT NULL "
                "ORDER BY rowid").fetchall()
        return {tuple(item[:-1]): self._decode_trace(item[-1]) for item in found}

    def done(self, machines: Collection[str] | None = None, run: str | None = None
             ) -> set[Key]:
        """Keys of rows that a new run need not measure again.

        Parameters
        ----------
        machines : collection of str, optional
            Machine labels (see :func:`machine_label`) whose rows count, e.g. the
            workers of a cluster. Default: this machine only.
        run : str, optional
            A run being resumed: only its own rows count (what :func:`~benchmarks.harness.run`
            uses). Without it, the rows measured by runs of this database on
            ``machines``: rows imported from a CSV (a fresh clone's) never count.
        """
        here = {machine_label()} if machines is None else set(machines)
        with self._reading() as conn:
            if conn is None:
                return set()
            if run is not None:
                found = conn.execute(f"SELECT {_COLUMNS} FROM results WHERE run = ?",
                                     (run,)).fetchall()
                return {tuple(item) for item in found}
            found = conn.execute(f"SELECT {_COLUMNS}, machine FROM results WHERE run IN "
                                 "(SELECT id FROM runs)").fetchall()
        return {tuple(item[:-1]) for item in found if item[-1] in here}

    # runs
    def start_run(self, invocation: str, cells: int, resume: bool = True) -> tuple[str, bool]:
        """Begin a run of ``invocation`` (:func:`invocation_key`) over ``cells`` cells.

        Returns
        -------
        run : str
            Its id: that of the last interrupted run of the same invocation on this
            machine when ``resume`` (it goes on), else a new one.
        resumed : bool
        """
        with self._writing() as conn:
            if resume:
                found = conn.execute(
                    "SELECT id FROM runs WHERE invocation = ? AND machine = ? AND finished IS "
                    "NULL ORDER BY started DESC, rowid DESC LIMIT 1",
                    (invocation, machine_label())).fetchone()
                if found is not None:
                    return str(found[0]), True
            run = uuid.uuid4().hex[:12]
            conn.execute("INSERT INTO runs (id, invocation, machine, started, cells) "
                         "VALUES (?, ?, ?, ?, ?)",
                         (run, invocation, machine_label(), utc_now(), int(cells)))
        return run, False

    def finish_run(self, run: str) -> None:
        """Mark ``run`` finished: a later run of its invocation starts afresh."""
        with self._writing() as conn:
            conn.execute("UPDATE runs SET finished = ? WHERE id = ?", (utc_now(), run))

    def runs(self) -> pd.DataFrame:
        """The runs made with this database: id, invocation, machine, started, finished,
        cells (in order)."""
        columns = ["id", "invocation", "machine", "started", "finished", "cells"]
        with self._reading() as conn:
            found = [] if conn is None else conn.execute(
                f"SELECT {', '.join(columns)} FROM runs ORDER BY rowid").fetchall()
        return pd.DataFrame(found, columns=columns)

    def reference(self) -> pd.DataFrame:
        """The rows imported from a results CSV (measured elsewhere, or before this
        database), as imported, even after this machine measured the same cells."""
        with self._reading() as conn:
            texts = [] if conn is None else conn.execute(
                "SELECT row FROM reference ORDER BY rowid").fetchall()
        return _frame({_key(row): row for row in (self._decode_row(t) for (t,) in texts)})

    # writing
    def append(self, row: dict[str, Any], trace: NDArray | None = None) -> None:
        """Store one cell's row (and trace, (N, m) in N), replacing a row of the same key."""
        self.append_many([(row, trace)])

    def append_many(self, entries: Iterable[Entry]) -> None:
        """Store a chunk of rows (and traces) in one transaction: all of them or none.

        Parameters
        ----------
        entries : iterable of (dict, ndarray or None)
            Rows with their traces (N, m) (N); a row replaces the stored row of its key,
            and keeps the stored trace if it comes without one.
        """
        params = [_params(row, trace) for row, trace in entries]
        if params:
            with self._writing() as conn:
                conn.executemany(_UPSERT, params)

    def export(self) -> pd.DataFrame:
        """Write ``results.csv`` and ``traces.npz`` from the database; return the table.

        Each file is written to a temporary file and renamed over the old one, under the
        store's write lock, so concurrent exports never mix and a kill leaves the old or
        the new file. A file that already holds the same table or traces is left
        untouched, and nothing is written while the store holds no row.
        """
        if not self._sync():
            return _frame({})
        with self._writing() as conn:
            rows, traces = self._read_all(conn)
            frame = _frame(rows)
            if rows:
                data = frame.to_csv(index=False, float_format="%.6g").encode()
                conn.execute(_SET_META, (RESULTS_FILE, replace_file(self.results_path, data)))
            if traces:
                buffer = io.BytesIO()
                # Any: a dict unpacked into **kwds would otherwise have to fit allow_pickle.
                arrays: dict[str, Any] = {"|".join(k): v for k, v in traces.items()}
                np.savez_compressed(buffer, **arrays)
                digest = replace_file(self.traces_path, buffer.getvalue(),
                                  lambda old: same_traces(old, arrays))
                conn.execute(_SET_META, (TRACES_FILE, digest))
        return frame

    def consolidate(self) -> pd.DataFrame:
        """Same as :meth:`export` (the name of earlier versions)."""
        return self.export()

    @contextlib.contextmanager
    def exclusive(self) -> Iterator[None]:
        """Hold the store's write lock: other processes' writes and exports wait.

        Inside, every store of this directory in this thread reads and writes through the
        held transaction, so e.g. a report written there sees what was just exported.
        """
        if _lock_name(self.database_path) in _HELD:
            yield
            return
        with self._writing() as conn:
            _HELD[_lock_name(self.database_path)] = conn
            try:
                yield
            finally:
                del _HELD[_lock_name(self.database_path)]

    # connections
    @contextlib.contextmanager
    def _reading(self) -> Iterator[sqlite3.Connection | None]:
        """A connection to read from, or None if nothing was ever stored here."""
        with self._errors():
            held = _HELD.get(_lock_name(self.database_path))
            if held is not None:
                self._sync()
                yield held
            elif not self._sync():
                yield None
            else:
                with contextlib.closing(_connect(self.database_path)) as conn:
                    yield conn

    @contextlib.contextmanager
    def _writing(self) -> Iterator[sqlite3.Connection]:
        """A connection inside a write transaction, committed at the end (else rolled back)."""
        with self._errors():
            held = _HELD.get(_lock_name(self.database_path))
            if held is not None:
                self._sync()
                yield held
                return
            self.directory.mkdir(parents=True, exist_ok=True)
            self._sync(create=True)
            with contextlib.closing(_connect(self.database_path)) as conn, _transaction(conn):
                yield conn

    def _sync(self, create: bool = False) -> bool:
        """Make the database current with the CSV, traces and journal beside it, once.

        Returns whether there is a database (False: nothing stored and ``create`` false).
        """
        if self._synced:
            return True
        held = _HELD.get(_lock_name(self.database_path))
        if held is not None:
            with self._errors():
                self._import(held)
            self._synced = True
            return True
        sources = (self.results_path, self.traces_path, self.journal_path)
        if not (create or self.database_path.exists() or any(p.exists() for p in sources)):
            return False
        with self._errors(), contextlib.closing(_connect(self.database_path)) as conn:
            if self._stale(conn):
                with _transaction(conn):
                    journal = self._import(conn)
                if journal:  # merged and committed: the rows are in the database now
                    self.journal_path.unlink(missing_ok=True)
        self._synced = True
        return True

    def _stale(self, conn: sqlite3.Connection) -> bool:
        """Whether the database lacks the schema or a CSV, traces or journal it has not seen."""
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if version > _SCHEMA_VERSION:
            raise StoreError(f"{self.database_path} was written by a newer version of the "
                             "benchmarks; update them, or delete the file to rebuild it from "
                             f"{self.results_path}")
        if version < _SCHEMA_VERSION:
            return True
        seen = dict(conn.execute("SELECT name, value FROM meta").fetchall())
        return any(path.exists() and digest(path.read_bytes()) != seen.get(path.name)
                   for path in (self.results_path, self.traces_path, self.journal_path))

    def _import(self, conn: sqlite3.Connection) -> bool:
        """Create the schema and import the files not seen yet (within a write transaction).

        Returns whether a journal was imported.
        """
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        fresh = version < _SCHEMA_VERSION
        if fresh:
            for statement in _SCHEMA:
                conn.execute(statement)
            columns = {c[1] for c in conn.execute("PRAGMA table_info(results)").fetchall()}
            if "run" not in columns:  # a database of schema 1
                conn.execute("ALTER TABLE results ADD COLUMN run TEXT")
            conn.execute(f"PRAGMA user_version = {_SCHEMA_VERSION}")
        seen = dict(conn.execute("SELECT name, value FROM meta").fetchall())
        journal = False
        for path in (self.results_path, self.traces_path, self.journal_path):
            data = path.read_bytes() if path.exists() else None
            if data is None or digest(data) == seen.get(path.name):
                continue
            if path == self.results_path:
                rows = self._parse_csv(data, fresh)
                conn.executemany(_UPSERT, [_params(row, None) for row in rows])
                conn.executemany(_KEEP_REFERENCE, [
                    (*_key(row), json.dumps(row, default=_json_default)) for row in rows])
            elif path == self.traces_path:
                traces = self._parse_traces(data, fresh)
                conn.executemany(_SET_TRACE, [(_encode_trace(v), *k) for k, v in traces.items()])
            else:
                conn.executemany(_UPSERT, [_params(*e) for e in parse_journal(data)])
                journal = True
            conn.execute(_SET_META, (path.name, digest(data)))
        return journal

    def _read_all(self, conn: sqlite3.Connection,
                  ) -> tuple[dict[Key, dict[str, Any]], dict[Key, NDArray]]:
        rows: dict[Key, dict[str, Any]] = {}
        traces: dict[Key, NDArray] = {}
        for text, blob in conn.execute("SELECT row, trace FROM results ORDER BY rowid"):
            row = self._decode_row(text)
            rows[_key(row)] = row
            if blob is not None:
                traces[_key(row)] = self._decode_trace(blob)
        return rows, traces

    # errors and decoding
    def _recovery(self) -> str:
        return (f"delete {self.database_path} (with its -wal and -shm files if any) or move "
                f"it aside, and run again: it is rebuilt from {self.results_path}, which "
                "holds the rows of every finished run; rows measured since are run again")

    @contextlib.contextmanager
    def _errors(self) -> Iterator[None]:
        """Turn sqlite3's errors, and a refused write of a file, into :class:`StoreError`
        saying which problem it is (damage, a lock, permissions), the file and the fix."""
        try:
            yield
        except (sqlite3.DatabaseError, PermissionError) as exc:
            raise self._problem(exc) from exc

    def _problem(self, exc: sqlite3.DatabaseError | PermissionError) -> StoreError:
        db, what, problem = self.database_path, error_text(exc), database_problem(exc)
        if problem == "corrupt":
            return StoreError(f"{db} is not a readable results database: it is damaged "
                              f"({what}); {self._recovery()}")
        if problem == "locked":
            return StoreError(f"{db} is locked: another run is writing it (waited "
                              f"{BUSY_TIMEOUT:g} s: {what}); wait for that run to finish, "
                              "or stop it, and run again")
        if problem == "permissions":
            name = getattr(exc, "filename", None) or db
            return StoreError(f"cannot write {name} ({what}): the directory {self.directory} "
                              "or the file is not writable; make them writable, or choose "
                              "another results directory (--results DIR)")
        return StoreError(f"cannot use the results database {db} ({what}); run again once "
                          f"that is fixed (SQLite needs a local file system with free space)")

    def _decode_row(self, text: str) -> dict[str, Any]:
        try:
            row = json.loads(text)
            _key(row)
        except (ValueError, TypeError, KeyError) as exc:
            raise StoreError(f"{self.database_path} is damaged: it holds a broken row "
                             f"({exc}); {self._recovery()}") from exc
        return dict(row)

    def _decode_trace(self, blob: bytes) -> NDArray:
        try:
            return np.load(io.BytesIO(blob), allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise StoreError(f"{self.database_path} is damaged: it holds a broken trace "
                             f"({exc}); {self._recovery()}") from exc

    def _file_error(self, path: Path, what: str, exc: Exception, fresh: bool) -> StoreError:
        keep = ("a run then starts from an empty table" if fresh
                else "the database keeps the rows and the next run writes it again")
        return StoreError(f"{path} is not a readable {what} ({exc}); restore it (the "
                          f"committed copy) or delete it: {keep}")

    def _parse_csv(self, data: bytes, fresh: bool) -> list[dict[str, Any]]:
        """Rows of a results CSV, checked whole: a cut or garbled file raises StoreError."""
        try:
            text = data.decode("utf-8")
            check_csv(text)
            frame = pd.read_csv(io.StringIO(text), keep_default_na=False,
                                na_values=["", "nan", "NaN"])
        except (UnicodeDecodeError, csv.Error, ValueError) as exc:
            raise self._file_error(self.results_path, "results table", exc, fresh) from exc
        return frame.to_dict("records")

    def _parse_traces(self, data: bytes, fresh: bool) -> dict[Key, NDArray]:
        try:
            with np.load(io.BytesIO(data), allow_pickle=False) as found:
                return {tuple(k.split("|")): found[k] for k in found.files}
        except Exception as exc:  # zipfile, zlib and numpy each raise their own errors
            raise self._file_error(self.traces_path, "traces archive", exc, fresh) from exc


def _connect(path: Path) -> sqlite3.Connection:
    # Autocommit mode: transactions are explicit (see _transaction).
    conn = sqlite3.connect(path, timeout=BUSY_TIMEOUT, isolation_level=None)
    conn.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT * 1000)}")
    # Switching to WAL needs the file to itself for a moment, and SQLite answers
    # "locked" at once, without the busy timeout, while another process holds it.
    deadline, delay = time.monotonic() + BUSY_TIMEOUT, 0.001
    while True:
        try:
            conn.execute("PRAGMA journal_mode = WAL")
            break
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                conn.close()
                raise
            time.sleep(delay)
            delay = min(2 * delay, 0.1)
    conn.execute("PRAGMA synchronous = FULL")  # a committed chunk survives a power cut
    return conn


@contextlib.contextmanager
def _transaction(conn: sqlite3.Connection) -> Iterator[None]:
    """``BEGIN IMMEDIATE`` (takes the write lock at once) ... ``COMMIT``, else rollback."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        yield
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


def _lock_name(path: Path) -> tuple[str, int]:
    return os.path.realpath(path), threading.get_ident()


def _key(row: dict[str, Any]) -> Key:
    return tuple(str(row[k]) for k in KEY)


def _params(row: dict[str, Any], trace: NDArray | None) -> tuple[Any, ...]:
    """The upsert's parameters of one row."""
    run = row.get("run")
    return (*_key(row), str(row.get("machine", "")),
            None if run is None or (isinstance(run, float) and np.isnan(run)) else str(run),
            json.dumps(row, default=_json_default), _encode_trace(trace))


def _encode_trace(trace: NDArray | None) -> bytes | None:
    """A trace as ``.npy`` bytes of float32 rounded to 1e-3 (N), as the report plots it."""
    if trace is None:
        return None
    buffer = io.BytesIO()
    np.save(buffer, np.round(np.asarray(trace, dtype=float), 3).astype(np.float32),
            allow_pickle=False)
    return buffer.getvalue()


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
