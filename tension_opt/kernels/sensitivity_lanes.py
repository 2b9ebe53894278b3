"""Jacobians of a four-cable point robot's optimal tensions, poses side by side.

:func:`tension_opt.kernels.sensitivity.jacobian_poses` differentiates pose by pose; for
the point robot on four cables (three equations, a null space of dimension 1) this
module runs the common poses :data:`LANES` at a time, so that the compiler puts one pose
in each lane of the vector unit (the style of
:mod:`tension_opt.kernels.certified_lane_steps`: branch-free arithmetic on scalars, one
loop over the lanes). A common pose is certified and unique, with exactly one bound
active (a vertex) or, for a quadratic objective, none; strict complementarity, a
well-conditioned reduced matrix and a KKT point that is the solution. Every other pose
is marked :data:`REDO` and left to the pose-by-pose loop, which gives it its status.

The reduced systems of the pose-by-pose kernel are written with a weighted
pseudo-inverse. With ``Ar`` the row-scaled structure matrix and ``W = Q^-1`` (the
identity for a linear objective), ``S = Ar W Ar'`` and ``Pw = W Ar' S^-1`` (m, n):

- quadratic, every cable free: ``dT = -W e + Pw (g + Ar W e)``;
- a vertex, cable ``a`` on its bound (linear or quadratic: the three equations fix the
  three free tensions): ``Pi = Pw - N Pw[a] / N[a]`` (``N`` the null vector) has the
  rows of ``Ar_F^-1`` on the free cables and zero on ``a``, whatever the weights:
  ``dT = Pi g``;

with ``g`` the right-hand side of the equations and ``e = dA' y`` (the pose's). By a
tension bound, only the vertex's held cable ``a`` moves with its own active bound
(``g = -Ar_a``, ``dT_a = 1``), and for the centred objective an interior optimum
follows the bound's share of its target (``e = -q_j e_j / 2``:
``dT = (e_j - Pw Ar_j) / 2``). The answers agree with the pose-by-pose loop to rounding
(tests compare them).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.certified_lane_steps import LANES, REDO, at, fmax, fmin
from tension_opt.tolerances import SENSITIVITY_ACTIVE_TOL, SENSITIVITY_MULTIPLIER_TOL

__all__ = ["LANES", "REDO", "lane_jacobians"]

#: The pose-by-pose kernel's tolerances (:mod:`tension_opt.kernels.sensitivity`).
_ACTIVE_TOL, _MULTIPLIER_TOL = SENSITIVITY_ACTIVE_TOL, SENSITIVITY_MULTIPLIER_TOL
#: Lanes whose reduced matrix is worse conditioned than this go pose by pose, where the
#: reference's limit (1e10) is judged exactly.
_COND_LANES = 1e8
# Fields of the work array: pose (3), wrench (3), tensions (4), multipliers (4), flag,
# Jacobian (up to 16: [i, j] at F_J + 4 i + j), code.
F_P, F_W, F_T, F_Z, F_OK, F_J, F_CODE = 0, 3, 6, 10, 14, 15, 31
FIELDS = 32
#: ``wrt`` codes (:mod:`tension_opt.kernels.sensitivity`): the pose, the lower bounds,
#: and the flag of a cost that follows the bounds (centred).
_POSE, _T_MIN, _MOVES_TARGET = 1, 2, 4


@njit(cache=True, error_model="numpy", inline="always")
def _unit(anchor: tuple, off: tuple, p0: float, p1: float, p2: float
          ) -> tuple[float, float, float, float]:
    """Unit vector from the attachment point to the drawing point, and one over the
    length."""
    v0 = anchor[0] - (p0 + off[0])
    v1 = anchor[1] - (p1 + off[1])
    v2 = anchor[2] - (p2 + off[2])
    L = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    inv = 1.0 / L  # one division (they cost more than the rest of the arithmetic)
    return v0 * inv, v1 * inv, v2 * inv, inv


@njit(cache=True, error_model="numpy", inline="always")
def _sym_inverse(s00: float, s01: float, s02: float, s11: float, s12: float, s22: float
                 ) -> tuple[float, float, float, float, float, float, float]:
    """Inverse of a symmetric 3 x 3 matrix by its adjugate (upper triangle) and its
    1-norm condition number."""
    c00, c01, c02 = s11 * s22 - s12 * s12, s02 * s12 - s01 * s22, s01 * s12 - s02 * s11
    c11, c12, c22 = s00 * s22 - s02 * s02, s01 * s02 - s00 * s12, s00 * s11 - s01 * s01
    inv = 1.0 / (s00 * c00 + s01 * c01 + s02 * c02)
    i00, i01, i02, i11, i12, i22 = c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, \
        c22 * inv
    norm = fmax(fmax(abs(s00) + abs(s01) + abs(s02), abs(s01) + abs(s11) + abs(s12)),
                abs(s02) + abs(s12) + abs(s22))
    inorm = fmax(fmax(abs(i00) + abs(i01) + abs(i02), abs(i01) + abs(i11) + abs(i12)),
                 abs(i02) + abs(i12) + abs(i22))
    return i00, i01, i02, i11, i12, i22, norm * inorm


@njit(cache=True, error_model="numpy", inline="always")
def _pick(t: tuple, a: int) -> float:
    """``t[a]`` of a 4-tuple, as choices (a read at a variable index keeps a loop from
    vectors)."""
    return t[0] if a == 0 else (t[1] if a == 1 else (t[2] if a == 2 else t[3]))


@njit(cache=True, error_model="numpy", inline="always")
def _column(ax: tuple, ay: tuple, az: tuple, ws: tuple, c0: float, c1: float, c2: float
            ) -> tuple[float, float, float, float]:
    """``W Ar' v`` for ``v = (c0, c1, c2)``: a column of ``Pw`` (4,)."""
    return (ws[0] * (ax[0] * c0 + ay[0] * c1 + az[0] * c2),
            ws[1] * (ax[1] * c0 + ay[1] * c1 + az[1] * c2),
            ws[2] * (ax[2] * c0 + ay[2] * c1 + az[2] * c2),
            ws[3] * (ax[3] * c0 + ay[3] * c1 + az[3] * c2))


