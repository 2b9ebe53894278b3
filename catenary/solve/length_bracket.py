"""Bracketing search for the unstretched length of a prescribed tension.

The slow but sure fallback of :func:`catenary.solve.solve_length`: it finds the
taut root for the cables Newton cannot finish and detects infeasible data.

At fixed geometry the catenaries through both ends form a one-parameter
family. It is parametrised here by ``d = (b - a)/2``, half the difference of
the hyperbolic end angles (``V_A = H sinh(a)``, ``V_B = H sinh(b)``, so
``d = w x_c / (2 H)`` with ``x_c`` the span without stretch): ``d`` runs from 0
(taut, straight) to infinity (slack, hanging), and for every ``d`` the span
equations fix the member through one monotone equation in the mean end angle
(:class:`_FamilyTension`), after which its forces and length are closed forms
without cancellation. The end tension along the family falls from infinity to
a minimum and rises again (for ``end="H"`` it falls all the way); grid scans and
a golden-section search in ``log(d)`` find a member with tension at most the
prescribed one, or show that none exists, and the Illinois method finds the
taut root. Every loop has a hard iteration cap.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import NDArray

from .common import (
    CONVERGED,
    EPS,
    INFEASIBLE,
    NOT_CONVERGED,
    STATUS_DTYPE,
    FloatArray,
    bracketed_newton,
)

__all__ = ["bracket_length", "end_tension"]

# Golden-section ratio.
_GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)
#: Range of ``log(d)`` searched: 1e-300 (straight to rounding) to 700 (sinh(d) finite).
_LOG_D = (float(np.log(1e-300)), float(np.log(700.0)))
#: Range of ``log(mu)`` searched by the inner solve (mu from the least double to 1500).
_LOG_MU = (float(np.log(5e-324)), float(np.log(1500.0)))
#: Golden-section steps after the grid scans: the bracket shrinks by 1e-7.
_GOLDEN_STEPS = 35
#: Steps of the root search on the taut side (at least bisection's 2**-64 of the bracket).
_BISECTION_STEPS = 64


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


class _FamilyTension:
    """End tension (N) of the catenary through both ends with parameter ``d``.

    With ``m = (a + b)/2`` (sign of ``z``), ``mu = |m|``, ``alpha = w/(2 EA)``
    and ``beta = alpha / tanh(d)``, the span equations read ``|z| = L0
    tanh(mu) (1 + beta L0)`` and ``x = L0 (d + alpha L0) / (cosh(mu) sinh(d))``.
    The first gives ``L0(mu)``, decreasing; the second is then one decreasing
    equation in ``mu``, from ``+inf`` at ``mu = 0`` (``z = 0``: ``mu = 0`` and
    ``L0`` from a quadratic), solved in logarithms (of the span and of ``mu``,
    ``mu`` up to 1500) by safeguarded Newton, from the inextensible member or
    the last ``mu`` of each cable, whichever fits better. The end
    forces follow in closed form (:meth:`members`). Inner iterations are
    counted per cable in ``its``.
    """

    def __init__(self, end: str, x: FloatArray, z: FloatArray, w: FloatArray,
                 inv_EA: FloatArray) -> None:
        self.end, self.x, self.z, self.w = end, x, np.abs(z), w
        self.upward = z >= 0.0
        self.alpha = 0.5 * w * inv_EA
        self.mu = np.full(x.size, np.nan)
        self.its = np.zeros(x.size, np.int64)

    @staticmethod
    def _length_of(
        mu: FloatArray, beta: FloatArray, z: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """``(q, L0)`` with ``q = |z| / tanh(mu)`` and ``beta L0^2 + L0 = q`` (m, m)."""
        q = z / np.tanh(mu)
        s = 4.0 * beta * q
        r = 1.0 / q
        # The same root written for large beta q (no overflow in s).
        L = np.where(s < 1e300, 2.0 * q / (1.0 + np.sqrt(1.0 + s)),
                     2.0 / (r + np.sqrt(r * r + 4.0 * (beta * r))))
        return q, L

    def mid_angle(self, d: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
        """``(mu, L0)`` of the members ``d`` of the families ``j`` (NaN where not found)."""
        x, z, alpha = self.x[j], self.z[j], self.alpha[j]
        beta = alpha / np.tanh(d)
        # (Level cables, z = 0, are set apart below: the search only flags them.)
        log_target = np.log(x) + d + np.log(-0.5 * np.expm1(-2.0 * d))  # log(x sinh(d))

        def residual(nu: FloatArray, i: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
            """``-log(x(mu)/x)`` (increasing) and its derivative in ``nu = log(mu)``."""
            mu = np.exp(nu)
            q, L = self._length_of(mu, beta[i], z[i])
            stretch = d[i] + alpha[i] * L
            log_cosh = mu + np.log1p(np.exp(-2.0 * mu)) - np.log(2.0)
            g = np.log(L) + np.log(stretch) - log_cosh - log_target[i]
            # dq/dmu = -q / (sinh(mu) cosh(mu)), dL0/dq = 1 / (1 + 2 beta L0).
            dlog_L = -(q / L) / ((1.0 + 2.0 * beta[i] * L) * (0.5 * np.sinh(2.0 * mu)))
            return -g, -mu * (dlog_L * (1.0 + alpha[i] * L / stretch) - np.tanh(mu))

        lo, hi = np.full(x.size, _LOG_MU[0]), np.full(x.size, _LOG_MU[1])
        # Start: the inextensible member (exact there), tanh(mu) = |z| / L0 with
        # L0 = hypot(z, x sinh(d)/d), unless the last member is closer.
        cold = np.log(np.arctanh(np.minimum(z / np.hypot(z, x * (np.sinh(d) / d)), 1.0 - EPS)))
        warm = np.log(self.mu[j])
        closer = np.isfinite(warm) & (alpha > 0)
        if np.any(closer):
            k = np.flatnonzero(closer)
            closer[k] = np.abs(residual(warm[k], k)[0]) < np.abs(residual(cold[k], k)[0])
        start = np.where(closer, warm, cold)
        nu, _, it = bracketed_newton(residual, lo, hi, start, atol=1e-15, ftol=1e-14,
                                     max_iter=80)
        mu = np.exp(nu)
        np.add.at(self.its, j, it)
        L = self._length_of(mu, beta, z)[1]
        bad = ~(np.abs(residual(nu, np.arange(nu.size))[0]) <= 1e-10)
        # Level cables: mu = 0 and alpha L0^2 + d L0 = x sinh(d).
        flat = z == 0.0
        rhs = x * np.sinh(d)
        level = 2.0 * rhs / (d + np.sqrt(d * d + 4.0 * alpha * rhs))
        # Nearly level ones whose mean angle is so small that cosh(mu) is 1 in floating
        # point: the level length solves the span equation exactly, and the height
        # gives mu (the search in log(mu) loses it there, among subnormal numbers).
        near = np.arctanh(np.minimum(z / (level * (1.0 + beta * level)), 1.0 - EPS))
        nearly = bad & ~flat & (np.cosh(near) == 1.0)
        L = np.where(flat | nearly, level, L)
        mu = np.where(flat, 0.0, np.where(nearly, near, np.where(bad, np.nan, mu)))
        self.mu[j] = np.where(np.isnan(mu), self.mu[j], mu)
        return mu, np.where(np.isnan(mu), np.nan, L)

    def members(self, u: FloatArray, j: NDArray[np.intp]) -> tuple[FloatArray, ...]:
        """``(H, V_B, V_A, L0)`` (N, N, N, m) of the members ``log(d) = u`` of families ``j``.

        In closed form without cancellation: with ``D = -expm1(-2d) (1 +
        exp(-2 mu))``, ``H = 2 W exp(-d - mu) / D``, and ``cosh(mu +- d)`` and
        ``sinh(mu +- d)`` over ``2 sinh(d) cosh(mu)`` as ratios of exponentials
        of negative arguments; ``W = w L0``.
        """
        d = np.exp(u)
        mu, L = self.mid_angle(d, j)
        W = self.w[j] * L
        e2m, e2d = np.exp(-2.0 * mu), np.exp(-2.0 * d)
        D = -np.expm1(-2.0 * d) * (1.0 + e2m)
        H = 2.0 * W * np.exp(-d - mu) / D
        v_far, v_near = W * (1.0 - e2m * e2d) / D, W * (e2d - e2m) / D
        up = self.upward[j]
        # z >= 0: V_B = W sinh(mu + d)/(..), V_A = W sinh(mu - d)/(..); z < 0: mirrored.
        return H, np.where(up, v_far, -v_near), np.where(up, v_near, -v_far), L

    def __call__(self, u: FloatArray, j: NDArray[np.intp]) -> FloatArray:
        """End tension (N) at ``log(d) = u`` for the families ``j``: ``inf`` where it
        overflows, NaN where the member was not found."""
        with np.errstate(all="ignore"):
            H, V_B, V_A, _ = self.members(u, j)
            return H if self.end == "H" else np.hypot(H, V_B if self.end == "B" else V_A)

    def forces(self, u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(H, V_B, L0)`` (N, N, m) of the members ``log(d) = u`` of every family."""
        with np.errstate(all="ignore"):
            H, V_B, _, L = self.members(u, np.arange(u.size))
        return H, V_B, L


