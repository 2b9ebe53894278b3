"""The files of the results store: checks of a results CSV, the journal of earlier
versions, atomic writes, and what an error of the database stands for
(:mod:`benchmarks.store` keeps the rows in SQLite)."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from benchmarks.plan import KEY

__all__ = ["check_csv", "database_problem", "digest", "error_text", "parse_journal",
           "replace_file", "same_traces"]

#: SQLite's primary result codes by the problem they stand for.
_PROBLEM_CODES = {
    "corrupt": {sqlite3.SQLITE_CORRUPT, sqlite3.SQLITE_NOTADB},
    "locked": {sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED},
    "permissions": {sqlite3.SQLITE_READONLY, sqlite3.SQLITE_PERM, sqlite3.SQLITE_CANTOPEN,
                    sqlite3.SQLITE_AUTH},
}
#: The same told by the message, for errors that carry no code (the sqlite3 module's own,
#: such as a stored text that is not UTF-8).
_PROBLEM_WORDS = {
    "corrupt": ("could not decode", "malformed", "not a database", "corrupt"),
    "locked": ("locked", "busy"),
    "permissions": ("readonly", "read-only", "unable to open", "permission"),
}


def database_problem(exc: BaseException) -> str:
    """What an error of the results database stands for: ``"corrupt"`` (the file is
    damaged), ``"locked"`` (another connection holds the write lock), ``"permissions"``
    (the file or its directory cannot be written) or ``"other"``."""
    if isinstance(exc, PermissionError):
        return "permissions"
    code = getattr(exc, "sqlite_errorcode", None)
    text = str(exc).lower()
    for problem, codes in _PROBLEM_CODES.items():
        if code is not None and code & 0xFF in codes:
            return problem
    for problem, words in _PROBLEM_WORDS.items():
        if any(word in text for word in words):
            return problem
    if type(exc) is sqlite3.DatabaseError:  # SQLite's own "not a database" family
        return "corrupt"
    return "other"


def error_text(exc: BaseException) -> str:
    """The error's message without the stored data it may quote (a row that could not be
    decoded is quoted whole by the sqlite3 module)."""
    text = str(exc)
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
    return text.split(" with text ", 1)[0]


def check_csv(text: str) -> None:
    """Raise ValueError unless ``text`` is a whole table with the key columns in each row."""
    if "\x00" in text:
        raise ValueError("binary data")
    if not text:
        raise ValueError("the file is empty")
    if not text.endswith("\n"):
        raise ValueError("the last line is cut: the file does not end with a line end")
    reader = csv.reader(io.StringIO(text), strict=True)
    header = next(reader, [])
    missing = [k for k in KEY if k not in header]
    if missing:
        raise ValueError(f"no column {missing[0]!r} in the header")
    places = [header.index(k) for k in KEY]
    for record in reader:
        if not record:  # a blank line, skipped by pandas too
            continue
        if len(record) != len(header):
            raise ValueError(f"line {reader.line_num} has {len(record)} fields, "
                             f"the header {len(header)}")
        if not all(record[i] for i in places):
            raise ValueError(f"line {reader.line_num} lacks a key field {list(KEY)}")


def parse_journal(data: bytes) -> list[tuple[dict[str, Any], NDArray | None]]:
    """Entries of a journal of earlier versions; a torn last line is ignored."""
    entries: list[tuple[dict[str, Any], NDArray | None]] = []
    for line in data.decode("utf-8", errors="replace").splitlines():
        try:
            entry = json.loads(line)
            tuple(str(entry["row"][k]) for k in KEY)
        except (ValueError, TypeError, KeyError):  # torn write of an interrupted run
            continue
        trace = entry.get("trace")
        entries.append((entry["row"], None if trace is None else np.asarray(trace, float)))
    return entries


def replace_file(path: Path, data: bytes,
             unchanged: Callable[[bytes], bool] | None = None) -> str:
    """Write ``data`` to ``path`` through a temporary file and a rename; return its digest.

    A file already holding ``data`` (or of which ``unchanged`` says so) is left as it is.
    """
    old = path.read_bytes() if path.exists() else None
    if old is not None and (old == data or (unchanged is not None and unchanged(old))):
        return digest(old)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return digest(data)


def same_traces(data: bytes, arrays: dict[str, NDArray]) -> bool:
    """Whether an ``.npz`` archive holds exactly ``arrays`` (its zip dates may differ)."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as found:
            return set(found.files) == set(arrays) and all(
                np.array_equal(found[k], v, equal_nan=True) for k, v in arrays.items())
    except Exception:  # not an archive: it is replaced
        return False


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()
