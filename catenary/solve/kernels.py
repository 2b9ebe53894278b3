"""Compiled (numba) kernels of the elastic catenary: the span equations of one cable,
the taut-branch Newton of :func:`catenary.solve.solve_length` and the Newton of
:func:`catenary.solve.solve_forces`, for one cable or many (in parallel).

The numpy implementations are the reference (:func:`catenary.elastic.evaluate`,
:mod:`catenary.solve.length_newton`, :mod:`catenary.solve.forces`): the same
nondimensional data (lengths over a power of two of the chord, forces over one of the
tension or force scale), formulas without cancellation, initial guess, Newton step,
safeguards, stopping rule and certificate (span residuals within ``RES_TOL`` of the
chord, end tension within ``T_TOL``). A cable the kernels do not settle that way
(vertical, weightless or zero-tension cables, a degenerate limit of the span formulas,
Newton not converging or leaving the taut branch, data beyond the double range) gets
the code :data:`FALLBACK`, and the caller solves it by the numpy path, whose closed
forms and bracketing searches cover every case; data the numpy path rejects get
:data:`INVALID`. Over a batch, :func:`solve_length_cables` also decides the cables
whose tension no catenary through both ends carries (:data:`INFEASIBLE`) and finds the
taut root of the ones Newton leaves, from the family of cables with that end tension
(:mod:`catenary.solve.kernels_bracket`). This module (and that one) import numpy and
numba only; numba compiles them on first use and keeps the machine code on disk
(``cache=True``; numba checks a cached function against its own module only, so a
change to ``kernels_bracket`` alone needs this module's cache cleared).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from .kernels_bracket import FEASIBLE, family_decision
from .kernels_bracket import INFEASIBLE as NO_MEMBER

__all__ = ["CONVERGED", "FALLBACK", "INFEASIBLE", "INVALID", "PARALLEL_FROM", "hypot",
           "solve_forces_batch", "solve_forces_cables", "solve_forces_cables_parallel",
           "solve_forces_one", "solve_length_cables", "solve_length_cables_parallel",
           "solve_length_one", "solve_length_serial", "spans_one"]

#: Codes of the solvers: certified, to be solved by the numpy path, invalid data, no
#: catenary through both ends carries the prescribed tension.
CONVERGED, FALLBACK, INVALID, INFEASIBLE = 0, 1, 2, 3
#: Cables from which a batch runs in parallel (below, waking threads costs more than
#: the work).
PARALLEL_FROM = 2048
RES_TOL = 1e-8
EPS = float(np.finfo(np.float64).eps)
T_TOL = 1e-9
_SERIES_CUT = 0.1
_SMALLEST_NORMAL = 2.0**-1022
_LARGEST_POWER = 2.0**1023
_ASINHC_M1 = np.array([-1 / 6, 3 / 40, -5 / 112, 35 / 1152, -63 / 2816, 231 / 13312,
                       -143 / 10240, 6435 / 557056])
_G_SERIES = np.array([1 / 3, -3 / 10, 15 / 56, -35 / 144, 315 / 1408, -693 / 3328,
                      1001 / 5120, -6435 / 34816])


#: Magnitudes between which ``sqrt(a * a + b * b)`` neither overflows nor loses the
#: larger square to underflow (:func:`hypot`).
_SQUARES_SAFE = (1e-150, 1e150)


@njit(cache=True, error_model="numpy", inline="always")
def hypot(a: float, b: float) -> float:
    """``sqrt(a^2 + b^2)`` as :func:`math.hypot` to rounding; a square root where the
    squares are safe (the solves' nondimensional data always are), else libm's
    ``hypot``, a call several times as long. NaN and inf as :func:`math.hypot`."""
    big = max(abs(a), abs(b))
    if _SQUARES_SAFE[0] < big < _SQUARES_SAFE[1]:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@njit(cache=True, error_model="numpy", inline="always")
def _poly(coeffs: NDArray, u2: float) -> float:
    acc = coeffs[-1]
    for k in range(coeffs.size - 2, -1, -1):
        acc = acc * u2 + coeffs[k]
    return acc


@njit(cache=True, error_model="numpy", inline="always")
def _g(a: float) -> float:
    """``asinh(a) - a / sqrt(1 + a^2)`` without cancellation."""
    a2 = a * a
    if abs(a) < _SERIES_CUT:
        return a * a2 * _poly(_G_SERIES, a2)
    return math.asinh(a) - math.copysign(1.0, a) / math.sqrt(1.0 + 1.0 / a2)


@njit(cache=True, error_model="numpy", inline="always")
def _spans(H: float, V_B: float, L0: float, w: float, inv_EA: float, fast: bool
           ) -> tuple[float, float, float, float, float, float, float, float, bool, bool]:
    """The spans part of :func:`spans_one`: ``(x, z, V_A, T_A, T_B, rho, qm1, S,
    opposite, regular)`` (``qm1`` only where not ``opposite``: it is not needed there).
    ``fast``: the end tensions by :func:`hypot` (the length solve, on nondimensional
    data), else by libm's (the force solve: near a taut inextensible cable its forces
    follow the last bit of the tensions, and the numpy path's iterations with them)."""
    wL = w * L0
    V_A = V_B - wL
    if fast:
        T_A, T_B = hypot(H, V_A), hypot(H, V_B)
    else:
        T_A, T_B = math.hypot(H, V_A), math.hypot(H, V_B)
    S, TS = V_A + V_B, T_A + T_B
    rho = S / (V_B * T_A + V_A * T_B)
    HL = H * L0
    opposite = V_A < 0.0 and V_B > 0.0
    qm1 = 0.0
    if opposite:
        x_c = H / w * (math.asinh(V_B / H) - math.asinh(V_A / H))
    else:
        u = wL * rho
        if abs(u) < _SERIES_CUT:
            qm1 = u * u * _poly(_ASINHC_M1, u * u)
            q = 1.0 + qm1
        else:
            q = math.asinh(u) / u
            qm1 = q - 1.0
        x_c = HL * rho * q
    z_c = L0 * S / TS
    regular = math.isfinite(x_c) and H != 0.0 and not abs(S) < 1e-150 * H
    x = HL * inv_EA + x_c
    z = 0.5 * L0 * S * inv_EA + z_c
    return x, z, V_A, T_A, T_B, rho, qm1, S, opposite, regular


@njit(cache=True, error_model="numpy", inline="always")
def spans_one(H: float, V_B: float, L0: float, w: float, inv_EA: float
              ) -> tuple[float, float, float, float, float, float, float, bool]:
    """Spans, flexibility and end tensions of one cable, ``(x, z, F_xx, F_xz, F_zz,
    T_A, T_B, regular)`` (:func:`catenary.elastic.evaluate`); ``regular`` is False
    at the degenerate limits (vertical cable, ``|V_A + V_B| << H``), which the numpy
    path handles."""
    return _spans_flex(H, V_B, L0, w, inv_EA, False)


@njit(cache=True, error_model="numpy", inline="always")
def _spans_flex(H: float, V_B: float, L0: float, w: float, inv_EA: float, fast: bool
                ) -> tuple[float, float, float, float, float, float, float, bool]:
    """:func:`spans_one`, the end tensions as :func:`_spans` computes them with
    ``fast``."""
    x, z, V_A, T_A, T_B, rho, qm1, S, opposite, regular = _spans(H, V_B, L0, w, inv_EA,
                                                                  fast)
    TS, HL = T_A + T_B, H * L0
    TT, H2 = T_A * T_B, H * H
    F_xz = -HL * S / (TT * TS)
    VA2, VB2 = V_A * V_A, V_B * V_B
    prod_m_h2 = (H2 * (VA2 + VB2) + VA2 * VB2) / (TT + H2)
    Lrho = L0 * rho
    F_xx = Lrho * (qm1 + prod_m_h2 / TT)
    F_zz = H2 * Lrho / TT
    if opposite:
        F_xx = (_g(V_B / H) + _g(-V_A / H)) / w
        F_zz = (V_B / T_B - V_A / T_A) / w
    base = L0 * inv_EA
    return x, z, base + F_xx, F_xz, base + F_zz, T_A, T_B, regular


@njit(cache=True, error_model="numpy", inline="always")
def _clip(a: float, lo: float, hi: float) -> float:
    """``numpy.clip`` of one number (NaN stays NaN)."""
    if a != a:
        return a
    return min(max(a, lo), hi)


@njit(cache=True, error_model="numpy", inline="always")
def _nanmax(a: float, b: float) -> float:
    """``numpy.maximum`` of two numbers (NaN if either is)."""
    if a != a or b != b:
        return np.nan
    return max(a, b)


@njit(cache=True, error_model="numpy", inline="always")
def _power_of_two(scale: float) -> float:
    """:func:`catenary.elastic.power_of_two` of one number: ``p <= |scale| < 2 p``,
    within ``[2**-1022, 2**1023]``."""
    a = abs(scale)
    if not a < np.inf:
        return _LARGEST_POWER
    if not a >= _SMALLEST_NORMAL:
        return _SMALLEST_NORMAL
    return math.ldexp(1.0, math.frexp(a)[1] - 1)


@njit(cache=True, error_model="numpy", inline="always")
def _initial(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float
             ) -> tuple[float, float, float]:
    """Near-straight guess ``(p, q, L0)`` (``_initial_length`` of
    :mod:`catenary.solve.length_newton`)."""
    c = hypot(x, z)
    cos_t, sin_t = x / c, z / c
    Tm = _nanmax(T - 0.5 * w * z if at_b else T + 0.5 * w * z, 0.5 * T)
    t = 0.5 * w * x / Tm
    Ls = c + (t * t) * (c / 6.0)
    L0 = Ls / (1.0 + Tm * inv_EA)
    if not at_b:
        t = -t
    r = 1.0 / math.sqrt(1.0 + t * t)
    p = (cos_t - t * sin_t) * r
    q = (sin_t + t * cos_t) * r
    if p < 0.01:
        p, q = 0.01, math.copysign(math.sqrt(1.0 - 1e-4), q)
    return p, q, L0


@njit(cache=True, error_model="numpy", inline="always")
def _newton_length(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                   rtol: float, max_iter: int
                   ) -> tuple[float, float, float, bool, int, bool]:
    """Newton in (end angle, ``L0``) on nondimensional data, as
    :func:`catenary.solve.length_newton.newton_length`: ``(p, q, L0, converged,
    iterations, regular)``; not converged, and not ``regular``, also where the span
    formulas reach a limit (which the numpy path's Newton passes)."""
    p, q, l0 = _initial(at_b, x, z, T, w, inv_EA)
    return _newton_from(at_b, x, z, T, w, inv_EA, p, q, l0, rtol, max_iter)


@njit(cache=True, error_model="numpy", inline="always")
def _newton_from(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                 p: float, q: float, l0: float, rtol: float, max_iter: int
                 ) -> tuple[float, float, float, bool, int, bool]:
    """:func:`_newton_length` from the start ``(p, q, l0)``."""
    tol = RES_TOL * hypot(x, z)
    for its in range(1, max_iter + 1):
        h = T * p
        v = T * q if at_b else T * q + w * l0
        va = v - w * l0 if at_b else T * q
        xs, zs, fxx, fxz, fzz, ta, tb, regular = _spans_flex(h, v, l0, w, inv_EA, True)
        if not regular:
            return p, q, l0, False, its, False
        rx, rz = xs - x, zs - z
        if at_b:
            xp, zp = h * fxz - v * fxx, h * fzz - v * fxz
            kk = 1.0 / ta + inv_EA
            xl, zl = h * kk, (v - w * l0) * kk
        else:
            xp, zp = h * fxz - va * fxx, h * fzz - va * fxz
            kk = 1.0 / tb + inv_EA
            xl, zl = h * kk, v * kk
        det = xp * zl - xl * zp
        dp = (xl * rz - zl * rx) / det
        dl = (zp * rx - xp * rz) / det
        ln = _clip(l0 + dl, 0.5 * l0, 2.0 * l0)
        if dp * q > 0.9 * p:  # keep H > 0
            dp = 0.9 * p / q
        r = 1.0 / math.sqrt(1.0 + dp * dp)
        pn, qn = (p - dp * q) * r, (q + dp * p) * r
        small = abs(dp) <= rtol and abs(dl) <= rtol * l0
        fit = abs(rx) <= tol and abs(rz) <= tol
        if not (math.isfinite(pn) and math.isfinite(qn) and math.isfinite(ln)):
            return p, q, l0, False, its, True
        p, q, l0 = pn, qn, ln
        if small:  # the taut branch has det < 0 at its root
            return p, q, l0, fit and det < 0.0, its, True
    return p, q, l0, False, max_iter, True


@njit(cache=True, error_model="numpy")
def solve_length_one(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                     rtol: float, max_iter: int, out: NDArray) -> int:
    """Taut catenary of one cable with tension ``T`` (N) at end B (``at_b``) or A.

    In units of the chord and of ``T`` (powers of two, as the numpy path), Newton from
    the near-straight guess, then the certificate. ``out`` (5,) gets ``(H, V_B, V_A,
    L0, iterations)`` (N, N, N, m) where solved. Returns :data:`CONVERGED` (certified)
    or :data:`FALLBACK`.
    """
    code, H, V_B, V_A, L0, its = _length_values(at_b, x, z, T, w, inv_EA, rtol, max_iter,
                                                False)
    if code == CONVERGED:
        out[0], out[1], out[2], out[3], out[4] = H, V_B, V_A, L0, its
    return code


@njit(cache=True, error_model="numpy", inline="always")
def _length_values(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                   rtol: float, max_iter: int, decide: bool
                   ) -> tuple[int, float, float, float, float, int]:
    """:func:`solve_length_one` as ``(code, H, V_B, V_A, L0, iterations)``; with
    ``decide`` the family of the cable decides (:mod:`catenary.solve.kernels_bracket`)
    the data too light to be held, before Newton, and the cables Newton leaves:
    :data:`INFEASIBLE` (0 iterations, as the numpy path), or the taut member polished
    by the same Newton (its iterations added), the numpy path's bracketing search and
    polish."""
    nan = np.nan
    if not (x > 0.0 and T > 0.0 and 0.0 <= w < np.inf and 0.0 <= inv_EA < np.inf
            and math.isfinite(x) and math.isfinite(z) and math.isfinite(T)):
        return FALLBACK, nan, nan, nan, nan, 0  # the numpy path decides
    ell, F = _power_of_two(hypot(x, z)), _power_of_two(T)
    xs, zs, Ts = x / ell, z / ell, T / F
    ws, ies = (w / F) * ell, inv_EA * F
    if not math.isfinite(ws * ies):
        return FALLBACK, nan, nan, nan, nan, 0
    decide = decide and ws > 0.0
    if decide and family_decision(at_b, xs, zs, Ts, ws, ies, False)[0] == NO_MEMBER:
        return INFEASIBLE, nan, nan, nan, nan, 0
    p, q, l0, converged, its, regular = _newton_length(at_b, xs, zs, Ts, ws, ies, rtol,
                                                      max_iter)
    if not converged and decide and regular:  # where the numpy path brackets
        outcome, p, q, l0 = family_decision(at_b, xs, zs, Ts, ws, ies, True)
        if outcome == NO_MEMBER:
            return INFEASIBLE, nan, nan, nan, nan, 0
        if outcome == FEASIBLE:  # polished as the numpy path's bracketed roots
            start = l0
            p, q, l0, converged, polish, _ = _newton_from(at_b, xs, zs, Ts, ws, ies, p,
                                                          q, l0, rtol, max_iter)
            its += polish
            converged = converged and abs(l0 - start) <= 1e-6 * start
    if not converged:
        return FALLBACK, nan, nan, nan, nan, its
    H = Ts * p
    V_A = Ts * q if not at_b else Ts * q - ws * l0
    V_B = Ts * q if at_b else V_A + ws * l0
    if not _certified(at_b, xs, zs, Ts, ws, ies, H, V_B, V_A, l0):
        return FALLBACK, nan, nan, nan, nan, its
    H, V_B, V_A, l0 = H * F, V_B * F, V_A * F, l0 * ell
    if not (math.isfinite(H) and math.isfinite(V_B) and math.isfinite(V_A)
            and math.isfinite(l0) and l0 > 0.0):
        return FALLBACK, nan, nan, nan, nan, its
    return CONVERGED, H, V_B, V_A, l0, its


@njit(cache=True, error_model="numpy", inline="always")
def _certified(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
               H: float, V_B: float, V_A: float, L0: float) -> bool:
    """The certificate of ``_certify_length`` (:mod:`catenary.solve.length`), in the
    nondimensional units of the solve (the same test: the units are powers of two)."""
    got = hypot(H, V_B) if at_b else hypot(H, V_A)
    if not (abs(got - T) <= T_TOL * T and math.isfinite(V_A)):
        return False
    if not (math.isfinite(H) and math.isfinite(V_B) and math.isfinite(L0) and H >= 0
            and L0 > 0):
        return False
    xs, zs = _spans(H, V_B, L0, w, inv_EA, True)[:2]
    tol = RES_TOL * hypot(x, z)
    return abs(xs - x) <= tol and abs(zs - z) <= tol


@njit(cache=True, error_model="numpy", inline="always")
def _valid(x: float, z: float, third: float, w: float, EA: float, length: bool) -> bool:
    """The checks of :func:`catenary.solve.common.prepare`: ``x, w >= 0`` finite, ``z``
    finite, the tension ``>= 0`` finite (``length``) or ``L0 > 0`` finite, ``EA > 0``
    (``inf`` allowed)."""
    third_ok = (third >= 0.0) if length else (third > 0.0)
    return (0.0 <= x < np.inf and -np.inf < z < np.inf and third_ok and third < np.inf
            and 0.0 <= w < np.inf and EA > 0.0)


@njit(cache=True, error_model="numpy")
def solve_length_cables(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                       EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                       ints: NDArray) -> int:
    """:func:`solve_length_one` over ``n = out.shape[1]`` cables in the calling thread.

    ``x, z, T, w, EA`` have ``n`` entries or one (the same for every cable). ``out``
    (4, n) gets rows ``(H, V_B, V_A, L0)``; ``ints`` (2, n) the code
    (:data:`CONVERGED`, :data:`INFEASIBLE`, :data:`FALLBACK`, or :data:`INVALID` for
    data the numpy path rejects) and the iterations. Beyond :func:`solve_length_one`,
    the family of each cable decides infeasible data (before Newton where a bound
    shows it) and the taut root of cables Newton does not settle. Returns the number
    of cables not :data:`CONVERGED`.
    """
    unsettled = 0
    for i in range(out.shape[1]):
        unsettled += _length_entry(at_b, x, z, T, w, EA, rtol, max_iter, out, ints, i)
    return unsettled


@njit(cache=True, error_model="numpy", parallel=True)
def solve_length_cables_parallel(at_b: bool, x: NDArray, z: NDArray, T: NDArray,
                                 w: NDArray, EA: NDArray, rtol: float, max_iter: int,
                                 out: NDArray, ints: NDArray) -> int:
    """:func:`solve_length_cables` over threads (a separate kernel: calling one compiled
    with ``parallel=True`` starts numba's threading layer, which a forked child of the
    process could not use)."""
    unsettled = 0
    for k in prange(out.shape[1]):
        # An int64 index: the serial kernel's compiled _length_entry serves (a prange
        # index is unsigned, and compiling another costs seconds).
        unsettled += _length_entry(at_b, x, z, T, w, EA, rtol, max_iter, out, ints,
                                   np.int64(k))
    return unsettled


@njit(cache=True, error_model="numpy")
def _length_entry(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                  EA: NDArray, rtol: float, max_iter: int, out: NDArray, ints: NDArray,
                  k: int) -> int:
    """Cable ``k`` of :func:`solve_length_cables`; 1 if not :data:`CONVERGED`, else 0."""
    j = np.int64(k)  # a prange index is unsigned: mixed with 0 it would become a float
    xk, zk, Tk = x[j if x.size > 1 else 0], z[j if z.size > 1 else 0], T[j if T.size > 1 else 0]
    wk, EAk = w[j if w.size > 1 else 0], EA[j if EA.size > 1 else 0]
    if not _valid(xk, zk, Tk, wk, EAk, True):
        ints[0, k], ints[1, k] = INVALID, 0
        return 1
    code, H, V_B, V_A, L0, its = _length_values(at_b, xk, zk, Tk, wk, 1.0 / EAk, rtol,
                                                max_iter, True)
    ints[0, k], ints[1, k] = code, its
    out[0, k], out[1, k], out[2, k], out[3, k] = H, V_B, V_A, L0
    return 0 if code == CONVERGED else 1


@njit(cache=True, error_model="numpy")
def _initial_forces(x: float, z: float, L0: float, w: float, inv_EA: float
                    ) -> tuple[float, float]:
    """Closed-form guess of ``(H, V_B)`` (:func:`catenary.solve.forces._initial_forces`):
    a parabolic cable along the chord, or the inextensible catenary of this length
    where the cable is well longer than its chord."""
    c = math.hypot(x, z)
    cos_t, sin_t = x / c, z / c
    e = L0 - c
    k = (w * cos_t) ** 2 * c ** 3 / 24.0
    a = L0 * inv_EA
    t_up = max(-e, 0.0) / a + np.cbrt(k / a)
    t_inext = math.sqrt(k / e) if e > 0 else np.nan
    T = t_up
    if e > 0:  # numpy.fmin: the other one where one is NaN
        T = t_inext if t_up != t_up else (t_up if t_inext != t_inext else min(t_up, t_inext))
    for _ in range(12):
        p = a * T ** 3 + e * T ** 2 - k
        dp = 3 * a * T ** 2 + 2 * e * T
        if dp > 0:
            T = T - p / dp
    H = T * cos_t
    V = T * sin_t + 0.5 * w * L0
    if e > 1e-3 * c:  # deeper sag: the inextensible catenary with this length
        R = math.sqrt(L0 - z) * math.sqrt(L0 + z) / x
        logR = math.log(R)
        lam = _nanmax(math.sqrt(6.0 * (R - 1.0)), logR + math.log(2.0 * logR + 2.0))
        if R < 1.2:
            lam = math.sqrt(6.0 * (R - 1.0))
        for _ in range(30):
            lsh = lam + math.log1p(-math.exp(-2.0 * lam)) - math.log(2.0) - math.log(lam)
            d = 1.0 / math.tanh(lam) - 1.0 / lam
            lam = _nanmax(lam - (lsh - logR) / d, 0.5 * lam)
        Hs = w * x / (2.0 * lam)
        Vs = 0.5 * w * (z / math.tanh(lam) + L0)
        if math.isfinite(Hs):
            H = Hs
        if math.isfinite(Vs):
            V = Vs
    return H, V


@njit(cache=True, error_model="numpy")
def _newton_forces(x: float, z: float, L0: float, w: float, inv_EA: float, H: float,
                   V: float, rtol: float, max_iter: int) -> tuple[float, float, bool, int]:
    """Safeguarded Newton on the span equations of one cable
    (:func:`catenary.solve.forces._newton_forces`): ``(H, V_B, converged, iterations)``;
    iterations -1 where the span formulas reach a limit the numpy path handles."""
    its = 0
    tol = RES_TOL * math.hypot(x, z)
    for _ in range(max_iter):
        xs, zs, fxx, fxz, fzz, _, _, regular = spans_one(H, V, L0, w, inv_EA)
        if not regular:
            return H, V, False, -1
        rx, rz = xs - x, zs - z
        det = fxx * fzz - fxz * fxz
        dh = -(fzz * rx - fxz * rz) / det
        dv = -(fxx * rz - fxz * rx) / det
        its += 1
        hn = _clip(H + dh, 0.1 * H, 10.0 * H)
        fscale = math.hypot(H, V) + w * L0
        vn = V + _clip(dv, -10 * fscale, 10 * fscale)
        ok = math.isfinite(hn) and math.isfinite(vn)
        small_step = abs(dh) <= rtol * H and abs(dv) <= rtol * fscale
        tiny_res = (abs(rx) <= 2 * EPS * (x + L0)) and (abs(rz) <= 2 * EPS * (abs(z) + L0))
        if ok:
            H, V = hn, vn
        fit = abs(rx) <= tol and abs(rz) <= tol
        if ok and fit and (small_step or tiny_res):
            return H, V, True, its
        if not ok or (small_step and not fit):
            return H, V, False, its
    return H, V, False, its


@njit(cache=True, error_model="numpy")
def solve_forces_one(x: float, z: float, L0: float, w: float, inv_EA: float, rtol: float,
                     max_iter: int, out: NDArray) -> int:
    """End forces of one cable of unstretched length ``L0`` (m) (forward problem).

    The general case of :func:`catenary.solve.forces.solve_forces_flat` (``x > 0``,
    ``w > 0``, a feasible length): nondimensional data (lengths over a power of two of
    the chord, forces over one of the force scale), closed-form guess, Newton,
    certificate. ``out`` (4,) gets ``(H, V_B, V_A, iterations)`` (N) where solved.
    Returns :data:`CONVERGED` (certified) or :data:`FALLBACK` (the numpy path decides:
    weightless, vertical, infeasible, invalid data, Newton not converging).
    """
    code, H, V, its = _forces_values(x, z, L0, w, inv_EA, rtol, max_iter)
    if code == CONVERGED:
        out[0], out[1], out[2], out[3] = H, V, V - w * L0, its
    return code


@njit(cache=True, error_model="numpy")
def _forces_values(x: float, z: float, L0: float, w: float, inv_EA: float, rtol: float,
                   max_iter: int) -> tuple[int, float, float, int]:
    """:func:`solve_forces_one` as ``(code, H, V_B, iterations)``."""
    nan = np.nan
    if not (math.isfinite(x) and math.isfinite(z) and math.isfinite(L0) and L0 > 0.0
            and 0.0 < w < np.inf and 0.0 <= inv_EA < np.inf):
        return FALLBACK, nan, nan, 0
    c = math.hypot(x, z)
    if not x > 1e-15 * c or (inv_EA == 0.0 and L0 <= c):
        return FALLBACK, nan, nan, 0
    stretching = (c - L0) / (L0 * inv_EA) if c > L0 else 0.0
    force_scale = _nanmax(w * max(c, L0), stretching)
    ell, F = _power_of_two(c), _power_of_two(force_scale)
    ws, ies = (w / F) * ell, inv_EA * F
    if not (math.isfinite(force_scale) and math.isfinite(ws * ies)):
        return FALLBACK, nan, nan, 0
    xs, zs, Ls = x / ell, z / ell, L0 / ell
    H0, V0 = _initial_forces(xs, zs, Ls, ws, ies)
    H, V, converged, its = _newton_forces(xs, zs, Ls, ws, ies, H0, V0, rtol, max_iter)
    if not converged:
        return FALLBACK, nan, nan, max(its, 0)
    H, V = H * F, V * F
    if not (math.isfinite(H) and math.isfinite(V) and H >= 0.0):
        return FALLBACK, nan, nan, its
    xc, zc = _spans(H, V, L0, w, inv_EA, False)[:2]
    tol = RES_TOL * c
    if not (abs(xc - x) <= tol and abs(zc - z) <= tol):
        return FALLBACK, nan, nan, its
    return CONVERGED, H, V, its


@njit(cache=True, error_model="numpy")
def solve_forces_cables(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, EA: NDArray,
                       rtol: float, max_iter: int, out: NDArray, ints: NDArray) -> int:
    """:func:`solve_forces_one` over ``n = out.shape[1]`` cables in the calling thread.

    ``x, z, L0, w, EA`` have ``n`` entries or one. ``out`` (3, n) gets rows ``(H, V_B,
    V_A)``; ``ints`` (2, n) the code (:data:`CONVERGED`, :data:`FALLBACK`,
    :data:`INVALID`) and the iterations. Returns the number of cables not
    :data:`CONVERGED`.
    """
    unsettled = 0
    for i in range(out.shape[1]):
        unsettled += _forces_entry(x, z, L0, w, EA, rtol, max_iter, out, ints, i)
    return unsettled


@njit(cache=True, error_model="numpy", parallel=True)
def solve_forces_cables_parallel(x: NDArray, z: NDArray, L0: NDArray, w: NDArray,
                                 EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                                 ints: NDArray) -> int:
    """:func:`solve_forces_cables` over threads (see :func:`solve_length_cables_parallel`)."""
    unsettled = 0
    for k in prange(out.shape[1]):
        unsettled += _forces_entry(x, z, L0, w, EA, rtol, max_iter, out, ints, np.int64(k))
    return unsettled


@njit(cache=True, error_model="numpy")
def _forces_entry(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, EA: NDArray,
                  rtol: float, max_iter: int, out: NDArray, ints: NDArray, k: int) -> int:
    """Cable ``k`` of :func:`solve_forces_cables`; 1 if not :data:`CONVERGED`, else 0."""
    j = np.int64(k)  # a prange index is unsigned: mixed with 0 it would become a float
    xk, zk, Lk = x[j if x.size > 1 else 0], z[j if z.size > 1 else 0], L0[j if L0.size > 1 else 0]
    wk, EAk = w[j if w.size > 1 else 0], EA[j if EA.size > 1 else 0]
    if not _valid(xk, zk, Lk, wk, EAk, False):
        ints[0, k], ints[1, k] = INVALID, 0
        return 1
    code, H, V, its = _forces_values(xk, zk, Lk, wk, 1.0 / EAk, rtol, max_iter)
    ints[0, k], ints[1, k] = code, its
    out[0, k], out[1, k], out[2, k] = H, V, V - wk * Lk
    return 0 if code == CONVERGED else 1


@njit(cache=True, error_model="numpy")
def solve_length_serial(at_b: bool, x: NDArray, z: NDArray, T: NDArray, w: NDArray,
                        inv_EA: NDArray, rtol: float, max_iter: int, out: NDArray,
                        codes: NDArray) -> None:
    """:func:`solve_length_one` over flat cables (K,) given their compliance, in the
    calling thread; ``out`` (K, 5), ``codes`` (K,) (the kernel alone, for timings)."""
    for k in range(x.size):
        codes[k] = solve_length_one(at_b, x[k], z[k], T[k], w[k], inv_EA[k], rtol,
                                    max_iter, out[k])


@njit(cache=True, error_model="numpy")
def solve_forces_batch(x: NDArray, z: NDArray, L0: NDArray, w: NDArray, inv_EA: NDArray,
                       rtol: float, max_iter: int, out: NDArray, codes: NDArray,
                       parallel: bool) -> None:
    """:func:`solve_forces_one` over flat cables (K,) given their compliance, in the
    calling thread; ``out`` (K, 4), ``codes`` (K,) (the kernel alone, for timings;
    ``parallel`` is ignored)."""
    for k in range(x.size):
        codes[k] = solve_forces_one(x[k], z[k], L0[k], w[k], inv_EA[k], rtol, max_iter,
                                    out[k])
