"""Forward problem: unstretched length -> end forces (unknowns H, V_B).

Newton on the two span equations with the analytic flexibility matrix of
:func:`catenary.elastic.evaluate`, from a closed-form guess; the few cables
Newton leaves unconverged are finished by a nested bracketing solve.
Weightless and vertical cables are solved in closed form.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..elastic import axial_compliance, evaluate
from .common import (
    CONVERGED,
    EPS,
    INDETERMINATE,
    INFEASIBLE,
    NOT_CONVERGED,
    RES_TOL,
    SLACK,
    FloatArray,
    ForcesResult,
    bracketed_newton,
    prepare,
    status_array,
)

__all__ = ["solve_forces", "solve_forces_flat"]


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
        xs, zs, fxx, fxz, fzz, *_ = evaluate(h, v, l0, ww, ie)
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
        tiny_res = (np.abs(rx) <= 2 * EPS * (x[idx] + l0)) & (
            np.abs(rz) <= 2 * EPS * (np.abs(z[idx]) + l0)
        )
        H[idx] = np.where(ok, hn, h)
        V[idx] = np.where(ok, vn, v)
        fit = (np.abs(rx) <= RES_TOL * (x[idx] + l0)) & (
            np.abs(rz) <= RES_TOL * (np.abs(z[idx]) + l0)
        )
        fin = ok & ((small_step & fit) | tiny_res)
        conv[idx] = fin
        # Non-finite steps leave Newton for the fallback.
        idx = idx[~fin & ok]
    return H, V, conv, its


class _NestedForces:
    """Bracketing fallback for x > 0, w > 0 (slow but sure).

    For fixed H the z-equation is increasing in V_B, so V_B(H) is found on a
    bracket (:meth:`vertical_force`); the reduced x(H, V_B(H)) is increasing
    in H (its derivative is det(F)/F_zz > 0), so H is found on a bracket in
    log H (:meth:`span_residual`). Both 1-D solves are safeguarded
    Newton-bisection. The last V_B found per cable warm-starts the next
    inner solve; iterations of the inner solves are counted per cable.
    """

    def __init__(
        self,
        x: FloatArray,
        z: FloatArray,
        L0: FloatArray,
        w: FloatArray,
        inv_EA: FloatArray,
        V0: FloatArray,
    ) -> None:
        self.x, self.z, self.L0, self.w, self.inv_EA = x, z, L0, w, inv_EA
        self.V_cache = np.where(np.isfinite(V0), V0, 0.5 * w * L0)
        self.its = np.zeros(x.size, np.int64)
        self.all_idx = np.arange(x.size)

    def vertical_force(
        self, h: FloatArray, sel: NDArray[np.intp]
    ) -> tuple[FloatArray, NDArray[np.int64]]:
        """``V_B`` (N) solving the z-equation at horizontal tension ``h`` for cables ``sel``."""
        zs, ls, ws, ie = self.z[sel], self.L0[sel], self.w[sel], self.inv_EA[sel]
        m0 = self.V_cache[sel] - 0.5 * ws * ls
        M = np.abs(m0) + h + ws * ls + 1.0
        # Expand [-M, M] until it brackets the z target.
        for _ in range(200):
            z_hi = evaluate(h, M + 0.5 * ws * ls, ls, ws, ie, jacobian=False)[1]
            z_lo = evaluate(h, -M + 0.5 * ws * ls, ls, ws, ie, jacobian=False)[1]
            grow = (z_hi < zs) | (z_lo > zs)
            if not np.any(grow):
                break
            M = np.where(grow, 4.0 * M, M)

        def fz(m: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
            _, zz, _, _, fzz, *_ = evaluate(h[j], m + 0.5 * ws[j] * ls[j], ls[j], ws[j], ie[j])
            return zz - zs[j], fzz

        m, _, it = bracketed_newton(fz, -M, M, m0)
        V = m + 0.5 * ws * ls
        self.V_cache[sel] = V
        return V, it

    def span_residual(self, t: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
        """Reduced x-residual (m) and its derivative in ``t = log H`` for cables ``j``."""
        sel = self.all_idx[j]
        h = np.exp(t)
        V, it = self.vertical_force(h, sel)
        self.its[sel] += it
        xs, _, fxx, fxz, fzz, *_ = evaluate(h, V, self.L0[sel], self.w[sel], self.inv_EA[sel])
        with np.errstate(all="ignore"):
            dxdh = (fxx * fzz - fxz * fxz) / fzz
        return xs - self.x[sel], dxdh * h

    def bracket_log_h(self, Hg: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Bracket ``[t_lo, t_hi]`` of ``log H`` around the guess ``Hg`` (N)."""
        all_idx = self.all_idx
        tlo = np.log(Hg) - 1.0
        thi = np.log(Hg) + 1.0
        for _ in range(100):
            flo = self.span_residual(tlo, all_idx)[0]
            bad = flo > 0
            if not np.any(bad):
                break
            tlo = np.where(bad, tlo - 5.0, tlo)
        for _ in range(100):
            fhi = self.span_residual(thi, all_idx)[0]
            bad = fhi < 0
            if not np.any(bad):
                break
            thi = np.where(bad, thi + 5.0, thi)
        return tlo, thi

    def solve(
        self, H0: FloatArray
    ) -> tuple[FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
        """``(H, V_B, done, iterations)`` starting from the guess ``H0`` (N)."""
        Hg = np.where(np.isfinite(H0) & (H0 > 0), H0, self.w * self.L0)
        tlo, thi = self.bracket_log_h(Hg)
        t, done, it = bracketed_newton(self.span_residual, tlo, thi, np.log(Hg), xtol=1e-16)
        H = np.exp(t)
        V, _ = self.vertical_force(H, self.all_idx)
        return H, V, done, self.its + it


def _weightless_forces(
    x: FloatArray, z: FloatArray, L0: FloatArray, inv_EA: FloatArray, c: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.str_]]:
    """Straight bar (``w = 0``) in closed form: ``(H, V_B, status)``, NaN unless solved."""
    inext = inv_EA == 0.0
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
    return np.where(ok, Hw, np.nan), np.where(ok, Vw, np.nan), st