@njit(cache=True, error_model="numpy", inline="always")
def _projected(P: tuple, N: tuple, a: int) -> tuple[float, float, float, float]:
    """A column of ``Pi = Pw - N Pw[a] / N[a]`` (zero on cable ``a``); ``N[4]`` holds
    ``1 / N[a]``."""
    f = _pick(P, a) * N[4]
    return P[0] - N[0] * f, P[1] - N[1] * f, P[2] - N[2] * f, P[3] - N[3] * f


@njit(cache=True, error_model="numpy", inline="always")
def _apply(P0: tuple, P1: tuple, P2: tuple, g0: float, g1: float, g2: float
           ) -> tuple[float, float, float, float]:
    """``P g`` for the columns ``P0, P1, P2`` (4,) of a 4 x 3 matrix."""
    return (P0[0] * g0 + P1[0] * g1 + P2[0] * g2, P0[1] * g0 + P1[1] * g1 + P2[1] * g2,
            P0[2] * g0 + P1[2] * g1 + P2[2] * g2, P0[3] * g0 + P1[3] * g1 + P2[3] * g2)


@njit(cache=True, error_model="numpy", inline="always")
def _dot(a: tuple, b: tuple) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@njit(cache=True, error_model="numpy", inline="always")
def _null(ux: tuple, uy: tuple, uz: tuple) -> tuple[float, float, float, float]:
    """Null vector of the 3 x 4 matrix of columns ``(ux[i], uy[i], uz[i])``: the signed
    determinants of its 3 x 3 minors."""
    return (_det3(ux, uy, uz, 1, 2, 3), -_det3(ux, uy, uz, 0, 2, 3),
            _det3(ux, uy, uz, 0, 1, 3), -_det3(ux, uy, uz, 0, 1, 2))


@njit(cache=True, error_model="numpy", inline="always")
def _det3(ux: tuple, uy: tuple, uz: tuple, i: int, j: int, k: int) -> float:
    """Determinant of columns ``i, j, k`` (constants) of the matrix of :func:`_null`."""
    return (ux[i] * (uy[j] * uz[k] - uz[j] * uy[k]) - ux[j] * (uy[i] * uz[k] - uz[i] * uy[k])
            + ux[k] * (uy[i] * uz[j] - uz[i] * uy[j]))


