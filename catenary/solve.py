"""Forward and inverse solvers of the elastic catenary, vectorised over cables.

* :func:`solve_forces` -- unstretched length -> end forces (2 unknowns H, V_B).
* :func:`solve_length` -- an end tension -> unstretched length (unknowns
  H, V_B, L0; the tension condition is built into the parametrisation, so
  Newton works on the two span equations only).

Both run one Newton iteration on all unconverged cables at once (analytic
Jacobian from :mod:`catenary.elastic`), starting from a closed-form guess that
is already accurate for taut cables, and hand the few cables Newton cannot
finish to a bracketing method that cannot fail to converge. Per-cable outcomes
are reported in ``status``; only invalid arguments raise.

Status values
-------------
``"converged"``      solution found (for :func:`solve_length`: the taut branch).
``"slack"``          weightless cable longer than its chord: zero tension.
``"infeasible"``     no catenary satisfies the data (inextensible cable shorter
                     than the chord, end tension too small to span the chord...).
``"indeterminate"``  the geometry does not fix the tension (taut inextensible
                     weightless or vertical cable); forces are NaN.
``"not_converged"``  the iteration limit was hit (not expected; please report).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .elastic import _evaluate, _inv
from .errors import InvalidCableError

__all__ = ["ForcesResult", "LengthResult", "solve_forces", "solve_length"]

FloatArray = NDArray[np.float64]

CONVERGED = "converged"
SLACK = "slack"
INFEASIBLE = "infeasible"
INDETERMINATE = "indeterminate"
NOT_CONVERGED = "not_converged"
_STATUS_DTYPE = "<U13"
_EPS = np.finfo(np.float64).eps
# Residual (relative to the lengths or the tension) above which a small Newton
# step is not trusted as convergence.
_RES_TOL = 1e-8
# Relative error of the prescribed tension above which a root is rejected.
_T_TOL = 1e-9


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
        See the module docstring.
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


@dataclass(frozen=True)
class LengthResult(ForcesResult):
    """Unstretched lengths (m) for a prescribed tension, plus the end forces."""

    L0: FloatArray = None  # type: ignore[assignment]


# ----------------------------------------------------------------------------
# argument checks


def _check(name: str, a: FloatArray, *, positive: bool = False, allow_inf: bool = False) -> None:
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


def _prepare(
    x: ArrayLike, z: ArrayLike, third: ArrayLike, w: ArrayLike, EA: ArrayLike, third_name: str
) -> tuple[tuple[int, ...], list[FloatArray]]:
    arrays = [np.asarray(a, dtype=np.float64) for a in (x, z, third, w, EA)]
    names = ("x", "z", third_name, "w", "EA")
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


# ----------------------------------------------------------------------------
# vectorised safeguarded Newton / bisection on a bracket


def _bracketed_newton(
    f: Callable[[FloatArray, NDArray[np.intp]], tuple[FloatArray, FloatArray]],
    lo: FloatArray,
    hi: FloatArray,
    x0: FloatArray,
    *,
    xtol: float = 4 * _EPS,
    max_iter: int = 200,
) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
    """Root of increasing functions ``f`` (one per element) on ``[lo, hi]``.

    ``f(t, idx)`` returns value and derivative at ``t`` for the elements
    ``idx``; ``f(lo) <= 0 <= f(hi)`` must hold. Newton steps are taken when
    they stay strictly inside the bracket, bisection steps otherwise, so the
    iteration always converges.
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
        exact = val == 0
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
            | (width <= xtol * np.maximum(np.abs(a), np.abs(b)))
            | (np.abs(tn - tt) <= xtol * np.abs(tt))
        )
        t[idx] = np.where(exact, tt, tn)
        done[idx] = fin
        idx = idx[~fin]
    return t, done, its


# ----------------------------------------------------------------------------
# forward problem


