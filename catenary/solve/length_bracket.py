"""Bracketing search for the unstretched length of a prescribed tension.

The slow but sure fallback of :func:`catenary.solve.solve_length`, built on
the forward solver: it finds the taut root for the cables Newton cannot
finish and detects infeasible data.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..elastic import axial_compliance
from .common import CONVERGED, INFEASIBLE, NOT_CONVERGED, STATUS_DTYPE, FloatArray
from .forces import solve_forces_flat

__all__ = ["bracket_length", "end_tension"]

# Golden-section ratio.
_GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)


def end_tension(
    end: str, H: FloatArray, V: FloatArray, L0: FloatArray, w: FloatArray
) -> FloatArray:
    """The tension that ``end`` prescribes (N), from the end forces.

    Parameters
    ----------
    end : {"B", "A", "H"}
        Tension magnitude at end B, at end A, or the horizontal tension.
    H, V : ndarray
        Horizontal tension and vertical component at end B (N).
    L0, w : ndarray
        Unstretched length (m) and weight per length (N/m).

    Returns
    -------
    ndarray
        Broadcast shape of the arguments (``H`` itself for ``end="H"``).
    """
    if end == "B":
        return np.hypot(H, V)
    if end == "A":
        return np.hypot(H, V - w * L0)
    return H


class _TensionOfLength:
    """End tension (N) of cables of given length at fixed geometry, by the forward solver.

    NaN where the forward solver does not converge; its iterations are
    counted per cable in ``its``.
    """

    def __init__(
        self, end: str, x: FloatArray, z: FloatArray, w: FloatArray, EA: FloatArray
    ) -> None:
        self.end, self.x, self.z, self.w, self.EA = end, x, z, w, EA
        self.its = np.zeros(x.size, np.int64)

    def __call__(self, L: FloatArray, j: NDArray[np.intp]) -> FloatArray:
        H, V, it, conv, _ = solve_forces_flat(
            self.x[j], self.z[j], L, self.w[j], self.EA[j], 1e-9, 30
        )
        self.its[j] += it
        return np.where(conv, end_tension(self.end, H, V, L, self.w[j]), np.nan)


def _taut_start(
    tens: _TensionOfLength, T: FloatArray, inv_EA: FloatArray, c: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Length scale ``Lt`` (m) and ``s_lo`` with tension above ``T`` at ``Lt exp(s_lo)``.

    ``Lt`` is the taut limit (the chord for an inextensible cable);
    ``s_lo`` moves towards it until the tension exceeds ``T``.
    """
    all_idx = np.arange(T.size)
    Lt = c / (1.0 + 4.0 * T * inv_EA + 1e-12 * (inv_EA > 0))
    Lt = np.where(inv_EA > 0, Lt, c)
    s_lo = np.full(T.size, 1e-3)
    s_lo = np.where(inv_EA > 0, 0.0, s_lo)
    for _ in range(60):
        Tl = tens(Lt * np.exp(s_lo), all_idx)
        bad = ~(Tl > T)
        if not np.any(bad):
            break
        s_lo = np.where(bad & (inv_EA == 0), 0.01 * s_lo, s_lo)
        Lt = np.where(bad & (inv_EA > 0), Lt * 0.9, Lt)
    return Lt, s_lo


