"""Newton's method of :func:`catenary.solve.solve_length` (see :mod:`catenary.solve.length`).

Unknowns ``(H, V_B, L0)`` parametrised so that the tension condition holds exactly:
the direction angle of the cable at the given end and ``L0`` (``end="B"``/``"A"``),
or ``V_B`` and ``L0`` with ``H = T`` (``end="H"``); closed-form guesses; the polish
of the bracketing fallback's roots.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..elastic import evaluate
from .common import CONVERGED, NOT_CONVERGED, RES_TOL, T_TOL, FloatArray
from .length_bracket import end_tension

__all__ = ["newton_length", "newton_with_second_guess", "polish_length"]


def _initial_length(
    end: str, x: FloatArray, z: FloatArray, T: FloatArray, w: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Near-straight cable guess with first-order sag, x > 0.

    Returns ``(p, q, L0)``: for ``end="B"`` (``"A"``) the unit direction
    ``(cos(phi), sin(phi))`` of the cable at that end, so that
    ``(H, V) = T (p, q)``; for ``end="H"``, ``p = H = T`` and ``q = V_B``.

    Shallow-cable (parabola) estimates in the chord frame: the end tangent
    leaves the chord by ``atan(w c cos(theta) / (2 T_m))`` (above it at B,
    below it at A), with ``T_m`` the tension at mid-height, and the stretched
    length exceeds the chord by ``q^2 c^3 / (24 T_m^2)`` with ``q = w
    cos(theta)`` the transverse load. Errors are ``O((w c / T)^2)``; the
    direction is built by rotating the chord's unit vector, so the tiny
    deviation of a light cable keeps full precision.
    """
    c = np.hypot(x, z)
    cos_t = x / c
    sin_t = z / c
    with np.errstate(all="ignore"):
        if end == "H":
            # The mean vertical force is H z/x (parabola): V_B = H z/x + w L0/2.
            Tm = T / cos_t
            q = w * cos_t
            Ls = c + q * q * c**3 / (24.0 * Tm * Tm)
            Ls = np.minimum(Ls, 3.0 * c + 2.0 * T / np.where(w > 0, w, 1.0))
            L0 = Ls / (1.0 + Tm * inv_EA)
            return T, T * (z / x) + 0.5 * w * L0, L0
        Tm = np.maximum(T - 0.5 * w * z if end == "B" else T + 0.5 * w * z, 0.5 * T)
        t = 0.5 * w * x / Tm  # tan of the deviation from the chord
        Ls = c + (t * t) * (c / 6.0)  # = c + (w cos c)^2 c^3 / (24 Tm^2)
        L0 = Ls / (1.0 + Tm * inv_EA)
        if end == "A":
            t = -t
        r = 1.0 / np.sqrt(1.0 + t * t)
        p = (cos_t - t * sin_t) * r
        q = (sin_t + t * cos_t) * r
        # Beyond vertical: start from a steep but non-vertical direction.
        steep = p < 0.01
        if np.any(steep):
            p = np.where(steep, 0.01, p)
            q = np.where(steep, np.copysign(np.sqrt(1.0 - 1e-4), q), q)
    return p, q, L0