def _convex_floor(a: FloatArray, p1: FloatArray, p2: FloatArray, b: FloatArray,
                  f: tuple[FloatArray, FloatArray, FloatArray, FloatArray]) -> FloatArray:
    """Lower bound of a convex function on ``[a, b]`` from its values at ``a < p1 < p2 < b``.

    Left of ``p1`` and right of ``p2`` the function lies above the chord through
    ``p1, p2``; between them, above both outer chords (through ``a, p1`` and
    ``p2, b``) extended inwards.
    """
    fa, f1, f2, fb = f
    with np.errstate(all="ignore"):
        s12 = (f2 - f1) / (p2 - p1)
        outer = np.fmin(np.fmin(f1 + s12 * (a - p1), f1), np.fmin(f2 + s12 * (b - p2), f2))
        s1, s2 = (f1 - fa) / (p1 - a), (fb - f2) / (b - p2)
        cross = np.clip((f2 - s2 * p2 - f1 + s1 * p1) / (s1 - s2), p1, p2)
        inner = np.maximum(f1 + s1 * (cross - p1), f2 + s2 * (cross - p2))
        floor = np.fmin(outer, inner)
    return np.where(np.isfinite(floor), floor, -np.inf)


def _scan(
    tens: _FamilyTension, T: FloatArray, lo: FloatArray, hi: FloatArray,
    idx: NDArray[np.intp], points: int,
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
           FloatArray]:
    """Tension on a grid of ``points`` values of ``log(d)`` in ``[lo, hi]`` of families ``idx``.

    Returns ``(found, u_above, u_below, a, b, fa, fb)``, each of length
    ``idx.size``: where ``found``, the first grid point with tension at most
    ``T`` (``u_below``) and the one before it (``u_above``, tension above
    ``T`` if the first point's is); elsewhere the grid cells around the
    smallest tension, ``[a, b]``, with the tensions at their ends.
    """
    grid = lo[idx, None] + (hi[idx] - lo[idx])[:, None] * np.linspace(0.0, 1.0, points)
    f = tens(grid.ravel(), np.repeat(idx, points)).reshape(grid.shape)
    rows = np.arange(idx.size)
    below = f <= T[idx, None]
    # A row reduction of a 2-D mask: an array (the stubs also allow a scalar).
    found = cast("NDArray[np.bool_]", below.any(axis=1))
    first = np.argmax(below, axis=1)
    best = np.argmin(np.where(np.isnan(f), np.inf, f), axis=1)
    left, right = np.maximum(best - 1, 0), np.minimum(best + 1, points - 1)
    return (found, grid[rows, np.maximum(first - 1, 0)], grid[rows, first],
            grid[rows, left], grid[rows, right], f[rows, left], f[rows, right])


