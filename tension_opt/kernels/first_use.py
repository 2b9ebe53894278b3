"""A first call that will compile says so, once per process.

numba compiles a kernel on its first call, which takes seconds to a minute per family
of kernels, once per installation (the machine code then loads from the disk cache).
:func:`announce` is called before a family's first use: where the disk cache does not
hold the family's kernels, it logs one warning on the ``tension_opt`` logger naming the
warm-up command (``python -m tension_opt warmup``, :mod:`tension_opt.warmup`), and
nothing after that in the process. A family already checked costs one set lookup.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["WARMUP_COMMAND", "announce", "compiling_ahead"]

LOGGER = logging.getLogger("tension_opt")
#: The command that compiles every kernel ahead.
WARMUP_COMMAND = "python -m tension_opt warmup"
_CHECKED: set[str] = set()
_LOCK = threading.Lock()
_said = [False]


def _cached(kernel: Any) -> bool:
    """Whether numba's disk cache holds an index of ``kernel`` (a dispatcher compiled
    with ``cache=True``); True where that cannot be told."""
    try:
        return bool(os.path.exists(kernel._cache._cache_file._index_path))
    except (AttributeError, TypeError):
        return True


@contextmanager
def compiling_ahead() -> Iterator[None]:
    """Say nothing while the block runs: it is the warm-up, which compiles on purpose."""
    before, _said[0] = _said[0], True
    try:
        yield
    finally:
        _said[0] = before


def announce(family: str, *kernels: Any) -> None:
    """Before the first use of a kernel family in this process: where the disk cache
    lacks any of ``kernels`` and nothing was said yet, log that the call compiles and
    how to compile ahead."""
    if family in _CHECKED:
        return
    with _LOCK:
        if family in _CHECKED:
            return
        _CHECKED.add(family)
        if _said[0] or all(_cached(kernel) for kernel in kernels):
            return
        _said[0] = True
    LOGGER.warning(
        "compiling the %s kernels on their first use: this call waits for the compiler "
        "(seconds to a minute), once per installation; `%s` compiles every kernel ahead",
        family, WARMUP_COMMAND)
