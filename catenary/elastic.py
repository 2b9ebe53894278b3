"""Irvine's elastic catenary in the vertical plane of one cable (pure, vectorised).

Conventions (SI units throughout)
---------------------------------
The cable runs from its lower end A to its upper end B. ``x >= 0`` is the
horizontal span (m) and ``z`` the height of B over A (m, either sign). The
unknown end forces are the horizontal tension ``H >= 0`` (N, constant along the
cable) and the vertical tension component ``V_B`` at B (N). Vertical components
are positive upward along the cable (from A towards B), so that
``V_A = V_B - w * L0`` with ``L0`` the unstretched length (m) and ``w`` the
weight per unit length (N/m). ``EA`` (N) is the axial stiffness, ``inf`` for an
inextensible cable. The force the cable exerts on support A is ``(H, V_A)``,
the force on support B is ``(-H, -V_B)``.

Span equations (Irvine, *Cable Structures*, 1981)::

    x = H L0/EA + (H/w) (asinh(V_B/H) - asinh(V_A/H))
    z = (V_B L0 - w L0^2/2)/EA + (H/w) (sqrt(1 + (V_B/H)^2) - sqrt(1 + (V_A/H)^2))

Numerics
--------
The differences of asinh and sqrt above cancel catastrophically for light or
taut cables (``w L0 / T`` tiny) and are singular at ``w = 0`` and ``H = 0``.
They are evaluated here in forms that keep full precision:

* ``(H/w) (sqrt(1+a^2) - sqrt(1+b^2)) = L0 (V_A + V_B) / (T_A + T_B)``.
* When ``V_A`` and ``V_B`` have the same sign,
  ``asinh(a) - asinh(b) = asinh(u)`` with
  ``u = w L0 (V_A + V_B) / (V_B T_A + V_A T_B)`` (no cancellation), and
  ``(H/w) asinh(u) = H L0 rho asinhc(u)`` with ``rho = u / (w L0)``,
  which is finite at ``w = 0`` (straight bar) and at ``H = 0`` (vertical cable).
* When they have opposite signs the two asinh terms add (no cancellation).

All functions broadcast their arguments against each other (numpy rules) and
return arrays of the broadcast shape ``S`` (or ``S + (2, 2)`` for matrices).
They do not validate arguments: see :mod:`catenary.solve` for checked entry
points.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "FullEvaluation",
    "SpansEvaluation",
    "axial_compliance",
    "evaluate",
    "flexibility",
    "length_derivative",
    "power_of_two",
    "profile",
    "span_jacobian",
    "spans",
    "stiffness",
    "stretched_length",
    "tension",
]

FloatArray = NDArray[np.float64]
#: Result of :func:`evaluate`: ``(x, z, F_xx, F_xz, F_zz, x_c, T_A, T_B)``.
FullEvaluation = tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray
]
#: Result of :func:`evaluate` with ``jacobian=False`` (no flexibility entries).
SpansEvaluation = tuple[
    FloatArray, FloatArray, None, None, None, FloatArray, FloatArray, FloatArray
]

# Taylor coefficients (exact fractions) of asinh(u)/u - 1 = sum c_n u^(2n), n >= 1.
_ASINHC_M1 = (
    -1 / 6,
    3 / 40,
    -5 / 112,
    35 / 1152,
    -63 / 2816,
    231 / 13312,
    -143 / 10240,
    6435 / 557056,
)
# g(a) = asinh(a) - a/sqrt(1+a^2) = a^3 sum d_n a^(2n), n >= 0.
_G_SERIES = (
    1 / 3,
    -3 / 10,
    15 / 56,
    -35 / 144,
    315 / 1408,
    -693 / 3328,
    1001 / 5120,
    -6435 / 34816,
)
# Below this |argument| the series are used; 8 terms give full double precision.
_SERIES_CUT = 0.1
# The exponent field of an IEEE double, and the range of powers of two used as scales.
_EXPONENT_BITS = np.int64(0x7FF0000000000000)
_SMALLEST_NORMAL = 2.0**-1022
_LARGEST_POWER = 2.0**1023


def _poly_u2(coeffs: tuple[float, ...], u2: FloatArray) -> FloatArray:
    """Evaluate sum_k coeffs[k] * u2**k by Horner's rule."""
    acc = np.full_like(u2, coeffs[-1])
    for c in coeffs[-2::-1]:
        acc = acc * u2 + c
    return acc