@njit(cache=True, error_model="numpy", inline="always")
def _lane_step(S: NDArray, anchors: tuple, offs: tuple, weight: float, lb: tuple,
               ub: tuple, q: tuple, inv_q: tuple, c: tuple, linear: bool, numbers: tuple,
               wrt: int) -> None:
    """The Jacobians of the block's lanes (see the module docstring); ``inv_q``: one over
    the Hessian's entries (ones for a linear objective); ``numbers``: ``(top_lb, top_ub,
    ub_share, row_floor)`` of the pose scaling; ``wrt``: the kernel's code. Divisions
    are taken once and multiplied by (the answers differ from the pose-by-pose loop's in
    rounding only).

    A hot numerical kernel: one loop over the lanes, which the compiler turns into
    vectors only as one body."""
    top_lb, top_ub, ub_share, row_floor = numbers
    what, is_min, bounds = wrt & 3, (wrt & 3) == _T_MIN, (wrt & 3) >= _T_MIN
    share = 0.5 if wrt >= _MOVES_TARGET else 0.0  # a centred cost follows the bounds
    for lane in range(LANES):
        p0, p1, p2 = S[at(F_P, lane)], S[at(F_P + 1, lane)], S[at(F_P + 2, lane)]
        b0 = 0.0 - S[at(F_W, lane)] + 0.0
        b1 = 0.0 - S[at(F_W + 1, lane)] + 0.0
        b2 = weight - S[at(F_W + 2, lane)] + 0.0
        x0, y0, z0, i0 = _unit(anchors[0], offs[0], p0, p1, p2)
        x1, y1, z1, i1 = _unit(anchors[1], offs[1], p0, p1, p2)
        x2, y2, z2, i2 = _unit(anchors[2], offs[2], p0, p1, p2)
        x3, y3, z3, i3 = _unit(anchors[3], offs[3], p0, p1, p2)
        ux, uy, uz, L = (x0, x1, x2, x3), (y0, y1, y2, y3), (z0, z1, z2, z3), (i0, i1, i2, i3)
        T = (S[at(F_T, lane)], S[at(F_T + 1, lane)], S[at(F_T + 2, lane)],
             S[at(F_T + 3, lane)])
        z = (S[at(F_Z, lane)], S[at(F_Z + 1, lane)], S[at(F_Z + 2, lane)],
             S[at(F_Z + 3, lane)])
        # The pose's scaling (kernels.scaling.pose_scaling; unit columns).
        col = fmax(fmax(math.sqrt(x0 * x0 + y0 * y0 + z0 * z0),
                        math.sqrt(x1 * x1 + y1 * y1 + z1 * z1)),
                   fmax(math.sqrt(x2 * x2 + y2 * y2 + z2 * z2),
                        math.sqrt(x3 * x3 + y3 * y3 + z3 * z3)))
        s = fmax(fmax(math.sqrt(b0 * b0 + b1 * b1 + b2 * b2) / fmax(col, 1e-300), top_lb),
                 1e-12)
        s = fmax(s, ub_share * top_ub)
        n0, n1, n2 = math.sqrt(_dot(ux, ux)), math.sqrt(_dot(uy, uy)), math.sqrt(_dot(uz, uz))
        floor = row_floor * fmax(fmax(n0, n1), n2)
        r0, r1, r2 = 1.0 / fmax(n0, floor), 1.0 / fmax(n1, floor), 1.0 / fmax(n2, floor)
        # The active set (kernels.sensitivity._active): a lane that leaves the common
        # path goes pose by pose.
        good = S[at(F_OK, lane)] != 0.0
        inv_s = 1.0 / s
        # Each cable's (active, on its lower bound, failing complementarity, bound), by
        # calls with constant indices: a read at a loop index keeps a loop from vectors.
        c0_ = _classify(T[0], z[0], lb[0], ub[0], inv_s)
        c1_ = _classify(T[1], z[1], lb[1], ub[1], inv_s)
        c2_ = _classify(T[2], z[2], lb[2], ub[2], inv_s)
        c3_ = _classify(T[3], z[3], lb[3], ub[3], inv_s)
        good = good and not (c0_[2] or c1_[2] or c2_[2] or c3_[2])
        nact = int(c0_[0]) + int(c1_[0]) + int(c2_[0]) + int(c3_[0])
        a = 3 if c3_[0] else (2 if c2_[0] else (1 if c1_[0] else 0))
        beta = c3_[3] if c3_[0] else (c2_[3] if c2_[0] else (c1_[3] if c1_[0] else c0_[3]))
        lower = c3_[1] if c3_[0] else (c2_[1] if c2_[0] else (c1_[1] if c1_[0] else c0_[1]))
        # A vertex (one bound active: the equations fix the free tensions) or, for a
        # quadratic objective, an interior optimum.
        vertex = nact == 1
        good = good and (vertex or (nact == 0 and not linear))
        ws = inv_q  # W = Q^-1, or the identity
        ax = (r0 * x0, r0 * x1, r0 * x2, r0 * x3)
        ay = (r1 * y0, r1 * y1, r1 * y2, r1 * y3)
        az = (r2 * z0, r2 * z1, r2 * z2, r2 * z3)
        wx, wy, wz = ((ax[0] * ws[0], ax[1] * ws[1], ax[2] * ws[2], ax[3] * ws[3]),
                      (ay[0] * ws[0], ay[1] * ws[1], ay[2] * ws[2], ay[3] * ws[3]),
                      (az[0] * ws[0], az[1] * ws[1], az[2] * ws[2], az[3] * ws[3]))
        i00, i01, i02, i11, i12, i22, cond_s = _sym_inverse(
            _dot(ax, wx), _dot(ax, wy), _dot(ax, wz), _dot(ay, wy), _dot(ay, wz),
            _dot(az, wz))
        # The columns of Pw = W Ar' S^-1, and of Pi at a vertex (cable a held): Pi's
        # rows are Ar_F^-1's whatever the weights.
        P0 = _column(ax, ay, az, ws, i00, i01, i02)
        P1 = _column(ax, ay, az, ws, i01, i11, i12)
        P2 = _column(ax, ay, az, ws, i02, i12, i22)
        N4 = _null(ux, uy, uz)
        N = (N4[0], N4[1], N4[2], N4[3], 1.0 / _pick(N4, a))
        V0, V1, V2 = _projected(P0, N, a), _projected(P1, N, a), _projected(P2, N, a)
        Q0, Q1, Q2 = (V0 if vertex else P0), (V1 if vertex else P1), (V2 if vertex else P2)
        sums = (abs(ax[0]) + abs(ay[0]) + abs(az[0]), abs(ax[1]) + abs(ay[1]) + abs(az[1]),
                abs(ax[2]) + abs(ay[2]) + abs(az[2]), abs(ax[3]) + abs(ay[3]) + abs(az[3]))
        free_norm = fmax(fmax(0.0 if a == 0 else sums[0], 0.0 if a == 1 else sums[1]),
                         fmax(0.0 if a == 2 else sums[2], 0.0 if a == 3 else sums[3]))
        inorm = fmax(fmax(abs(V0[0]) + abs(V0[1]) + abs(V0[2]) + abs(V0[3]),
                          abs(V1[0]) + abs(V1[1]) + abs(V1[2]) + abs(V1[3])),
                     abs(V2[0]) + abs(V2[1]) + abs(V2[2]) + abs(V2[3]))
        good = good and (free_norm * inorm if vertex else cond_s) <= _COND_LANES
        # The KKT point of the active set, and its checks. At a vertex: the free tensions
        # from the equations, y from the free cables' stationarity, the held cable's
        # multiplier's sign.
        xv = _apply(V0, V1, V2, r0 * b0 - _pick(ax, a) * beta, r1 * b1 - _pick(ay, a) * beta,
                    r2 * b2 - _pick(az, a) * beta)
        xv = (beta if a == 0 else xv[0], beta if a == 1 else xv[1], beta if a == 2 else xv[2],
              beta if a == 3 else xv[3])
        gv = (c[0] + q[0] * xv[0], c[1] + q[1] * xv[1], c[2] + q[2] * xv[2],
              c[3] + q[3] * xv[3])
        yv0, yv1, yv2 = -_dot(V0, gv), -_dot(V1, gv), -_dot(V2, gv)
        za = -(_pick(gv, a) + _pick(ax, a) * yv0 + _pick(ay, a) * yv1 + _pick(az, a) * yv2)
        good = good and (not vertex or (za < 0.0 if lower else za > 0.0))
        h0, h1, h2 = r0 * b0 + _dot(wx, c), r1 * b1 + _dot(wy, c), r2 * b2 + _dot(wz, c)
        yi0 = -(i00 * h0 + i01 * h1 + i02 * h2)
        yi1 = -(i01 * h0 + i11 * h1 + i12 * h2)
        yi2 = -(i02 * h0 + i12 * h1 + i22 * h2)
        xi = (-ws[0] * (c[0] + ax[0] * yi0 + ay[0] * yi1 + az[0] * yi2),
              -ws[1] * (c[1] + ax[1] * yi0 + ay[1] * yi1 + az[1] * yi2),
              -ws[2] * (c[2] + ax[2] * yi0 + ay[2] * yi1 + az[2] * yi2),
              -ws[3] * (c[3] + ax[3] * yi0 + ay[3] * yi1 + az[3] * yi2))
        xs = xv if vertex else xi
        y0_, y1_, y2_ = (yv0 if vertex else yi0), (yv1 if vertex else yi1), \
            (yv2 if vertex else yi2)
        moved = fmax(fmax(abs(xs[0] - T[0]), abs(xs[1] - T[1])),
                     fmax(abs(xs[2] - T[2]), abs(xs[3] - T[3]))) * inv_s
        good = good and moved <= 10 * _ACTIVE_TOL
        S[at(F_CODE, lane)] = 0.0 if good else float(REDO)
        # The Jacobian, column by column (g = -rows_j e_j for the wrench).
        rows, y, Q = (r0, r1, r2), (y0_, y1_, y2_), (Q0, Q1, Q2)
        # By a bound: the vertex's held cable on its own active bound moves by one (``&``:
        # a select, not a branch), the rest as the equations make it.
        held = vertex & (lower == is_min)
        dv = _apply(V0, V1, V2, -_pick(ax, a), -_pick(ay, a), -_pick(az, a))
        dv = (1.0 if a == 0 else dv[0], 1.0 if a == 1 else dv[1],
              1.0 if a == 2 else dv[2], 1.0 if a == 3 else dv[3])
        half = 0.0 if vertex else share
        if what == _POSE:
            _put(S, lane, 0, _pose_column(0, ux, uy, uz, L, T, rows, y, ws, (wx, wy, wz), Q,
                                          vertex))
            _put(S, lane, 1, _pose_column(1, ux, uy, uz, L, T, rows, y, ws, (wx, wy, wz), Q,
                                          vertex))
            _put(S, lane, 2, _pose_column(2, ux, uy, uz, L, T, rows, y, ws, (wx, wy, wz), Q,
                                          vertex))
        else:  # the wrench's columns or the bounds', chosen value by value
            _put(S, lane, 0, _choose(bounds, _bound_column(0, a, held, dv, half, ax, ay, az,
                                                           P0, P1, P2),
                                     (-r0 * Q0[0], -r0 * Q0[1], -r0 * Q0[2], -r0 * Q0[3])))
            _put(S, lane, 1, _choose(bounds, _bound_column(1, a, held, dv, half, ax, ay, az,
                                                           P0, P1, P2),
                                     (-r1 * Q1[0], -r1 * Q1[1], -r1 * Q1[2], -r1 * Q1[3])))
            _put(S, lane, 2, _choose(bounds, _bound_column(2, a, held, dv, half, ax, ay, az,
                                                           P0, P1, P2),
                                     (-r2 * Q2[0], -r2 * Q2[1], -r2 * Q2[2], -r2 * Q2[3])))
        # Stored on every path (unused but by the bounds): a store on one path only keeps
        # the loop from vectors.
        _put(S, lane, 3, _bound_column(3, a, held, dv, half, ax, ay, az, P0, P1, P2))


