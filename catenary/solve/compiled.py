"""The plumbing between the solvers' plain calls and their compiled kernels
(:mod:`catenary.solve.kernels`): arguments as flat arrays without numpy's per-call
broadcasting cost, the kernels loaded on first use (numba is imported only then), and
the pieces of a result where every cable converged.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .common import CONVERGED, STATUS_DTYPE, FloatArray

__all__ = ["FEW_CABLES", "all_converged", "all_true", "flat_arguments", "load_kernels",
           "new_result", "run_cables", "serial_entry", "take"]

T = TypeVar("T")

_KERNELS: list[ModuleType] = []
_F64 = np.dtype(np.float64)
#: Calls of up to this many cables (a robot's) are served by the serial kernels, and
#: their all-converged rows are copied from ready ones of their length.
FEW_CABLES = 64
#: Statuses of cables that all converged, copied from: one row per length up to
#: ``FEW_CABLES`` (slicing a longer one costs a tenth of a microsecond), then one
#: row grown on demand.
_CONVERGED_ROW: list[NDArray[np.str_]] = [
    np.full(n, CONVERGED, dtype=STATUS_DTYPE) for n in range(FEW_CABLES + 2)]
#: ``True`` entries to copy ``converged`` masks from (as ``_CONVERGED_ROW``).
_TRUE_ROW: list[NDArray[np.bool_]] = [np.ones(n, dtype=bool) for n in range(FEW_CABLES + 2)]


#: One parallel launch at a time: numba's "workqueue" layer aborts the process on two
#: at once (the serial branch of a kernel needs no lock).
_LAUNCH = threading.Lock()
#: Whether this process is a forked child: GNU OpenMP (numba's "omp" layer) terminates
#: a child that launches a parallel region after its parent did, so children run serial.
_FORKED = [False]
os.register_at_fork(after_in_child=lambda: _FORKED.__setitem__(0, True))


def run_cables(name: str, n: int, *args: object, variant: str = "") -> int:
    """Kernel ``name`` of :mod:`catenary.solve.kernels` over ``n`` cables: its parallel
    variant (one launch at a time) from ``PARALLEL_FROM`` cables in a process that is no
    forked child, else the serial one (which starts no threading layer).

    Every array in ``args`` is C-contiguous with the dtype of its kind (the flat float64
    arguments of :func:`flat_arguments`, the result arrays the callers allocate), so
    the serial kernel is called through its entry point (:func:`_entry`); ``variant``
    names another choice of argument types (numbers in place of arrays), whose entry
    point is kept apart."""
    kernels = load_kernels()
    if n >= kernels.PARALLEL_FROM and not _FORKED[0]:
        with _LAUNCH:
            return getattr(kernels, f"{name}_parallel")(*args)
    return serial_entry(name + variant, args)(*args)


#: Entry points of the serial kernels, by name and variant (:func:`_entry`).
_ENTRIES: dict[str, Callable[..., int]] = {}


def serial_entry(key: str, args: tuple[object, ...]) -> Callable[..., int]:
    """The entry point of the serial kernel named by ``key`` (its name, then its
    variant: see :func:`run_cables`, whose contract ``args`` meets), compiled for the
    types of ``args`` on the first call and kept."""
    entry = _ENTRIES.get(key)
    if entry is None:
        kernel = getattr(load_kernels(), key.partition(":")[0])
        entry = _ENTRIES[key] = _entry(kernel, args)
    return entry


def _entry(kernel: Any, args: tuple[object, ...]) -> Callable[..., int]:
    """The machine code of ``kernel`` for writable C-contiguous arrays of the dtypes
    and dimensions of ``args`` (and its scalars' types), called without numba's type
    dispatch: for a few cables that dispatch costs as much as the solves. It checks no
    type, hence the contract of :func:`run_cables` on its arguments (a read-only array
    only read by the kernel is fine)."""
    import numba

    examples = [np.zeros((1,) * a.ndim, dtype=a.dtype) if isinstance(a, np.ndarray) else a
                for a in args]
    return kernel.compile(tuple(numba.typeof(a) for a in examples))


def load_kernels() -> ModuleType:
    """:mod:`catenary.solve.kernels`, imported on the first call (importing numba and
    loading the machine code from its disk cache costs a fraction of a second)."""
    if not _KERNELS:
        from . import kernels

        _KERNELS.append(kernels)
    return _KERNELS[0]


def _numbers(value: ArrayLike) -> FloatArray | None:
    """``value`` as a float array if it holds numbers (not text, not objects), else
    None."""
    if isinstance(value, float):
        return np.asarray(value)
    if isinstance(value, str | bytes):
        return None
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):
        return None
    return raw.astype(_F64, copy=False) if raw.dtype.kind in "biuf" else None


def flat_arguments(*args: ArrayLike) -> tuple[tuple[int, ...], int, list[FloatArray]] | None:
    """The arguments as flat float arrays for the kernels, or None where the numpy path
    must decide (shapes that do not broadcast, no cable at all: the numpy checks then
    raise the package's error or return the empty result).

    Returns
    -------
    shape : tuple of int
        The broadcast shape ``S``.
    n : int
        ``prod(S)``, the number of cables.
    flat : list of ndarray
        One contiguous float array per argument, of ``n`` entries or of one (an
        argument with a single value, not broadcast: the kernels read entry 0).
    """
    found = [a if type(a) is np.ndarray and a.dtype is _F64 else _numbers(a) for a in args]
    if any(a is None for a in found):
        return None  # not numbers: the numpy path's checks name the argument
    arrays = cast("list[FloatArray]", found)  # no None left (a quoted type: no runtime cost)
    # Arrays of one shape and scalars (the usual call) skip numpy's broadcast_shapes,
    # whose cost is that of solving several cables.
    shape: tuple[int, ...] = ()
    for a in arrays:
        if a.shape != shape and a.shape != ():
            if shape != ():
                try:
                    shape = np.broadcast_shapes(*(b.shape for b in arrays))
                except ValueError:
                    return None
                break
            shape = a.shape
    n = math.prod(shape)
    if n == 0:
        return None
    flat = []
    for a in arrays:
        if a.ndim == 1 and a.shape == shape and a.flags.c_contiguous:
            flat.append(a)  # the usual argument, as it is
        elif a.size == 1:
            flat.append(a.reshape(1))
        elif a.shape == shape:
            flat.append(a.ravel())  # a view of contiguous data, else a contiguous copy
        else:
            flat.append(np.ascontiguousarray(np.broadcast_to(a, shape)).ravel())
    return shape, n, flat


def new_result(cls: type[T], **fields: object) -> T:
    """``cls(**fields)`` for a frozen dataclass without checks of its own, skipping its
    ``__init__`` (which sets each field through ``object.__setattr__``: a few
    microseconds, as much as the kernel's work for a few cables)."""
    result = cls.__new__(cls)
    result.__dict__.update(fields)
    return result


def take(a: FloatArray | float, idx: NDArray[np.intp]) -> FloatArray:
    """Entries ``idx`` of a flat argument of :func:`flat_arguments` (its single value
    repeated if it has one), or of a number for every cable."""
    if isinstance(a, float):
        return np.full(idx.size, a)
    return a[idx] if a.size > 1 else np.full(idx.size, a[0])


def all_converged(n: int) -> NDArray[np.str_]:
    """A status array of ``n`` cables, all ``"converged"`` (a fresh copy)."""
    return _CONVERGED_ROW[n].copy() if n <= FEW_CABLES else _fresh(_CONVERGED_ROW, n)


def all_true(n: int) -> NDArray[np.bool_]:
    """A boolean array of ``n`` entries, all True (a fresh copy; ``np.ones`` costs
    several times as much for a few cables)."""
    return _TRUE_ROW[n].copy() if n <= FEW_CABLES else _fresh(_TRUE_ROW, n)


def _fresh(store: list[NDArray[Any]], n: int) -> NDArray[Any]:
    """The first ``n`` entries of the last row kept in ``store`` (whose entries are all
    equal), copied; the row is grown, with the same value, when it is too short."""
    row = store[-1]
    if row.size < n:
        row = np.full(max(n, 2 * row.size), row[0], dtype=row.dtype)
        store[-1] = row
    return row[:n].copy()