def _asinhc_m1(u: FloatArray) -> FloatArray:
    """``asinh(u)/u - 1`` without cancellation (0 at u = 0)."""
    u2 = u * u
    small = np.abs(u) < _SERIES_CUT
    series = u2 * _poly_u2(_ASINHC_M1, u2)
    safe = np.where(small, 1.0, u)
    direct = np.arcsinh(safe) / safe - 1.0
    return np.where(small, series, direct)


def _g(a: FloatArray) -> FloatArray:
    """``asinh(a) - a/sqrt(1+a^2)`` without cancellation; odd; ``inf`` at ``a = inf``."""
    a2 = a * a
    small = np.abs(a) < _SERIES_CUT
    series = a * a2 * _poly_u2(_G_SERIES, a2)
    # a / sqrt(1+a^2) written to survive a = +-inf.
    direct = np.arcsinh(a) - np.sign(a) / np.sqrt(1.0 + 1.0 / np.where(small, 1.0, a2))
    return np.where(small, series, direct)


def _as_float(*args: ArrayLike) -> list[FloatArray]:
    return [np.asarray(a, dtype=np.float64) for a in args]


def axial_compliance(EA: FloatArray) -> FloatArray:
    """Axial compliance ``1/EA`` (1/N), exactly ``0`` for an inextensible cable.

    Parameters
    ----------
    EA : ndarray
        Axial stiffness (N), ``> 0``; ``inf`` for an inextensible cable.

    Returns
    -------
    ndarray
        ``1/EA`` (1/N), the shape of ``EA``.
    """
    with np.errstate(divide="ignore"):
        return 1.0 / EA


def _shaped(shape: tuple[int, ...], *arrays: FloatArray) -> tuple[FloatArray, ...]:
    """Flat results back to ``shape`` (numpy scalars for ``shape == ()``)."""
    if shape == ():
        return tuple(a[0] for a in arrays)
    return tuple(a.reshape(shape) for a in arrays)


@dataclass(slots=True)
class _Branches:
    """Flat working arrays of one :func:`evaluate` call, shape ``(K,)``.

    The inputs, the end quantities, the same-sign terms ``rho`` and
    ``q = asinh(u)/u`` (``u = w L0 rho``), the spans without stretch
    ``x_c, z_c``, and the index sets of the branches scattered in: ``small``
    (series for ``|u| < 0.1``, with ``qm1_small = q - 1`` there), ``opp``
    (``V_A < 0 < V_B``, with its gathered ``(H, V_B, V_A, w L0 / H)``) and ``bad``
    (degenerate limits).
    """

    H: FloatArray
    V_B: FloatArray
    L0: FloatArray
    w: FloatArray
    V_A: FloatArray
    T_A: FloatArray
    T_B: FloatArray
    S: FloatArray
    TS: FloatArray
    rho: FloatArray
    q: FloatArray
    HL: FloatArray
    x_c: FloatArray
    z_c: FloatArray
    small: NDArray[np.intp]
    qm1_small: FloatArray | None
    opp: NDArray[np.intp]
    opp_args: tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None = None
    bad: NDArray[np.intp] | None = None