def _golden_section_below(
    tens: _TensionOfLength,
    T: FloatArray,
    w: FloatArray,
    c: FloatArray,
    Lt: FloatArray,
    s_lo: FloatArray,
) -> tuple[NDArray[np.bool_], FloatArray]:
    """``(found, s_m)``: a log length excess ``s_m`` with tension at most ``T``.

    Golden-section search for the minimum tension over ``s`` above
    ``s_lo``, stopped per cable once a tension at most ``T`` is seen;
    ``found`` is false where the minimum exceeds ``T`` (infeasible).
    """
    all_idx = np.arange(T.size)
    s_hi = np.log(np.maximum(2.0 * T / np.maximum(w, 1e-300) + 2 * c, 4 * c) / Lt) + 1.0
    s_hi = np.maximum(s_hi, s_lo + 1.0)
    a, b = s_lo.copy(), s_hi.copy()
    g = _GOLDEN
    found = np.zeros(T.size, bool)
    s_m = b.copy()
    p1, p2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = tens(Lt * np.exp(p1), all_idx), tens(Lt * np.exp(p2), all_idx)
    for _ in range(80):
        hit1, hit2 = f1 <= T, f2 <= T
        newly = ~found & (hit1 | hit2)
        s_m = np.where(newly, np.where(hit1, p1, p2), s_m)
        found |= newly
        if np.all(found):
            break
        left = f1 < f2
        b = np.where(left, p2, b)
        a = np.where(left, a, p1)
        p1, p2 = b - g * (b - a), a + g * (b - a)
        idx = np.flatnonzero(~found)
        f1n, f2n = f1.copy(), f2.copy()
        f1n[idx] = tens(Lt[idx] * np.exp(p1[idx]), idx)
        f2n[idx] = tens(Lt[idx] * np.exp(p2[idx]), idx)
        f1, f2 = f1n, f2n
    return found, s_m


def _bisect_taut_root(
    tens: _TensionOfLength,
    T: FloatArray,
    Lt: FloatArray,
    s_lo: FloatArray,
    s_m: FloatArray,
    found: NDArray[np.bool_],
) -> FloatArray:
    """Length (m) of tension ``T`` by bisection in ``s`` on ``[s_lo, s_m]`` where ``found``."""
    lo, hi = s_lo.copy(), s_m.copy()
    fi = np.flatnonzero(found)
    for _ in range(200):
        if fi.size == 0:
            break
        mid = 0.5 * (lo[fi] + hi[fi])
        Tm = tens(Lt[fi] * np.exp(mid), fi)
        above = Tm > T[fi]
        lo[fi] = np.where(above, mid, lo[fi])
        hi[fi] = np.where(above, hi[fi], mid)
        fi = fi[np.abs(hi[fi] - lo[fi]) > 1e-15 * (1 + np.abs(lo[fi]))]
    return Lt * np.exp(0.5 * (lo + hi))


def bracket_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    EA: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_], NDArray[np.int64]]:
    """Bracketing solve in L0 using the forward solver (slow but sure).

    The end tension as a function of L0 (at fixed geometry) falls from
    infinity at the taut limit to a minimum and rises again (for ``end="H"``
    it falls monotonically). The taut root lies between a length with tension
    above T (found by moving towards the taut limit) and one with tension at
    most T (found by golden-section search for the minimum); if the minimum
    tension exceeds T the data are infeasible. The root is then bracketed
    with bisection on log of the length excess.

    Parameters
    ----------
    end : {"B", "A", "H"}
        Which tension is prescribed (see :func:`catenary.solve.solve_length`).
    x, z, T, w, EA : ndarray, shape ``(n,)``
        Checked spans (m, ``x > 0``), prescribed tension (N, ``> 0``),
        weight per length (N/m) and axial stiffness (N).

    Returns
    -------
    H, V_B, L0 : ndarray, shape ``(n,)``
        End forces (N) and length (m), NaN unless the status is ``"converged"``.
    status : ndarray of str, shape ``(n,)``
        ``"converged"``, ``"infeasible"`` or ``"not_converged"``.
    iterations : ndarray of int, shape ``(n,)``
        Forward-solver iterations spent per cable.
    """
    inv_EA = axial_compliance(EA)
    c = np.hypot(x, z)
    tens = _TensionOfLength(end, x, z, w, EA)
    Lt, s_lo = _taut_start(tens, T, inv_EA, c)
    found, s_m = _golden_section_below(tens, T, w, c, Lt, s_lo)
    status = np.where(found, CONVERGED, INFEASIBLE).astype(STATUS_DTYPE)
    L = _bisect_taut_root(tens, T, Lt, s_lo, s_m, found)
    H, V, _, conv, _ = solve_forces_flat(x, z, L, w, EA, 1e-9, 30)
    status = np.where(found & ~conv, NOT_CONVERGED, status)
    nan = status != CONVERGED
    return (
        np.where(nan, np.nan, H),
        np.where(nan, np.nan, V),
        np.where(nan, np.nan, L),
        status,
        tens.its,
    )