def _golden_section_below(
    tens: _FamilyTension, T: FloatArray, u_min: FloatArray
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], FloatArray, FloatArray]:
    """Search in ``log(d)`` for a member with tension at most ``T``.

    Two grid scans (:func:`_scan`, 40 then 20 points) narrow the range to a few
    cells around the smallest tension, then golden-section search follows.
    Returns ``(found, infeasible, u_above, u_below)``: where ``found``, the
    tension is above ``T`` at ``u_above`` and at most ``T`` at ``u_below >
    u_above``. ``infeasible`` where the minimum tension exceeds ``T``: shown
    once the bracket of the minimum is narrow (``log(d)`` within 0.5) and the
    tension, convex there, is bounded below by more than ``T``
    (:func:`_convex_floor`), or at the end of the search. The search stops per
    cable as soon as it decides.
    """
    n = T.size
    a, b = u_min.copy(), np.full(n, _LOG_D[1])
    fa, fb = np.full(n, np.inf), np.full(n, np.inf)
    found = np.zeros(n, bool)
    above, below = np.full(n, np.nan), np.full(n, np.nan)
    idx = np.arange(n)
    reachable = tens(a, idx) > T
    idx = idx[reachable]
    for points in (40, 20):
        if idx.size == 0:
            break
        hit, u_above, u_below, a[idx], b[idx], fa[idx], fb[idx] = _scan(
            tens, T, a, b, idx, points)
        found[idx], above[idx], below[idx] = hit, u_above, u_below
        # The smallest tension at the slack end of the range: the minimum, if any, is
        # out of reach (always so for end "H", whose tension falls all the way); next
        # to a member not found: no minimum to trust. Either way, not converged.
        idx = idx[~hit & (b[idx] < _LOG_D[1]) & ~np.isnan(fa[idx]) & ~np.isnan(fb[idx])]
    infeasible = np.zeros(n, bool)
    p1, p2 = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    f1, f2 = np.full(n, np.inf), np.full(n, np.inf)
    if idx.size:
        both = tens(np.concatenate([p1[idx], p2[idx]]), np.concatenate([idx, idx]))
        f1[idx], f2[idx] = both[:idx.size], both[idx.size:]
    for k in range(_GOLDEN_STEPS + 1):
        hit = np.zeros(n, bool)
        hit[idx] = (f1[idx] <= T[idx]) | (f2[idx] <= T[idx])
        # The point before the hit is the bracket's end a (or p1 when p2 hits).
        above = np.where(hit, np.where(f1 <= T, a, p1), above)
        below = np.where(hit, np.where(f1 <= T, p1, p2), below)
        found |= hit
        # Only where every member around the minimum was found (finite tension).
        known = ~(np.isnan(fa) | np.isnan(f1) | np.isnan(f2) | np.isnan(fb))
        narrow = (b - a < 0.5) & (b < _LOG_D[1] - 1e-3) & known
        floor = _convex_floor(a, p1, p2, b, (fa, f1, f2, fb))
        infeasible[idx] |= ~hit[idx] & narrow[idx] & (floor[idx] > T[idx])
        # No member found at either point: nothing to go on (not converged).
        lost = np.isnan(f1[idx]) & np.isnan(f2[idx])
        # Narrowing onto the slack end of the range: the minimum is out of reach.
        at_end = (b[idx] - a[idx] < 0.5) & (b[idx] >= _LOG_D[1] - 1e-3)
        idx = idx[~hit[idx] & ~infeasible[idx] & ~lost & ~at_end]
        if idx.size == 0 or k == _GOLDEN_STEPS:
            break
        left = f1[idx] < f2[idx]
        a[idx], fa[idx] = np.where(left, a[idx], p1[idx]), np.where(left, fa[idx], f1[idx])
        b[idx], fb[idx] = np.where(left, p2[idx], b[idx]), np.where(left, f2[idx], fb[idx])
        # One new point per step: the other is kept.
        new = np.where(left, b[idx] - _GOLDEN * (b[idx] - a[idx]),
                       a[idx] + _GOLDEN * (b[idx] - a[idx]))
        f_new = tens(new, idx)
        p1[idx], p2[idx] = np.where(left, new, p2[idx]), np.where(left, p1[idx], new)
        f1[idx], f2[idx] = np.where(left, f_new, f2[idx]), np.where(left, f1[idx], f_new)
    # At the end of the search: conclusive where the minimum lies inside the range.
    inside = np.zeros(n, bool)
    inside[idx] = ((b[idx] < _LOG_D[1] - 1e-3) & known[idx] & np.isfinite(f1[idx])
                   & np.isfinite(f2[idx]))
    infeasible |= inside & (np.fmin(f1, f2) > T)
    return found & reachable, infeasible & reachable & ~found, above, below


