"""DAQP's C solver called straight from compiled code, without the Python interface.

The ``daqp`` Python package is one extension module that also exports DAQP's C API;
:func:`load` finds ``daqp_quadprog`` and ``daqp_default_settings`` in it, and
:func:`quadprog` (compiled) fills DAQP's three structs and calls ``daqp_quadprog``
from inside a numba kernel, so that a pose costs no Python call, no argument
conversion and no result dictionary. The call is the one ``daqp.solve`` makes for a
problem without a primal or dual start (same problem, same settings, same result
arrays), so the answer is the same to the last bit, including the iteration count;
:func:`load` checks this once per process on a small QP and gives up (returns None,
and callers keep ``daqp.solve``) if anything differs.

The structs' layouts are not part of DAQP's Python interface and have changed between
versions (fields were added to the settings), so :func:`load` only accepts versions
whose layout was checked: :data:`VERIFIED_VERSIONS`. The three structs and the
address of ``daqp_quadprog`` live in one int64 array (:func:`struct_buffer`) owned by
the caller, one per thread: DAQP allocates its workspace inside each call and frees it
before returning.

Layouts of DAQP 0.11.0 (x86-64, ``c_float`` double; byte offsets):

- ``DAQPResult`` (64 bytes): ``x`` 0, ``lam`` 8 (pointers to arrays the caller owns),
  ``fval`` 16, ``soft_slack`` 24, ``exitflag`` 32 and ``iter`` 36 (int), ``nodes`` 40
  (int), ``solve_time`` 48, ``setup_time`` 56.
- ``DAQPProblem`` (80 bytes): ``n`` 0, ``m`` 4, ``ms`` 8 (int), then pointers ``H`` 16,
  ``f`` 24, ``A`` 32, ``bupper`` 40, ``blower`` 48, ``sense`` 56 (int array),
  ``break_points`` 64, then ``nh`` 72 and ``problem_type`` 76 (int).
- ``DAQPSettings`` (136 bytes): :data:`SETTINGS_FIELDS`.

They are those of DAQP's ``include/types.h`` and ``include/api.h`` (github
darnstrom/daqp, release 0.9.1, the newest source at hand), checked against the
installed 0.11.0 binary: the disassembly of ``daqp_quadprog`` and
``daqp_extract_result`` (the result's offsets) and of the Python interface's ``solve``
(80 bytes of problem and 64 of result on its stack, the settings' fields stored at
these offsets); ``daqp_default_settings`` writes 136 bytes, holding the defaults of
``daqp.solve``'s keywords at these offsets. Of the fields 0.11.0 added, ``w_soft`` and
``eq_reduction`` were placed by their effect (each, set at its offset, changes DAQP's
answer as ``daqp.solve`` given the option does: tests/tension_opt/test_daqp_native.py),
as was ``time_limit`` before ``w_soft`` (a limit of 1e-7 s stopped a large QP at the
same iteration both ways); ``presolve``, the last int, holds its default 1.
"""

from __future__ import annotations

import ctypes
import functools
import inspect
import sys
from dataclasses import dataclass
from importlib import metadata
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic
from numpy.typing import NDArray

from tension_opt.errors import InvalidInputError

__all__ = ["FUNCTION", "PROBLEM", "RESULT", "SETTINGS", "SETTINGS_FIELDS", "STRUCT_WORDS",
           "TEMPLATE", "VERIFIED_VERSIONS", "NativeDaqp", "load", "quadprog", "quadprog_batch",
           "struct_buffer"]

#: daqp versions whose struct layouts were checked (see the module docstring).
VERIFIED_VERSIONS = frozenset({"0.11.0"})

#: ``DAQPSettings`` of the verified versions: name -> (byte offset, "d" double or "i" int).
SETTINGS_FIELDS: dict[str, tuple[int, str]] = {
    "primal_tol": (0, "d"), "dual_tol": (8, "d"), "zero_tol": (16, "d"),
    "pivot_tol": (24, "d"), "progress_tol": (32, "d"), "cycle_tol": (40, "i"),
    "iter_limit": (44, "i"), "fval_bound": (48, "d"), "eps_prox": (56, "d"),
    "eta_prox": (64, "d"), "rho_soft": (72, "d"), "rel_subopt": (80, "d"),
    "abs_subopt": (88, "d"), "sing_tol": (96, "d"), "refactor_tol": (104, "d"),
    "time_limit": (112, "d"), "w_soft": (120, "d"), "eq_reduction": (128, "i"),
    "presolve": (132, "i"),
}

