"""Parts shared by the forward and inverse catenary solvers.

Per-cable status strings, the result types, the checks and preparation of
the arguments, and a vectorised safeguarded Newton-bisection on brackets.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..elastic import evaluate
from ..errors import InvalidCableError

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "CONVERGED",
    "EPS",
    "INDETERMINATE",
    "INFEASIBLE",
    "MAX_ITER_CAP",
    "NOT_CONVERGED",
    "RES_TOL",
    "SLACK",
    "STATUS_DTYPE",
    "T_TOL",
    "FloatArray",
    "ForcesResult",
    "LengthResult",
    "bracketed_newton",
    "certify_spans",
    "check_settings",
    "float_argument",
    "in_pieces",
    "prepare",
    "selection",
    "status_array",
]

FloatArray = NDArray[np.float64]

# The status strings are values of ``tension_opt.status.Status``; they are
# spelled out here so that the single-cable solvers need no robot package.
CONVERGED = "converged"
SLACK = "slack"
INFEASIBLE = "infeasible"
INDETERMINATE = "indeterminate"
NOT_CONVERGED = "not_converged"
#: Numpy unicode dtype of the status arrays (fits the longest status).
STATUS_DTYPE = "<U13"
EPS = np.finfo(np.float64).eps
#: Largest span residual, relative to the chord, of a cable reported converged: the
#: solvers' stopping test and the final certificate (:func:`certify_spans`).
RES_TOL = 1e-8
#: Relative error of the prescribed tension above which a root is rejected.
T_TOL = 1e-9
#: Largest iteration limit a solver takes: with it every call ends in bounded time.
MAX_ITER_CAP = 10_000


def selection(mask: NDArray[np.bool_]) -> NDArray[np.intp] | slice:
    """Where ``mask`` holds, to gather and scatter with: its indices, or ``slice(None)``
    when it holds everywhere (the usual batch: views, no copies)."""
    return slice(None) if mask.all() else np.flatnonzero(mask)


def status_array(n: int, fill: str) -> NDArray[np.str_]:
    """Status array of ``n`` cables, all ``fill`` (numpy unicode, shape ``(n,)``)."""
    return np.full(n, fill, dtype=STATUS_DTYPE)


@dataclass(frozen=True)
class ForcesResult:
    """End forces of cables of given unstretched length.

    All arrays have the broadcast shape of the inputs. Forces in N.

    Attributes
    ----------
    H : ndarray
        Horizontal tension.
    V_A, V_B : ndarray
        Vertical tension components at the lower end A and upper end B,
        positive upward along the cable (``V_A = V_B - w L0``).
    iterations : ndarray of int
        Newton iterations per cable (fallback iterations are added).
    converged : ndarray of bool
        True where a solution was found (status ``"converged"`` or ``"slack"``).
    status : ndarray of str
        See :mod:`catenary.solve`.
    """

    H: FloatArray
    V_A: FloatArray
    V_B: FloatArray
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    status: NDArray[np.str_]

    @property
    def T_A(self) -> FloatArray:
        """Tension magnitude at end A (N)."""
        return np.hypot(self.H, self.V_A)

    @property
    def T_B(self) -> FloatArray:
        """Tension magnitude at end B (N)."""
        return np.hypot(self.H, self.V_B)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per cable (arrays flattened in C order)."""
        import pandas as pd  # only for tables: the solvers themselves need numpy alone

        columns = {"cable": np.arange(np.size(self.H))}
        if isinstance(self, LengthResult):
            columns["L0"] = np.ravel(self.L0)
        columns.update(H=np.ravel(self.H), V_A=np.ravel(self.V_A), V_B=np.ravel(self.V_B),
                       T_A=np.ravel(self.T_A), T_B=np.ravel(self.T_B),
                       iterations=np.ravel(self.iterations),
                       converged=np.ravel(self.converged), status=np.ravel(self.status))
        return pd.DataFrame(columns)


@dataclass(frozen=True)
class LengthResult(ForcesResult):
    """Unstretched lengths (m) for a prescribed tension, plus the end forces.

    ``iterations`` counts Newton steps only (a bracketing search's are not added), and
    is 0 for an infeasible cable.
    """

    L0: FloatArray = None  # type: ignore[assignment]


# ----------------------------------------------------------------------------
# argument checks


def _check(name: str, a: FloatArray, *, positive: bool = False, allow_inf: bool = False) -> None:
    """Raise unless ``a`` is ``>= 0`` (``> 0`` if ``positive``), finite unless ``allow_inf``."""
    bad = np.isnan(a)
    if not allow_inf:
        bad |= np.isinf(a)
    bad |= (a <= 0) if positive else (a < 0)
    if np.any(bad):
        value = a[bad].flat[0] if a.ndim else float(a)
        rule = "> 0" if positive else ">= 0"
        raise InvalidCableError(
            f"{name} must be {rule}{' (inf allowed)' if allow_inf else ' and finite'}; "
            f"got {name}={value!r}"
        )


