"""Compiled code that a source change made stale, removed before numba loads it.

numba's disk cache (``cache=True``) keeps the machine code of a compiled function
beside its source file and trusts it while that one file keeps its modification time
and size. A kernel also carries the machine code of the compiled functions it calls
or inlines from other modules, and the module constants it reads (tolerances, codes),
frozen when it was compiled. After a change to one of those modules alone (a ``git
pull`` into an editable install, a local edit), numba would load the kernel's old
machine code and answer with the old arithmetic, silently.

:func:`guard` runs when ``tension_opt`` or ``catenary`` is imported, before any
kernel is loaded. It keeps, beside the package's own ``__pycache__``, the modification
time and size of every module of the packages; when one changed, it finds each module
with compiled functions whose imports (direct or not, within the packages) reach a
changed module, and deletes that module's cache files, so that numba compiles it
again. An unchanged tree costs one ``stat`` per module. Only caches numba keeps beside
the sources (``__pycache__``) or under ``NUMBA_CACHE_DIR`` are handled: a package
installed read-only changes only by reinstalling, which gives every file a new time.
Standard library only: numba is not imported here.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = ["STAMP_NAME", "guard", "import_closure", "stale_modules"]

#: The record of the sources, in the ``__pycache__`` of the guarded package.
STAMP_NAME = "compiled-sources.json"
#: The packages this process has checked.
_GUARDED: set[str] = set()


def guard(package: str, roots: Mapping[str, Path]) -> list[str]:
    """Delete the stale numba caches of ``package``'s modules (once per process).

    Parameters
    ----------
    package : str
        The package whose compiled modules are checked, one of ``roots``.
    roots : mapping of str to Path
        The directory of each package whose modules those may import (the package
        included).

    Returns
    -------
    list of str
        The modules whose caches were deleted (empty when nothing changed, the tree
        is not writable or this process already checked).
    """
    if package in _GUARDED:
        return []
    _GUARDED.add(package)
    try:
        return _guard(package, roots)
    except OSError:  # a tree or cache that cannot be read or written: numba decides
        return []


def _guard(package: str, roots: Mapping[str, Path]) -> list[str]:
    """:func:`guard` without its once-per-process and error handling."""
    files = _modules(roots)
    stamps = {name: _stamp(path) for name, path in files.items()}
    record = roots[package] / "__pycache__" / STAMP_NAME
    try:
        before = json.loads(record.read_text()).get("stamps")
    except (OSError, ValueError, AttributeError):  # none yet, or not a record
        before = None
    if before == stamps:
        return []
    before = before if isinstance(before, dict) else {}  # no record: all changed
    own = {name: path for name, path in files.items()
           if name == package or name.startswith(package + ".")}
    changed = {name for name in stamps if before.get(name) != stamps[name]}
    stale = stale_modules(own, files, changed)
    removed = [name for name in stale if _delete_caches(files[name])]
    record.parent.mkdir(exist_ok=True)
    temporary = record.with_suffix(f".{os.getpid()}.tmp")
    temporary.write_text(json.dumps({"stamps": stamps}, sort_keys=True))
    temporary.replace(record)  # atomic: a process reading it sees one or the other
    return removed


def stale_modules(candidates: Mapping[str, Path], files: Mapping[str, Path],
                  changed: Iterable[str]) -> list[str]:
    """The modules of ``candidates`` with compiled functions whose import closure
    within ``files`` (module name -> source path) contains a module of ``changed``."""
    changed = set(changed)
    closures = import_closure(files)
    stale = []
    for name, path in sorted(candidates.items()):
        if changed & closures.get(name, set()) and _has_compiled(path):
            stale.append(name)
    return stale


def import_closure(files: Mapping[str, Path]) -> dict[str, set[str]]:
    """For each module (name -> source path), the modules among ``files`` it imports,
    directly or not, itself included (imports anywhere in its source: inside
    functions too)."""
    direct = {name: _imports(name, path, files) for name, path in files.items()}
    closure: dict[str, set[str]] = {}
    for name in files:
        seen, todo = {name}, [name]
        while todo:
            for other in direct.get(todo.pop(), ()):
                if other not in seen:
                    seen.add(other)
                    todo.append(other)
        closure[name] = seen
    return closure


def _modules(roots: Mapping[str, Path]) -> dict[str, Path]:
    """Every module of the packages: dotted name -> source path."""
    files = {}
    for package, root in roots.items():
        for path in sorted(root.rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if "__pycache__" in parts:
                continue
            if parts[-1] == "__init__":
                parts = parts[:-1]
            files[".".join((package, *parts))] = path
    return files


def _stamp(path: Path) -> list[int]:
    """What numba compares of a source: its modification time and size."""
    info = path.stat()
    return [info.st_mtime_ns, info.st_size]


def _imports(name: str, path: Path, files: Mapping[str, Path]) -> set[str]:
    """The modules among ``files`` whose names module ``name`` imports: for ``from X
    import a``, module ``X.a`` where there is one, else ``X`` (``a`` is defined there).
    The packages above a module run when it is imported but give it no names, so they
    are left out (else every kernel would depend on every module its package's
    ``__init__`` imports)."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return set(files)  # unreadable: assume it depends on everything
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name in files)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            for alias in node.names:
                module = f"{base}.{alias.name}"
                if module in files:
                    found.add(module)
                elif base in files:
                    found.add(base)
    return found


def _has_compiled(path: Path) -> bool:
    """Whether a module may compile functions (it names numba)."""
    try:
        return "numba" in path.read_text(encoding="utf-8")
    except OSError:
        return True


def _cache_dirs(source: Path) -> list[Path]:
    """Where numba keeps the caches of a source: beside it, or under
    ``NUMBA_CACHE_DIR`` (numba's own naming of that directory's subfolders)."""
    dirs = [source.parent / "__pycache__"]
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        folder = os.path.dirname(os.path.abspath(source))
        digest = hashlib.sha1(folder.encode()).hexdigest()
        dirs.append(Path(user).absolute() / f"{os.path.basename(folder)}_{digest}")
    return dirs


def _delete_caches(source: Path) -> bool:
    """Delete numba's index and data files of the functions of ``source``; whether
    there were any."""
    found = False
    for folder in _cache_dirs(source):
        if not folder.is_dir():
            continue
        for pattern in (f"{source.stem}.*.nbi", f"{source.stem}.*.nbc"):
            for cache in folder.glob(pattern):
                cache.unlink(missing_ok=True)
                found = True
    return found
