"""The steps of :mod:`tension_opt.kernels.certified_lanes` on one block of :data:`LANES` poses.

Every intermediate value lives in one work array in "structure of arrays" order: field
``f`` of lane ``l`` at ``f * LANES + l`` (:func:`at`; the fields ``F_*`` below), at
fixed offsets, so that the compiler sees that no step's writes overlap its reads. Each
step is a loop over the lanes with the pose-by-pose step's arithmetic in the same
order, its branches written as choices between computed values (and without calls:
a call, even numba's ``max`` or a tuple read at a constant index in cached code, keeps
a loop from vectors). So every lane gets the pose-by-pose answer to the last bit.

A lane that leaves the common path is flagged (``F_GOOD``, ``F_FIT`` zero, or
``F_CODE`` :data:`REDO`); :func:`~tension_opt.kernels.certified_lanes.lane_poses` hands its pose
back.
"""

from __future__ import annotations

import math
from typing import overload

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.certificate import nan_max
from tension_opt.kernels.closed_form import HUGE
from tension_opt.kernels.lowdim import FEAS_TOL, FLAT_TOL

__all__ = ["FIELDS", "F_A", "F_AEQ", "F_B0", "F_B1", "F_B2", "F_BEQ", "F_CODE", "F_CS", "F_DUAL",
           "F_FIT", "F_GAP", "F_GOOD", "F_INFEASIBLE", "F_LBS", "F_N", "F_OVER", "F_P0", "F_P1",
           "F_P2", "F_PRIMAL", "F_RES", "F_STATION", "F_T", "F_TOL", "F_TP", "F_UBS",
           "F_UNIQUE", "F_VALUE", "F_W0", "F_W1", "F_W2", "F_X", "F_Y", "F_Z", "LANES", "REDO",
           "at", "certify_step", "estimate_step", "fmax", "fmin", "geometry_step", "load_block",
           "measure_step", "point4_step", "turned"]

#: Poses per block (a power of two; the work array is about 100 * LANES floats).
LANES = 16
#: Code of a pose the caller solves pose by pose.
REDO = 9
_HUGE: float = np.finfo(np.float64).max

# Fields of the work array (see the module docstring).
(F_P0, F_P1, F_P2, F_W0, F_W1, F_W2, F_B0, F_B1, F_B2, F_GOOD, F_INFEASIBLE, F_UNIQUE,
 F_RES, F_OVER, F_VALUE, F_TOL, F_PRIMAL, F_DUAL, F_GAP, F_CODE, F_FIT) = range(21)
F_A = 21  # A[r, i] at F_A + 4 r + i
F_TP = F_A + 12  # particular solution (4)
F_N = F_TP + 4  # null vector (4)
F_T = F_N + 4  # tensions (4)
F_AEQ = F_T + 4  # scaled A (12)
F_BEQ = F_AEQ + 12  # scaled b (3)
F_X = F_BEQ + 3  # scaled tensions (4)
F_LBS = F_X + 4  # scaled bounds (4)
F_UBS = F_LBS + 4
F_CS = F_UBS + 4  # scaled linear cost (4)
F_Y = F_CS + 4  # multipliers of the equations (3)
F_Z = F_Y + 3  # multipliers of the bounds (4)
F_STATION = F_Z + 4  # stationarity of each scaled variable (4)
FIELDS = F_STATION + 4


# fmin and fmax of two ints are an int (a pose index), of floats a float.
@overload
def fmax(a: int, b: int) -> int: ...
@overload
def fmax(a: float, b: float) -> float: ...
@njit(cache=True, inline="always")
def fmax(a: float, b: float) -> float:
    """numba's ``max(a, b)`` of two floats, written out: the builtin is a call that
    keeps a loop from vectors where the compiler does not inline it."""
    return b if b > a else a


@overload
def fmin(a: int, b: int) -> int: ...
@overload
def fmin(a: float, b: float) -> float: ...
@njit(cache=True, inline="always")
def fmin(a: float, b: float) -> float:
    """numba's ``min(a, b)`` of two floats, written out (see :func:`fmax`)."""
    return b if b < a else a


