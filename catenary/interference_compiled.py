"""The compiled path of :func:`catenary.interference.curve_distance`: curves packed for
:func:`catenary.interference_kernels.curve_pairs`, pairs solved in chunks, and the
pairs the kernel leaves handed back to the numpy path.

Which path answers is decided by size alone (pairs compared at least
:data:`tension_opt.kernels.launch.COMPILED_MIN`, or ``compiled=True``), never by whether a
kernel happens to be compiled; both agree to rounding (distances and lower bounds; the
arc parameters of a flat minimum to the refinement's tolerance).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .curves import CatenaryCurves

__all__ = ["PAIRS_PER_CALL", "pack_curves", "solve_pairs", "use_compiled"]

#: Pairs per kernel call: the kernel's sample cache holds ``4 n`` floats per curve.
PAIRS_PER_CALL = 8192


def use_compiled(pairs: int, compiled: bool | None) -> bool:
    """Whether ``pairs`` pairs take the kernel: ``compiled``, or by default at least
    :data:`~tension_opt.kernels.launch.COMPILED_MIN` of them."""
    from tension_opt.kernels import launch

    return pairs >= launch.COMPILED_MIN if compiled is None else bool(compiled)


def pack_curves(curves: CatenaryCurves) -> NDArray:
    """Flat curves (any batch shape) as rows of
    :data:`~catenary.interference_kernels.CURVE_COLUMNS` floats, C-contiguous."""
    from .interference_kernels import CURVE_COLUMNS

    H = np.asarray(curves.H, dtype=float)
    out = np.empty((*H.shape, CURVE_COLUMNS))  # broadcast in place, then flat
    out[..., 0:3] = curves.origin
    out[..., 3:6] = curves.e_h
    out[..., 6] = H
    out[..., 7] = curves.V_A
    out[..., 8] = curves.L0
    out[..., 9:12] = curves.closure
    out[..., 12] = curves.w
    out[..., 13] = curves.EA
    return out.reshape(-1, CURVE_COLUMNS)


def solve_pairs(packed: NDArray, pairs: NDArray, ranges: NDArray, samples: int
                ) -> tuple[NDArray, NDArray]:
    """The kernel on pairs ``(S, 2)`` of rows of ``packed`` with their intervals
    ``(S, 4)``: results (S, :data:`~catenary.interference_kernels.OUT_COLUMNS`) and the
    pairs it left (S,) bool, whose rows are NaN. Chunks of :data:`PAIRS_PER_CALL`
    pairs, each with the curves it compares only."""
    from tension_opt.kernels.first_use import announce

    from .interference_kernels import OUT_COLUMNS, curve_pairs

    announce("sagging-cable interference", curve_pairs)
    S = len(pairs)
    out = np.empty((S, OUT_COLUMNS))
    left = np.zeros(S, dtype=np.int64)
    for lo in range(0, S, PAIRS_PER_CALL):
        sl = slice(lo, min(S, lo + PAIRS_PER_CALL))
        rows, index = packed, pairs[sl]
        if S > PAIRS_PER_CALL:  # only the curves of this chunk
            used, local = np.unique(pairs[sl], return_inverse=True)
            rows, index = packed[used], local.reshape(-1, 2)
        curve_pairs(np.ascontiguousarray(rows), np.ascontiguousarray(index, dtype=np.int64),
                    np.ascontiguousarray(ranges[sl], dtype=float), int(samples), out[sl],
                    left[sl])
    gone = left.astype(bool)
    out[gone] = np.nan
    return out, gone
