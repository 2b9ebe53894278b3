"""Inverse problem: a prescribed tension -> unstretched length.

Method
------
Unknowns ``(H, V_B, L0)``, parametrised so that the tension condition holds
exactly: the direction angle of the cable at the given end and ``L0``
(``end="B"``/``"A"``), or ``V_B`` and ``L0`` with ``H = T`` (``end="H"``).
The data are nondimensional: lengths in units of the chord, forces in units
of the prescribed tension (powers of two, exact). Newton on the two span
equations starts from a straight cable along the chord with first-order sag
corrections (``_initial_length``; steep cables given ``H`` start from the
catenary in end angles); for taut cables this guess is within ``O((w c /
T)^2)`` of the answer, so two or three steps reach full precision. The
Jacobian stays regular for weightless and very light cables, whose sag is
below the rounding of ``L0``. At a root the sign of the Jacobian determinant
is that of ``dT/dL0`` at fixed geometry and tells the taut branch (negative)
from the sagging one; cables that reach the sagging branch or do not
converge are solved by a bracketing search over the family of catenaries
through both ends (:mod:`catenary.solve.length_bracket`), which also detects
infeasibility, and polished by the same Newton. A cable is reported
converged only if its span residuals are below ``1e-8`` of its chord and its
end tension is within ``1e-9`` of the prescribed one (``V_A`` is kept as
found for ``end="A"``, not recomputed as ``V_B - w L0``, which may have lost
its digits). Vertical cables are solved in closed form.
"""

from __future__ import annotations

from typing import Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..elastic import axial_compliance, power_of_two
from ..errors import InvalidCableError
from .common import (
    CONVERGED,
    INDETERMINATE,
    INFEASIBLE,
    MAX_ITER_CAP,
    NOT_CONVERGED,
    STATUS_DTYPE,
    T_TOL,
    FloatArray,
    LengthResult,
    certify_spans,
    check_settings,
    in_pieces,
    prepare,
    selection,
    status_array,
)
from .compiled import (
    FEW_CABLES,
    all_converged,
    all_true,
    flat_arguments,
    load_kernels,
    new_result,
    run_cables,
    serial_entry,
    take,
)
from .length_bracket import bracket_length, end_tension
from .length_newton import newton_with_second_guess, polish_length

__all__ = ["End", "solve_length"]

#: Which tension :func:`solve_length` prescribes: at end B, at end A, or horizontal.
End = Literal["B", "A", "H"]


def _vertical_length(
    end: str, z: FloatArray, T: FloatArray, w: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.str_]]:
    """Straight vertical cable (x = 0): closed form, H = 0: ``(H, V_B, V_A, L0, status)``."""
    h = np.abs(z)
    n = z.size
    status = status_array(n, CONVERGED)
    if end == "H":
        status[:] = np.where(T > 0, INFEASIBLE, INDETERMINATE)
        nan = np.full(n, np.nan)
        return nan, nan, nan, nan, status
    # Tension known at the upper end (B with z > 0, A with z < 0): weight reduces
    # the tension downwards, otherwise it adds.
    upper = (z > 0) if end == "B" else (z < 0)
    sgn = np.where(upper, -1.0, 1.0)
    p = 1.0 + T * inv_EA
    with np.errstate(all="ignore"):
        # The root of p L0 + sgn w inv_EA L0^2 / 2 = h, written not to overflow in p^2.
        disc = 1.0 + sgn * 2.0 * w * h * (inv_EA / p) / p
        L0 = 2.0 * h / (p * (1.0 + np.sqrt(disc)))
        bad = (disc < 0) | (upper & (T < w * L0)) | (h == 0)
    status[bad] = INFEASIBLE
    # End B known -> V_B = +-T; end A known -> V_A = +-T, V_B = V_A + w L0.
    known = np.where(z > 0, T, -T)
    if end == "B":
        V, V_A = known, known - w * L0
    else:
        V, V_A = known + w * L0, known
    nan = status != CONVERGED
    return (
        np.where(nan, np.nan, 0.0),
        np.where(nan, np.nan, V),
        np.where(nan, np.nan, V_A),
        np.where(nan, np.nan, L0),
        status,
    )


