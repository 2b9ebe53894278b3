"""Compiled (numba) length solve of many cables side by side in the vector unit: the
start, the Newton steps and the certificate of :mod:`catenary.solve.kernels`, written
for groups of :data:`LANES` cables.

Each stage is one loop over the lanes of a structure-of-arrays work array (field ``f``
of lane ``j`` at ``f * LANES + j``), over all :data:`LANES` lanes (a loop of a constant
count becomes vector code; one of a variable count did not), with the scalar code's
branches written as choices between values computed on both sides: the same operations
in the same order, so the same bits, and no call in the loop, which LLVM turns into
AVX-512 code. :func:`start_lanes` is ``kernels._length_start`` and ``kernels._initial``;
:func:`newton_lanes` runs ``kernels._newton_step`` in lockstep until every lane has
stopped; :func:`finish_lanes` is ``kernels._length_finish`` of a converged cable (its
certificate ``kernels._certified``). Where the scalar code would call libm (a
``hypot`` whose squares are unsafe, an ``asinh`` from ``1e100``, the two-``asinh`` span
of a cable with a low point and ``H`` below ``1e-150``) or decide a cable from its
family (``kernels_bracket``), the lane's code hands the cable back to the scalar code:
from its start (:data:`SCALAR`), for the family's screen (:data:`SCREEN`), or for the
finish (:data:`FINISH`). Imports numpy and numba only.
"""

from __future__ import annotations

import math

from numba import njit
from numpy.typing import NDArray

from .kernels_bracket import BAND, C_LEVEL
from .kernels_spans import (
    ASINH_LARGE,
    RES_TOL,
    SAFE_HIGH,
    SAFE_LOW,
    SERIES_CUT,
    T_TOL,
    asinh_series,
    g_series,
    log_fast,
    power_of_two,
    square,
    valid,
)

__all__ = ["CONVERGED", "DONE", "FALLBACK", "FIELDS", "FINISH", "GO_ON", "IDLE", "INFEASIBLE",
           "INVALID", "IRREGULAR", "LANES", "NEWTON", "REDO", "SCALAR", "SCREEN", "STOPPED",
           "at", "finish_lanes", "newton_lanes", "start_lanes"]

#: Cables per lockstep group.
LANES = 8
#: Outcomes of a lane (as :mod:`catenary.solve.kernels`' step outcomes), :data:`REDO`
#: (a step would call libm: the scalar path solves the cable) and :data:`IDLE` (no
#: cable in the lane).
GO_ON, DONE, STOPPED, IRREGULAR, REDO, IDLE = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0
#: Fields of the work array: the cable's data in units of the solve, the span
#: tolerance, the point ``(p, q, l0)``, the Newton outcome and iterations; the data as
#: given (``x, z, T, w, EA``), the units ``ell`` (m) and ``F`` (N), whether the family
#: decides the cable Newton leaves (1 or 0), the code of the lane and the results
#: ``(H, V_B, V_A, L0)`` (N, N, N, m).
(F_X, F_Z, F_T, F_W, F_IE, F_TOL, F_P, F_Q, F_L0, F_OUT, F_ITS, F_RX, F_RZ, F_RT, F_RW,
 F_REA, F_ELL, F_F, F_DECIDE, F_CODE, F_H, F_VB, F_VA, F_LEN) = range(24)
FIELDS = 24
#: Codes of a lane: those of :mod:`catenary.solve.kernels` (converged, to the numpy
#: path, invalid data, infeasible) and the lane's own: Newton to run, the family's
#: screen to run first (a scalar call), the scalar solve from the start, the scalar
#: finish after Newton (the family's decision, a certificate that would call libm).
CONVERGED, FALLBACK, INVALID, INFEASIBLE = 0.0, 1.0, 2.0, 3.0
NEWTON, SCREEN, SCALAR, FINISH = 4.0, 5.0, 6.0, 7.0


@njit(cache=True, inline="always")
def at(field: int, lane: int) -> int:
    """Index of field ``field`` of lane ``lane`` in the work array."""
    return field * LANES + lane


@njit(cache=True, error_model="numpy", inline="always")
def _fmax(a: float, b: float) -> float:
    """numba's ``max`` of two floats, written out (the builtin can stay a call)."""
    return b if b > a else a


@njit(cache=True, error_model="numpy", inline="always")
def _fmin(a: float, b: float) -> float:
    """numba's ``min`` of two floats, written out."""
    return b if b < a else a


@njit(cache=True, error_model="numpy", inline="always")
def _safe(a: float, b: float) -> bool:
    """Whether ``kernels_spans.hypot(a, b)`` takes its square root (not libm's)."""
    big = _fmax(abs(a), abs(b))
    return SAFE_LOW < big < SAFE_HIGH