def _same_sign_branch(H: FloatArray, V_B: FloatArray, L0: FloatArray, w: FloatArray) -> _Branches:
    """Spans of every element as if ``V_A`` and ``V_B`` had the same sign.

    There ``asinh(a) - asinh(b) = asinh(w L0 rho)``; the series replaces
    ``asinh(u)/u`` only where ``|u| < 0.1`` (including ``u = 0``).
    """
    wL = w * L0
    V_A = V_B - wL
    T_A = np.hypot(H, V_A)
    T_B = np.hypot(H, V_B)
    S = V_A + V_B
    TS = T_A + T_B
    rho = S / (V_B * T_A + V_A * T_B)
    u = wL * rho
    q = np.arcsinh(u) / u  # asinh(u)/u
    small = np.flatnonzero(np.abs(u) < _SERIES_CUT)  # includes u = 0 and NaN-free
    qm1_s = None
    if small.size:
        us = u[small]
        u2 = us * us
        qm1_s = u2 * _poly_u2(_ASINHC_M1, u2)
        q[small] = 1.0 + qm1_s
    HL = H * L0
    x_c = HL * rho * q
    z_c = L0 * S / TS
    opp = np.flatnonzero((V_A < 0.0) & (V_B > 0.0))
    return _Branches(
        H, V_B, L0, w, V_A, T_A, T_B, S, TS, rho, q, HL, x_c, z_c, small, qm1_s, opp
    )


def _opposite_sign_branch(b: _Branches) -> None:
    """Scatter in ``x_c`` where ``V_A < 0 < V_B`` (needs ``w > 0``): the asinh terms add;
    ``1/w = L0 / (H span)``, ``span = (V_B - V_A)/H`` (no overflow for tiny ``w``)."""
    opp = b.opp
    if opp.size:
        h, vb, va = b.H[opp], b.V_B[opp], b.V_A[opp]
        span = vb / h - va / h  # w L0 / H, no cancellation (opposite signs)
        # span = 0: |V| below the subnormals of H, a straight bar (mean slope 1).
        slope = np.where(span > 0, (np.arcsinh(vb / h) - np.arcsinh(va / h)) / span, 1.0)
        b.x_c[opp] = slope * b.L0[opp]
        b.opp_args = (h, vb, va, span)


def _degenerate_limits(b: _Branches) -> None:
    """Scatter in ``rho``, ``q`` and ``x_c`` where the general formulas fail.

    ``|S| << H`` (nearly horizontal weightless bar, where ``S`` and the
    denominator of ``rho`` may underflow: ``rho = 1/H`` in the limit),
    ``H = 0`` (vertical cable) or ``V/H`` overflowing (limit ``x_c = 0``).
    """
    H, S, x_c = b.H, b.S, b.x_c
    bad = np.flatnonzero(~np.isfinite(x_c) | (H == 0.0) | (np.abs(S) < 1e-150 * H))
    b.bad = bad
    if bad.size:
        V_A, V_B, T_A, T_B, rho = b.V_A, b.V_B, b.T_A, b.T_B, b.rho
        Sb, Hb = S[bad], H[bad]
        same = (V_A[bad] >= 0.0) | (V_B[bad] <= 0.0)
        sb = bad[same & (np.abs(Sb) < 1e-150 * Hb) & (Hb > 0.0)]
        m = np.maximum(np.abs(V_A[sb]), np.abs(V_B[sb]))
        a = np.where(m > 0, V_A[sb] / m, 0.0)
        c = np.where(m > 0, V_B[sb] / m, 0.0)
        rs = (a + c) / (c * T_A[sb] + a * T_B[sb])
        rho[sb] = np.where(np.isfinite(rs), rs, 1.0 / H[sb])
        b.q[sb] = 1.0
        x_c[sb] = b.HL[sb] * rho[sb]
        hz = bad[(H[bad] == 0.0) | ~np.isfinite(x_c[bad]) & np.isfinite(H[bad])]
        x_c[hz] = 0.0