def check_settings(tol: object, max_iter: object, tol_name: str = "rtol") -> None:
    """Raise :class:`InvalidCableError` unless ``tol`` is a number in ``(0, 1)`` and
    ``max_iter`` a whole number in ``[1, 10000]``: the settings that bound a solver's
    time (a tolerance of 0, a negative or NaN one, would let it run to any limit; the
    answers are judged by their certificates whatever the tolerance)."""
    if not (type(tol) is float and 0.0 < tol < 1.0):
        ok = isinstance(tol, int | float | np.integer | np.floating) and not isinstance(
            tol, bool | np.bool_) and 0.0 < float(tol) < 1.0
        if not ok:
            raise InvalidCableError(
                f"{tol_name} must be a number in (0, 1) (a relative tolerance); "
                f"got {tol_name}={tol!r}")
    if not (type(max_iter) is int and 1 <= max_iter <= MAX_ITER_CAP):
        ok = isinstance(max_iter, int | np.integer) and not isinstance(
            max_iter, bool | np.bool_) and 1 <= int(max_iter) <= MAX_ITER_CAP
        if not ok:
            raise InvalidCableError(
                f"max_iter must be a whole number from 1 to {MAX_ITER_CAP}; "
                f"got max_iter={max_iter!r}")


def float_argument(name: str, value: ArrayLike) -> FloatArray:
    """``value`` as a float array, or :class:`InvalidCableError` naming the argument
    (strings, ragged nesting, None, objects numpy cannot read as numbers)."""
    if value is None or isinstance(value, str | bytes):
        raise InvalidCableError(f"{name} must be numbers; got {name}={value!r}")
    try:
        raw = np.asarray(value)
        if raw.dtype.kind in "USV":  # text is not numbers, even where numpy reads it so
            raise TypeError
        return raw.astype(np.float64, copy=False)
    except (TypeError, ValueError):
        raise InvalidCableError(
            f"{name} must be a rectangular array of numbers; got {name}={value!r}"[:300]
        ) from None


def prepare(
    x: ArrayLike, z: ArrayLike, third: ArrayLike, w: ArrayLike, EA: ArrayLike, third_name: str
) -> tuple[tuple[int, ...], list[FloatArray]]:
    """Check the arguments of a solver and flatten them to one common shape.

    Parameters
    ----------
    x, z, third, w, EA : array_like
        Horizontal span (m), height of B over A (m), the solver's third
        argument (``L0`` in m or a tension in N), weight per length (N/m)
        and axial stiffness (N).
    third_name : str
        Name of the third argument in messages; ``"L0"`` must be ``> 0``,
        any other ``>= 0``.

    Returns
    -------
    shape : tuple of int
        Broadcast shape ``S`` of the arguments.
    flat : list of ndarray
        ``[x, z, third, w, EA]`` as contiguous float arrays of shape ``(prod(S),)``.

    Raises
    ------
    InvalidCableError
        NaN, out-of-domain values or shapes that do not broadcast.
    """
    names = ("x", "z", third_name, "w", "EA")
    arrays = [float_argument(n, a) for n, a in zip(names, (x, z, third, w, EA), strict=True)]
    for n, a in zip(names, arrays, strict=True):
        if np.any(np.isnan(a)):
            raise InvalidCableError(f"{n} contains NaN")
    _check("x", arrays[0])
    zbad = ~np.isfinite(arrays[1])
    if np.any(zbad):
        raise InvalidCableError(f"z must be finite; got z={arrays[1][zbad].flat[0]!r}")
    _check(third_name, arrays[2], positive=third_name == "L0")
    _check("w", arrays[3])
    _check("EA", arrays[4], positive=True, allow_inf=True)
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
    except ValueError as exc:
        raise InvalidCableError(f"arguments do not broadcast: {exc}") from None
    flat = [np.ascontiguousarray(np.broadcast_to(a, shape)).ravel() for a in arrays]
    return shape, flat


#: Cables per piece of a batch on the numpy path (:func:`in_pieces`).
PIECE = 65536


#: The tuple of per-cable result arrays a piece's solver returns (:func:`in_pieces`).
_Arrays = TypeVar("_Arrays", bound=tuple[NDArray[Any], ...])


def in_pieces(solve: Callable[..., _Arrays], arrays: list[FloatArray]) -> _Arrays:
    """``solve(*arrays)`` of flat per-cable arrays (n,), run on pieces of at most
    :data:`PIECE` cables and written into result arrays of the whole batch, so that the
    numpy path's work arrays (some tens per cable) take bounded memory whatever the
    batch; ``solve`` returns per-cable arrays (k,) of its piece of k cables."""
    n = arrays[0].size
    if n <= PIECE:
        return solve(*arrays)
    whole: list[NDArray[Any]] = []
    for start in range(0, n, PIECE):
        piece = slice(start, start + PIECE)
        part = solve(*(a[piece] for a in arrays))
        if not whole:
            whole = [np.empty(n, dtype=values.dtype) for values in part]
        for into, values in zip(whole, part, strict=True):
            into[piece] = values
    # The arrays of a piece's result, in its order and with its dtypes, for every cable.
    return cast(_Arrays, tuple(whole))