@njit(cache=True, inline="always")
def at(field: int, lane: int) -> int:
    """Index of field ``field`` of lane ``lane`` in the work array."""
    return field * LANES + lane


@njit(cache=True, error_model="numpy", inline="always")
def _norm3(a: float, b: float, c: float) -> float:
    """:func:`~tension_opt.kernels.scaling.safe_norm_of` of ``(a, b, c)``, the same
    operations in the same order."""
    top = 0.0
    for v in (a, b, c):
        x = abs(v)
        top = top if x <= top else x
    norm = top
    ok = top != 0.0 and math.isfinite(top)
    ra, rb, rc = a / top, b / top, c / top
    total = 0.0
    total += ra * ra
    total += rb * rb
    total += rc * rc
    return top * math.sqrt(total) if ok else norm


@njit(cache=True, error_model="numpy", inline="always")
def turned(attachments: NDArray, i: int) -> tuple[float, float, float]:
    """Attachment point ``i`` turned by the identity, as
    :func:`~tension_opt.kernels.geometry.geometry_into` turns it."""
    a0, a1, a2 = attachments[i, 0], attachments[i, 1], attachments[i, 2]
    return (1.0 * a0 + 0.0 * a1 + 0.0 * a2, 0.0 * a0 + 1.0 * a1 + 0.0 * a2,
            0.0 * a0 + 0.0 * a1 + 1.0 * a2)


@njit(cache=True, error_model="numpy", inline="always")
def geometry_step(S: NDArray, anchors: tuple, offsets: tuple, weight: float,
                  zero_length: float) -> None:
    """:func:`~tension_opt.kernels.geometry.geometry_into` of a point robot and
    :func:`~tension_opt.kernels.closed_form.plain`'s check of the pose's data
    (``offsets``: the attachment points turned by the identity, as there)."""
    for lane in range(LANES):
        px, py, pz = S[at(F_P0, lane)], S[at(F_P1, lane)], S[at(F_P2, lane)]
        good = True
        for i in range(4):
            r0, r1, r2 = offsets[i]
            a0, a1, a2 = anchors[i]
            v0 = a0 - (px + r0)
            v1 = a1 - (py + r1)
            v2 = a2 - (pz + r2)
            length = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
            good = good and math.isfinite(length) and length > zero_length
            u0, u1, u2 = v0 / length, v1 / length, v2 / length
            good = good and abs(u0) < HUGE and abs(u1) < HUGE and abs(
                u2) < HUGE
            S[at(F_A + i, lane)] = u0
            S[at(F_A + 4 + i, lane)] = u1
            S[at(F_A + 8 + i, lane)] = u2
        b0 = 0.0 - S[at(F_W0, lane)] + 0.0
        b1 = 0.0 - S[at(F_W1, lane)] + 0.0
        b2 = weight - S[at(F_W2, lane)] + 0.0
        good = good and abs(b0) < HUGE and abs(b1) < HUGE and abs(b2) < HUGE
        S[at(F_B0, lane)], S[at(F_B1, lane)], S[at(F_B2, lane)] = b0, b1, b2
        S[at(F_GOOD, lane)] = 1.0 if good else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _beyond_slack(lo: float, hi: float, nn: float, u00: float, u01: float, u02: float,
                  u03: float, u10: float, u11: float, u12: float, u13: float, u20: float,
                  u21: float, u22: float, u23: float, b0: float, b1: float, b2: float,
                  top_lb: float) -> bool:
    """Whether an empty interval ``[lo, hi]`` of the null vector's coefficient lies
    beyond the general path's slack (``point4``, with ``pose_scales(A, b, lb)[0]``)."""
    col = 0.0
    for a, e, f in ((u00, u10, u20), (u01, u11, u21), (u02, u12, u22),
                    (u03, u13, u23)):
        s = 0.0
        s += a * a
        s += e * e
        s += f * f
        col = fmax(col, math.sqrt(s))
    bn = 0.0
    bn += b0 * b0
    bn += b1 * b1
    bn += b2 * b2
    bn = math.sqrt(bn)
    typical = fmax(fmax(bn / fmax(col, 1e-300), top_lb), 1e-12)
    return not (math.isnan(lo - hi) or (lo - hi) * math.sqrt(nn) <= FEAS_TOL * typical)