# Sizes of the structs in int64 words, and where each lives in :func:`struct_buffer`'s
# array: the result, the problem, the settings DAQP is handed, the settings asked for
# (copied into the former before each call: DAQP's branch and bound and AVI solvers
# write to their settings while they run), and the address of ``daqp_quadprog``.
RESULT_WORDS, PROBLEM_WORDS, SETTINGS_WORDS = 8, 10, 17
#: Word offsets of the structs and the function in :func:`struct_buffer`'s array.
RESULT, PROBLEM, SETTINGS, TEMPLATE, FUNCTION = 0, 8, 18, 35, 52
#: int64 words of :func:`struct_buffer`'s array.
STRUCT_WORDS = 53


@dataclass(frozen=True)
class NativeDaqp:
    """DAQP's C entry points, as :func:`load` found and checked them.

    Attributes
    ----------
    quadprog : int
        Address of ``daqp_quadprog`` (for :func:`quadprog`).
    defaults : ndarray, shape (SETTINGS_WORDS,), int64
        DAQP's default settings (``daqp_default_settings``), as raw words.
    """

    quadprog: int
    defaults: NDArray


@intrinsic
def _call_c(typingctx: Any, function: Any, result: Any, problem: Any,
            settings: Any) -> Any:
    """``((void (*)(void*, void*, void*)) function)(result, problem, settings)`` with
    every argument an address (an integer), so the compiled caller holds no address
    of its own and numba can cache it."""
    sig = types.void(types.intp, types.intp, types.intp, types.intp)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        pointer = ir.IntType(8).as_pointer()
        kind = ir.FunctionType(ir.VoidType(), [pointer, pointer, pointer])
        target = builder.inttoptr(args[0], kind.as_pointer())
        builder.call(target, [builder.inttoptr(a, pointer) for a in args[1:]])
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, nogil=True)
def _one_qp(H: NDArray, f: NDArray, A: NDArray, upper: NDArray, lower: NDArray,
            sense: NDArray, x: NDArray, lam: NDArray, structs: NDArray) -> bool:
    """Whether the arrays are one QP as DAQP reads it (sizes, C order, int32 types,
    doubles) and ``structs`` holds DAQP's address: DAQP trusts its pointers."""
    k, p = x.size, upper.size
    contiguous = (H.flags.c_contiguous and f.flags.c_contiguous and A.flags.c_contiguous
                  and upper.flags.c_contiguous and lower.flags.c_contiguous
                  and sense.flags.c_contiguous and x.flags.c_contiguous
                  and lam.flags.c_contiguous and structs.flags.c_contiguous)
    return (contiguous and H.shape[0] == k and H.shape[1] == k and f.size == k
            and A.shape[1] == k and A.shape[0] <= p and lower.size == p and sense.size == p
            and lam.size == p and sense.itemsize == 4 and structs.size >= STRUCT_WORDS
            and structs.itemsize == 8 and structs[FUNCTION] != 0
            and H.itemsize == f.itemsize == A.itemsize == upper.itemsize
            == lower.itemsize == x.itemsize == lam.itemsize == 8)


