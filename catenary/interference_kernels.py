"""Closest distances between pairs of catenaries, compiled: the bracket, certificate and
refinement of :func:`catenary.interference.curve_distance`, one pair after another.

The reference is that numpy code (:mod:`catenary.interference`, module notes): the same
samples, the same balls and chords, the same lower bound and the same bounded
Gauss-Newton steps, so both agree to rounding. What numpy does with (n - 1)^2 temporaries
per pair is here a loop per pair on the sample points, side by side in the vector unit
where it pays (the squared distances of one sample to all samples of the other curve);
the exact chord distances are taken only for the pieces whose balls come within the
closest samples' distance. A pair whose curve the compiled spans do not take (a vertical
or degenerate cable, :func:`catenary.solve.kernels_spans.spans`'s ``regular``) is left
to the numpy path (flag 1).

Curves are packed one row each (:data:`CURVE_COLUMNS`): attachment point, unit vector
of the plane, ``H``, ``V_A``, ``L0``, closure, weight per length and ``EA``; each curve
is sampled once per compared interval, however many pairs it is in.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from catenary.solve.kernels_spans import spans
from tension_opt.workspace.interference import PARALLEL

__all__ = ["CURVE_COLUMNS", "OUT_COLUMNS", "curve_pairs"]

#: Columns of a packed curve: origin (3), e_h (3), H, V_A, L0, closure (3), w, EA.
CURVE_COLUMNS = 14
#: Columns of a pair's result: distance, lower bound, s, t, point a (3), point b (3).
OUT_COLUMNS = 10
#: Gauss-Newton steps of the refinement (the numpy reference's too).
STEPS = 30


@njit(cache=True, error_model="numpy")
def _point(c: NDArray, w: float, inv_EA: float, s: float) -> tuple[float, float, float, bool]:
    """Point of curve ``c`` at arc parameter ``s`` (:meth:`CatenaryCurves.points`), and
    whether the compiled spans took it."""
    x = z = 0.0
    regular = True
    if s > 0.0:
        out = spans(c[6], c[7] + w * s, s, w, inv_EA, False)
        x, z, regular = out[0], out[1], out[9]
    share = s / c[8] if c[8] > 0.0 else 0.0
    return (c[0] + x * c[3] + share * c[9], c[1] + x * c[4] + share * c[10],
            c[2] + x * c[5] + z + share * c[11], regular)


@njit(cache=True, error_model="numpy", inline="always")
def _tangent(c: NDArray, w: float, EA: float, s: float) -> tuple[float, float, float]:
    """``dr/ds`` of curve ``c`` at ``s`` (:meth:`CatenaryCurves.tangents`)."""
    H, V = c[6], c[7] + w * s
    T = math.hypot(H, V)
    stretch = 1.0 + T / EA
    ch = stretch * H / T if T > 0.0 else 0.0
    cv = stretch * V / T if T > 0.0 else 1.0
    lin = 1.0 / c[8] if c[8] > 0.0 else 0.0
    return (ch * c[3] + lin * c[9], ch * c[4] + lin * c[10], ch * c[5] + cv + lin * c[11])


@njit(cache=True, error_model="numpy", inline="always")
def _bounds(c: NDArray, w: float, EA: float) -> tuple[float, float]:
    """Lipschitz constant and curvature bound of curve ``c``
    (:meth:`CatenaryCurves.bounds`)."""
    H, V_A, L0 = c[6], c[7], c[8]
    V_B = V_A + w * L0
    T_max = max(math.hypot(H, V_A), math.hypot(H, V_B))
    V_min = 0.0 if (V_A < 0.0 and V_B > 0.0) else min(abs(V_A), abs(V_B))
    stretch = 1.0 + T_max / EA
    closure = math.sqrt(c[9] * c[9] + c[10] * c[10] + c[11] * c[11])
    lam = stretch + (closure / L0 if L0 > 0.0 else 0.0)
    T2 = H * H + V_min * V_min
    bend = w * H / T2 if H > 0.0 else (0.0 if V_min > 0.0 else np.inf)
    K = w / EA + stretch * (bend if w > 0.0 else 0.0)
    return lam, K


@njit(cache=True, error_model="numpy")
def _segments(p0: NDArray, p1: NDArray, q0: NDArray, q1: NDArray
              ) -> tuple[float, float, float]:
    """Exact closest points of segments ``p0 p1`` and ``q0 q1`` (3,) each:
    ``(distance, s, t)`` (:func:`tension_opt.workspace.interference.segment_distance`,
    the same candidates and the first of the closest)."""
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    f = d2x * rx + d2y * ry + d2z * rz
    denom = a * e - b * b
    inside = denom > PARALLEL * a * e
    s_in = (b * f - c * e) / denom if inside else 0.0
    t_in = (a * f - b * c) / denom if inside else 0.0
    inside = inside and 0.0 <= s_in <= 1.0 and 0.0 <= t_in <= 1.0
    best, bs, bt, nan_at = np.inf, 0.0, 0.0, -1
    for k in range(5):  # np.argmin's choice: the first NaN, else the first smallest
        if k == 0:
            s, t = s_in, t_in
        elif k == 1:
            s, t = 0.0, _fraction(f, e)
        elif k == 2:
            s, t = 1.0, _fraction(f + b, e)
        elif k == 3:
            s, t = _fraction(-c, a), 0.0
        else:
            s, t = _fraction(b - c, a), 1.0
        dx = (p0[0] + s * d1x) - (q0[0] + t * d2x)
        dy = (p0[1] + s * d1y) - (q0[1] + t * d2y)
        dz = (p0[2] + s * d1z) - (q0[2] + t * d2z)
        dist = math.sqrt(dx * dx + dy * dy + dz * dz) if (k > 0 or inside) else np.inf
        if math.isnan(dist) and nan_at < 0:
            nan_at, best, bs, bt = k, dist, s, t
        elif nan_at < 0 and dist < best:
            best, bs, bt = dist, s, t
        elif nan_at < 0 and k == 0:
            bs, bt = s, t  # an infinite first candidate stays the choice while none is less
    return best, bs, bt


@njit(cache=True, error_model="numpy", inline="always")
def _fraction(num: float, den: float) -> float:
    """``clip(num / den, 0, 1)``, 0 where ``den <= 0``."""
    value = num / den if den > 0.0 else 0.0
    if math.isnan(value):
        return value
    return 0.0 if value < 0.0 else (1.0 if value > 1.0 else value)


@njit(cache=True, error_model="numpy")
def _sample(c: NDArray, w: float, inv_EA: float, lo: float, hi: float, n: int,
            s: NDArray, P: NDArray) -> bool:
    """``n`` arc parameters evenly over ``[lo, hi]`` (as ``np.linspace``) and the
    curve's points there, (n,) and (3, n); False where a point is not regular or not
    finite."""
    step = 1.0 / (n - 1)
    ok = True
    for k in range(n):
        u = k * step if k < n - 1 else 1.0
        s[k] = lo + (hi - lo) * u
        x, y, z, regular = _point(c, w, inv_EA, s[k])
        P[0, k], P[1, k], P[2, k] = x, y, z
        ok = ok and regular and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)
    return ok


@njit(cache=True, error_model="numpy")
def _closest_samples(Pa: NDArray, Pb: NDArray, row: NDArray) -> float:
    """Smallest distance between a sample of one curve and one of the other; ``row``
    (n,) work space (each sample's squared distances to the other curve's, side by
    side)."""
    n = Pa.shape[1]
    best = np.inf
    for j in range(n):
        ax, ay, az = Pa[0, j], Pa[1, j], Pa[2, j]
        for k in range(n):
            dx, dy, dz = ax - Pb[0, k], ay - Pb[1, k], az - Pb[2, k]
            row[k] = dx * dx + dy * dy + dz * dz
        for k in range(n):
            best = min(best, row[k])
    return math.sqrt(best)


@njit(cache=True, error_model="numpy")
def _balls(P: NDArray, e: float, M: NDArray, rad: NDArray) -> None:
    """Each piece's chord midpoint (3, n - 1) and ball radius (n - 1,): half its chord
    plus its tube ``e``."""
    for j in range(P.shape[1] - 1):
        dx, dy, dz = P[0, j + 1] - P[0, j], P[1, j + 1] - P[1, j], P[2, j + 1] - P[2, j]
        M[0, j] = 0.5 * (P[0, j + 1] + P[0, j])
        M[1, j] = 0.5 * (P[1, j + 1] + P[1, j])
        M[2, j] = 0.5 * (P[2, j + 1] + P[2, j])
        rad[j] = 0.5 * math.sqrt(dx * dx + dy * dy + dz * dz) + e


@njit(cache=True, error_model="numpy")
def _bracket(Pa: NDArray, Pb: NDArray, sa: NDArray, sb: NDArray, ha: float, hb: float,
             lam: tuple[float, float], tube: tuple[float, float], work: NDArray
             ) -> tuple[float, float, float]:
    """Start parameters and certified lower bound of one pair (the reference's
    ``_bracket``): ``(s0, t0, lower)``."""
    n = Pa.shape[1]
    e_a, e_b = tube
    Ma, Mb = work[:3 * (n - 1)].reshape((3, n - 1)), work[3 * n:6 * n - 3].reshape((3, n - 1))
    rad_a, rad_b = work[6 * n:7 * n - 1], work[7 * n:8 * n - 1]
    row = work[8 * n:9 * n]
    upper = _closest_samples(Pa, Pb, row)
    lips = upper - (lam[0] * ha + lam[1] * hb) / 2
    _balls(Pa, e_a, Ma, rad_a)
    _balls(Pb, e_b, Mb, rad_b)
    low, best, jb, kb, fs, ft, unknown = np.inf, np.inf, 0, 0, 0.0, 0.0, False
    p0, p1, q0, q1 = work[9 * n:9 * n + 3], work[9 * n + 3:9 * n + 6], \
        work[9 * n + 6:9 * n + 9], work[9 * n + 9:9 * n + 12]
    for j in range(n - 1):
        for k in range(n - 1):  # squared centre distances, side by side
            dx, dy, dz = Ma[0, j] - Mb[0, k], Ma[1, j] - Mb[1, k], Ma[2, j] - Mb[2, k]
            row[k] = dx * dx + dy * dy + dz * dz
        for k in range(n - 1):
            # Balls clearly farther apart than the closest samples (no square root):
            # such a piece pair cannot hold the minimum, and its ball bound, above
            # ``upper``, is never the least bound (the closest samples' pieces are
            # within it), so it is passed over.
            reach = upper + rad_a[j] + rad_b[k]
            if row[k] > reach * reach * (1.0 + 1e-12):
                continue
            balls = math.sqrt(row[k]) - rad_a[j] - rad_b[k]
            if balls > upper:  # the reference's test, to the last bit
                continue
            for i in range(3):
                p0[i], p1[i], q0[i], q1[i] = Pa[i, j], Pa[i, j + 1], Pb[i, k], Pb[i, k + 1]
            exact, s, t = _segments(p0, p1, q0, q1)
            exact = np.inf if math.isnan(exact) else exact
            bound = exact - e_a - e_b
            unknown = unknown or math.isnan(bound)  # numpy's min: NaN, then lips alone
            low = min(low, bound)
            if exact < best:
                best, jb, kb, fs, ft = exact, j, k, s, t
    lower = max(lips if unknown else max(low, lips), 0.0)
    return sa[jb] + fs * ha, sb[kb] + ft * hb, lower


@njit(cache=True, error_model="numpy")
def _refine(a: NDArray, b: NDArray, r: tuple[float, float, float, float],
            w: tuple[float, float], inv_EA: tuple[float, float], EA: tuple[float, float],
            s: float, t: float, ha: float, hb: float, out: NDArray, seg: NDArray) -> bool:
    """The reference's bounded Gauss-Newton (``_refine``) of one pair from ``s, t``:
    writes distance, s, t and the two points into ``out`` (columns 0, 2-9); False where
    a point is not regular (the numpy path's). ``r`` the two compared intervals,
    ``seg`` (12,) work space."""
    xa, ya, za, ok_a = _point(a, w[0], inv_EA[0], s)
    xb, yb, zb, ok_b = _point(b, w[1], inv_EA[1], t)
    d = math.sqrt((xa - xb) ** 2 + (ya - yb) ** 2 + (za - zb) ** 2)
    regular = ok_a and ok_b
    tol = 1e-12 * (1.0 + r[1] + r[3])
    p0, p1, q0, q1 = seg[:3], seg[3:6], seg[6:9], seg[9:12]
    for _ in range(STEPS if math.isfinite(d) else 0):
        ta = _tangent(a, w[0], EA[0], s)
        tb = _tangent(b, w[1], EA[1], t)
        a_lo, a_hi = max(r[0], s - ha), min(r[1], s + ha)
        b_lo, b_hi = max(r[2], t - hb), min(r[3], t + hb)
        pa, pb = (xa, ya, za), (xb, yb, zb)
        for i in range(3):
            p0[i], p1[i] = pa[i] + (a_lo - s) * ta[i], pa[i] + (a_hi - s) * ta[i]
            q0[i], q1[i] = pb[i] + (b_lo - t) * tb[i], pb[i] + (b_hi - t) * tb[i]
        _, fs, ft = _segments(p0, p1, q0, q1)
        s1, t1 = a_lo + fs * (a_hi - a_lo), b_lo + ft * (b_hi - b_lo)
        qxa, qya, qza, ok_a = _point(a, w[0], inv_EA[0], s1)
        qxb, qyb, qzb, ok_b = _point(b, w[1], inv_EA[1], t1)
        regular = regular and ok_a and ok_b
        d1 = math.sqrt((qxa - qxb) ** 2 + (qya - qyb) ** 2 + (qza - qzb) ** 2)
        moved = abs(s1 - s) + abs(t1 - t)
        better = d1 < d
        if better:
            s, t, d = s1, t1, d1
            xa, ya, za, xb, yb, zb = qxa, qya, qza, qxb, qyb, qzb
        else:
            ha, hb = 0.5 * ha, 0.5 * hb
        # A step the distance cannot tell from staying ends the search too (reference).
        if moved <= tol or ha + hb <= tol or (not better and moved <= 1e5 * tol):
            break
    out[0], out[2], out[3] = d, s, t
    out[4], out[5], out[6], out[7], out[8], out[9] = xa, ya, za, xb, yb, zb
    return regular


@njit(cache=True, error_model="numpy")
def _samples_of(curves: NDArray, i: int, lo: float, hi: float, n: int, s_cache: NDArray,
                P_cache: NDArray, span: NDArray) -> int:
    """Curve ``i``'s samples over ``[lo, hi]`` in the caches (sampled once per interval:
    a cable of ``m`` is in ``m - 1`` pairs); 1 where a point is not regular or finite."""
    if span[i, 0] == lo and span[i, 1] == hi:
        return int(span[i, 2])
    c = curves[i]
    ok = _sample(c, c[12], 1.0 / c[13] if math.isfinite(c[13]) else 0.0, lo, hi, n,
                 s_cache[i], P_cache[i])
    span[i, 0], span[i, 1], span[i, 2] = lo, hi, 0.0 if ok else 1.0
    return 0 if ok else 1


@njit(cache=True, nogil=True, error_model="numpy")
def curve_pairs(curves: NDArray, pairs: NDArray, ranges: NDArray, n: int, out: NDArray,
                left: NDArray) -> int:
    """Closest points of pairs of curves with ``n`` samples each (the reference's
    :func:`catenary.interference.curve_distance`).

    Parameters
    ----------
    curves : ndarray, shape (C, CURVE_COLUMNS)
        Packed curves (module docstring), ``w`` (N/m) and ``EA`` (N, inf inextensible)
        in their last two columns.
    pairs : ndarray of int, shape (S, 2)
        Rows of ``curves`` compared.
    ranges : ndarray, shape (S, 4)
        Compared intervals of arc parameters ``lo_a, hi_a, lo_b, hi_b`` (m).
    n : int
        Samples along each curve, >= 2.
    out : ndarray, shape (S, OUT_COLUMNS)
        Written: distance, lower bound, s, t, the two points.
    left : ndarray of int, shape (S,)
        Written: 1 for a pair the numpy path must take (a point the compiled spans do
        not take, or not finite; its row of ``out`` is not written), else 0.

    Returns
    -------
    int
        The count of pairs left.
    """
    C, S = curves.shape[0], pairs.shape[0]
    s_cache, P_cache = np.empty((C, n)), np.empty((C, 3, n))
    span = np.full((C, 3), np.nan)
    work = np.empty(9 * n + 12)
    count = 0
    for p in range(S):
        i, j = pairs[p, 0], pairs[p, 1]
        ca, cb = curves[i], curves[j]
        bad = _samples_of(curves, i, ranges[p, 0], ranges[p, 1], n, s_cache, P_cache, span)
        bad += _samples_of(curves, j, ranges[p, 2], ranges[p, 3], n, s_cache, P_cache, span)
        left[p] = 1 if bad else 0
        if bad:
            count += 1
            continue
        w, EA = (ca[12], cb[12]), (ca[13], cb[13])
        inv_EA = (1.0 / EA[0] if math.isfinite(EA[0]) else 0.0,
                  1.0 / EA[1] if math.isfinite(EA[1]) else 0.0)
        ha, hb = (ranges[p, 1] - ranges[p, 0]) / (n - 1), (ranges[p, 3] - ranges[p, 2]) / (n - 1)
        lam_a, K_a = _bounds(ca, w[0], EA[0])
        lam_b, K_b = _bounds(cb, w[1], EA[1])
        s0, t0, lower = _bracket(P_cache[i], P_cache[j], s_cache[i], s_cache[j], ha, hb,
                                 (lam_a, lam_b), (K_a * ha ** 2 / 8, K_b * hb ** 2 / 8), work)
        if not _refine(ca, cb, (ranges[p, 0], ranges[p, 1], ranges[p, 2], ranges[p, 3]),
                       w, inv_EA, EA, s0, t0, ha, hb, out[p], work[9 * n:]):
            left[p] = 1
            count += 1
            continue
        out[p, 1] = min(lower, out[p, 0])
    return count