@njit(cache=True, error_model="numpy", inline="always")
def point4_step(S: NDArray, lb: tuple, ub: tuple, q: tuple, c: tuple, quadratic: bool,
                top_lb: float) -> None:
    """:func:`~tension_opt.kernels.closed_form.point4`, a settled feasible pose's
    tensions, an infeasible pose's line."""
    for lane in range(LANES):
        u00, u01, u02, u03 = (S[at(F_A, lane)], S[at(F_A + 1, lane)], S[at(F_A + 2, lane)],
                              S[at(F_A + 3, lane)])
        u10, u11, u12, u13 = (S[at(F_A + 4, lane)], S[at(F_A + 5, lane)], S[at(F_A + 6, lane)],
                              S[at(F_A + 7, lane)])
        u20, u21, u22, u23 = (S[at(F_A + 8, lane)], S[at(F_A + 9, lane)], S[at(F_A + 10, lane)],
                              S[at(F_A + 11, lane)])
        b0, b1, b2 = S[at(F_B0, lane)], S[at(F_B1, lane)], S[at(F_B2, lane)]
        # C_j = u_a x u_e, (a, e) = (1, 2), (2, 0), (0, 1)
        C00, C01, C02 = u11 * u22 - u21 * u12, u21 * u02 - u01 * u22, u01 * u12 - u11 * u02
        C10, C11, C12 = u12 * u20 - u22 * u10, u22 * u00 - u02 * u20, u02 * u10 - u12 * u00
        C20, C21, C22 = u10 * u21 - u20 * u11, u20 * u01 - u00 * u21, u00 * u11 - u10 * u01
        det = u00 * C00 + u10 * C01 + u20 * C02
        settled = abs(det) > 1e-9
        T0 = (b0 * C00 + b1 * C01 + b2 * C02) / det
        T1 = (b0 * C10 + b1 * C11 + b2 * C12) / det
        T2 = (b0 * C20 + b1 * C21 + b2 * C22) / det
        T3 = 0.0
        n0 = u03 * C00 + u13 * C01 + u23 * C02
        n1 = u03 * C10 + u13 * C11 + u23 * C12
        n2 = u03 * C20 + u13 * C21 + u23 * C22
        n3 = -det
        top = fmax(fmax(abs(n0), abs(n1)), fmax(abs(n2), abs(n3)))
        lo, hi, nn = -np.inf, np.inf, 0.0
        for i, ni, Ti in ((0, n0, T0), (1, n1, T1), (2, n2, T2), (3, n3, T3)):
            settled = settled and abs(ni) > 1e-9 * top
            nn += ni * ni
            r_lb, r_ub = (lb[i] - Ti) / ni, (ub[i] - Ti) / ni
            up = ni > 0
            lo_up, hi_up = fmax(lo, r_lb), fmin(hi, r_ub)
            lo_down, hi_down = fmax(lo, r_ub), fmin(hi, r_lb)
            lo = lo_up if up else lo_down
            hi = hi_up if up else hi_down
        infeasible = settled and not lo <= hi
        beyond = _beyond_slack(lo, hi, nn, u00, u01, u02, u03, u10, u11, u12, u13, u20, u21,
                               u22, u23, b0, b1, b2, top_lb)
        settled = beyond if infeasible else settled
        unique = True
        if quadratic:
            num = den = 0.0
            for i, ni, Ti in ((0, n0, T0), (1, n1, T1), (2, n2, T2), (3, n3, T3)):
                num += (q[i] * Ti + c[i]) * ni
                den += q[i] * ni * ni
            t = -num / den
            settled = settled and (infeasible or not math.isnan(t))
            t = fmin(fmax(t, lo), hi)
        else:
            slope = cc = tn = 0.0
            for i, ni, Ti in ((0, n0, T0), (1, n1, T1), (2, n2, T2), (3, n3, T3)):
                slope += c[i] * ni
                cc += c[i] * c[i]
                tn += Ti * ni
            flat = abs(slope) <= FLAT_TOL * math.sqrt(cc * nn)
            edge = lo if slope > 0 else hi
            t = fmin(fmax(-tn / nn, lo), hi) if flat else edge
            unique = infeasible or not flat or lo == hi
        settled = settled and (infeasible or math.isfinite(t))
        for i, ni, Ti in ((0, n0, T0), (1, n1, T1), (2, n2, T2), (3, n3, T3)):
            S[at(F_TP + i, lane)] = Ti
            S[at(F_N + i, lane)] = ni
            S[at(F_T + i, lane)] = Ti + t * ni
        good = S[at(F_GOOD, lane)] != 0.0 and settled
        S[at(F_GOOD, lane)] = 1.0 if good else 0.0
        S[at(F_INFEASIBLE, lane)] = 1.0 if infeasible else 0.0
        S[at(F_UNIQUE, lane)] = 1.0 if unique else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def measure_step(S: NDArray, lb: tuple, ub: tuple, ct: tuple, w: tuple,
                 r: tuple, linear: bool, quadratic: bool, top_lb: float, top_ub: float,
                 ub_share: float, row_floor: float, tol_factor: float) -> None:
    """``_measured`` of :mod:`~tension_opt.kernels.certified` (residual, bound violation,
    objective), :func:`~tension_opt.kernels.scaling.pose_scaled` (no min-max term),
    ``_lifted`` and the tolerance of the status (``pose_scales``); ``ct`` is ``c /
    top``."""
    for lane in range(LANES):
        good = S[at(F_GOOD, lane)] != 0.0 and S[at(F_INFEASIBLE, lane)] == 0.0  # to certify
        T0, T1, T2, T3 = (S[at(F_T, lane)], S[at(F_T + 1, lane)], S[at(F_T + 2, lane)],
                          S[at(F_T + 3, lane)])
        good = good and math.isfinite(T0) and math.isfinite(T1) and math.isfinite(
            T2) and math.isfinite(T3)
        b = (S[at(F_B0, lane)], S[at(F_B1, lane)], S[at(F_B2, lane)])
        total = 0.0
        for k in range(3):
            e = -b[k]
            e += S[at(F_A + 4 * k, lane)] * T0
            e += S[at(F_A + 4 * k + 1, lane)] * T1
            e += S[at(F_A + 4 * k + 2, lane)] * T2
            e += S[at(F_A + 4 * k + 3, lane)] * T3
            total += e * e
        residual = math.sqrt(total)
        good = good and math.isfinite(residual)  # else rescaled, pose by pose
        violation = 0.0
        value = 0.0
        for i, Ti in ((0, T0), (1, T1), (2, T2), (3, T3)):
            violation = fmax(violation, fmax(lb[i] - Ti, Ti - ub[i]))
            d = Ti - r[i]
            value += Ti * w[i] if linear else d * d * w[i]
        # pose_scaling
        col = 0.0
        for i in range(4):
            col = fmax(col, _norm3(S[at(F_A + i, lane)], S[at(F_A + 4 + i, lane)],
                                  S[at(F_A + 8 + i, lane)]))
        s = fmax(fmax(_norm3(b[0], b[1], b[2]) / fmax(col, 1e-300), top_lb), 1e-12)
        good = good and math.isfinite(s)
        s = fmax(s, ub_share * top_ub)
        longest = 0.0
        for k in range(3):
            norm = 0.0
            for i in range(4):
                a = S[at(F_A + 4 * k + i, lane)]
                norm += a * a
            S[at(F_BEQ + k, lane)] = math.sqrt(norm)  # the row's norm, for now
            longest = fmax(longest, S[at(F_BEQ + k, lane)])
        floor = row_floor * longest
        per_s = s if quadratic else 1.0
        for k in range(3):
            size = fmax(S[at(F_BEQ + k, lane)], floor)
            factor = 1.0 / size if size > 0.0 and math.isfinite(size) else 1.0
            for i in range(4):
                S[at(F_AEQ + 4 * k + i, lane)] = S[at(F_A + 4 * k + i, lane)] * factor
            S[at(F_BEQ + k, lane)] = b[k] * factor / s
        for i, Ti in ((0, T0), (1, T1), (2, T2), (3, T3)):
            S[at(F_LBS + i, lane)] = lb[i] / s
            S[at(F_UBS + i, lane)] = ub[i] / s
            S[at(F_CS + i, lane)] = ct[i] / per_s
            x = Ti / s
            good = good and math.isfinite(x)
            S[at(F_X + i, lane)] = x
        bn = 0.0
        for k in range(3):
            bn += b[k] * b[k]
        bn = math.sqrt(bn)
        S[at(F_TOL, lane)] = tol_factor * fmax(fmax(bn, top_lb), 1e-12)
        S[at(F_RES, lane)], S[at(F_OVER, lane)], S[at(F_VALUE, lane)] = (
            residual, violation, value)
        S[at(F_FIT, lane)] = 1.0 if good else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _pick(cond: bool, a: float, b: float) -> float:
    return a if cond else b