def _vertical_forces(
    z: FloatArray, L0: FloatArray, w: FloatArray, inv_EA: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.str_]]:
    """Vertical cable (``x = 0``, ``w > 0``): ``(H, V_B, status)``, ``H = 0``.

    Closed form; forces are NaN unless solved.
    """
    inext = inv_EA == 0.0
    with np.errstate(all="ignore"):
        m_fold = z / (L0 * inv_EA + 2.0 / w)
        # Folded (V_A < 0 < V_B) up to where the lower end just lifts (V_A = 0).
        fold = np.abs(z) <= L0 + 0.5 * w * L0 * L0 * inv_EA
        m_taut = np.where(z > 0, z / L0 - 1.0, z / L0 + 1.0) / (L0 * inv_EA) * L0
        m = np.where(fold, m_fold, m_taut)
    st = status_array(z.size, CONVERGED)
    st = np.where(inext & (np.abs(z) > L0), INFEASIBLE, st)
    st = np.where(inext & (np.abs(z) == L0), INDETERMINATE, st)
    ok = st == CONVERGED
    return np.where(ok, 0.0, np.nan), np.where(ok, m + 0.5 * w * L0, np.nan), st


def _general_forces(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64], NDArray[np.str_]]:
    """Cables with ``x > 0``, ``w > 0``: ``(H, V_B, iterations, status)``.

    Closed-form guess, Newton, and the nested bracketing solve for the rest.
    """
    H0, V0 = _initial_forces(x, z, L0, w, inv_EA)
    H, V, conv, its = _newton_forces(x, z, L0, w, inv_EA, H0, V0, rtol, max_iter)
    st = np.where(conv, CONVERGED, NOT_CONVERGED)
    if not np.all(conv):
        f = np.flatnonzero(~conv)
        nested = _NestedForces(x[f], z[f], L0[f], w[f], inv_EA[f], V0[f])
        Hf, Vf, okf, itf = nested.solve(H0[f])
        H[f], V[f] = Hf, Vf
        its[f] += itf
        st[f] = np.where(okf, CONVERGED, NOT_CONVERGED)
    return H, V, its, st


def solve_forces_flat(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64], NDArray[np.bool_], NDArray[np.str_]]:
    """:func:`solve_forces` on checked flat arrays, without the result type.

    Parameters
    ----------
    x, z, L0, w, EA : ndarray, shape ``(n,)``
        As in :func:`solve_forces`, already checked (see
        :func:`catenary.solve.common.prepare`).
    rtol, max_iter
        As in :func:`solve_forces`.

    Returns
    -------
    H, V_B : ndarray, shape ``(n,)``
        End forces (N), NaN where not solved.
    iterations : ndarray of int, shape ``(n,)``
    converged : ndarray of bool, shape ``(n,)``
    status : ndarray of str, shape ``(n,)``
    """
    n = x.size
    inv_EA = axial_compliance(EA)
    H = np.full(n, np.nan)
    V = np.full(n, np.nan)
    its = np.zeros(n, np.int64)
    status = status_array(n, NOT_CONVERGED)
    c = np.hypot(x, z)

    wz = w == 0.0
    if np.any(wz):
        Hw, Vw, st = _weightless_forces(x, z, L0, inv_EA, c)
        H, V, status = np.where(wz, Hw, H), np.where(wz, Vw, V), np.where(wz, st, status)
    # Spans below 1e-15 of the cable size count as vertical (their H is below rounding).
    vert = (x <= 1e-15 * (c + L0)) & ~wz
    if np.any(vert):
        Hv, Vv, st = _vertical_forces(z, L0, w, inv_EA)
        H, V, status = np.where(vert, Hv, H), np.where(vert, Vv, V), np.where(vert, st, status)

    gen = ~wz & ~vert
    # Inextensible cables cannot span a chord as long as themselves.
    infeas = gen & (inv_EA == 0.0) & (L0 <= c)
    status[infeas] = INFEASIBLE
    gi = np.flatnonzero(gen & ~infeas)
    if gi.size:
        H[gi], V[gi], its[gi], status[gi] = _general_forces(
            x[gi], z[gi], L0[gi], w[gi], inv_EA[gi], rtol, max_iter
        )
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
    nested bracketing solve (see ``_NestedForces``). Vertical (``x = 0``) and
    weightless (``w = 0``) cables are solved in closed form.
    """
    shape, (xf, zf, lf, wf, ef) = prepare(x, z, L0, w, EA, "L0")
    H, V, its, conv, status = solve_forces_flat(xf, zf, lf, wf, ef, rtol, max_iter)
    return ForcesResult(
        H=H.reshape(shape),
        V_A=(V - wf * lf).reshape(shape),
        V_B=V.reshape(shape),
        iterations=its.reshape(shape),
        converged=conv.reshape(shape),
        status=status.reshape(shape),
    )