@njit(cache=True, nogil=True)
def quadprog(H: NDArray, f: NDArray, A: NDArray, upper: NDArray, lower: NDArray,
             sense: NDArray, x: NDArray, lam: NDArray, structs: NDArray) -> tuple[int, int]:
    """Solve a QP with ``daqp_quadprog`` as ``daqp.solve(H, f, A, upper, lower, sense)``
    would (without a primal or dual start).

    Parameters
    ----------
    H : ndarray, shape (k, k)
        Hessian (C order).
    f : ndarray, shape (k,)
    A : ndarray, shape (r, k)
        General constraint rows (C order).
    upper, lower : ndarray, shape (p,)
        Bounds: ``p - r`` simple bounds on the first variables, then the rows' bounds.
    sense : ndarray of int32, shape (p,)
        DAQP's constraint types (the working set to start from); DAQP reads it.
    x : ndarray, shape (k,)
        The solution, written.
    lam : ndarray, shape (p,)
        The multipliers, written (when DAQP finds a solution).
    structs : ndarray of int64, shape (STRUCT_WORDS,)
        :func:`struct_buffer`'s array.

    Returns
    -------
    tuple
        ``(exitflag, iterations)`` as DAQP reports them (exitflag 1 or 2 for a solution).

    Raises
    ------
    InvalidInputError
        The arrays are not one QP as DAQP reads it (sizes, C order, int32 ``sense``).
    """
    k, p = x.size, upper.size
    if not _one_qp(H, f, A, upper, lower, sense, x, lam, structs):
        raise InvalidInputError(
            "quadprog needs H (k, k), f (k,), A (r, k) with r <= p, upper, lower, sense "
            "(int32) and lam (p,), x (k,), all C-contiguous, and structs from struct_buffer")
    for w in range(RESULT, RESULT + RESULT_WORDS):
        structs[w] = 0
    structs[RESULT] = x.ctypes.data
    structs[RESULT + 1] = lam.ctypes.data
    problem = PROBLEM
    structs[problem] = k | (p << 32)  # n, m
    structs[problem + 1] = p - A.shape[0]  # ms (and padding)
    structs[problem + 2] = H.ctypes.data
    structs[problem + 3] = f.ctypes.data
    structs[problem + 4] = A.ctypes.data
    structs[problem + 5] = upper.ctypes.data
    structs[problem + 6] = lower.ctypes.data
    structs[problem + 7] = sense.ctypes.data
    structs[problem + 8] = 0  # no break points (not a hierarchy)
    structs[problem + 9] = 0  # nh, problem_type 0 (a QP)
    for w in range(SETTINGS_WORDS):
        structs[SETTINGS + w] = structs[TEMPLATE + w]
    base = np.intp(structs.ctypes.data)
    # (numba passes the typing context of an intrinsic itself)
    _call_c(structs[FUNCTION], base, base + 8 * PROBLEM,  # type: ignore[call-arg]
            base + 8 * SETTINGS)
    word = structs[RESULT + 4]  # exitflag (low half), iterations (high half)
    low = word & 0xFFFFFFFF
    return int(low - (1 << 32) if low >= (1 << 31) else low), int(word >> 32)


@njit(cache=True, nogil=True)
def quadprog_batch(H: NDArray, f: NDArray, A: NDArray, upper: NDArray, lower: NDArray,
                   sense: NDArray, x: NDArray, lam: NDArray, flags: NDArray,
                   iterations: NDArray, structs: NDArray) -> None:
    """:func:`quadprog` pose by pose over a batch, each pose from the working set
    ``sense``, as the ``qpsolvers:daqp`` backend calls ``daqp.solve`` per pose.

    Parameters
    ----------
    H : ndarray, shape (N, k, k)
    f : ndarray, shape (N, k)
    A : ndarray, shape (N, r, k)
    upper, lower : ndarray, shape (N, p)
    sense : ndarray of int32, shape (p,)
        The constraint types every pose starts from (not changed).
    x : ndarray, shape (N, k)
    lam : ndarray, shape (N, p)
        Solutions and multipliers, written.
    flags, iterations : ndarray of int64, shape (N,)
        DAQP's exit flag and iteration count per pose, written.
    structs : ndarray of int64, shape (STRUCT_WORDS,)
    """
    start = sense.copy()
    for i in range(H.shape[0]):
        start[:] = sense
        flags[i], iterations[i] = quadprog(H[i], f[i], A[i], upper[i], lower[i], start,
                                           x[i], lam[i], structs)


def struct_buffer(native: NativeDaqp, options: dict[str, Any]) -> NDArray | None:
    """The int64 array :func:`quadprog` fills and calls DAQP with: DAQP's address, and
    its default settings with ``options`` (``daqp.solve``'s keyword names, e.g.
    ``primal_tol``) on top. One per thread (DAQP's structs are written per call).

    Returns None when an option is not a field of the settings struct (the caller then
    keeps ``daqp.solve``, which knows every option of the installed version).
    """
    buffer = np.zeros(STRUCT_WORDS, dtype=np.int64)
    buffer[FUNCTION] = native.quadprog
    template = buffer[TEMPLATE:TEMPLATE + SETTINGS_WORDS]
    template[:] = native.defaults
    raw = template.view(np.uint8)
    for name, value in options.items():
        if name not in SETTINGS_FIELDS:
            return None
        offset, kind = SETTINGS_FIELDS[name]
        if kind == "i":
            if int(value) != value:
                return None
            raw[offset:offset + 4] = np.array([int(value)], dtype=np.int32).view(np.uint8)
        else:
            raw[offset:offset + 8] = np.array([float(value)]).view(np.uint8)
    return buffer


