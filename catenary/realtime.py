""":func:`solve_length_compiled` and :func:`solve_forces_compiled`:
:func:`catenary.solve_length` and :func:`catenary.solve_forces` through the compiled
kernels of :mod:`catenary.kernels`, for control loops and large batches.

Cables the kernels settle (certified as the numpy path certifies them) are answered
by them; the others (vertical, weightless or zero-tension cables, degenerate limits,
Newton not converging) by the numpy functions, so every status is that of the numpy
path and every value agrees with it to rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from catenary.errors import InvalidCableError
from catenary.solve import ForcesResult, LengthResult, solve_forces, solve_length
from catenary.solve.common import CONVERGED, STATUS_DTYPE, prepare

__all__ = ["PARALLEL_FROM", "solve_forces_compiled", "solve_length_compiled"]

#: Cables from which the kernel runs in parallel (below, starting threads costs more
#: than the work).
PARALLEL_FROM = 2048


def solve_length_compiled(x: ArrayLike, z: ArrayLike, tension: ArrayLike, w: ArrayLike,
                          EA: ArrayLike = np.inf, end: str = "B", *, rtol: float = 1e-9,
                          max_iter: int = 30) -> LengthResult:
    """:func:`catenary.solve_length` (same arguments, same result) on compiled kernels.

    ``end="H"`` goes to the numpy path entirely. The first call compiles the kernel
    (or loads it from numba's on-disk cache).

    Raises
    ------
    InvalidCableError
        As :func:`catenary.solve_length`.
    """
    if end not in ("B", "A"):
        if end != "H":
            raise InvalidCableError(f'end must be "B", "A" or "H"; got end={end!r}')
        return solve_length(x, z, tension, w, EA, end=end, rtol=rtol, max_iter=max_iter)
    from catenary import kernels

    shape, (xf, zf, tf, wf, ef) = _flat(x, z, tension, w, EA)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_EA = 1.0 / ef
    out = np.zeros((xf.size, 5))
    codes = np.empty(xf.size, dtype=np.int64)
    run = kernels.solve_length_batch if xf.size >= PARALLEL_FROM else kernels.solve_length_serial
    run(end == "B", xf, zf, tf, wf, inv_EA, float(rtol), int(max_iter), out, codes)
    H, V_B, V_A, L0 = (np.ascontiguousarray(out[:, k]) for k in range(4))
    iterations = out[:, 4].astype(np.int64)
    status = np.full(xf.size, CONVERGED, dtype=STATUS_DTYPE)
    redo = np.flatnonzero(codes != kernels.CONVERGED)
    if redo.size:  # the numpy path also rejects invalid data, naming the argument
        ref = solve_length(xf[redo], zf[redo], tf[redo], wf[redo], ef[redo], end=end,
                           rtol=rtol, max_iter=max_iter)
        H[redo], V_B[redo], V_A[redo], L0[redo] = ref.H, ref.V_B, ref.V_A, ref.L0
        iterations[redo], status[redo] = ref.iterations, ref.status
    return LengthResult(H=H.reshape(shape), V_A=V_A.reshape(shape), V_B=V_B.reshape(shape),
                        iterations=iterations.reshape(shape),
                        converged=(status == CONVERGED).reshape(shape),
                        status=status.reshape(shape), L0=L0.reshape(shape))


def solve_forces_compiled(x: ArrayLike, z: ArrayLike, L0: ArrayLike, w: ArrayLike,
                          EA: ArrayLike = np.inf, *, rtol: float = 1e-9,
                          max_iter: int = 30) -> ForcesResult:
    """:func:`catenary.solve_forces` (same arguments, same result) on compiled kernels.

    The first call compiles the kernel (or loads it from numba's on-disk cache).

    Raises
    ------
    InvalidCableError
        As :func:`catenary.solve_forces`.
    """
    from catenary import kernels

    shape, (xf, zf, lf, wf, ef) = _flat(x, z, L0, w, EA)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_EA = 1.0 / ef
    out = np.zeros((xf.size, 4))
    codes = np.empty(xf.size, dtype=np.int64)
    kernels.solve_forces_batch(xf, zf, lf, wf, inv_EA, float(rtol), int(max_iter), out,
                               codes, xf.size >= PARALLEL_FROM)
    H, V_B, V_A = (np.ascontiguousarray(out[:, k]) for k in range(3))
    iterations = out[:, 3].astype(np.int64)
    status = np.full(xf.size, CONVERGED, dtype=STATUS_DTYPE)
    redo = np.flatnonzero(codes != kernels.CONVERGED)
    if redo.size:  # the numpy path also rejects invalid data, naming the argument
        ref = solve_forces(xf[redo], zf[redo], lf[redo], wf[redo], ef[redo], rtol=rtol,
                           max_iter=max_iter)
        H[redo], V_B[redo], V_A[redo] = ref.H, ref.V_B, ref.V_A
        iterations[redo], status[redo] = ref.iterations, ref.status
    converged = status == CONVERGED
    if redo.size:
        converged[redo] = ref.converged
    return ForcesResult(H=H.reshape(shape), V_A=V_A.reshape(shape), V_B=V_B.reshape(shape),
                        iterations=iterations.reshape(shape),
                        converged=converged.reshape(shape), status=status.reshape(shape))


def _flat(*args: ArrayLike) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The arguments as flat float arrays of their broadcast shape; the numpy path's
    checks (:func:`catenary.solve.common.prepare`) where they do not broadcast. Values
    are checked by the kernel, which hands invalid cables to the numpy path.

    Arrays of one common shape and scalars (the usual call) skip numpy's broadcasting,
    whose cost is that of several cables' solves."""
    arrays = [np.asarray(a, dtype=np.float64) for a in args]
    shapes = {a.shape for a in arrays} - {()}
    if len(shapes) <= 1:
        shape = shapes.pop() if shapes else ()
    else:
        try:
            shape = np.broadcast_shapes(*(a.shape for a in arrays))
        except ValueError:
            prepare(*arrays, "tension")  # raises the package's error
            raise
    size = math.prod(shape)
    return shape, [a.ravel() if a.shape == shape else np.full(size, a.item()) if a.size == 1
                   else np.ascontiguousarray(np.broadcast_to(a, shape)).ravel() for a in arrays]