@njit(cache=True, error_model="numpy", inline="always")
def _put(S: NDArray, lane: int, j: int, d: tuple) -> None:
    """Column ``j`` (a constant) of the lane's Jacobian into its fields."""
    S[at(F_J + j, lane)] = d[0]
    S[at(F_J + 4 + j, lane)] = d[1]
    S[at(F_J + 8 + j, lane)] = d[2]
    S[at(F_J + 12 + j, lane)] = d[3]


@njit(cache=True, error_model="numpy", inline="always")
def _choose(flag: bool, a: tuple, b: tuple) -> tuple[float, float, float, float]:
    """``a`` where ``flag``, else ``b``, value by value (selects)."""
    return (a[0] if flag else b[0], a[1] if flag else b[1], a[2] if flag else b[2],
            a[3] if flag else b[3])


@njit(cache=True, error_model="numpy", inline="always")
def _bound_column(j: int, a: int, held: bool, dv: tuple, half: float, ax: tuple, ay: tuple,
                  az: tuple, P0: tuple, P1: tuple, P2: tuple
                  ) -> tuple[float, float, float, float]:
    """Column ``j`` (a constant) of ``dT / d bound``: ``dv`` where cable ``j`` is the
    vertex's held cable on that bound (``held``), else ``half (e_j - Pw Ar_j)`` (``half``
    zero but for a centred interior optimum)."""
    on = held & (a == j)
    k0, k1, k2 = ax[j], ay[j], az[j]
    f0 = half * ((1.0 if j == 0 else 0.0) - (P0[0] * k0 + P1[0] * k1 + P2[0] * k2))
    f1 = half * ((1.0 if j == 1 else 0.0) - (P0[1] * k0 + P1[1] * k1 + P2[1] * k2))
    f2 = half * ((1.0 if j == 2 else 0.0) - (P0[2] * k0 + P1[2] * k1 + P2[2] * k2))
    f3 = half * ((1.0 if j == 3 else 0.0) - (P0[3] * k0 + P1[3] * k1 + P2[3] * k2))
    return (dv[0] if on else f0, dv[1] if on else f1, dv[2] if on else f2,
            dv[3] if on else f3)