@njit(cache=True, error_model="numpy", inline="always")
def _grad(S: NDArray, Pi: float, i: int, lane: int) -> tuple[float, float, float, float,
                                                        float]:
    """Gradient, shrink factor and ``B[i, :] = Aeq[:, i]`` of scaled variable ``i``
    (:func:`~tension_opt.kernels.certificate.pose_estimate`)."""
    x = S[at(F_X + i, lane)]
    grad = Pi * x + S[at(F_CS + i, lane)]
    near = fmin(abs(x - S[at(F_LBS + i, lane)]), abs(S[at(F_UBS + i, lane)] - x))
    shrink = 1.0 / (1.0 + near * near)
    return (grad, shrink, S[at(F_AEQ + i, lane)], S[at(F_AEQ + 4 + i, lane)],
            S[at(F_AEQ + 8 + i, lane)])


@njit(cache=True, error_model="numpy", inline="always")
def _accumulate(acc: tuple, grad: float, shrink: float, B0: float, B1: float, B2: float
                ) -> tuple:
    """One scaled variable's terms added to ``u`` and the upper triangle of ``H``
    (``acc``: ``u0, u1, u2, h00, h01, h02, h11, h12, h22``), as ``pose_estimate``."""
    u0, u1, u2, h00, h01, h02, h11, h12, h22 = acc
    weight = 1.0 - shrink
    Bw0, Bw1, Bw2 = B0 * weight, B1 * weight, B2 * weight
    return (u0 - Bw0 * grad, u1 - Bw1 * grad, u2 - Bw2 * grad, h00 + Bw0 * B0,
            h01 + Bw0 * B1, h02 + Bw0 * B2, h11 + Bw1 * B1, h12 + Bw1 * B2, h22 + Bw2 * B2)


