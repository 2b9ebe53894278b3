"""Forward problem: unstretched length -> end forces (unknowns H, V_B).

Newton on the two span equations with the analytic flexibility matrix of
:func:`catenary.elastic.evaluate`, from a closed-form guess, on
nondimensional data; the few cables Newton leaves unconverged are solved
through one monotone equation in the half-difference of the hyperbolic end
angles (:class:`_EndAngleEquation`) and polished by Newton. Weightless and
vertical cables are solved in closed form. Every answer is certified
(:func:`catenary.solve.common.certify_spans`) before it is reported.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..elastic import axial_compliance, evaluate, power_of_two
from .common import (
    CONVERGED,
    EPS,
    INDETERMINATE,
    INFEASIBLE,
    MAX_ITER_CAP,
    NOT_CONVERGED,
    RES_TOL,
    SLACK,
    STATUS_DTYPE,
    FloatArray,
    ForcesResult,
    bracketed_newton,
    certify_spans,
    check_settings,
    in_pieces,
    prepare,
    selection,
    status_array,
)
from .compiled import (
    all_converged,
    all_true,
    flat_arguments,
    load_kernels,
    new_result,
    run_cables,
    take,
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
        with np.errstate(all="ignore"):
            R = np.sqrt(Ls - zs) * np.sqrt(Ls + zs) / xs
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
        # The spans must fit the chord (the certificate), whatever the length.
        tol = RES_TOL * np.hypot(x[idx], z[idx])
        fit = (np.abs(rx) <= tol) & (np.abs(rz) <= tol)
        fin = ok & fit & (small_step | tiny_res)
        conv[idx] = fin
        # Non-finite steps, and small steps that leave the residual large (a
        # residual at rounding level above the tolerance), leave Newton.
        idx = idx[~fin & ok & ~(small_step & ~fit)]
    return H, V, conv, its


# Bounds of log(d) in the fallback: d = 1e-300 (straight to rounding) to 800 (exp(-d)
# underflows, the cable hangs vertically to rounding).
_LOG_D_MIN = float(np.log(1e-300))
_LOG_D_MAX = float(np.log(800.0))


class _EndAngleEquation:
    """The span equations of ``x > 0, w > 0`` cables as one decreasing equation in ``d``.

    With lengths in units of ``L0`` and forces in units of the weight
    ``W = w L0`` (``X = x/L0``, ``Z = z/L0``, ``e = W/EA``), and ``a, b`` the
    hyperbolic end angles (``V_A = H sinh(a)``, ``V_B = H sinh(b)``), the
    half-difference ``d = (b - a)/2`` fixes the rest: ``tanh((a+b)/2) = t(d) =
    2 Z tanh(d)/(2 tanh(d) + e)``, and the horizontal span reads
    ``phi(d) = (d + e/2) sqrt(1 - t^2)/sinh(d) = X``. ``phi`` is a product of two
    positive decreasing functions of ``d`` that falls from ``+inf`` (or
    ``sqrt(1 - Z^2) > X`` if inextensible) to 0, so the root is unique and
    bracketed; :meth:`forces` turns it into ``(H, V_B)``.
    """

    def __init__(self, x: FloatArray, z: FloatArray, L0: FloatArray, w: FloatArray,
                 inv_EA: FloatArray) -> None:
        self.W = w * L0
        self.X, self.Z, self.e = x / L0, z / L0, self.W * inv_EA

    def _terms(self, d: FloatArray, j: NDArray[np.intp] | slice) -> tuple[FloatArray, ...]:
        """``(t, sqrt(1 - t^2), tanh(d), 1/sinh(d))`` for the cables ``j``."""
        th = np.tanh(d)
        t = 2.0 * self.Z[j] * th / (2.0 * th + self.e[j])
        root = np.sqrt(np.maximum((1.0 - t) * (1.0 + t), 0.0))
        inv_sinh = 2.0 * np.exp(-d) / -np.expm1(-2.0 * d)  # no overflow at large d
        return t, root, th, inv_sinh

    def __call__(self, u: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
        """``X - phi(d)`` (increasing) and its derivative in ``u = log(d)``."""
        with np.errstate(all="ignore"):
            d = np.exp(u)
            e = self.e[j]
            t, root, th, inv_sinh = self._terms(d, j)
            A = (d + 0.5 * e) * inv_sinh
            dA = (1.0 - (d + 0.5 * e) / th) * inv_sinh
            dt = 2.0 * self.Z[j] * e / (np.cosh(d) * (2.0 * th + e)) ** 2
            d_root = np.where(root > 0.0, -t * dt / root, -np.inf)
            return self.X[j] - A * root, -d * (dA * root + A * d_root)

    def bracket(self, u0: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``[lo, hi]`` in ``log(d)`` around ``u0`` with a sign change (capped widening)."""
        idx = np.arange(u0.size)
        lo, hi = u0 - 1.0, u0 + 1.0
        step = 2.0
        for _ in range(12):  # steps double: 12 of them span every double
            low = self(lo, idx)[0] > 0.0
            high = self(hi, idx)[0] < 0.0
            if not (low.any() or high.any()):
                break
            lo = np.where(low, np.maximum(lo - step, _LOG_D_MIN), lo)
            hi = np.where(high, np.minimum(hi + step, _LOG_D_MAX), hi)
            step *= 2.0
        return lo, hi

    def forces(self, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(H, V_B)`` in the units of the data at the root ``u = log(d)``."""
        with np.errstate(all="ignore"):
            t, root, th, inv_sinh = self._terms(np.exp(u), slice(None))
            return self.W * (0.5 * root * inv_sinh), self.W * (0.5 + 0.5 * t / th)


def _end_angle_forces(
    x: FloatArray, z: FloatArray, L0: FloatArray, w: FloatArray, inv_EA: FloatArray,
    H0: FloatArray,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64]]:
    """Fallback for ``x > 0, w > 0``: ``(H, V_B, iterations)`` from one equation in ``d``.

    A safeguarded Newton-bisection on :class:`_EndAngleEquation` in ``log(d)``,
    from ``d ~ w x/(2 H0)`` (``H0`` the closed-form guess, N); at most 12
    bracket widenings and 100 iterations. Newton on the span equations
    polishes the result (near-taut cables lose digits in ``d``).
    """
    eq = _EndAngleEquation(x, z, L0, w, inv_EA)
    with np.errstate(all="ignore"):
        d0 = 0.5 * w * x / H0
    u0 = np.clip(np.log(np.where(np.isfinite(d0) & (d0 > 0), d0, 1.0)), _LOG_D_MIN, _LOG_D_MAX)
    lo, hi = eq.bracket(u0)
    u, _, its = bracketed_newton(eq, lo, hi, u0, atol=1e-15, max_iter=100)
    H, V = eq.forces(u)
    return H, V, its + 12


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

    Nondimensional: lengths in units of the chord and forces in units of the
    weight ``w max(chord, L0)`` or of the stretching force ``EA (chord/L0 - 1)``,
    whichever is larger (both rounded to powers of two, so the rounding is that
    of SI units). Closed-form guess and Newton; the cables Newton leaves are
    solved by :func:`_end_angle_forces` and polished by Newton again.
    Forces that do not fit in a double are ``"not_converged"``.
    """
    c = np.hypot(x, z)
    stretching = np.where(c > L0, (c - L0) / (L0 * inv_EA), 0.0)
    force_scale = np.maximum(w * np.maximum(c, L0), stretching)
    ell, F = power_of_two(c), power_of_two(force_scale)
    xs, zs, Ls = x / ell, z / ell, L0 / ell
    ws, ies = (w / F) * ell, inv_EA * F
    # Forces, weight, compliance or stretch under the weight beyond the double range
    # in these units (inf or NaN here): no answer.
    fine = np.isfinite(force_scale) & np.isfinite(ws * ies)
    if fine.all():
        H, V, conv, its = _scaled_forces(xs, zs, Ls, ws, ies, rtol, max_iter)
    else:
        n = x.size
        H, V = np.full(n, np.nan), np.full(n, np.nan)
        its = np.zeros(n, np.int64)
        conv = np.zeros(n, bool)
        s = np.flatnonzero(fine)
        H[s], V[s], conv[s], its[s] = _scaled_forces(
            xs[s], zs[s], Ls[s], ws[s], ies[s], rtol, max_iter)
    st = np.where(conv, CONVERGED, NOT_CONVERGED).astype(STATUS_DTYPE)
    return H * F, V * F, its, st


def _scaled_forces(
    x: FloatArray,
    z: FloatArray,
    L0: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
    rtol: float,
    max_iter: int,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_], NDArray[np.int64]]:
    """:func:`_general_forces` on nondimensional data: ``(H, V_B, converged, iterations)``."""
    H0, V0 = _initial_forces(x, z, L0, w, inv_EA)
    H, V, conv, its = _newton_forces(x, z, L0, w, inv_EA, H0, V0, rtol, max_iter)
    f = np.flatnonzero(~conv)
    if f.size:
        Hf, Vf, itf = _end_angle_forces(x[f], z[f], L0[f], w[f], inv_EA[f], H0[f])
        Hf, Vf, conv[f], itp = _newton_forces(
            x[f], z[f], L0[f], w[f], inv_EA[f], Hf, Vf, rtol, max_iter
        )
        H[f], V[f] = Hf, Vf
        its[f] += itf + itp
    return H, V, conv, its


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

    The batch is solved in pieces of bounded memory
    (:func:`~catenary.solve.common.in_pieces`).
    """
    return in_pieces(lambda x, z, L0, w, EA: _forces_piece(x, z, L0, w, EA, rtol, max_iter),
                     [x, z, L0, w, EA])


def _forces_piece(x: FloatArray, z: FloatArray, L0: FloatArray, w: FloatArray, EA: FloatArray,
                  rtol: float, max_iter: int
                  ) -> tuple[FloatArray, FloatArray, NDArray[np.int64], NDArray[np.bool_],
                             NDArray[np.str_]]:
    """:func:`solve_forces_flat` of one piece of the batch."""
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
    # Spans below 1e-15 of the chord count as vertical (their H is below rounding).
    vert = (x <= 1e-15 * c) & ~wz
    if np.any(vert):
        Hv, Vv, st = _vertical_forces(z, L0, w, inv_EA)
        H, V, status = np.where(vert, Hv, H), np.where(vert, Vv, V), np.where(vert, st, status)

    gen = ~wz & ~vert
    # Inextensible cables cannot span a chord as long as themselves.
    infeas = gen & (inv_EA == 0.0) & (L0 <= c)
    status[infeas] = INFEASIBLE
    general = gen & ~infeas
    if general.any():
        s = selection(general)
        H[s], V[s], its[s], status[s] = _general_forces(
            x[s], z[s], L0[s], w[s], inv_EA[s], rtol, max_iter
        )
    # The certificate: finite forces whose catenary spans the chord (else no answer).
    converged = status == CONVERGED
    if converged.any():
        s = selection(converged)
        certified = np.zeros(n, bool)
        certified[s] = certify_spans(x[s], z[s], H[s], V[s], L0[s], w[s], inv_EA[s])
        status[converged & ~certified] = NOT_CONVERGED
    unsolved = (status != CONVERGED) & (status != SLACK)
    if unsolved.any():
        H[unsolved], V[unsolved] = np.nan, np.nan
    converged = ~unsolved
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
    compiled: bool = True,
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
        Newton stops once its step is below ``rtol`` (in (0, 1)) relative to the forces;
        with quadratic convergence the result is then accurate to rounding.
    max_iter : int
        Newton iterations (1 to 10000) before the fallback takes over (and its polish).
    compiled : bool
        Whether the compiled kernels (:mod:`catenary.solve.kernels`) solve the cables
        they settle (default), the numpy path the others; False solves every cable by
        the numpy reference. Both give the same statuses and values to rounding.

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
    Newton on ``(H, V_B)`` with the analytic flexibility matrix, from a parabolic
    (taut) or inextensible-catenary (slack) closed-form guess, with H kept positive, in
    units of the chord and of the cable's force scale. Cables Newton leaves unconverged
    are solved through one monotone equation in the end angles (``_EndAngleEquation``)
    and polished. Vertical (``x <= 1e-15`` chord) and weightless (``w = 0``) cables are
    solved in closed form. Converged means finite forces and spans within ``1e-8`` of
    the chord of ``(x, z)``; else ``"not_converged"`` with NaN forces. The
    compiled kernels run the same guess, Newton and certificate per cable (in parallel
    over large batches); the first call loads them. Both agree to about 1e-12 save on
    taut, nearly vertical cables, where ``H`` moves by 1e-6 for a change of ``z`` of
    1e-14 of the chord: up to 3e-8 apart, each exact for the data to rounding.
    """
    if not (type(rtol) is float and 0.0 < rtol < 1.0 and type(max_iter) is int
            and 0 < max_iter <= MAX_ITER_CAP):  # the usual settings pass without a call
        check_settings(rtol, max_iter)
    if compiled:
        result = _compiled_forces(x, z, L0, w, EA, rtol, max_iter)
        if result is not None:
            return result
    shape, (xf, zf, lf, wf, ef) = prepare(x, z, L0, w, EA, "L0")
    # Overflow is expected at extreme data: the certificate checks every result.
    with np.errstate(all="ignore"):
        H, V, its, conv, status = solve_forces_flat(xf, zf, lf, wf, ef, rtol, max_iter)
        V_A = V - wf * lf
    return ForcesResult(
        H=H.reshape(shape),
        V_A=V_A.reshape(shape),
        V_B=V.reshape(shape),
        iterations=its.reshape(shape),
        converged=conv.reshape(shape),
        status=status.reshape(shape),
    )


