"""Compiled (numba) span equations of one elastic catenary and the scalar helpers the
solvers of :mod:`catenary.solve.kernels` share: spans, flexibility and end tensions
(:func:`spans_one`, the kernel twin of :func:`catenary.elastic.evaluate`, the numpy
reference), ``hypot`` on safe squares, the power-of-two units, and the argument checks.
The length solve's spans (``fast``) differ from the reference by rounding only: one
``asinh`` of the two where the cable has a low point between its ends, and ``asinh`` to
about one ulp at about half libm's latency (:func:`asinh_fast`). Imports numpy and
numba only.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload
from numpy.typing import NDArray

__all__ = ["ASINH_LARGE", "EPS", "RES_TOL", "SAFE_HIGH", "SAFE_LOW", "SERIES_CUT", "T_TOL",
           "asinh_fast", "asinh_series", "at", "clip", "g_series", "hypot", "log_fast",
           "nanmax", "power_of_two", "spans", "spans_call", "spans_flex", "spans_flex_call",
           "spans_one", "square", "valid"]

RES_TOL = 1e-8
EPS = float(np.finfo(np.float64).eps)
T_TOL = 1e-9
SERIES_CUT = 0.1
_SMALLEST_NORMAL = 2.0**-1022
_LARGEST_POWER = 2.0**1023
# Coefficients of the series of (asinh(u) / u - 1) / u^2 and of g(u) / u^3 in u^2
# (asinh_series, g_series).
_A0, _A1, _A2, _A3 = -1 / 6, 3 / 40, -5 / 112, 35 / 1152
_A4, _A5, _A6, _A7 = -63 / 2816, 231 / 13312, -143 / 10240, 6435 / 557056
_G0, _G1, _G2, _G3 = 1 / 3, -3 / 10, 15 / 56, -35 / 144
_G4, _G5, _G6, _G7 = 315 / 1408, -693 / 3328, 1001 / 5120, -6435 / 34816


#: Magnitudes between which ``sqrt(a * a + b * b)`` neither overflows nor loses the
#: larger square to underflow (:func:`hypot`).
SAFE_LOW, SAFE_HIGH = 1e-150, 1e150


@njit(cache=True, error_model="numpy", inline="always")
def hypot(a: float, b: float) -> float:
    """``sqrt(a^2 + b^2)`` as :func:`math.hypot` to rounding; a square root where the
    squares are safe (the solves' nondimensional data always are), else libm's
    ``hypot``, a call several times as long. NaN and inf as :func:`math.hypot`."""
    big = max(abs(a), abs(b))
    if SAFE_LOW < big < SAFE_HIGH:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@njit(cache=True, error_model="numpy", inline="always")
def _horner(u2: float, c7: float, c6: float, c5: float, c4: float, c3: float, c2: float,
            c1: float, c0: float) -> float:
    """``c0 + c1 u2 + ... + c7 u2^7`` by Horner's rule."""
    acc = c7 * u2 + c6
    acc = acc * u2 + c5
    acc = acc * u2 + c4
    acc = acc * u2 + c3
    acc = acc * u2 + c2
    acc = acc * u2 + c1
    return acc * u2 + c0


@njit(cache=True, error_model="numpy", inline="always")
def asinh_series(u2: float) -> float:
    """``(asinh(u) / u - 1) / u^2`` by its series in ``u2 = u^2``, eight terms (for
    ``|u| < SERIES_CUT``)."""
    return _horner(u2, _A7, _A6, _A5, _A4, _A3, _A2, _A1, _A0)


@njit(cache=True, error_model="numpy", inline="always")
def g_series(u2: float) -> float:
    """``(asinh(u) - u / sqrt(1 + u^2)) / u^3`` by its series in ``u2 = u^2``, eight
    terms (for ``|u| < SERIES_CUT``)."""
    return _horner(u2, _G7, _G6, _G5, _G4, _G3, _G2, _G1, _G0)


#: Veltkamp's splitter of a double into two halves of 26 bits (:func:`square`).
_SPLIT = 2.0**27 + 1.0
#: Arguments above which :func:`asinh_fast` calls libm (its squares would overflow).
ASINH_LARGE = 1e100


@njit(cache=True, error_model="numpy", inline="always")
def square(a: float) -> tuple[float, float]:
    """``a * a`` as ``hi + lo`` exactly (Dekker's product, no fused multiply-add),
    ``|a|`` below ``1e100``."""
    hi = a * a
    c = _SPLIT * a
    a_hi = c - (c - a)
    a_lo = a - a_hi
    return hi, ((a_hi * a_hi - hi) + 2.0 * a_hi * a_lo) + a_lo * a_lo


#: fdlibm's ``log``: the coefficients of its polynomial in ``s = f / (2 + f)`` on ``1 +
#: f`` in ``[1 / sqrt(2), sqrt(2))``, and ``ln 2`` in two parts (:func:`log_fast`).
_LG1, _LG2, _LG3 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01
_LG4, _LG5, _LG6 = 2.222219843214978396e-01, 1.818357216161805012e-01, 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10
#: Bits of a double: the exponent field, the fraction.
_EXPONENT_BITS, _FRACTION_BITS = 0x7FF0000000000000, 0x000FFFFFFFFFFFFF


@njit(cache=True, error_model="numpy", inline="always")
def log_fast(y: float) -> float:
    """``log(y)`` of a positive normal ``y`` to within one ulp (0.83 measured against an
    extended-precision log; libm's 0.52): fdlibm's method, written on the 64-bit
    pattern of ``y`` so that a loop of it over many arguments becomes vector code (a
    libm call cannot). Not for zero, subnormals, inf or NaN."""
    bits = np.float64(y).view(np.int64)
    k = (bits >> 52) - 1023
    fraction = bits & _FRACTION_BITS
    # fdlibm's split: the fraction from sqrt(2) on is taken as that of y / 2.
    half = ((fraction >> 32) + 0x95F64) & 0x100000
    m = np.int64(fraction | ((half ^ 0x3FF00000) << 32)).view(np.float64)
    e = float(k + (half >> 20))
    f = m - 1.0  # exact
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    hfsq = 0.5 * f * f
    return e * _LN2_HI - ((hfsq - (s * (hfsq + (t2 + t1)) + e * _LN2_LO)) - f)


@njit(cache=True, error_model="numpy", inline="always")
def asinh_fast(a: float) -> float:
    """``asinh(a)`` to about one ulp (as libm's), at about half its latency: the
    series below ``SERIES_CUT``, else ``log(y)`` of ``y = |a| + sqrt(1 + a^2)``
    plus ``y_lo / y``, ``y_lo`` the rounding errors of ``y`` found exactly (error-free
    sums and squares); libm's beyond ``1e100`` and for NaN and inf."""
    b = abs(a)
    if b < SERIES_CUT:
        b2 = b * b
        r = b + b * b2 * asinh_series(b2)
    elif b < ASINH_LARGE:
        b2, b2_lo = square(b)
        t = 1.0 + b2  # and its error t_lo (the larger term first)
        t_lo = (((1.0 - t) + b2) if b2 < 1.0 else ((b2 - t) + 1.0)) + b2_lo
        s = math.sqrt(t)
        s2, s2_lo = square(s)
        s_lo = (((t - s2) - s2_lo) + t_lo) / (2.0 * s)  # sqrt(t + t_lo) - s
        y = b + s  # s > b
        y_lo = ((s - y) + b) + s_lo
        r = log_fast(y) + y_lo / y
    else:
        r = math.asinh(b)
    return math.copysign(r, a)


@njit(cache=True, error_model="numpy", inline="always")
def _g(a: float, asinh_a: float) -> float:
    """``asinh(a) - a / sqrt(1 + a^2)`` without cancellation, given ``asinh(a)`` (the
    spans computed it already)."""
    a2 = a * a
    if abs(a) < SERIES_CUT:
        return a * a2 * g_series(a2)
    return asinh_a - math.copysign(1.0, a) / math.sqrt(1.0 + 1.0 / a2)


@njit(cache=True, error_model="numpy", inline="always")
def _spread(H: float, V_B: float, V_A: float, T_A: float, T_B: float) -> float:
    """``asinh(V_B / H) - asinh(V_A / H)`` for ``V_A < 0 < V_B``, ``H`` above
    ``1e-150``: by ``asinh(a) - asinh(b) = asinh(a sqrt(1 + b^2) - b sqrt(1 + a^2))``,
    one ``asinh`` (a libm call as long as several divisions) of a sum of two positive
    terms, without cancellation."""
    return asinh_fast((V_B * T_A - V_A * T_B) / (H * H))


@njit(cache=True, error_model="numpy", inline="always")
def _g_pair(H: float, V_b: float, V_a: float, spread: float, r_b: float, r_a: float
            ) -> float:
    """``_g(a) + _g(b)`` (:func:`_g`) of ``a = V_b / H > 0`` and ``b = V_a / H > 0``,
    given ``spread = asinh(a) + asinh(b)`` and each ``r = V / T = a / sqrt(1 + a^2)``:
    a small argument's ``asinh`` by its series, the other's as the spread less that,
    so no ``asinh`` is called."""
    small_b, small_a = V_b < SERIES_CUT * H, V_a < SERIES_CUT * H
    if not (small_b or small_a):
        return spread - (r_b + r_a)
    a, b = V_b / H, V_a / H
    if small_b and small_a:
        return a * a * a * g_series(a * a) + b * b * b * g_series(b * b)
    s, r_l = (a, r_a) if small_b else (b, r_b)  # the small one, the other's V / T
    s2 = s * s
    ash_s = s + s * s2 * asinh_series(s2)
    return s * s2 * g_series(s2) + ((spread - ash_s) - r_l)


@njit(cache=True, error_model="numpy", inline="always")
def spans(H: float, V_B: float, L0: float, w: float, inv_EA: float, fast: bool
          ) -> tuple[float, float, float, float, float, float, float, float, bool, bool,
                     float, float]:
    """The spans part of :func:`spans_one`: ``(x, z, V_A, T_A, T_B, rho, qm1, S,
    opposite, regular, asinh(V_B / H), asinh(V_A / H))`` (``qm1`` only where not
    ``opposite``, the two ``asinh`` only where it is: each is needed only there).
    ``fast``: the end tensions by :func:`hypot` (the length solve, on nondimensional
    data), else by libm's (the force solve: near a taut inextensible cable its forces
    follow the last bit of the tensions, and the numpy path's iterations with them);
    and where ``opposite``, their difference by one ``asinh`` (:func:`_spread`) in
    place of the two, returned as ``asinh(V_B / H)`` with NaN as ``asinh(V_A / H)``;
    and ``asinh`` by :func:`asinh_fast`."""
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
    qm1 = ash_b = ash_a = 0.0
    if opposite and fast and H > SAFE_LOW:
        ash_b, ash_a = _spread(H, V_B, V_A, T_A, T_B), np.nan
        x_c = H / w * ash_b
    elif opposite:
        ash_b, ash_a = math.asinh(V_B / H), math.asinh(V_A / H)
        x_c = H / w * (ash_b - ash_a)
    else:
        u = wL * rho
        if abs(u) < SERIES_CUT:
            qm1 = u * u * asinh_series(u * u)
            q = 1.0 + qm1
        else:
            q = (asinh_fast(u) if fast else math.asinh(u)) / u
            qm1 = q - 1.0
        x_c = HL * rho * q
    z_c = L0 * S / TS
    regular = math.isfinite(x_c) and H != 0.0 and not abs(S) < 1e-150 * H
    x = HL * inv_EA + x_c
    z = 0.5 * L0 * S * inv_EA + z_c
    return x, z, V_A, T_A, T_B, rho, qm1, S, opposite, regular, ash_b, ash_a


@njit(cache=True, error_model="numpy", inline="always")
def spans_one(H: float, V_B: float, L0: float, w: float, inv_EA: float
              ) -> tuple[float, float, float, float, float, float, float, bool]:
    """Spans, flexibility and end tensions of one cable, ``(x, z, F_xx, F_xz, F_zz,
    T_A, T_B, regular)`` (:func:`catenary.elastic.evaluate`); ``regular`` is False
    at the degenerate limits (vertical cable, ``|V_A + V_B| << H``), which the numpy
    path handles."""
    return spans_flex(H, V_B, L0, w, inv_EA, False)


@njit(cache=True, error_model="numpy", inline="always")
def spans_flex(H: float, V_B: float, L0: float, w: float, inv_EA: float, fast: bool
               ) -> tuple[float, float, float, float, float, float, float, bool]:
    """:func:`spans_one`, the end tensions as :func:`spans` computes them with
    ``fast``."""
    x, z, V_A, T_A, T_B, rho, qm1, S, opposite, regular, ash_b, ash_a = spans(
        H, V_B, L0, w, inv_EA, fast)
    TS, HL = T_A + T_B, H * L0
    TT, H2 = T_A * T_B, H * H
    F_xz = -HL * S / (TT * TS)
    if opposite and ash_a != ash_a:  # ash_b is the spread (spans, fast)
        r_b, r_a = V_B / T_B, -V_A / T_A
        F_xx = _g_pair(H, V_B, -V_A, ash_b, r_b, r_a) / w
        F_zz = (r_b + r_a) / w
    elif opposite:  # asinh is odd: asinh(-V_A / H) = -asinh(V_A / H)
        F_xx = (_g(V_B / H, ash_b) + _g(-V_A / H, -ash_a)) / w
        F_zz = (V_B / T_B - V_A / T_A) / w
    else:
        VA2, VB2 = V_A * V_A, V_B * V_B
        prod_m_h2 = (H2 * (VA2 + VB2) + VA2 * VB2) / (TT + H2)
        Lrho = L0 * rho
        F_xx = Lrho * (qm1 + prod_m_h2 / TT)
        F_zz = H2 * Lrho / TT
    base = L0 * inv_EA
    return x, z, base + F_xx, F_xz, base + F_zz, T_A, T_B, regular


#: :func:`spans` and :func:`spans_flex` as called functions, each compiled once, for the
#: scalar solves (:mod:`catenary.solve.kernels`): inlined at each of their call sites
#: there, they took 35 of the 45 s the first ``solve_length`` spent compiling, for no
#: measured gain. The side-by-side lanes and the coupled model's kernels inline theirs.
spans_call = njit(cache=True, error_model="numpy")(spans.py_func)
spans_flex_call = njit(cache=True, error_model="numpy")(spans_flex.py_func)


@njit(cache=True, error_model="numpy", inline="always")
def clip(a: float, lo: float, hi: float) -> float:
    """``numpy.clip`` of one number (NaN stays NaN)."""
    if a != a:
        return a
    return min(max(a, lo), hi)


@njit(cache=True, error_model="numpy", inline="always")
def nanmax(a: float, b: float) -> float:
    """``numpy.maximum`` of two numbers (NaN if either is)."""
    if a != a or b != b:
        return np.nan
    return max(a, b)


@njit(cache=True, error_model="numpy", inline="always")
def power_of_two(scale: float) -> float:
    """:func:`catenary.elastic.power_of_two` of one number: ``p <= |scale| < 2 p``,
    within ``[2**-1022, 2**1023]``."""
    a = abs(scale)
    if not a < np.inf:
        return _LARGEST_POWER
    if not a >= _SMALLEST_NORMAL:
        return _SMALLEST_NORMAL
    # The exponent field alone (no frexp call, so loops of it vectorize).
    return np.int64(np.float64(a).view(np.int64) & _EXPONENT_BITS).view(np.float64)


@njit(cache=True, error_model="numpy", inline="always")
def valid(x: float, z: float, third: float, w: float, EA: float, length: bool) -> bool:
    """The checks of :func:`catenary.solve.common.prepare`: ``x, w >= 0`` finite, ``z``
    finite, the tension ``>= 0`` finite (``length``) or ``L0 > 0`` finite, ``EA > 0``
    (``inf`` allowed)."""
    third_ok = (third >= 0.0) if length else (third > 0.0)
    return (0.0 <= x < np.inf and -np.inf < z < np.inf and third_ok and third < np.inf
            and 0.0 <= w < np.inf and EA > 0.0)


def at(a: NDArray | float, k: int | np.int64) -> float:
    """Entry ``k`` of a cable argument in compiled code: an array of one entry per cable,
    an array of one entry for every cable, or a number for every cable (each compiles
    to its own code)."""
    raise NotImplementedError("at() is compiled code: call it from a kernel")


@overload(at)
def _at_typed(a, k):
    # Unannotated: numba matches these parameters to those of the implementations.
    if isinstance(a, types.Array):
        def entry(a, k):
            return a[k] if a.size > 1 else a[0]

        return entry

    def number(a, k):
        return a

    return number