@njit(cache=True, error_model="numpy", inline="always")
def _multiplier(S: NDArray, i: int, lane: int, grad: float, shrink: float, t0: float,
                t1: float, t2: float) -> None:
    """``z_i`` from the stationarity left over (terms ``B[i, a] u_a``), as
    ``pose_estimate``: NaN as 0, an infinite one as the largest float."""
    total = grad
    total += t0
    total += t1
    total += t2
    zi = -total * shrink
    zi = 0.0 if math.isnan(zi) else zi
    # an infinite one clamped (a test for infinity would keep the loop from vectors)
    S[at(F_Z + i, lane)] = fmin(fmax(zi, -_HUGE), _HUGE)


@njit(cache=True, error_model="numpy", inline="always")
def _solve3(h00: float, h01: float, h02: float, h11: float, h12: float, h22: float,
            u0: float, u1: float, u2: float) -> tuple[float, float, float, bool]:
    """``H v = u`` for symmetric ``H`` (its upper triangle given) by
    :func:`~tension_opt.kernels.certificate.solve_small`'s elimination with partial
    pivoting, its row swaps written as choices; ``(v, ok)``, ok False for a zero or
    non-finite pivot."""
    # rows of H (symmetric at the start) and u, eliminated as solve_small does
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = h00, h01, h02, h01, h11, h12, h02, \
        h12, h22
    # column 0: pivot among rows 0-2 (choices without branches: & rather than
    # "and", so that the loop stays one block of vector code)
    p1 = abs(r10) > abs(r00)
    p2 = abs(r20) > abs(_pick(p1, r10, r00))
    p1 = p1 & (not p2)
    # bring the pivot row to row 0 (swap with row 1 or row 2)
    r00, r10 = _pick(p1, r10, r00), _pick(p1, r00, r10)
    r01, r11 = _pick(p1, r11, r01), _pick(p1, r01, r11)
    r02, r12 = _pick(p1, r12, r02), _pick(p1, r02, r12)
    u0, u1 = _pick(p1, u1, u0), _pick(p1, u0, u1)
    r00, r20 = _pick(p2, r20, r00), _pick(p2, r00, r20)
    r01, r21 = _pick(p2, r21, r01), _pick(p2, r01, r21)
    r02, r22 = _pick(p2, r22, r02), _pick(p2, r02, r22)
    u0, u2 = _pick(p2, u2, u0), _pick(p2, u0, u2)
    ok = (r00 != 0.0) & (abs(r00) <= _HUGE)
    f = r10 / r00
    keep = f != 0.0  # solve_small leaves a row whose factor is 0 as it is
    r10 = _pick(keep, r10 - f * r00, r10)
    r11 = _pick(keep, r11 - f * r01, r11)
    r12 = _pick(keep, r12 - f * r02, r12)
    u1 = _pick(keep, u1 - f * u0, u1)
    f = r20 / r00
    keep = f != 0.0
    r20 = _pick(keep, r20 - f * r00, r20)
    r21 = _pick(keep, r21 - f * r01, r21)
    r22 = _pick(keep, r22 - f * r02, r22)
    u2 = _pick(keep, u2 - f * u0, u2)
    # column 1: pivot among rows 1-2
    p2 = abs(r21) > abs(r11)
    r10, r20 = _pick(p2, r20, r10), _pick(p2, r10, r20)
    r11, r21 = _pick(p2, r21, r11), _pick(p2, r11, r21)
    r12, r22 = _pick(p2, r22, r12), _pick(p2, r12, r22)
    u1, u2 = _pick(p2, u2, u1), _pick(p2, u1, u2)
    ok = ok & (r11 != 0.0) & (abs(r11) <= _HUGE)
    f = r21 / r11
    keep = f != 0.0
    r21 = _pick(keep, r21 - f * r11, r21)
    r22 = _pick(keep, r22 - f * r12, r22)
    u2 = _pick(keep, u2 - f * u1, u2)
    ok = ok & (r22 != 0.0) & (abs(r22) <= _HUGE)
    # back substitution
    u2 = u2 / r22
    total = u1
    total -= r12 * u2
    u1 = total / r11
    total = u0
    total -= r01 * u1
    total -= r02 * u2
    u0 = total / r00
    return u0, u1, u2, ok