def _compiled_forces(x: ArrayLike, z: ArrayLike, L0: ArrayLike, w: ArrayLike,
                     EA: ArrayLike, rtol: float, max_iter: int) -> ForcesResult | None:
    """:func:`solve_forces` through the compiled kernel, the cables it leaves by
    :func:`solve_forces_flat`; None where the numpy path must decide for the whole call
    (invalid data, shapes that do not broadcast, no cable)."""
    flat = flat_arguments(x, z, L0, w, EA)
    if flat is None:
        return None
    shape, n, (xf, zf, lf, wf, ef) = flat
    kernels = load_kernels()
    out = np.empty((3, n))
    ints = np.empty((2, n), dtype=np.int64)
    unsettled = run_cables("solve_forces_cables", n, xf, zf, lf, wf, ef, float(rtol),
                           int(max_iter), out, ints)
    if unsettled:
        codes = ints[0]
        if np.any(codes == kernels.INVALID):
            return None  # the numpy checks raise the package's error
        redo = np.flatnonzero(codes != kernels.CONVERGED)
        lr, wr = take(lf, redo), take(wf, redo)
        with np.errstate(all="ignore"):
            H, V, its, conv, st = solve_forces_flat(take(xf, redo), take(zf, redo), lr, wr,
                                                    take(ef, redo), rtol, max_iter)
            out[0, redo], out[1, redo], out[2, redo] = H, V, V - wr * lr
        ints[1, redo] = its
        status = all_converged(n)
        status[redo] = st
        converged = all_true(n)
        converged[redo] = conv
    else:
        status, converged = all_converged(n), all_true(n)
    H, V_B, V_A, its = out[0], out[1], out[2], ints[1]
    if len(shape) != 1:
        H, V_B, V_A = H.reshape(shape), V_B.reshape(shape), V_A.reshape(shape)
        its, converged, status = its.reshape(shape), converged.reshape(shape), status.reshape(shape)
    return new_result(ForcesResult, H=H, V_A=V_A, V_B=V_B, iterations=its,
                      converged=converged, status=status)