def _end_forces(
    end: str, T: FloatArray, p: FloatArray, q: FloatArray, l0: FloatArray, w: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """``(H, V_B, V_A)`` (N) of the Newton unknowns; ``V_A`` only for ``end="A"``."""
    if end == "H":
        return T, q, None
    if end == "B":
        return T * p, T * q, None
    va = T * q
    return T * p, va + w * l0, va


def _length_step(
    end: str,
    x: FloatArray,
    z: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    h: FloatArray,
    v: FloatArray,
    va: FloatArray | None,
    l0: FloatArray,
) -> tuple[FloatArray, ...]:
    """Residuals and Newton step of the span equations in ``(phi or V_B, L0)``.

    Returns ``(rx, rz, det, dp, dl, T_A, T_B)``: span residuals (m), the
    Jacobian determinant, the steps of the first unknown (``phi`` in rad or
    ``V_B`` in N) and of ``L0`` (m), and the end tensions (N).
    """
    xs, zs, fxx, fxz, fzz, _, ta, tb = evaluate(h, v, l0, w, inv_EA)
    with np.errstate(all="ignore"):
        rx, rz = xs - x, zs - z
        if end == "H":
            xp, zp = fxz, fzz
            kk = 1.0 / ta + inv_EA
            xl, zl = h * kk, (v - w * l0) * kk
        elif end == "B":
            xp, zp = h * fxz - v * fxx, h * fzz - v * fxz
            kk = 1.0 / ta + inv_EA
            xl, zl = h * kk, (v - w * l0) * kk
        else:
            assert va is not None  # given for end "A"
            xp, zp = h * fxz - va * fxx, h * fzz - va * fxz
            # At fixed (H, V_A) the cable grows at end B, along its tangent.
            kk = 1.0 / tb + inv_EA
            xl, zl = h * kk, v * kk
        det = xp * zl - xl * zp
        dp = (xl * rz - zl * rx) / det
        dl = (zp * rx - xp * rz) / det
    return rx, rz, det, dp, dl, ta, tb


def _length_update(
    end: str,
    p: FloatArray,
    q: FloatArray,
    l0: FloatArray,
    dp: FloatArray,
    dl: FloatArray,
    ta: FloatArray,
    tb: FloatArray,
    rtol: float,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Safeguarded Newton update: ``(p_new, q_new, L0_new, small_step, finite)``."""
    ln = np.clip(l0 + dl, 0.5 * l0, 2.0 * l0)
    if end == "H":
        fscale = ta + tb
        pn = q + np.clip(dp, -10 * fscale, 10 * fscale)
        qn = pn
        small_p = np.abs(dp) <= rtol * fscale
        ok = np.isfinite(pn) & np.isfinite(ln)
    else:
        # Keep H > 0: cos(phi) may shrink at most tenfold per step.
        with np.errstate(all="ignore"):
            dp = np.where(dp * q > 0.9 * p, 0.9 * p / q, dp)
            r = 1.0 / np.sqrt(1.0 + dp * dp)
            pn = (p - dp * q) * r
            qn = (q + dp * p) * r
        small_p = np.abs(dp) <= rtol
        ok = np.isfinite(pn) & np.isfinite(qn) & np.isfinite(ln)
    small = small_p & (np.abs(dl) <= rtol * l0)
    return pn, qn, ln, small, ok


def newton_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    P: FloatArray,
    Q: FloatArray,
    L: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]
]:
    """2-D Newton on the span equations with the tension condition built in.

    For ``end="B"`` (``"A"``) the unknowns are the direction angle ``phi`` of
    the cable at that end and ``L0``, with ``(H, V_end) = T (cos(phi),
    sin(phi))``; for ``end="H"`` they are ``V_B`` and ``L0`` with ``H = T``.
    The tension condition thus holds exactly at every iterate (to rounding),
    and the Jacobian stays regular for weightless and very light cables,
    whose length carries no information about their tension (a Newton
    iteration that solves for the tension through ``L0`` stalls there).
    The direction is stored as a unit vector ``(P, Q)`` and rotated by
    ``atan(dphi)`` per step (no trigonometric functions; quadratic
    convergence is kept).

    Arguments as :func:`newton_with_second_guess`, from the start ``P, Q, L``
    (the unit direction at the given end, or ``H`` and ``V_B`` in N for
    ``end="H"``, and ``L0`` in m). Returns ``(H, V_B, V_A, L0, converged,
    iterations)``, shape ``(n,)`` each (``V_A = T sin(phi)`` exactly for
    ``end="A"``, where ``V_B - w L0`` may have lost its digits). ``converged``
    requires a small step, span residuals below ``RES_TOL`` of the chord and
    the taut branch: at a root ``dT/dL0`` at fixed geometry has the sign of
    ``det J`` (``J`` the Jacobian in (phi or V_B, L0)), so ``det J < 0`` there.
    """
    P, Q, L = np.array(P, dtype=np.float64), Q.copy(), L.copy()
    P = np.broadcast_to(P, L.shape).copy()
    n = L.size
    conv = np.zeros(n, bool)
    its = np.zeros(n, np.int64)
    idx = np.arange(n)
    xa, za, Ta, wa, ia = x, z, T, w, inv_EA
    for k in range(max_iter):
        if idx.size == 0:
            break
        if k:
            xa, za, Ta, wa, ia = x[idx], z[idx], T[idx], w[idx], inv_EA[idx]
            p, q, l0 = P[idx], Q[idx], L[idx]
        else:
            # All cables take the first step: no gathering.
            p, q, l0 = P, Q, L
        h, v, va = _end_forces(end, Ta, p, q, l0, wa)
        rx, rz, det, dp, dl, ta, tb = _length_step(end, xa, za, wa, ia, h, v, va, l0)
        its[idx] += 1
        pn, qn, ln, small, ok = _length_update(end, p, q, l0, dp, dl, ta, tb, rtol)
        # Spans fit to the chord (the certificate); before the writes below, which on
        # the first step change l0 (L itself).
        tol = RES_TOL * np.hypot(xa, za)
        fit = (np.abs(rx) <= tol) & (np.abs(rz) <= tol)
        if end == "H":
            Q[idx] = np.where(ok, qn, q)
        else:
            P[idx] = np.where(ok, pn, p)
            Q[idx] = np.where(ok, qn, q)
        L[idx] = np.where(ok, ln, l0)
        fin = ok & small & fit
        # A root with dT/dL0 >= 0 is the sagging branch: reject it.
        conv[idx] = fin & (det < 0)
        # A small step with a large residual (singular Jacobian, rounding): stop too.
        idx = idx[~small & ok]
    if end == "A":
        H, V_A = T * P, T * Q
        return H, V_A + w * L, V_A, L, conv, its
    if end == "H":
        H, V = np.broadcast_to(T, L.shape).copy(), Q
    else:
        H, V = T * P, T * Q
    return H, V, V - w * L, L, conv, its


def _catenary_guess_h(
    x: FloatArray,
    z: FloatArray,
    H: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    V: FloatArray,
    L: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Guess ``(V_B, L0)`` for a prescribed horizontal tension, ``x > 0``, ``w > 0``.

    In the hyperbolic end angles ``a = asinh(V_A/H)``, ``b = asinh(V_B/H)``
    the inextensible catenary is explicit: ``b - a = w x_c / H``,
    ``z_c = (2H/w) sinh((a+b)/2) sinh((b-a)/2)`` and
    ``L0 = (2H/w) cosh((a+b)/2) sinh((b-a)/2)``, where ``x_c, z_c`` are the
    spans without stretch. A few fixed-point passes, starting from the
    guess ``(V, L)`` (N, m), subtract the stretch. This is exact for
    inextensible cables and good for steep ones with moderate stretch, where
    the parabolic guess of ``_initial_length`` is poor.
    """
    with np.errstate(all="ignore"):
        for _ in range(4):
            xc = np.maximum(x - H * L * inv_EA, 0.5 * x)
            zc = z - (V * L - 0.5 * w * L * L) * inv_EA
            d = w * xc / H
            sh = np.sinh(0.5 * d)
            m = np.arcsinh(w * zc / (2.0 * H * sh))
            L = 2.0 * H / w * np.cosh(m) * sh
            V = H * np.sinh(m + 0.5 * d)
    return V, L


def polish_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    H: FloatArray,
    V: FloatArray,
    L: FloatArray,
    status: NDArray[np.str_],
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.str_], NDArray[np.int64]]:
    """Finish the bracketing fallback's roots and check the tension condition.

    Newton with the tension built in (:func:`newton_length`) is restarted
    from each root; its answer is taken where it converges to the same
    cable (``L0`` within ``1e-6``). Any root whose end tension is still off
    by more than ``T_TOL`` relative is reported ``"not_converged"``, never
    as a solution.

    Parameters
    ----------
    end, x, z, T, w, inv_EA, rtol, max_iter
        As in :func:`newton_with_second_guess`, shape ``(n,)``.
    H, V, L, status : ndarray, shape ``(n,)``
        The fallback's roots: end forces (N), ``L0`` (m) and statuses.

    Returns
    -------
    tuple
        ``(H, V_B, V_A, L0, status, iterations)``, shape ``(n,)`` each; NaN
        values where the status is not ``"converged"``.
    """
    its = np.zeros(x.size, np.int64)
    H, V, L, status = H.copy(), V.copy(), L.copy(), status.copy()
    V_A = V - w * L
    i = np.flatnonzero(status == CONVERGED)
    if i.size:
        Ti = T[i]
        with np.errstate(all="ignore"):
            if end == "H":
                P, Q = Ti, V[i]
            else:
                Ve = V[i] if end == "B" else V[i] - w[i] * L[i]
                Te = np.hypot(H[i], Ve)
                P, Q = H[i] / Te, Ve / Te
        Hp, Vp, VAp, Lp, cp, itp = newton_length(
            end, x[i], z[i], Ti, w[i], inv_EA[i], P, Q, L[i], rtol, max_iter
        )
        its[i] = itp
        same = cp & (np.abs(Lp - L[i]) <= 1e-6 * L[i])
        H[i] = np.where(same, Hp, H[i])
        V[i] = np.where(same, Vp, V[i])
        V_A[i] = np.where(same, VAp, V_A[i])
        L[i] = np.where(same, Lp, L[i])
        with np.errstate(all="ignore"):
            got = np.hypot(H[i], V_A[i]) if end == "A" else end_tension(end, H[i], V[i], L[i], w[i])
            off = ~(np.abs(got - Ti) <= T_TOL * Ti)
        status[i[off]] = NOT_CONVERGED
    nan = status != CONVERGED
    H[nan], V[nan], V_A[nan], L[nan] = np.nan, np.nan, np.nan, np.nan
    return H, V, V_A, L, status, its