def _taut_root(
    tens: _FamilyTension, T: FloatArray, lo: FloatArray, hi: FloatArray,
    todo: NDArray[np.bool_],
) -> FloatArray:
    """``log(d)`` of tension ``T`` on ``[lo, hi]`` (tension above ``T`` at ``lo``, at
    most ``T`` at ``hi``) where ``todo``, by the Illinois method on ``log(tension/T)``.

    Regula falsi whose retained end has its value halved when kept twice
    (superlinear), with bisection where a value is not finite; at most
    ``_BISECTION_STEPS`` steps.
    """
    lo, hi = lo.copy(), hi.copy()
    fi = np.flatnonzero(todo)
    with np.errstate(all="ignore"):
        f_lo = np.log(tens(lo[fi], fi) / T[fi]) if fi.size else np.zeros(0)
        f_hi = np.log(tens(hi[fi], fi) / T[fi]) if fi.size else np.zeros(0)
    F_lo, F_hi = np.full(lo.size, np.nan), np.full(lo.size, np.nan)
    F_lo[fi], F_hi[fi] = f_lo, f_hi
    side = np.zeros(lo.size, np.int8)
    for _ in range(_BISECTION_STEPS):
        if fi.size == 0:
            break
        a, b, fa, fb = lo[fi], hi[fi], F_lo[fi], F_hi[fi]
        with np.errstate(all="ignore"):
            u = b - fb * (b - a) / (fb - fa)
            u = np.where(np.isfinite(u) & (u > a) & (u < b), u, 0.5 * (a + b))
            fu = np.log(tens(u, fi) / T[fi])
        above = ~(fu <= 0.0)
        lo[fi], F_lo[fi] = np.where(above, u, a), np.where(above, fu, fa)
        hi[fi], F_hi[fi] = np.where(above, b, u), np.where(above, fb, fu)
        # Illinois: an end kept twice in a row has its value halved.
        F_hi[fi] = np.where(above & (side[fi] == 1), 0.5 * F_hi[fi], F_hi[fi])
        F_lo[fi] = np.where(~above & (side[fi] == -1), 0.5 * F_lo[fi], F_lo[fi])
        side[fi] = np.where(above, 1, -1)
        done = (np.abs(fu) <= 1e-15) | (hi[fi] - lo[fi] <= 1e-13 * (1.0 + np.abs(lo[fi])))
        hi[fi] = np.where(done, u, hi[fi])
        fi = fi[~done]
    return hi