def _weightless_length(
    end: str, x: FloatArray, z: FloatArray, T: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_]]:
    """Straight bar (``w = 0``, ``x > 0``) in closed form: ``(H, V_B, L0, status)``."""
    c = np.hypot(x, z)
    with np.errstate(all="ignore"):
        T_bar = T * c / x if end == "H" else T
        L0 = c / (1.0 + T_bar * inv_EA)
        H, V = T_bar * (x / c), T_bar * (z / c)
    return H, V, L0, status_array(x.size, CONVERGED)


def _general_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64], NDArray[np.str_]]:
    """Cables with ``x > 0`` and ``T > 0``: ``(H, V_B, V_A, L0, iterations, status)``.

    Nondimensional: lengths in units of the chord and forces in units of
    ``T`` (both rounded to powers of two, so the rounding is that of SI
    units). Newton (:func:`newton_with_second_guess`), then for the rest the
    bracketing search (closed form for weightless cables) and a polish.
    Data whose scaled weight or compliance overflows are ``"not_converged"``.
    """
    ell, F = power_of_two(np.hypot(x, z)), power_of_two(T)
    x, z, T = x / ell, z / ell, T / F
    w, inv_EA = (w / F) * ell, inv_EA * F
    # A weight, compliance or stretch under the weight beyond the double range in
    # these units (inf or NaN here): no answer.
    fine = np.isfinite(w * inv_EA)
    if fine.all():
        H, V, V_A, L, its, st = _scaled_length(end, x, z, T, w, inv_EA, rtol, max_iter)
    else:
        n = x.size
        H, V, V_A, L = (np.full(n, np.nan) for _ in range(4))
        its = np.zeros(n, np.int64)
        st = status_array(n, NOT_CONVERGED)
        s = np.flatnonzero(fine)
        H[s], V[s], V_A[s], L[s], its[s], st[s] = _scaled_length(
            end, x[s], z[s], T[s], w[s], inv_EA[s], rtol, max_iter
        )
    return H * F, V * F, V_A * F, L * ell, its, st


def _scaled_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64], NDArray[np.str_]]:
    """:func:`_general_length` on nondimensional data: Newton, then the fallbacks."""
    H, V, V_A, L, conv, its = newton_with_second_guess(end, x, z, T, w, inv_EA, rtol, max_iter)
    st = np.where(conv, CONVERGED, NOT_CONVERGED).astype(STATUS_DTYPE)
    f = np.flatnonzero(~conv & (w > 0))
    if f.size:
        # The search's inner iterations are not counted: the compiled kernels reach
        # the same roots by another search (catenary.solve.kernels_bracket).
        Hf, Vf, Lf, stf, _ = bracket_length(end, x[f], z[f], T[f], w[f], inv_EA[f])
        H[f], V[f], V_A[f], L[f], st[f], itp = polish_length(
            end, x[f], z[f], T[f], w[f], inv_EA[f], Hf, Vf, Lf, stf, rtol, max_iter
        )
        its[f] += itp
    f = np.flatnonzero(~conv & (w == 0))
    if f.size:
        H[f], V[f], L[f], st[f] = _weightless_length(end, x[f], z[f], T[f], inv_EA[f])
        V_A[f] = V[f]
    return H, V, V_A, L, its, st


def _certify_length(
    end: str, x: FloatArray, z: FloatArray, T: FloatArray, w: FloatArray,
    inv_EA: FloatArray, H: FloatArray, V: FloatArray, V_A: FloatArray, L: FloatArray,
) -> NDArray[np.bool_]:
    """Where the spans certificate holds and the prescribed tension is met to ``T_TOL``."""
    with np.errstate(all="ignore"):
        got = np.hypot(H, V_A) if end == "A" else end_tension(end, H, V, L, w)
        met = np.abs(got - T) <= T_TOL * T
    return met & np.isfinite(V_A) & certify_spans(x, z, H, V, L, w, inv_EA)


