""":func:`solve_length_compiled` and :func:`solve_forces_compiled`: the names under
which the compiled catenary solvers were first published.

:func:`catenary.solve_length` and :func:`catenary.solve_forces` now run the compiled
kernels of :mod:`catenary.solve.kernels` themselves (cables the kernels settle,
certified as the numpy path certifies them, are answered by them; the others by the
numpy path, so every status is that of the numpy path and every value agrees with it
to rounding); these functions call them with ``compiled=True``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from catenary.solve import End, ForcesResult, LengthResult, solve_forces, solve_length
from catenary.solve.kernels import PARALLEL_FROM

__all__ = ["PARALLEL_FROM", "solve_forces_compiled", "solve_length_compiled"]


def solve_length_compiled(x: ArrayLike, z: ArrayLike, tension: ArrayLike, w: ArrayLike,
                          EA: ArrayLike = np.inf, end: End = "B", *, rtol: float = 1e-9,
                          max_iter: int = 30) -> LengthResult:
    """:func:`catenary.solve_length` (same arguments, same result) on compiled kernels.

    Raises
    ------
    InvalidCableError
        As :func:`catenary.solve_length`.
    """
    return solve_length(x, z, tension, w, EA, end, rtol=rtol, max_iter=max_iter,
                        compiled=True)


def solve_forces_compiled(x: ArrayLike, z: ArrayLike, L0: ArrayLike, w: ArrayLike,
                          EA: ArrayLike = np.inf, *, rtol: float = 1e-9,
                          max_iter: int = 30) -> ForcesResult:
    """:func:`catenary.solve_forces` (same arguments, same result) on compiled kernels.

    Raises
    ------
    InvalidCableError
        As :func:`catenary.solve_forces`.
    """
    return solve_forces(x, z, L0, w, EA, rtol=rtol, max_iter=max_iter, compiled=True)