@njit(cache=True, error_model="numpy", inline="always")
def _classify(T: float, z: float, lb: float, ub: float, inv_s: float
              ) -> tuple[bool, bool, bool, float]:
    """One cable's part of the active set (kernels.sensitivity._active): whether a bound
    is active, whether it is the lower one, whether strict complementarity fails, and
    the bound's value."""
    t = T * inv_s
    near_lo, near_hi = t - lb * inv_s <= _ACTIVE_TOL, ub * inv_s - t <= _ACTIVE_TOL
    lo = near_lo and z < -_MULTIPLIER_TOL
    hi = near_hi and z > _MULTIPLIER_TOL and not lo
    active = lo or hi
    bad = (near_lo and near_hi) or ((near_lo or near_hi or abs(z) > _MULTIPLIER_TOL)
                                    and not active)
    return active, lo, bad, lb if lo else ub


@njit(cache=True, error_model="numpy", inline="always")
def _pose_column(j: int, ux: tuple, uy: tuple, uz: tuple, L: tuple, T: tuple, r: tuple,
                 y: tuple, ws: tuple, w: tuple, Q: tuple, vertex: bool
                 ) -> tuple[float, float, float, float]:
    """Column ``j`` of ``dT / d pose`` of a point robot (``L``: one over the lengths): the
    columns move by ``du_i = -(e_j - u_i u_ij) / L_i``; ``g = -rows (dA_j T)``, and for a quadratic
    objective ``e_i = du_i . (rows y)`` enters as in the module docstring."""
    e0, e1, e2 = (1.0 if j == 0 else 0.0), (1.0 if j == 1 else 0.0), (1.0 if j == 2 else 0.0)
    uj = ux if j == 0 else (uy if j == 1 else uz)
    dx = ((ux[0] * uj[0] - e0) * L[0], (ux[1] * uj[1] - e0) * L[1],
          (ux[2] * uj[2] - e0) * L[2], (ux[3] * uj[3] - e0) * L[3])
    dy = ((uy[0] * uj[0] - e1) * L[0], (uy[1] * uj[1] - e1) * L[1],
          (uy[2] * uj[2] - e1) * L[2], (uy[3] * uj[3] - e1) * L[3])
    dz = ((uz[0] * uj[0] - e2) * L[0], (uz[1] * uj[1] - e2) * L[1],
          (uz[2] * uj[2] - e2) * L[2], (uz[3] * uj[3] - e2) * L[3])
    g0, g1, g2 = -r[0] * _dot(dx, T), -r[1] * _dot(dy, T), -r[2] * _dot(dz, T)
    yu0, yu1, yu2 = r[0] * y[0], r[1] * y[1], r[2] * y[2]
    e = (dx[0] * yu0 + dy[0] * yu1 + dz[0] * yu2, dx[1] * yu0 + dy[1] * yu1 + dz[1] * yu2,
         dx[2] * yu0 + dy[2] * yu1 + dz[2] * yu2, dx[3] * yu0 + dy[3] * yu1 + dz[3] * yu2)
    zero = 0.0
    if vertex:  # the equations fix the free tensions: the multipliers' term cancels
        e = (zero, zero, zero, zero)
    g0, g1, g2 = g0 + _dot(w[0], e), g1 + _dot(w[1], e), g2 + _dot(w[2], e)
    out = _apply(Q[0], Q[1], Q[2], g0, g1, g2)
    return (out[0] - ws[0] * e[0], out[1] - ws[1] * e[1], out[2] - ws[2] * e[2],
            out[3] - ws[3] * e[3])