def _flexibility_terms(b: _Branches) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(F_xx, F_xz, F_zz)`` without the compliance ``L0/EA``, flat, in m per unit of
    the (scaled) forces held in ``b``."""
    H, V_A, V_B, T_A, T_B, TS = b.H, b.V_A, b.V_B, b.T_A, b.T_B, b.TS
    TT = T_A * T_B
    H2 = H * H
    F_xz = -b.HL * b.S / (TT * TS)
    # T_A T_B - H^2 written without cancellation.
    VA2, VB2 = V_A * V_A, V_B * V_B
    prod_m_h2 = (H2 * (VA2 + VB2) + VA2 * VB2) / (TT + H2)
    Lrho = b.L0 * b.rho
    qm1 = b.q - 1.0
    if b.small.size:
        qm1[b.small] = b.qm1_small
    F_xx = Lrho * (qm1 + prod_m_h2 / TT)
    F_zz = H2 * Lrho / TT
    if b.opp_args is not None:
        opp = b.opp
        h, vb, va, span = b.opp_args
        per_w, bar = b.L0[opp] / h, span == 0  # 1/w = per_w / span; a bar if span = 0
        F_xx[opp] = np.where(bar, 0.0, (_g(vb / h) + _g(-va / h)) / span) * per_w
        F_zz[opp] = np.where(bar, 1.0, (vb / T_B[opp] - va / T_A[opp]) / span) * per_w
    if b.bad is not None and b.bad.size:
        hz = b.bad[H[b.bad] == 0.0]
        F_xz[hz] = 0.0
    return F_xx, F_xz, F_zz


def power_of_two(scale: ArrayLike) -> FloatArray:
    """The largest power of two not above ``|scale|``, within ``[2**-1022, 2**1023]``.

    Read off the exponent bits (cheaper than ``np.frexp``). Dividing by it is exact: in
    its units a computation keeps its rounding, and its fourth powers stay in range.

    Parameters
    ----------
    scale : array_like
        Any shape and unit (0 and subnormals give ``2**-1022``, inf and NaN ``2**1023``).

    Returns
    -------
    ndarray
        Same shape: ``p <= |scale| < 2 p`` where ``scale`` is a normal number.
    """
    magnitude = np.abs(np.asarray(scale, dtype=np.float64))
    p = (magnitude.view(np.int64) & _EXPONENT_BITS).view(np.float64)
    return np.minimum(np.maximum(p, _SMALLEST_NORMAL), _LARGEST_POWER)


@overload
def evaluate(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    inv_EA: ArrayLike,
    jacobian: Literal[True] = ...,
) -> FullEvaluation: ...
@overload
def evaluate(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    inv_EA: ArrayLike,
    jacobian: Literal[False],
) -> SpansEvaluation: ...
@overload
def evaluate(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    inv_EA: ArrayLike,
    jacobian: bool = ...,
) -> FullEvaluation | SpansEvaluation: ...
def evaluate(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    inv_EA: ArrayLike,
    jacobian: bool = True,
) -> FullEvaluation | SpansEvaluation:
    """Spans, flexibility and end tensions in one pass (the solvers' hot path).

    Unchecked: the solvers call it once per Newton iteration on all unconverged cables.

    Parameters
    ----------
    H, V_B, L0, w : array_like
        As in :func:`spans` (N, N, m, N/m); broadcast to a shape ``S``.
    inv_EA : array_like
        Axial compliance ``1/EA`` (1/N), ``0`` for an inextensible cable
        (see :func:`axial_compliance`).
    jacobian : bool
        Whether to compute the flexibility terms.

    Returns
    -------
    tuple
        ``(x, z, F_xx, F_xz, F_zz, x_c, T_A, T_B)``, arrays of shape ``S``
        (numpy scalars for ``S == ()``): spans (m), flexibility entries
        ``dx/dH, dx/dV_B = dz/dH, dz/dV_B`` (m/N; ``None`` when ``jacobian``
        is false), the inextensible part ``x_c`` of the horizontal span (m)
        and the end tensions (N).

    Notes
    -----
    The common case (``V_A``, ``V_B`` of the same sign, ``|u| >= 0.1``) is computed on
    all elements; the series for small ``u``, the opposite-sign branch and the
    degenerate limits (``H = 0``, ``S = 0``) only on the index sets that need them,
    scattered in. Forces are taken in units of a power of two where any is extreme.
    """
    arrays = np.broadcast_arrays(H, V_B, L0, w, inv_EA)
    shape = arrays[0].shape
    Hf, Vf, Lf, wf, ief = (np.asarray(a, dtype=np.float64).reshape(-1) for a in arrays)
    with np.errstate(all="ignore"):
        # Forces in units of p = power_of_two(scale) (exact, same rounding): all at most
        # 4 p; newtons where all are moderate (their fourth powers in range).
        scale = np.maximum(np.abs(Hf), np.maximum(np.abs(Vf), wf * Lf))
        moderate = scale.size == 0 or (1e-60 < scale.min() and scale.max() < 1e60)
        p = 1.0 if moderate else power_of_two(scale)
        inv_p = 1.0 / p
        b = _same_sign_branch(Hf * inv_p, Vf * inv_p, Lf, wf * inv_p)
        _opposite_sign_branch(b)
        _degenerate_limits(b)
        x = (b.HL * ief) * p + b.x_c
        z = (0.5 * Lf * b.S * ief) * p + b.z_c
        T_A, T_B = b.T_A * p, b.T_B * p
        if not jacobian:
            x, z, x_c, T_A, T_B = _shaped(shape, x, z, b.x_c, T_A, T_B)
            return x, z, None, None, None, x_c, T_A, T_B
        base = Lf * ief
        F_xx, F_xz, F_zz = (f * inv_p for f in _flexibility_terms(b))
        F_xx, F_zz = base + F_xx, base + F_zz
    x, z, F_xx, F_xz, F_zz, x_c, T_A, T_B = _shaped(
        shape, x, z, F_xx, F_xz, F_zz, b.x_c, T_A, T_B
    )
    return x, z, F_xx, F_xz, F_zz, x_c, T_A, T_B


def spans(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
) -> tuple[FloatArray, FloatArray]:
    """Horizontal and vertical span of an elastic catenary from its end forces.

    Parameters
    ----------
    H : array_like
        Horizontal tension (N), ``>= 0``.
    V_B : array_like
        Vertical tension component at the upper end B (N), positive upward.
    L0 : array_like
        Unstretched length (m), ``> 0``.
    w : array_like
        Weight per unit length (N/m), ``>= 0`` (``0`` gives a straight bar).
    EA : array_like, optional
        Axial stiffness (N); ``inf`` (default) for an inextensible cable.

    Returns
    -------
    x, z : ndarray
        Horizontal span and height of B over A (m), broadcast shape.
    """
    H, V_B, L0, w, EA = _as_float(H, V_B, L0, w, EA)
    x, z, *_ = evaluate(H, V_B, L0, w, axial_compliance(EA), jacobian=False)
    return x, z


def flexibility(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
) -> FloatArray:
    """Flexibility matrix ``d(x, z) / d(H, V_B)`` of the cable end B (m/N).

    This is the analytic Jacobian of :func:`spans` with ``L0`` held fixed. It is
    symmetric (``dx/dV_B == dz/dH``) and positive definite for ``H > 0``.

    Parameters
    ----------
    H, V_B, L0, w, EA : array_like
        As in :func:`spans`.

    Returns
    -------
    ndarray, shape ``S + (2, 2)``
        ``[[dx/dH, dx/dV_B], [dz/dH, dz/dV_B]]``.
    """
    H, V_B, L0, w, EA = _as_float(H, V_B, L0, w, EA)
    _, _, fxx, fxz, fzz, *_ = evaluate(H, V_B, L0, w, axial_compliance(EA))
    fxx, fxz, fzz = np.broadcast_arrays(fxx, fxz, fzz)
    return np.stack([np.stack([fxx, fxz], -1), np.stack([fxz, fzz], -1)], -2)


span_jacobian = flexibility


def stiffness(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
) -> FloatArray:
    """Stiffness of the cable end B: ``d(H, V_B) / d(x, z)`` (N/m), end A fixed.

    The inverse of :func:`flexibility` (symmetric 2x2). Moving B by
    ``(dx, dz)`` changes the force the cable exerts on B by
    ``-(dH, dV_B) = -K @ (dx, dz)``.

    Parameters
    ----------
    H, V_B, L0, w, EA : array_like
        As in :func:`spans`.

    Returns
    -------
    ndarray, shape ``S + (2, 2)``
        ``[[dH/dx, dH/dz], [dV_B/dx, dV_B/dz]]``; ``inf`` entries where the
        flexibility is singular (inextensible straight or vertical cable).
    """
    F = flexibility(H, V_B, L0, w, EA)
    a, b, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 1]
    with np.errstate(all="ignore"):
        det = a * d - b * b
        K = np.stack([np.stack([d, -b], -1), np.stack([-b, a], -1)], -2) / det[..., None, None]
    return K


def length_derivative(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
) -> tuple[FloatArray, FloatArray]:
    """Derivative of the spans with respect to ``L0`` at fixed ``(H, V_B)``.

    Lengthening the cable at fixed end forces adds cable at end A, along the
    cable's tangent there: ``d(x, z)/dL0 = (H, V_A) (1/T_A + 1/EA)``.

    Returns
    -------
    dx_dL0, dz_dL0 : ndarray
        Dimensionless, broadcast shape.
    """
    H, V_B, L0, w, EA = _as_float(H, V_B, L0, w, EA)
    V_A = V_B - w * L0
    k = 1.0 / np.hypot(H, V_A) + axial_compliance(EA)
    return H * k, V_A * k


def tension(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    s: ArrayLike,
) -> FloatArray:
    """Tension magnitude at unstretched arc length ``s`` from end A (N).

    ``T(s) = sqrt(H^2 + (V_A + w s)^2)``; ``s = 0`` gives ``T_A`` and
    ``s = L0`` gives ``T_B``. Arguments broadcast.
    """
    H, V_B, L0, w, s = _as_float(H, V_B, L0, w, s)
    return np.hypot(H, V_B - w * L0 + w * s)


def stretched_length(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
) -> FloatArray:
    """Stretched (loaded) length of the cable (m).

    ``L = L0 + (1/EA) * integral_0^L0 T(s) ds``, with the integral in a
    cancellation-free closed form (exact for ``w = 0``).
    """
    H, V_B, L0, w, EA = _as_float(H, V_B, L0, w, EA)
    inv_EA = axial_compliance(EA)
    with np.errstate(all="ignore"):
        V_A = V_B - w * L0
        T_A = np.hypot(H, V_A)
        T_B = np.hypot(H, V_B)
        S = V_A + V_B
        TS = T_A + T_B
        x_c = evaluate(H, V_B, L0, w, inv_EA, jacobian=False)[5]
        integral = 0.25 * L0 * (np.where(TS > 0, S * (S / TS), 0.0) + TS) + 0.5 * H * x_c
        return L0 + np.where(inv_EA == 0.0, 0.0, integral * inv_EA)


def profile(
    H: ArrayLike,
    V_B: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
    n: int = 101,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Sampled cable shape for plots, relative to end A.

    Parameters
    ----------
    H, V_B, L0, w, EA : array_like
        As in :func:`spans`, broadcast shape ``S``.
    n : int
        Number of samples along the cable (including both ends).

    Returns
    -------
    s, x, z : ndarray, shape ``S + (n,)``
        Unstretched arc length from A (m) and the horizontal and vertical
        position of each sample relative to A (m). ``x[..., -1], z[..., -1]``
        equal :func:`spans`.
    """
    H, V_B, L0, w, EA = (a[..., None] for a in _as_float(H, V_B, L0, w, EA))
    t = np.linspace(0.0, 1.0, n)
    s = L0 * t
    # The piece of cable from A to s is a catenary with length s whose upper
    # end carries V_A + w s.
    V_s = V_B - w * L0 + w * s
    with np.errstate(all="ignore"):
        s_pos = np.where(s > 0, s, 1.0)
        x, z, *_ = evaluate(H, V_s, s_pos, w, axial_compliance(EA), jacobian=False)
    x = np.where(s > 0, x, 0.0)
    z = np.where(s > 0, z, 0.0)
    s, x, z = np.broadcast_arrays(s, x, z)
    return s, x, z