def _steep_guesses_h(
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    Q0: FloatArray,
    L0: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Second guesses ``(V_B, L0)`` for ``end="H"``, swapped in place with the first.

    Steep cables: the parabola is a poor guess, the catenary in end angles a
    good one (exact if inextensible); each is the other's second chance.
    ``Q0`` and ``L0`` (the first guesses) are modified in place.
    """
    Qc, Lc = Q0.copy(), L0.copy()
    cat_ok = np.flatnonzero(w > 0)
    Qc[cat_ok], Lc[cat_ok] = _catenary_guess_h(
        x[cat_ok], z[cat_ok], T[cat_ok], w[cat_ok], inv_EA[cat_ok], Q0[cat_ok], L0[cat_ok]
    )
    stretch = np.hypot(T, Q0) * inv_EA
    s = np.flatnonzero((np.abs(z) > 3.0 * x) & (w > 0) & (stretch < 0.2))
    Q0[s], Qc[s] = Qc[s], Q0[s]
    L0[s], Lc[s] = Lc[s], L0[s]
    return Qc, Lc


def newton_with_second_guess(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[
    FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]
]:
    """Newton from the closed-form guess (for ``end="H"`` a second Newton from
    the other guess).

    Parameters
    ----------
    end : {"B", "A", "H"}
        Which tension is prescribed.
    x, z, T, w, inv_EA : ndarray, shape ``(n,)``
        Spans (m, ``x > 0``), prescribed tension (N), weight per length (N/m)
        and axial compliance (1/N), best in units where the chord and ``T``
        are of order one.
    rtol, max_iter
        Newton step tolerance and iteration cap.

    Returns
    -------
    tuple
        ``(H, V_B, V_A, L0, converged, iterations)`` as :func:`newton_length`.
    """
    P0, Q0, L0 = _initial_length(end, x, z, T, w, inv_EA)
    Qc, Lc = Q0, L0
    if end == "H":
        Qc, Lc = _steep_guesses_h(x, z, T, w, inv_EA, Q0, L0)
    H, V, V_A, L, conv, its = newton_length(
        end, x, z, T, w, inv_EA, P0, Q0, L0, rtol, max_iter
    )
    if end == "H" and not np.all(conv):
        f = np.flatnonzero(~conv & (w > 0))
        Hr, Vr, VAr, Lr, convr, itr = newton_length(
            end, x[f], z[f], T[f], w[f], inv_EA[f], T[f], Qc[f], Lc[f], rtol, max_iter
        )
        H[f], V[f], V_A[f], L[f], conv[f] = Hr, Vr, VAr, Lr, convr
        its[f] += itr
    return H, V, V_A, L, conv, its