@njit(cache=True, error_model="numpy", inline="always")
def estimate_step(S: NDArray, P: tuple, ridge: float) -> None:
    """:func:`~tension_opt.kernels.certificate.pose_estimate` (three equations, no
    rows), :func:`~tension_opt.kernels.certificate.solve_small`'s elimination written
    with choices for its pivoting."""
    # The weights as numbers: a tuple read at a constant index is a call numba's
    # cached code does not inline, and a call keeps the loop from vectors.
    P0, P1, P2, P3 = P
    for lane in range(LANES):
        g0, s0, B00, B01, B02 = _grad(S, P0, 0, lane)
        g1, s1, B10, B11, B12 = _grad(S, P1, 1, lane)
        g2, s2, B20, B21, B22 = _grad(S, P2, 2, lane)
        g3, s3, B30, B31, B32 = _grad(S, P3, 3, lane)
        acc = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        acc = _accumulate(acc, g0, s0, B00, B01, B02)
        acc = _accumulate(acc, g1, s1, B10, B11, B12)
        acc = _accumulate(acc, g2, s2, B20, B21, B22)
        u0, u1, u2, h00, h01, h02, h11, h12, h22 = _accumulate(acc, g3, s3, B30, B31, B32)
        top = 0.0
        top = fmax(top, abs(h00))
        top = fmax(top, abs(h11))
        top = fmax(top, abs(h22))
        top = fmax(top, 1.0)
        extra = 0.0 + ridge * top
        h00 += extra
        h11 += extra
        h22 += extra
        u0, u1, u2, ok = _solve3(h00, h01, h02, h11, h12, h22, u0, u1, u2)
        S[at(F_Y, lane)], S[at(F_Y + 1, lane)], S[at(F_Y + 2, lane)] = u0, u1, u2
        _multiplier(S, 0, lane, g0, s0, B00 * u0, B01 * u1, B02 * u2)
        _multiplier(S, 1, lane, g1, s1, B10 * u0, B11 * u1, B12 * u2)
        _multiplier(S, 2, lane, g2, s2, B20 * u0, B21 * u1, B22 * u2)
        _multiplier(S, 3, lane, g3, s3, B30 * u0, B31 * u1, B32 * u2)
        S[at(F_FIT, lane)] = _pick((S[at(F_FIT, lane)] != 0.0) & ok, 1.0, 0.0)