#: ``(H, V_B, V_A, L0, iterations, status)`` of flat cables (:func:`_solve_length_flat`).
_LengthArrays = tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64],
                      NDArray[np.str_]]


def _solve_length_flat(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> _LengthArrays:
    """:func:`solve_length` on checked flat arrays: ``(H, V_B, V_A, L0, iterations, status)``,
    in pieces of bounded memory (:func:`~catenary.solve.common.in_pieces`)."""
    return in_pieces(lambda x, z, T, w, EA: _length_piece(end, x, z, T, w, EA, rtol, max_iter),
                     [x, z, T, w, EA])


def _length_piece(end: str, x: FloatArray, z: FloatArray, T: FloatArray, w: FloatArray,
                  EA: FloatArray, rtol: float, max_iter: int) -> _LengthArrays:
    """:func:`_solve_length_flat` of one piece of the batch."""
    n = x.size
    inv_EA = axial_compliance(EA)
    H, V, V_A, L = (np.full(n, np.nan) for _ in range(4))
    its = np.zeros(n, np.int64)
    status = status_array(n, NOT_CONVERGED)

    vert = x == 0.0
    if np.any(vert):
        i = np.flatnonzero(vert)
        H[i], V[i], V_A[i], L[i], status[i] = _vertical_length(end, z[i], T[i], w[i], inv_EA[i])
    # Zero tension cannot hold a weighted cable with x > 0 or stretch a bar.
    zero = ~vert & (T == 0.0)
    status[zero] = np.where(w[zero] > 0, INFEASIBLE, INDETERMINATE)
    general = ~vert & ~zero
    if general.any():
        s = selection(general)
        H[s], V[s], V_A[s], L[s], its[s], status[s] = _general_length(
            end, x[s], z[s], T[s], w[s], inv_EA[s], rtol, max_iter
        )
    converged = status == CONVERGED
    if converged.any():
        s = selection(converged)
        certified = np.zeros(n, bool)
        certified[s] = _certify_length(end, x[s], z[s], T[s], w[s], inv_EA[s], H[s], V[s],
                                       V_A[s], L[s])
        status[converged & ~certified] = NOT_CONVERGED
    unsolved = status != CONVERGED
    if unsolved.any():
        H[unsolved], V[unsolved], V_A[unsolved], L[unsolved] = np.nan, np.nan, np.nan, np.nan
        its[status == INFEASIBLE] = 0  # no answer to count steps towards (any path)
    return H, V, V_A, L, its, status


def solve_length(
    x: ArrayLike,
    z: ArrayLike,
    tension: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
    end: End = "B",
    *,
    rtol: float = 1e-9,
    max_iter: int = 30,
    compiled: bool = True,
) -> LengthResult:
    """Unstretched length of cables with a prescribed tension (inverse problem).

    Parameters
    ----------
    x : array_like
        Horizontal span (m), ``>= 0``.
    z : array_like
        Height of the upper end B over the lower end A (m), either sign.
    tension : array_like
        Prescribed tension (N), ``>= 0``: its magnitude at end B (``end="B"``),
        at end A (``end="A"``), or the horizontal tension (``end="H"``).
    w : array_like
        Weight per unit length (N/m), ``>= 0``.
    EA : array_like, optional
        Axial stiffness (N), ``> 0``; ``inf`` (default) for inextensible.
    end : {"B", "A", "H"}
        Which tension is prescribed.
    rtol, max_iter
        Newton step tolerance, in (0, 1), and iteration limit (1 to 10000).
    compiled : bool
        Compiled kernels for the cables they settle (``end`` "B", "A"); False: numpy.

    Returns
    -------
    LengthResult
        ``.L0`` (m) and the end forces, arrays of the broadcast input shape. Where two
        catenaries carry the tension, the taut one (shorter, larger H); where none does,
        ``"infeasible"``, NaN values and 0 iterations (Newton steps, not bracketing).

    Raises
    ------
    InvalidCableError
        NaN or out-of-domain arguments or settings, ``end`` not "B", "A" or "H".

    Notes
    -----
    Newton on the two span equations with the tension condition built in, from a
    near-straight guess; the sign of the Jacobian determinant tells the taut branch
    from the sagging one; cables Newton cannot finish are solved by a bracketing
    search over the catenaries through both ends and polished. Converged means finite
    forces, span residuals below ``1e-8`` of the chord and the end tension within
    ``1e-9`` of the prescribed one; else ``"not_converged"`` (``"infeasible"`` where
    no catenary carries the tension) with NaN values.
    The method in detail: :mod:`catenary.solve.length`; the kernels run the same.
    """
    if end not in ("B", "A", "H"):
        raise InvalidCableError(f'end must be "B", "A" or "H"; got end={end!r}')
    if not (type(rtol) is float and 0.0 < rtol < 1.0 and type(max_iter) is int
            and 0 < max_iter <= MAX_ITER_CAP):  # the usual settings pass without a call
        check_settings(rtol, max_iter)
    if compiled and end != "H":
        result = _compiled_length(end, x, z, tension, w, EA, rtol, max_iter)
        if result is not None:
            return result
    shape, (xf, zf, tf, wf, ef) = prepare(x, z, tension, w, EA, "tension")
    # Overflow is expected at extreme data: the certificate checks every result.
    with np.errstate(all="ignore"):
        H, V, V_A, L, its, status = _solve_length_flat(end, xf, zf, tf, wf, ef, rtol, max_iter)
    converged = status == CONVERGED
    return LengthResult(
        H=H.reshape(shape),
        V_A=V_A.reshape(shape),
        V_B=V.reshape(shape),
        iterations=its.reshape(shape),
        converged=converged.reshape(shape),
        status=status.reshape(shape),
        L0=L.reshape(shape),
    )


def _compiled_length(end: str, x: ArrayLike, z: ArrayLike, tension: ArrayLike,
                     w: ArrayLike, EA: ArrayLike, rtol: float, max_iter: int
                     ) -> LengthResult | None:
    """:func:`solve_length` for ``end`` "B" or "A" through the compiled kernel, the
    cables it leaves by :func:`_solve_length_flat`; None where the numpy path must
    decide for the whole call (invalid data, shapes that do not broadcast, no cable)."""
    shape: tuple[int, ...]
    wf: FloatArray | float  # a number for every cable on the serial call's path
    ef: FloatArray | float
    n = _cable_vectors(x, z, tension, w, EA)
    if 0 < n <= FEW_CABLES:
        # The usual call of a controller (a robot's cables), passed on as it is to the
        # serial kernel's entry point (through run_cables, its dispatch costs as much as
        # the work for a cable).
        out, ints = np.empty((4, n)), np.empty((2, n), dtype=np.int64)
        args = (end == "B", x, z, tension, w, EA, float(rtol), int(max_iter), out, ints)
        key = _VECTORS_AND_NUMBERS if n >= ONE_AT_A_TIME_BELOW else _SCALAR_NUMBERS
        unsettled = serial_entry(key, args)(*args)
        if not unsettled:
            result = object.__new__(LengthResult)  # field by field: see new_result
            fields = result.__dict__
            fields["H"], fields["V_B"], fields["V_A"], fields["L0"] = (out[0], out[1],
                                                                       out[2], out[3])
            fields["iterations"], fields["converged"], fields["status"] = (
                ints[1], all_true(n), all_converged(n))
            return result
        # As _cable_vectors found them: float64 vectors x, z, tension; floats w, EA.
        xf, zf, tf = cast("FloatArray", x), cast("FloatArray", z), cast("FloatArray", tension)
        shape, wf, ef = (n,), cast(float, w), cast(float, EA)
    else:
        flat = flat_arguments(x, z, tension, w, EA)
        if flat is None:
            return None
        shape, n, (xf, zf, tf, wf, ef) = flat
        out, ints = np.empty((4, n)), np.empty((2, n), dtype=np.int64)
        name = "solve_length_cables" if n >= ONE_AT_A_TIME_BELOW else "solve_length_cables_scalar"
        unsettled = run_cables(name, n, end == "B", xf, zf, tf, wf, ef, float(rtol),
                               int(max_iter), out, ints)
    if unsettled:
        kernels = load_kernels()
        codes = ints[0]
        if np.any(codes == kernels.INVALID):
            return None  # the numpy checks raise the package's error
        status = all_converged(n)
        status[codes == kernels.INFEASIBLE] = INFEASIBLE
        # From the codes: comparing the status strings costs as much as copying them.
        converged = codes == kernels.CONVERGED
        redo = np.flatnonzero(~converged & (codes != kernels.INFEASIBLE))
        if redo.size:
            with np.errstate(all="ignore"):
                H, V, V_A, L, its, st = _solve_length_flat(
                    end, take(xf, redo), take(zf, redo), take(tf, redo), take(wf, redo),
                    take(ef, redo), rtol, max_iter)
            out[0, redo], out[1, redo], out[2, redo], out[3, redo] = H, V, V_A, L
            ints[1, redo] = its
            status[redo] = st
            converged[redo] = st == CONVERGED
    else:
        status, converged = all_converged(n), all_true(n)
    H, V_B, V_A, L0, its = out[0], out[1], out[2], out[3], ints[1]
    if len(shape) != 1:
        H, V_B, V_A, L0 = (H.reshape(shape), V_B.reshape(shape), V_A.reshape(shape),
                           L0.reshape(shape))
        its, converged, status = its.reshape(shape), converged.reshape(shape), status.reshape(shape)
    return new_result(LengthResult, H=H, V_A=V_A, V_B=V_B, iterations=its,
                      converged=converged, status=status, L0=L0)


#: The serial length kernel's variant for float64 vectors and numbers ``w``, ``EA``.
_VECTORS_AND_NUMBERS = "solve_length_cables:numbers"
_SCALAR_NUMBERS = "solve_length_cables_scalar:numbers"
#: Fewer cables than two groups of lanes (:data:`catenary.solve.kernels_lanes.LANES` is
#: 8) are solved one at a time (the serial kernel the lanes are tested against bit for
#: bit, so the results are the same): a first call on a robot's cables (or three poses
#: of the study robot's four) compiles only the scalar steps (about 8 s on a 2-core
#: machine) and not the lanes (another 20 s). Per call (one run): 0.88-1.07x the lanes'
#: time for 1-7 cables, 1.13x for 12, 1.25x for 16 (a microsecond).
ONE_AT_A_TIME_BELOW = 16
_F64 = np.dtype(np.float64)
_ARRAY = np.ndarray
_ONE_FLOAT = (8,)


def _cable_vectors(x: ArrayLike, z: ArrayLike, tension: ArrayLike, w: ArrayLike,
                   EA: ArrayLike) -> int:
    """The number of cables where ``x``, ``z`` and ``tension`` are contiguous float64
    vectors of one length and ``w`` and ``EA`` numbers (floats), the call the kernel
    takes as it is; else 0."""
    if not (type(x) is _ARRAY and type(z) is _ARRAY and type(tension) is _ARRAY
            and isinstance(w, float) and isinstance(EA, float)):
        return 0
    # Strides of one float64 make a contiguous vector (cheaper to read than flags).
    if not (x.dtype is _F64 and z.dtype is _F64 and tension.dtype is _F64  # type: ignore[union-attr]
            and x.strides == z.strides == tension.strides == _ONE_FLOAT):  # type: ignore[union-attr]
        return 0
    n = x.shape[0]  # type: ignore[union-attr]
    return n if z.shape[0] == n and tension.shape[0] == n else 0  # type: ignore[union-attr]