def _entry_points() -> NativeDaqp | None:
    """DAQP's C functions in the installed extension, or None."""
    try:
        import daqp

        version = metadata.version("daqp")
    except (ImportError, metadata.PackageNotFoundError):
        return None
    if (version not in VERIFIED_VERSIONS or sys.byteorder != "little"
            or ctypes.sizeof(ctypes.c_void_p) != 8):
        return None
    try:
        library = ctypes.CDLL(daqp.__file__)
        solve, defaults = library.daqp_quadprog, library.daqp_default_settings
    except (OSError, AttributeError):
        return None
    defaults.argtypes, defaults.restype = [ctypes.c_void_p], None
    words = np.zeros(SETTINGS_WORDS, dtype=np.int64)
    defaults(words.ctypes.data)
    words.flags.writeable = False
    address = ctypes.cast(solve, ctypes.c_void_p).value
    return None if not address else NativeDaqp(int(address), words)


def _defaults_agree(native: NativeDaqp) -> bool:
    """Whether DAQP's default settings, read at :data:`SETTINGS_FIELDS`' offsets, are
    the defaults of ``daqp.solve``'s keywords (which it hands DAQP as its settings)."""
    import daqp

    try:
        keywords = inspect.signature(daqp.solve).parameters
    except (TypeError, ValueError):
        return False
    raw = native.defaults.view(np.uint8)
    for name, (offset, kind) in SETTINGS_FIELDS.items():
        if name not in keywords:
            return False
        dtype = np.dtype(np.int32 if kind == "i" else np.float64)
        if raw[offset:offset + dtype.itemsize].view(dtype)[0] != keywords[name].default:
            return False
    return True


def _agrees(native: NativeDaqp) -> bool:
    """Whether the settings' layout holds DAQP's defaults (:func:`_defaults_agree`), and
    :func:`quadprog` answers a small QP exactly as ``daqp.solve`` does: three variables
    with a dense Hessian, bounds (one of them active at the optimum, one infinite) and
    one equality, from a cold start and from the optimum's working set."""
    import daqp

    if not _defaults_agree(native):
        return False
    H = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.25], [0.5, 0.25, 2.0]])
    f = np.array([-8.0, 1.0, 0.5])
    A = np.array([[1.0, 1.0, 1.0]])
    upper = np.array([1.0, 2.0, 1e30, 1.5])
    lower = np.array([-1.0, -2.0, -1e30, 1.5])
    options = {"primal_tol": 1e-9}
    structs = struct_buffer(native, options)
    if structs is None:
        return False
    for start in ([0, 0, 0, 5], [1, 0, 0, 5]):
        sense = np.array(start, dtype=np.intc)
        x, _, flag, info = daqp.solve(H, f, A, upper, lower, sense.copy(), **options)
        mine, lam = np.full(3, np.nan), np.full(4, np.nan)
        got = quadprog(H, f, A, upper, lower, sense, mine, lam, structs)
        if (got != (flag, info["iterations"]) or flag != 1
                or not np.allclose(mine, x, rtol=0.0, atol=1e-12)
                or not np.allclose(lam, info["lam"], rtol=0.0, atol=1e-12)
                or lam[0] == 0.0):  # the first bound must be active (checks lam's order)
            return False
    return True


@functools.cache
def load() -> NativeDaqp | None:
    """DAQP's C solver for :func:`quadprog`, checked once per process; None when daqp is
    missing, its version's layout was not verified (:data:`VERIFIED_VERSIONS`), its
    symbols are missing, or the check against ``daqp.solve`` fails (its keywords'
    defaults at the settings' offsets, its answer to a small QP)."""
    native = _entry_points()
    return native if native is not None and _agrees(native) else None