def _initial_forces(
    x: FloatArray, z: FloatArray, L0: FloatArray, w: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Closed-form guess of (H, V_B) for cables with x > 0 and w > 0.

    Taut cables: a parabolic cable along the chord, whose length excess over
    the chord balances elastic stretch, ``L0 (1 + T/EA) - c = q^2 c^3 / (24 T^2)``
    with ``q = w cos(theta)`` the transverse load (a cubic in T, solved by
    Newton from an upper bound, where it converges monotonically).
    Slack cables (L0 well above the chord): the inextensible catenary of the
    same length, from ``sinh(lam)/lam = sqrt(L0^2 - z^2)/x`` with
    ``lam = w x / (2 H)``.
    """
    c = np.hypot(x, z)
    cos_t, sin_t = x / c, z / c
    e = L0 - c
    k = (w * cos_t) ** 2 * c**3 / 24.0
    a = L0 * inv_EA
    with np.errstate(all="ignore"):
        t_up = np.maximum(-e, 0.0) / a + np.cbrt(k / a)
        t_inext = np.sqrt(k / e)
        T = np.where(e > 0, np.fmin(t_up, t_inext), t_up)
        for _ in range(12):
            p = a * T**3 + e * T**2 - k
            dp = 3 * a * T**2 + 2 * e * T
            T = np.where(dp > 0, T - p / dp, T)
    H = T * cos_t
    V = T * sin_t + 0.5 * w * L0

    # Deeper sag: the inextensible catenary with this length.
    slack = e > 1e-3 * c
    if np.any(slack):
        i = np.flatnonzero(slack)
        xs, zs, Ls, ws = x[i], z[i], L0[i], w[i]
        R = np.sqrt((Ls - zs) * (Ls + zs)) / xs
        logR = np.log(R)
        lam = np.maximum(np.sqrt(6.0 * (R - 1.0)), logR + np.log(2.0 * logR + 2.0))
        lam = np.where(R < 1.2, np.sqrt(6.0 * (R - 1.0)), lam)
        for _ in range(30):
            # log(sinh(lam)/lam), overflow-safe for large lam
            lsh = lam + np.log1p(-np.exp(-2.0 * lam)) - np.log(2.0) - np.log(lam)
            d = 1.0 / np.tanh(lam) - 1.0 / lam
            lam = np.maximum(lam - (lsh - logR) / d, 0.5 * lam)
        Hs = ws * xs / (2.0 * lam)
        Vs = 0.5 * ws * (zs / np.tanh(lam) + Ls)
        # If stretch matters, keep the taut guess where it is the better one.
        H[i] = np.where(np.isfinite(Hs), Hs, H[i])
        V[i] = np.where(np.isfinite(Vs), Vs, V[i])
    return H, V


def _newton_forces(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    H: FloatArray,
    V: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
    """Safeguarded 2-D Newton on all cables at once; converged ones drop out."""
    H, V = H.copy(), V.copy()
    n = H.size
    conv = np.zeros(n, bool)
    its = np.zeros(n, np.int64)
    idx = np.arange(n)
    for _ in range(max_iter):
        if idx.size == 0:
            break
        h, v, l0, ww, ie = H[idx], V[idx], L0[idx], w[idx], inv_EA[idx]
        xs, zs, fxx, fxz, fzz, *_ = _evaluate(h, v, l0, ww, ie)
        rx, rz = xs - x[idx], zs - z[idx]
        with np.errstate(all="ignore"):
            det = fxx * fzz - fxz * fxz
            dh = -(fzz * rx - fxz * rz) / det
            dv = -(fxx * rz - fxz * rx) / det
        its[idx] += 1
        # Keep H positive and bound the change per step to a factor of 10.
        hn = np.clip(h + dh, 0.1 * h, 10.0 * h)
        fscale = np.hypot(h, v) + ww * l0
        vn = v + np.clip(dv, -10 * fscale, 10 * fscale)
        ok = np.isfinite(hn) & np.isfinite(vn)
        small_step = (np.abs(dh) <= rtol * h) & (np.abs(dv) <= rtol * fscale)
        tiny_res = (np.abs(rx) <= 2 * _EPS * (x[idx] + l0)) & (
            np.abs(rz) <= 2 * _EPS * (np.abs(z[idx]) + l0)
        )
        H[idx] = np.where(ok, hn, h)
        V[idx] = np.where(ok, vn, v)
        fit = (np.abs(rx) <= _RES_TOL * (x[idx] + l0)) & (
            np.abs(rz) <= _RES_TOL * (np.abs(z[idx]) + l0)
        )
        fin = ok & ((small_step & fit) | tiny_res)
        conv[idx] = fin
        # Non-finite steps leave Newton for the fallback.
        idx = idx[~fin & ok]
    return H, V, conv, its


def _nested_forces(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    H0: FloatArray,
    V0: FloatArray,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
    """Bracketing fallback for x > 0, w > 0 (slow but sure).

    For fixed H the z-equation is increasing in V_B, so V_B(H) is found on a
    bracket; the reduced x(H, V_B(H)) is increasing in H (its derivative is
    det(F)/F_zz > 0), so H is found on a bracket in log H. Both 1-D solves are
    safeguarded Newton-bisection.
    """
    n = x.size
    Vcache = np.where(np.isfinite(V0), V0, 0.5 * w * L0)

    def inner(h: FloatArray, sel: NDArray[np.intp]) -> tuple[FloatArray, NDArray[np.int64]]:
        zs, ls, ws, ie = z[sel], L0[sel], w[sel], inv_EA[sel]
        m0 = Vcache[sel] - 0.5 * ws * ls
        M = np.abs(m0) + h + ws * ls + 1.0
        # Expand [-M, M] until it brackets the z target.
        for _ in range(200):
            z_hi = _evaluate(h, M + 0.5 * ws * ls, ls, ws, ie, jacobian=False)[1]
            z_lo = _evaluate(h, -M + 0.5 * ws * ls, ls, ws, ie, jacobian=False)[1]
            grow = (z_hi < zs) | (z_lo > zs)
            if not np.any(grow):
                break
            M = np.where(grow, 4.0 * M, M)

        def fz(m: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
            _, zz, _, _, fzz, *_ = _evaluate(h[j], m + 0.5 * ws[j] * ls[j], ls[j], ws[j], ie[j])
            return zz - zs[j], fzz

        m, _, it = _bracketed_newton(fz, -M, M, m0)
        V = m + 0.5 * ws * ls
        Vcache[sel] = V
        return V, it

    its = np.zeros(n, np.int64)
    all_idx = np.arange(n)

    def outer(t: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
        sel = all_idx[j]
        h = np.exp(t)
        V, it = inner(h, sel)
        its[sel] += it
        xs, _, fxx, fxz, fzz, *_ = _evaluate(h, V, L0[sel], w[sel], inv_EA[sel])
        with np.errstate(all="ignore"):
            dxdh = (fxx * fzz - fxz * fxz) / fzz
        return xs - x[sel], dxdh * h

    # Bracket log H.
    Hg = np.where(np.isfinite(H0) & (H0 > 0), H0, w * L0)
    tlo = np.log(Hg) - 1.0
    thi = np.log(Hg) + 1.0
    for _ in range(100):
        flo = outer(tlo, all_idx)[0]
        bad = flo > 0
        if not np.any(bad):
            break
        tlo = np.where(bad, tlo - 5.0, tlo)
    for _ in range(100):
        fhi = outer(thi, all_idx)[0]
        bad = fhi < 0
        if not np.any(bad):
            break
        thi = np.where(bad, thi + 5.0, thi)
    t, done, it = _bracketed_newton(outer, tlo, thi, np.log(Hg), xtol=1e-16)
    H = np.exp(t)
    V, _ = inner(H, all_idx)
    return H, V, done, its + it


def _solve_forces_flat(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64], NDArray[np.bool_], NDArray[np.str_]]:
    """Flat ``solve_forces``: ``(H, V_B, iterations, converged, status)``."""
    n = x.size
    inv_EA = _inv(EA)
    inext = inv_EA == 0.0
    H = np.full(n, np.nan)
    V = np.full(n, np.nan)
    its = np.zeros(n, np.int64)
    status = np.full(n, NOT_CONVERGED, dtype=_STATUS_DTYPE)
    c = np.hypot(x, z)

    # Weightless cables: a straight bar, in closed form.
    wz = w == 0.0
    if np.any(wz):
        with np.errstate(all="ignore"):
            T = (c - L0) / (L0 * inv_EA)
        T = np.where(c > L0, T, 0.0)
        st = np.where(c < L0, SLACK, CONVERGED)
        st = np.where(inext & (c > L0), INFEASIBLE, st)
        st = np.where(inext & (c == L0), INDETERMINATE, st)
        st = np.where(c == 0.0, SLACK, st)
        with np.errstate(all="ignore"):
            Hw = np.where(c > 0, T * x / c, 0.0)
            Vw = np.where(c > 0, T * z / c, 0.0)
        ok = (st == CONVERGED) | (st == SLACK)
        H = np.where(wz, np.where(ok, Hw, np.nan), H)
        V = np.where(wz, np.where(ok, Vw, np.nan), V)
        status = np.where(wz, st, status)

    # Vertical cables (x = 0, w > 0): H = 0 and closed-form V_B. Spans below
    # 1e-15 of the cable size count as vertical (their H is below rounding).
    vert = (x <= 1e-15 * (c + L0)) & ~wz
    if np.any(vert):
        zz, ll, ww, ie = z, L0, w, inv_EA
        with np.errstate(all="ignore"):
            m_fold = zz / (ll * ie + 2.0 / ww)
            # Folded (V_A < 0 < V_B) up to where the lower end just lifts (V_A = 0).
            fold = np.abs(zz) <= ll + 0.5 * ww * ll * ll * ie
            m_taut = np.where(zz > 0, zz / ll - 1.0, zz / ll + 1.0) / (ll * ie) * ll
            m = np.where(fold, m_fold, m_taut)
        st = np.full(n, CONVERGED, dtype=_STATUS_DTYPE)
        st = np.where(inext & (np.abs(zz) > ll), INFEASIBLE, st)
        st = np.where(inext & (np.abs(zz) == ll), INDETERMINATE, st)
        ok = st == CONVERGED
        H = np.where(vert, np.where(ok, 0.0, np.nan), H)
        V = np.where(vert, np.where(ok, m + 0.5 * ww * ll, np.nan), V)
        status = np.where(vert, st, status)

    gen = ~wz & ~vert
    # Inextensible cables cannot span a chord as long as themselves.
    infeas = gen & inext & (L0 <= c)
    status[infeas] = INFEASIBLE
    gi = np.flatnonzero(gen & ~infeas)
    if gi.size:
        xg, zg, lg, wg, ig = x[gi], z[gi], L0[gi], w[gi], inv_EA[gi]
        H0, V0 = _initial_forces(xg, zg, lg, wg, ig)
        Hn, Vn, conv, itn = _newton_forces(xg, zg, lg, wg, ig, H0, V0, rtol, max_iter)
        st = np.where(conv, CONVERGED, NOT_CONVERGED)
        if not np.all(conv):
            f = np.flatnonzero(~conv)
            Hf, Vf, okf, itf = _nested_forces(xg[f], zg[f], lg[f], wg[f], ig[f], H0[f], V0[f])
            Hn[f], Vn[f] = Hf, Vf
            itn[f] += itf
            st[f] = np.where(okf, CONVERGED, NOT_CONVERGED)
        H[gi], V[gi], its[gi], status[gi] = Hn, Vn, itn, st
    converged = (status == CONVERGED) | (status == SLACK)
    return H, V, its, converged, status


def solve_forces(
    x: ArrayLike,
    z: ArrayLike,
    L0: ArrayLike,
    w: ArrayLike,
    EA: ArrayLike = np.inf,
    *,
    rtol: float = 1e-9,
    max_iter: int = 30,
) -> ForcesResult:
    """End forces of cables of given unstretched length (forward problem).

    Parameters
    ----------
    x : array_like
        Horizontal span (m), ``>= 0``.
    z : array_like
        Height of the upper end B over the lower end A (m), either sign.
    L0 : array_like
        Unstretched length (m), ``> 0``.
    w : array_like
        Weight per unit length (N/m), ``>= 0``.
    EA : array_like, optional
        Axial stiffness (N), ``> 0``; ``inf`` (default) for inextensible.
    rtol : float
        Newton stops once its step is below ``rtol`` relative to the forces;
        with quadratic convergence the result is then accurate to rounding.
    max_iter : int
        Newton iterations before the bracketing fallback takes over.

    Returns
    -------
    ForcesResult
        Arrays of the broadcast shape of the inputs.

    Raises
    ------
    InvalidCableError
        NaN or out-of-domain arguments (negative x, w; L0 <= 0; EA <= 0).

    Notes
    -----
    Newton on ``(H, V_B)`` with the analytic flexibility matrix, from a
    parabolic (taut) or inextensible-catenary (slack) closed-form guess,
    with H kept positive. Cables Newton leaves unconverged are finished by a
    nested bracketing solve (see ``_nested_forces``). Vertical (``x = 0``) and
    weightless (``w = 0``) cables are solved in closed form.
    """
    shape, (xf, zf, lf, wf, ef) = _prepare(x, z, L0, w, EA, "L0")
    H, V, its, conv, status = _solve_forces_flat(xf, zf, lf, wf, ef, rtol, max_iter)
    return ForcesResult(
        H=H.reshape(shape),
        V_A=(V - wf * lf).reshape(shape),
        V_B=V.reshape(shape),
        iterations=its.reshape(shape),
        converged=conv.reshape(shape),
        status=status.reshape(shape),
    )


# ----------------------------------------------------------------------------
# inverse problem

End = Literal["B", "A", "H"]


def _end_tension(end: str, H: FloatArray, V: FloatArray, L0: FloatArray, w: FloatArray):
    if end == "B":
        return np.hypot(H, V)
    if end == "A":
        return np.hypot(H, V - w * L0)
    return H


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


def _newton_length(
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
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
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

    Returns ``(H, V_B, L0, converged, iterations)``. ``converged`` requires a
    small step, span residuals below ``_RES_TOL`` and the taut branch: at a
    root ``dT/dL0`` at fixed geometry has the sign of ``det J`` (``J`` the
    Jacobian in (phi or V_B, L0)), so ``det J < 0`` there.
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
            p, q, l0 = P, Q, L
        if end == "H":
            h, v = Ta, q
        elif end == "B":
            h, v = Ta * p, Ta * q
        else:
            h, va_ = Ta * p, Ta * q
            v = va_ + wa * l0
        xs, zs, fxx, fxz, fzz, _, ta, tb = _evaluate(h, v, l0, wa, ia)
        with np.errstate(all="ignore"):
            rx, rz = xs - xa, zs - za
            if end == "H":
                xp, zp = fxz, fzz
                kk = 1.0 / ta + ia
                xl, zl = h * kk, (v - wa * l0) * kk
            elif end == "B":
                xp, zp = h * fxz - v * fxx, h * fzz - v * fxz
                kk = 1.0 / ta + ia
                xl, zl = h * kk, (v - wa * l0) * kk
            else:
                xp, zp = h * fxz - va_ * fxx, h * fzz - va_ * fxz
                # At fixed (H, V_A) the cable grows at end B, along its tangent.
                kk = 1.0 / tb + ia
                xl, zl = h * kk, v * kk
            det = xp * zl - xl * zp
            dp = (xl * rz - zl * rx) / det
            dl = (zp * rx - xp * rz) / det
        its[idx] += 1
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
        fit = (np.abs(rx) <= _RES_TOL * (xa + l0)) & (np.abs(rz) <= _RES_TOL * (np.abs(za) + l0))
        if end == "H":
            Q[idx] = np.where(ok, qn, q)
        else:
            P[idx] = np.where(ok, pn, p)
            Q[idx] = np.where(ok, qn, q)
        L[idx] = np.where(ok, ln, l0)
        # A small step with a large residual means a (near-)singular Jacobian.
        fin = ok & small & fit
        # A root with dT/dL0 >= 0 is the sagging branch: reject it.
        conv[idx] = fin & (det < 0)
        idx = idx[~fin & ok]
    if end == "H":
        H, V = np.broadcast_to(T, L.shape).copy(), Q
    elif end == "B":
        H, V = T * P, T * Q
    else:
        H, V = T * P, T * Q + w * L
    return H, V, L, conv, its


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
    the parabolic guess of :func:`_initial_length` is poor.
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


def _polish_length(
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
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_], NDArray[np.int64]]:
    """Finish the bracketing fallback's roots and check the tension condition.

    Newton with the tension built in (:func:`_newton_length`) is restarted
    from each root; its answer is taken where it converges to the same
    cable (``L0`` within ``1e-6``). Any root whose end tension is still off
    by more than ``_T_TOL`` relative is reported ``"not_converged"``, never
    as a solution.
    """
    its = np.zeros(x.size, np.int64)
    H, V, L, status = H.copy(), V.copy(), L.copy(), status.copy()
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
        Hp, Vp, Lp, cp, itp = _newton_length(
            end, x[i], z[i], Ti, w[i], inv_EA[i], P, Q, L[i], rtol, max_iter
        )
        its[i] = itp
        same = cp & (np.abs(Lp - L[i]) <= 1e-6 * L[i])
        H[i] = np.where(same, Hp, H[i])
        V[i] = np.where(same, Vp, V[i])
        L[i] = np.where(same, Lp, L[i])
        with np.errstate(all="ignore"):
            off = ~(np.abs(_end_tension(end, H[i], V[i], L[i], w[i]) - Ti) <= _T_TOL * Ti)
        status[i[off]] = NOT_CONVERGED
    nan = status != CONVERGED
    H[nan], V[nan], L[nan] = np.nan, np.nan, np.nan
    return H, V, L, status, its


def _fallback_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    EA: FloatArray,
    L_guess: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_], NDArray[np.int64]]:
    """Bracketing solve in L0 using the forward solver (slow but sure).

    The end tension as a function of L0 (at fixed geometry) falls from
    infinity at the taut limit to a minimum and rises again (for ``end="H"``
    it falls monotonically). The taut root lies between a length with tension
    above T (found by moving towards the taut limit) and one with tension at
    most T (found by golden-section search for the minimum); if the minimum
    tension exceeds T the data are infeasible. The root is then bracketed
    with bisection on log of the length excess.
    """
    n = x.size
    inv_EA = _inv(EA)
    c = np.hypot(x, z)
    its = np.zeros(n, np.int64)

    def tens(L: FloatArray, j: NDArray[np.intp]) -> FloatArray:
        H, V, it, conv, _ = _solve_forces_flat(x[j], z[j], L, w[j], EA[j], 1e-9, 30)
        its[j] += it
        return np.where(conv, _end_tension(end, H, V, L, w[j]), np.nan)

    all_idx = np.arange(n)
    # Length parameter: L0 = Lt * exp(s), Lt the taut limit (chord for inextensible).
    Lt = c / (1.0 + 4.0 * T * inv_EA + 1e-12 * (inv_EA > 0))
    Lt = np.where(inv_EA > 0, Lt, c)
    # Lower end: tension above T.
    s_lo = np.full(n, 1e-3)
    s_lo = np.where(inv_EA > 0, 0.0, s_lo)
    for _ in range(60):
        Tl = tens(Lt * np.exp(s_lo), all_idx)
        bad = ~(Tl > T)
        if not np.any(bad):
            break
        s_lo = np.where(bad & (inv_EA == 0), 0.01 * s_lo, s_lo)
        Lt = np.where(bad & (inv_EA > 0), Lt * 0.9, Lt)
    # Upper end: tension at most T, by golden-section search for the minimum.
    s_hi = np.log(np.maximum(2.0 * T / np.maximum(w, 1e-300) + 2 * c, 4 * c) / Lt) + 1.0
    s_hi = np.maximum(s_hi, s_lo + 1.0)
    a, b = s_lo.copy(), s_hi.copy()
    g = 0.5 * (np.sqrt(5.0) - 1.0)
    found = np.zeros(n, bool)
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
    status = np.where(found, CONVERGED, INFEASIBLE).astype(_STATUS_DTYPE)
    # Bisection on [s_lo, s_m] for the cables with a bracket.
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
    L = Lt * np.exp(0.5 * (lo + hi))
    H, V, _, conv, _ = _solve_forces_flat(x, z, L, w, EA, 1e-9, 30)
    status = np.where(found & ~conv, NOT_CONVERGED, status)
    nan = status != CONVERGED
    return (
        np.where(nan, np.nan, H),
        np.where(nan, np.nan, V),
        np.where(nan, np.nan, L),
        status,
        its,
    )


def _vertical_length(
    end: str, z: FloatArray, T: FloatArray, w: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_]]:
    """Straight vertical cable (x = 0): closed form, H = 0."""
    h = np.abs(z)
    n = z.size
    status = np.full(n, CONVERGED, dtype=_STATUS_DTYPE)
    if end == "H":
        status[:] = np.where(T > 0, INFEASIBLE, INDETERMINATE)
        nan = np.full(n, np.nan)
        return nan, nan, nan, status
    # Tension known at the upper end (B with z > 0, A with z < 0): weight reduces
    # the tension downwards, otherwise it adds.
    upper = (z > 0) if end == "B" else (z < 0)
    sgn = np.where(upper, -1.0, 1.0)
    p = 1.0 + T * inv_EA
    with np.errstate(all="ignore"):
        disc = p * p + sgn * 2.0 * w * h * inv_EA
        L0 = 2.0 * h / (p + np.sqrt(disc))
        bad = (disc < 0) | (upper & (T < w * L0)) | (h == 0)
    status[bad] = INFEASIBLE
    # V_B: end B known -> +-T; end A known -> V_A = +-T, V_B = V_A + w L0.
    if end == "B":
        V = np.where(z > 0, T, -T)
    else:
        V = np.where(z > 0, T, -T) + w * L0
    nan = status != CONVERGED
    return (
        np.where(nan, np.nan, 0.0),
        np.where(nan, np.nan, V),
        np.where(nan, np.nan, L0),
        status,
    )


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
        Newton step tolerance and iteration limit before the fallback.

    Returns
    -------
    LengthResult
        ``.L0`` (m) and the end forces, arrays of the broadcast input shape.
        Where two catenaries have the prescribed end tension, the taut one
        (shorter, larger H) is returned; where none has, status is
        ``"infeasible"`` and the values are NaN.

    Raises
    ------
    InvalidCableError
        NaN or out-of-domain arguments, or ``end`` not one of "B", "A", "H".

    Notes
    -----
    Unknowns ``(H, V_B, L0)``, parametrised so that the tension condition
    holds exactly: the direction angle of the cable at the given end and
    ``L0`` (``end="B"``/``"A"``), or ``V_B`` and ``L0`` with ``H = T``
    (``end="H"``). Newton on the two span equations starts from a straight
    cable along the chord with first-order sag corrections (see
    ``_initial_length``; steep cables given ``H`` start from the catenary in
    end angles); for taut cables this guess is within ``O((w c / T)^2)`` of
    the answer, so two or three steps reach full precision. The Jacobian
    stays regular for weightless and very light cables, whose sag is below
    the rounding of ``L0``. At a root the sign of the Jacobian determinant is
    that of ``dT/dL0`` at fixed geometry and tells the taut branch
    (negative) from the sagging one; cables that reach the sagging branch or
    do not converge are solved by a bracketing search in L0 built on
    :func:`solve_forces`, which also detects infeasibility, and polished by
    the same Newton. A cable is reported converged only if its span
    residuals are below ``1e-8`` of its size and its end tension is within
    ``1e-9`` of the prescribed one. Vertical cables are solved in closed
    form.
    """
    if end not in ("B", "A", "H"):
        raise InvalidCableError(f'end must be "B", "A" or "H"; got end={end!r}')
    shape, (xf, zf, tf, wf, ef) = _prepare(x, z, tension, w, EA, "tension")
    n = xf.size
    inv_EA = _inv(ef)
    H = np.full(n, np.nan)
    V = np.full(n, np.nan)
    L = np.full(n, np.nan)
    its = np.zeros(n, np.int64)
    status = np.full(n, NOT_CONVERGED, dtype=_STATUS_DTYPE)

    vert = xf == 0.0
    if np.any(vert):
        i = np.flatnonzero(vert)
        H[i], V[i], L[i], status[i] = _vertical_length(end, zf[i], tf[i], wf[i], inv_EA[i])
    # Zero tension cannot hold a weighted cable with x > 0 or stretch a bar.
    zero = ~vert & (tf == 0.0)
    status[zero] = np.where(wf[zero] > 0, INFEASIBLE, INDETERMINATE)
    gi = np.flatnonzero(~vert & ~zero)
    if gi.size:
        xg, zg, tg, wg, ig = xf[gi], zf[gi], tf[gi], wf[gi], inv_EA[gi]
        P0, Q0, L0 = _initial_length(end, xg, zg, tg, wg, ig)
        if end == "H":
            # Steep cables: the parabola is a poor guess, the catenary in end
            # angles a good one (exact if inextensible); each is the other's
            # second chance.
            Qc, Lc = Q0.copy(), L0.copy()
            cat_ok = np.flatnonzero(wg > 0)
            Qc[cat_ok], Lc[cat_ok] = _catenary_guess_h(
                xg[cat_ok], zg[cat_ok], tg[cat_ok], wg[cat_ok], ig[cat_ok], Q0[cat_ok], L0[cat_ok]
            )
            stretch = np.hypot(tg, Q0) * ig
            s = np.flatnonzero((np.abs(zg) > 3.0 * xg) & (wg > 0) & (stretch < 0.2))
            Q0[s], Qc[s] = Qc[s], Q0[s]
            L0[s], Lc[s] = Lc[s], L0[s]
        Hn, Vn, Ln, conv, itn = _newton_length(end, xg, zg, tg, wg, ig, P0, Q0, L0, rtol, max_iter)
        if end == "H" and not np.all(conv):
            f = np.flatnonzero(~conv & (wg > 0))
            Hr, Vr, Lr, convr, itr = _newton_length(
                end, xg[f], zg[f], tg[f], wg[f], ig[f], tg[f], Qc[f], Lc[f], rtol, max_iter
            )
            Hn[f], Vn[f], Ln[f], conv[f] = Hr, Vr, Lr, convr
            itn[f] += itr
        st = np.where(conv, CONVERGED, NOT_CONVERGED).astype(_STATUS_DTYPE)
        if not np.all(conv):
            f = np.flatnonzero(~conv)
            Hf, Vf, Lf, stf, itf = _fallback_length(
                end, xg[f], zg[f], tg[f], wg[f], ef[gi][f], Ln[f]
            )
            itn[f] += itf
            Hf, Vf, Lf, stf, itp = _polish_length(
                end, xg[f], zg[f], tg[f], wg[f], ig[f], Hf, Vf, Lf, stf, rtol, max_iter
            )
            Hn[f], Vn[f], Ln[f], st[f] = Hf, Vf, Lf, stf
            itn[f] += itp
        H[gi], V[gi], L[gi], its[gi], status[gi] = Hn, Vn, Ln, itn, st
    converged = status == CONVERGED
    return LengthResult(
        H=H.reshape(shape),
        V_A=(V - wf * L).reshape(shape),
        V_B=V.reshape(shape),
        iterations=its.reshape(shape),
        converged=converged.reshape(shape),
        status=status.reshape(shape),
        L0=L.reshape(shape),
    )