def bracket_length(
    end: str,
    x: FloatArray,
    z: FloatArray,
    T: FloatArray,
    w: FloatArray,
    inv_EA: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.str_], NDArray[np.int64]]:
    """Bracketing solve over the family of catenaries through both ends (slow but sure).

    The end tension along the family (in ``log(d)``, see the module notes)
    falls from infinity at the taut end to a minimum and rises again (for
    ``end="H"`` it falls monotonically). The taut root lies between a member
    with tension above T and one with tension at most T (found by
    golden-section search for the minimum); if the minimum tension exceeds T
    the data are infeasible. The root is then found by the Illinois method.

    Parameters
    ----------
    end : {"B", "A", "H"}
        Which tension is prescribed (see :func:`catenary.solve.solve_length`).
    x, z, T, w, inv_EA : ndarray, shape ``(n,)``
        Spans (m, ``x > 0``), prescribed tension (N, ``> 0``), weight per
        length (N/m, ``> 0``) and axial compliance (1/N), best in units where
        the chord and ``T`` are of order one.

    Returns
    -------
    H, V_B, L0 : ndarray, shape ``(n,)``
        End forces (N) and length (m), NaN unless the status is ``"converged"``
        (a bracketed root, still to be polished and checked by the caller).
    status : ndarray of str, shape ``(n,)``
        ``"converged"``, ``"infeasible"`` or ``"not_converged"`` (the root lies
        beyond the range of ``d`` searched).
    iterations : ndarray of int, shape ``(n,)``
        Inner (mid-angle) iterations spent per cable.
    """
    tens = _FamilyTension(end, x, z, w, inv_EA)
    # The taut end of the range: d = 1e-300, or where tanh(d) is 1e-300 of w/(2 EA).
    with np.errstate(divide="ignore"):
        u_min = np.maximum(_LOG_D[0], np.log(tens.alpha) + _LOG_D[0])
    found, infeasible, u_above, u_below = _golden_section_below(tens, T, u_min)
    u = _taut_root(tens, T, u_above, u_below, found)
    H, V, L = tens.forces(np.where(found, u, 0.0))
    status = np.where(found, CONVERGED, NOT_CONVERGED).astype(STATUS_DTYPE)
    status[infeasible] = INFEASIBLE
    ok = found & np.isfinite(H) & np.isfinite(V) & np.isfinite(L)
    status[found & ~ok] = NOT_CONVERGED
    nan = ~ok
    return (
        np.where(nan, np.nan, H),
        np.where(nan, np.nan, V),
        np.where(nan, np.nan, L),
        status,
        tens.its,
    )