@njit(cache=True, error_model="numpy", inline="always")
def _asinh(a: float) -> tuple[float, bool]:
    """:func:`~catenary.solve.kernels_spans.asinh_fast` and whether it would call libm (``|a|`` from
    ``1e100``, or NaN): both of its branches computed, the one it takes chosen."""
    b = abs(a)
    b2 = b * b
    series = b + b * b2 * asinh_series(b2)
    b2, b2_lo = square(b)
    t = 1.0 + b2
    t_lo = (((1.0 - t) + b2) if b2 < 1.0 else ((b2 - t) + 1.0)) + b2_lo
    s = math.sqrt(t)
    s2, s2_lo = square(s)
    s_lo = (((t - s2) - s2_lo) + t_lo) / (2.0 * s)
    y = b + s
    y_lo = ((s - y) + b) + s_lo
    r = series if b < SERIES_CUT else log_fast(y) + y_lo / y
    return math.copysign(r, a), not b < ASINH_LARGE


@njit(cache=True, error_model="numpy", inline="always")
def _g_pair(H: float, V_b: float, V_a: float, spread: float, r_b: float, r_a: float
            ) -> float:
    """``kernels_spans._g_pair``, its three cases computed and chosen."""
    small_b, small_a = V_b < SERIES_CUT * H, V_a < SERIES_CUT * H
    a, b = V_b / H, V_a / H
    both = a * a * a * g_series(a * a) + b * b * b * g_series(b * b)
    s = a if small_b else b
    r_l = r_a if small_b else r_b
    s2 = s * s
    ash_s = s + s * s2 * asinh_series(s2)
    one = s * s2 * g_series(s2) + ((spread - ash_s) - r_l)
    neither = spread - (r_b + r_a)
    return neither if not (small_b or small_a) else (both if small_b and small_a else one)


@njit(cache=True, error_model="numpy", inline="always")
def _spans_lane(H: float, V_B: float, L0: float, w: float, inv_EA: float
                ) -> tuple[float, float, float, float, float, float, float, bool, bool]:
    """``kernels_spans.spans_flex(H, V_B, L0, w, inv_EA, True)`` as choices, and
    whether it would call libm: ``(x, z, F_xx, F_xz, F_zz, T_A, T_B, regular, redo)``."""
    wL = w * L0
    V_A = V_B - wL
    safe = _safe(H, V_A) and _safe(H, V_B)
    T_A = math.sqrt(H * H + V_A * V_A)
    T_B = math.sqrt(H * H + V_B * V_B)
    S, TS = V_A + V_B, T_A + T_B
    rho = S / (V_B * T_A + V_A * T_B)
    HL = H * L0
    opposite = V_A < 0.0 and V_B > 0.0
    spread = opposite and H > SAFE_LOW
    u = wL * rho
    ash, ash_bad = _asinh((V_B * T_A - V_A * T_B) / (H * H) if spread else u)
    series = abs(u) < SERIES_CUT
    qm1_series = u * u * asinh_series(u * u)
    q = 1.0 + qm1_series if series else ash / u
    qm1 = qm1_series if series else q - 1.0
    x_c = H / w * ash if spread else HL * rho * q
    z_c = L0 * S / TS
    regular = x_c - x_c == 0.0 and H != 0.0 and not abs(S) < 1e-150 * H
    x = HL * inv_EA + x_c
    z = 0.5 * L0 * S * inv_EA + z_c
    TS, HL = T_A + T_B, H * L0
    TT, H2 = T_A * T_B, H * H
    F_xz = -HL * S / (TT * TS)
    r_b, r_a = V_B / T_B, -V_A / T_A
    VA2, VB2 = V_A * V_A, V_B * V_B
    prod_m_h2 = (H2 * (VA2 + VB2) + VA2 * VB2) / (TT + H2)
    Lrho = L0 * rho
    F_xx = (_g_pair(H, V_B, -V_A, ash, r_b, r_a) / w if spread
            else Lrho * (qm1 + prod_m_h2 / TT))
    F_zz = (r_b + r_a) / w if spread else H2 * Lrho / TT
    base = L0 * inv_EA
    redo = (not safe or (opposite and not spread)
            or (ash_bad and (spread or not (opposite or series))))
    return x, z, base + F_xx, F_xz, base + F_zz, T_A, T_B, regular, redo