@njit(cache=True, error_model="numpy", inline="always")
def _load(S: NDArray, poses: NDArray, wrenches: NDArray, T: NDArray, z: NDArray,
          y: NDArray, solved: NDArray, unique: NDArray, start: int) -> None:
    """The block from pose ``start`` into the work array (a short last block repeats its
    last pose); a pose is common only if solved, unique and with finite tensions and
    multipliers."""
    N = poses.shape[0]
    for lane in range(LANES):
        p = fmin(start + lane, N - 1)
        wp = p if wrenches.shape[0] > 1 else 0
        for k in range(3):
            S[at(F_P + k, lane)] = poses[p, k]
            S[at(F_W + k, lane)] = wrenches[wp, k]
        ok = solved[p] and unique[p]
        for i in range(4):
            S[at(F_T + i, lane)] = T[p, i]
            S[at(F_Z + i, lane)] = z[p, i]
            ok = ok and abs(T[p, i]) < np.inf and abs(z[p, i]) < np.inf
        for k in range(3):
            ok = ok and abs(y[p, k]) < np.inf
        S[at(F_OK, lane)] = 1.0 if ok else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def lane_jacobians(data: NDArray, views: tuple, poses: NDArray, wrenches: NDArray,
                   T: NDArray, z: NDArray, y: NDArray, solved: NDArray, unique: NDArray,
                   wrt: int, J: NDArray, codes: NDArray, numbers: tuple) -> int:
    """The Jacobians of a four-cable point robot's poses, :data:`LANES` at a time,
    written as :func:`tension_opt.kernels.sensitivity.jacobian_poses` writes them; a pose
    left to the caller gets the code :data:`REDO` (its row unwritten). A hot numerical
    kernel: the steps of a block, then its results written pose by pose.

    ``views``: anchors, attachments (4, 3) and ``q, c, lb, ub`` (4,) of the packed
    problem ``data`` (no min-max term; the Hessian zero or positive for every cable);
    ``numbers``: ``(top_lb, top_ub, ub_share, row_floor)``. Returns the poses marked.
    """
    anchors_v, attachments_v, q_v, c_v, lb_v, ub_v = views
    anchors = ((anchors_v[0, 0], anchors_v[0, 1], anchors_v[0, 2]),
               (anchors_v[1, 0], anchors_v[1, 1], anchors_v[1, 2]),
               (anchors_v[2, 0], anchors_v[2, 1], anchors_v[2, 2]),
               (anchors_v[3, 0], anchors_v[3, 1], anchors_v[3, 2]))
    offs = ((attachments_v[0, 0], attachments_v[0, 1], attachments_v[0, 2]),
            (attachments_v[1, 0], attachments_v[1, 1], attachments_v[1, 2]),
            (attachments_v[2, 0], attachments_v[2, 1], attachments_v[2, 2]),
            (attachments_v[3, 0], attachments_v[3, 1], attachments_v[3, 2]))
    q = (q_v[0], q_v[1], q_v[2], q_v[3])
    c = (c_v[0], c_v[1], c_v[2], c_v[3])
    lb = (lb_v[0], lb_v[1], lb_v[2], lb_v[3])
    ub = (ub_v[0], ub_v[1], ub_v[2], ub_v[3])
    linear = q[0] == 0.0 and q[1] == 0.0 and q[2] == 0.0 and q[3] == 0.0
    inv_q = (1.0, 1.0, 1.0, 1.0) if linear else (1.0 / q[0], 1.0 / q[1], 1.0 / q[2],
                                                  1.0 / q[3])
    weight = data[3]
    S = np.empty(FIELDS * LANES)
    N = poses.shape[0]
    redo = 0
    for start in range(0, N, LANES):
        _load(S, poses, wrenches, T, z, y, solved, unique, start)
        # One copy of the step (each copy costs its compile time): the choice of wrt
        # is a branch the compiler may hoist out of the lanes' loop.
        _lane_step(S, anchors, offs, weight, lb, ub, q, inv_q, c, linear, numbers, wrt)
        for lane in range(fmin(LANES, N - start)):
            p = start + lane
            if S[at(F_CODE, lane)] != 0.0:
                codes[p] = REDO
                redo += 1
                continue
            codes[p] = 0
            for i in range(4):
                for j in range(J.shape[2]):
                    J[p, i, j] = S[at(F_J + 4 * i + j, lane)]
    return redo
