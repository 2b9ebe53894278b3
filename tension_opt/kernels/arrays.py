"""Arguments of the compiled kernels, of one type per role.

numba compiles a kernel once per combination of argument types, and a read-only array
is another type than a writable one: a kernel called with the read-only arrays of a
cached scaled batch and, elsewhere, with the writable arrays of a subset of it would be
compiled (or loaded from the disk cache) twice, once per process, inside a timed call.
So data a kernel only reads is always passed read-only (:func:`frozen`) and arrays it
may write are always writable (:func:`writable`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["frozen", "writable"]


def frozen(a: ArrayLike) -> NDArray:
    """``a`` as a C-contiguous float64 array marked read-only (a view: no copy of a
    C-contiguous float64 array)."""
    view = np.ascontiguousarray(a, dtype=float)
    if view.flags.writeable:
        view = view.view()
        view.flags.writeable = False
    return view


def writable(a: ArrayLike) -> NDArray:
    """``a`` as a writable C-contiguous float64 array (a copy only if ``a`` is
    read-only, not C-contiguous or not float64)."""
    array = np.ascontiguousarray(a, dtype=float)
    return array if array.flags.writeable else array.copy()