@njit(cache=True, error_model="numpy", inline="always")
def _step_lanes(at_b: bool, W: NDArray, rtol: float, its: float) -> None:
    """One Newton step (``kernels._newton_step``) of every lane still going on."""
    for j in range(LANES):
        x, z, T, w, ie = W[at(F_X, j)], W[at(F_Z, j)], W[at(F_T, j)], W[at(F_W, j)], \
            W[at(F_IE, j)]
        p, q, l0 = W[at(F_P, j)], W[at(F_Q, j)], W[at(F_L0, j)]
        h = T * p
        v = T * q if at_b else T * q + w * l0
        va = v - w * l0 if at_b else T * q
        xs, zs, fxx, fxz, fzz, ta, tb, regular, redo = _spans_lane(h, v, l0, w, ie)
        rx, rz = xs - x, zs - z
        xp = h * fxz - (v if at_b else va) * fxx
        zp = h * fzz - (v if at_b else va) * fxz
        kk = 1.0 / (ta if at_b else tb) + ie
        xl = h * kk
        zl = ((v - w * l0) if at_b else v) * kk
        det = xp * zl - xl * zp
        dp = (xl * rz - zl * rx) / det
        dl = (zp * rx - xp * rz) / det
        lsum = l0 + dl
        ln = lsum if lsum != lsum else _fmin(_fmax(lsum, 0.5 * l0), 2.0 * l0)
        dp = 0.9 * p / q if dp * q > 0.9 * p else dp
        r = 1.0 / math.sqrt(1.0 + dp * dp)
        pn, qn = (p - dp * q) * r, (q + dp * p) * r
        finite = pn - pn == 0.0 and qn - qn == 0.0 and ln - ln == 0.0
        small = abs(dp) <= rtol and abs(dl) <= rtol * l0
        fit = abs(rx) <= W[at(F_TOL, j)] and abs(rz) <= W[at(F_TOL, j)]
        outcome = (IRREGULAR if not regular else STOPPED if not finite
                   else ((DONE if fit and det < 0.0 else STOPPED) if small else GO_ON))
        outcome = REDO if redo else outcome
        moves = outcome == GO_ON or (outcome != REDO and regular and finite and small)
        going = W[at(F_OUT, j)] == GO_ON
        W[at(F_P, j)] = pn if going and moves else p
        W[at(F_Q, j)] = qn if going and moves else q
        W[at(F_L0, j)] = ln if going and moves else l0
        W[at(F_ITS, j)] = its if going and outcome != GO_ON else W[at(F_ITS, j)]
        W[at(F_OUT, j)] = outcome if going else W[at(F_OUT, j)]


@njit(cache=True, error_model="numpy", inline="always")
def newton_lanes(at_b: bool, W: NDArray, rtol: float, max_iter: int) -> None:
    """``kernels._newton_from`` of the lanes of code :data:`NEWTON` in lockstep, from
    the points ``(p, q, l0)`` in ``W``: each lane's last point, outcome (:data:`GO_ON`
    where it ran out of iterations, :data:`REDO` where the scalar code must solve it)
    and iterations (``max_iter`` where it ran out). The lanes of another code are set
    idle (:data:`IDLE`); their values are never read."""
    for j in range(LANES):
        W[at(F_ITS, j)] = max_iter
        W[at(F_OUT, j)] = GO_ON if W[at(F_CODE, j)] == NEWTON else IDLE
    for its in range(1, max_iter + 1):
        _step_lanes(at_b, W, rtol, float(its))
        busy = 0
        for j in range(LANES):
            busy += 1 if W[at(F_OUT, j)] == GO_ON else 0
        if busy == 0:
            return