# ----------------------------------------------------------------------------
# vectorised safeguarded Newton / bisection on a bracket


def bracketed_newton(
    f: Callable[[FloatArray, NDArray[np.intp]], tuple[FloatArray, FloatArray]],
    lo: FloatArray,
    hi: FloatArray,
    x0: FloatArray,
    *,
    xtol: float = 4 * EPS,
    atol: float = 0.0,
    ftol: float = 0.0,
    max_iter: int = 200,
) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
    """Roots of increasing functions ``f`` (one per element) on ``[lo, hi]``.

    ``f(t, idx)`` returns value and derivative at ``t`` for the elements
    ``idx``; ``f(lo) <= 0 <= f(hi)`` must hold. Newton steps are taken when
    they stay strictly inside the bracket, bisection steps otherwise, so the
    iteration always converges.

    Parameters
    ----------
    f : callable
        ``f(t (k,), idx (k,) int) -> (value (k,), derivative (k,))``.
    lo, hi, x0 : ndarray, shape ``(n,)``
        Brackets and starting points (same unit as the root).
    xtol : float
        Relative tolerance on the bracket width or the step.
    atol : float
        Absolute tolerance added to ``xtol`` (for roots that may be near 0).
    ftol : float
        Stop where ``|f| <= ftol`` (for functions known only to a few digits
        short of full precision).
    max_iter : int
        Iteration limit (a hard cap: ``done`` is false where it was reached).

    Returns
    -------
    t : ndarray, shape ``(n,)``
        The roots.
    done : ndarray of bool, shape ``(n,)``
        Whether each element met the tolerance.
    iterations : ndarray of int, shape ``(n,)``
        Evaluations of ``f`` per element.
    """
    lo, hi = lo.copy(), hi.copy()
    t = np.clip(x0, lo, hi)
    t = np.where(np.isfinite(t), t, 0.5 * (lo + hi))
    done = np.zeros(t.shape, bool)
    its = np.zeros(t.shape, np.int64)
    idx = np.arange(t.size)
    for _ in range(max_iter):
        if idx.size == 0:
            break
        tt = t[idx]
        val, der = f(tt, idx)
        its[idx] += 1
        exact = np.abs(val) <= ftol
        neg = val < 0
        lo[idx] = np.where(neg, tt, lo[idx])
        hi[idx] = np.where(~neg & ~exact, tt, hi[idx])
        with np.errstate(all="ignore"):
            tn = tt - val / der
        a, b = lo[idx], hi[idx]
        inside = np.isfinite(tn) & (tn > a) & (tn < b)
        # Newton steps leaving the bracket are replaced by bisection.
        mid = 0.5 * (a + b)
        tn = np.where(inside, tn, mid)
        width = b - a
        fin = (
            exact
            | (width <= xtol * np.maximum(np.abs(a), np.abs(b)) + atol)
            | (np.abs(tn - tt) <= xtol * np.abs(tt) + atol)
        )
        t[idx] = np.where(exact, tt, tn)
        done[idx] = fin
        idx = idx[~fin]
    return t, done, its


# ----------------------------------------------------------------------------
# the certificate of a converged cable


def certify_spans(
    x: FloatArray,
    z: FloatArray,
    H: FloatArray,
    V_B: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
) -> NDArray[np.bool_]:
    """Where the end forces are finite and their catenary spans the chord.

    The certificate of a ``"converged"`` cable: ``H >= 0``, ``V_B`` and ``L0 > 0``
    finite, and the spans of :func:`catenary.elastic.evaluate` within
    ``RES_TOL`` of the chord ``hypot(x, z)`` of the targets ``(x, z)``.

    Parameters
    ----------
    x, z : ndarray, shape ``(n,)``
        Target spans (m).
    H, V_B, L0, w, inv_EA : ndarray, shape ``(n,)``
        End forces (N), unstretched length (m), weight per length (N/m) and
        axial compliance (1/N).

    Returns
    -------
    ndarray of bool, shape ``(n,)``
    """
    with np.errstate(all="ignore"):
        finite = np.isfinite(H) & np.isfinite(V_B) & np.isfinite(L0) & (H >= 0) & (L0 > 0)
        xs, zs, *_ = evaluate(H, V_B, L0, w, inv_EA, jacobian=False)
        tol = RES_TOL * np.hypot(x, z)
        return finite & (np.abs(xs - x) <= tol) & (np.abs(zs - z) <= tol)