@njit(cache=True, error_model="numpy", inline="always")
def certify_step(S: NDArray, P: tuple, target: float) -> None:
    """:func:`~tension_opt.kernels.certificate.pose_measures` (no rows), the verdict of the
    pose-by-pose loop and ``_in_cones``: the status code, or :data:`REDO`."""
    for lane in range(LANES):
        first = 0.0
        gap = 0.0
        objective = 0.0
        for i in range(4):
            xi = S[at(F_X + i, lane)]
            lo, hi = S[at(F_LBS + i, lane)], S[at(F_UBS + i, lane)]
            first = nan_max(first, lo - xi) if math.isfinite(lo) else first
            first = nan_max(first, xi - hi) if math.isfinite(hi) else first
            grad = P[i] * xi + S[at(F_CS + i, lane)]
            zi = S[at(F_Z + i, lane)]
            zi = 0.0 if (zi > 0.0 and not math.isfinite(hi)) or (
                zi < 0.0 and not math.isfinite(lo)) else zi
            S[at(F_Z + i, lane)] = zi  # in its cone (_in_cones, on the scaled bounds)
            S[at(F_STATION + i, lane)] = grad + zi
            gap += grad * xi
            gap = gap + hi * zi if zi > 0.0 else (gap + lo * zi if zi < 0.0 else (
                np.nan if math.isnan(zi) else gap))
            objective += (0.5 * P[i] * xi + S[at(F_CS + i, lane)]) * xi
        for k in range(3):
            row = -S[at(F_BEQ + k, lane)]
            yk = S[at(F_Y + k, lane)]
            for i in range(4):
                a = S[at(F_AEQ + 4 * k + i, lane)]
                row += a * S[at(F_X + i, lane)]
                S[at(F_STATION + i, lane)] += a * yk
            first = nan_max(first, abs(row))
            gap += S[at(F_BEQ + k, lane)] * yk
        second = 0.0
        for i in range(4):
            second = nan_max(second, abs(S[at(F_STATION + i, lane)]))
        third = abs(gap) / nan_max(1.0, abs(objective))
        met = first <= target and second <= target and third <= target
        tol = S[at(F_TOL, lane)]
        passed = met and S[at(F_RES, lane)] <= tol and S[at(F_OVER, lane)] <= tol
        code = 0.0 if passed else 3.0
        refit = first <= target and not met  # certify's sign-constrained refit
        good = S[at(F_FIT, lane)] != 0.0 and not refit
        S[at(F_CODE, lane)] = code if good else float(REDO)
        S[at(F_PRIMAL, lane)], S[at(F_DUAL, lane)], S[at(F_GAP, lane)] = first, second, third


@njit(cache=True, error_model="numpy", inline="always")
def load_block(S: NDArray, poses: NDArray, wrenches: NDArray, start: int) -> None:
    """The poses and wrenches of the block from pose ``start`` into the work array (a
    short last block repeats its last pose)."""
    N = poses.shape[0]
    for lane in range(LANES):
        p = fmin(start + lane, N - 1)
        wp = p if wrenches.shape[0] > 1 else 0
        S[at(F_P0, lane)], S[at(F_P1, lane)], S[at(F_P2, lane)] = (
            poses[p, 0], poses[p, 1], poses[p, 2])
        S[at(F_W0, lane)], S[at(F_W1, lane)], S[at(F_W2, lane)] = (
            wrenches[wp, 0], wrenches[wp, 1], wrenches[wp, 2])