@njit(cache=True, error_model="numpy", inline="always")
def start_lanes(at_b: bool, W: NDArray) -> None:
    """``kernels_spans.valid``, ``kernels._length_start`` (deciding) and
    ``kernels._initial`` of every lane from its data as given: the data in units, the
    start point and the lane's code (:data:`INVALID`, :data:`FALLBACK`,
    :data:`NEWTON`, or :data:`SCREEN` / :data:`SCALAR` where the scalar path must
    take over)."""
    for j in range(LANES):
        x, z, T, w, EA = (W[at(F_RX, j)], W[at(F_RZ, j)], W[at(F_RT, j)], W[at(F_RW, j)],
                          W[at(F_REA, j)])
        ok = valid(x, z, T, w, EA, True)
        inv_EA = 1.0 / EA
        taken = (x > 0.0 and T > 0.0 and 0.0 <= w < math.inf and 0.0 <= inv_EA < math.inf
                 and x - x == 0.0 and z - z == 0.0 and T - T == 0.0)
        chord_safe = _safe(x, z)
        ell, F = power_of_two(math.sqrt(x * x + z * z)), power_of_two(T)
        xs, zs, Ts = x / ell, z / ell, T / F
        ws, ies = (w / F) * ell, inv_EA * F
        product = ws * ies
        decide = ws > 0.0
        h = -zs if at_b else zs
        screened = ws * xs <= 2.0 * BAND * C_LEVEL * (Ts - ws * _fmax(0.0, -h))
        c = math.sqrt(xs * xs + zs * zs)
        cos_t, sin_t = xs / c, zs / c
        Tm = Ts - 0.5 * ws * zs if at_b else Ts + 0.5 * ws * zs
        Tm = math.nan if Tm != Tm else _fmax(Tm, 0.5 * Ts)  # kernels_spans.nanmax
        t = 0.5 * ws * xs / Tm
        Ls = c + (t * t) * (c / 6.0)
        W[at(F_L0, j)] = Ls / (1.0 + Tm * ies)
        t = t if at_b else -t
        r = 1.0 / math.sqrt(1.0 + t * t)
        p = (cos_t - t * sin_t) * r
        q = (sin_t + t * cos_t) * r
        low = p < 0.01
        W[at(F_P, j)] = 0.01 if low else p
        W[at(F_Q, j)] = math.copysign(math.sqrt(1.0 - 1e-4), q) if low else q
        W[at(F_X, j)], W[at(F_Z, j)], W[at(F_T, j)] = xs, zs, Ts
        W[at(F_W, j)], W[at(F_IE, j)], W[at(F_TOL, j)] = ws, ies, RES_TOL * c
        W[at(F_ELL, j)], W[at(F_F, j)] = ell, F
        W[at(F_DECIDE, j)] = 1.0 if decide else 0.0
        code = (SCREEN if decide and not screened else NEWTON) if _safe(xs, zs) else SCALAR
        code = code if product - product == 0.0 else FALLBACK
        code = code if chord_safe else SCALAR
        code = code if taken else FALLBACK
        W[at(F_CODE, j)] = code if ok else INVALID


@njit(cache=True, error_model="numpy", inline="always")
def finish_lanes(at_b: bool, W: NDArray) -> None:
    """``kernels._length_finish`` of the lanes whose Newton converged
    (:data:`DONE`): the certificate (``kernels._certified``) and the values in newtons
    and metres, code :data:`CONVERGED` or :data:`FALLBACK`; :data:`FINISH` for the
    other lanes Newton ran (the scalar finish decides them), :data:`SCALAR` for those
    it left (:data:`REDO`)."""
    for j in range(LANES):
        xs, zs, Ts, ws, ies = (W[at(F_X, j)], W[at(F_Z, j)], W[at(F_T, j)], W[at(F_W, j)],
                               W[at(F_IE, j)])
        p, q, l0 = W[at(F_P, j)], W[at(F_Q, j)], W[at(F_L0, j)]
        H = Ts * p
        V_A = Ts * q if not at_b else Ts * q - ws * l0
        V_B = Ts * q if at_b else V_A + ws * l0
        V_end = V_B if at_b else V_A
        got = math.sqrt(H * H + V_end * V_end)
        tension = abs(got - Ts) <= T_TOL * Ts and V_A - V_A == 0.0
        sane = (H - H == 0.0 and V_B - V_B == 0.0 and l0 - l0 == 0.0 and H >= 0.0
                and l0 > 0.0)
        x_c, z_c, _, _, _, _, _, _, redo = _spans_lane(H, V_B, l0, ws, ies)
        tol = W[at(F_TOL, j)]  # RES_TOL * hypot(xs, zs), from the start
        certified = tension and sane and abs(x_c - xs) <= tol and abs(z_c - zs) <= tol
        F, ell = W[at(F_F, j)], W[at(F_ELL, j)]
        Hn, V_Bn, V_An, L0n = H * F, V_B * F, V_A * F, l0 * ell
        finite = (Hn - Hn == 0.0 and V_Bn - V_Bn == 0.0 and V_An - V_An == 0.0
                  and L0n - L0n == 0.0 and L0n > 0.0)
        code = CONVERGED if certified and finite else FALLBACK
        code = FINISH if not _safe(H, V_end) or (tension and sane and redo) else code
        outcome = W[at(F_OUT, j)]
        code = code if outcome == DONE else (SCALAR if outcome == REDO else FINISH)
        W[at(F_CODE, j)] = code if W[at(F_CODE, j)] == NEWTON else W[at(F_CODE, j)]
        W[at(F_H, j)], W[at(F_VB, j)], W[at(F_VA, j)], W[at(F_LEN, j)] = Hn, V_Bn, V_An, L0n
