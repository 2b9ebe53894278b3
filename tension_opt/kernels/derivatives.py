"""Derivatives of the structure matrix and of the required wrench by the pose, and of a
column by its cable's points, compiled, for one pose: the twins of
:func:`tension_opt.robot.derivatives.pose_derivatives` and
:func:`~tension_opt.robot.derivatives.column_derivatives`.

A step moves the platform by ``t`` and turns it by ``omega`` (the left Jacobian of SO(3)
for ``"spatial6"``), so ``dr = omega x r``, ``dv = -t - dr``,
``du = (dv - u (u . dv)) / L`` and the column moves by ``[du; dr x u + r x du]``;
gravity's moment moves by ``(omega x R c) x f``. :func:`pose_terms` gives these
derivatives already applied to the tensions and the multipliers, as the Jacobians of
:mod:`tension_opt.kernels.sensitivity` use them. A drawing point's step ``e_c`` moves
only its own cable's column, with ``dv = e_c`` and ``dr = 0``; an attachment's (platform
frame) with ``dr = R e_c`` and ``dv = -dr`` (:func:`point_column`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.geometry import arm_and_vector, platform_position, rotation

__all__ = ["point_column", "pose_terms"]


@njit(cache=True, error_model="numpy", inline="always")
def _kept(kind: int, k: int, f0: float, f1: float, f2: float, f3: float, f4: float,
          f5: float) -> float:
    """Row ``k`` of the kind's rows of a full wrench ``(f, m)`` (as the geometry's)."""
    out = f0
    if kind == 1:
        out = f2 if k == 1 else f0
    elif kind == 2:
        out = f1 if k == 1 else (f5 if k == 2 else f0)
    elif k > 0:
        out = (f0, f1, f2, f3, f4, f5)[k]
    return out


@njit(cache=True, error_model="numpy", inline="always")
def _step(kind: int, j: int, pose: NDArray, a: float, b: float
          ) -> tuple[float, float, float, float, float, float]:
    """Translation ``t`` and small rotation ``omega`` of a unit step of pose coordinate
    ``j`` (``omega`` about the base axes; the left Jacobian's column for spatial6, whose
    coefficients are ``a, b``: :func:`_left_coefficients`)."""
    t0 = t1 = t2 = w0 = w1 = w2 = 0.0
    if kind == 0 or (kind == 3 and j < 3):
        t0, t1, t2 = 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0, 1.0 if j == 2 else 0.0
    elif kind == 1:
        t0, t2 = 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0
    elif kind == 2:
        t0, t1, w2 = 1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0, 1.0 if j == 2 else 0.0
    else:
        x, y, z = pose[3], pose[4], pose[5]
        e0, e1, e2 = 1.0 if j == 3 else 0.0, 1.0 if j == 4 else 0.0, 1.0 if j == 5 else 0.0
        # J_l e = e + a (theta x e) + b theta x (theta x e)
        c0, c1, c2 = y * e2 - z * e1, z * e0 - x * e2, x * e1 - y * e0
        d0, d1, d2 = y * c2 - z * c1, z * c0 - x * c2, x * c1 - y * c0
        w0, w1, w2 = e0 + a * c0 + b * d0, e1 + a * c1 + b * d1, e2 + a * c2 + b * d2
    if pose.size < 0:  # never: the pose read after the branches
        t0 = np.nan
    return t0, t1, t2, w0, w1, w2


@njit(cache=True, error_model="numpy", inline="always")
def _left_coefficients(kind: int, pose: NDArray) -> tuple[float, float]:
    """``a, b`` of the left Jacobian of SO(3) at a spatial6 pose's rotation vector
    (``J_l = I + a [theta]x + b [theta]x^2``); zeros for other kinds."""
    a = b = 0.0
    if kind == 3:
        phi2 = pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5]
        if phi2 < 1e-8:  # the reference's series below phi = 1e-4
            a, b = 0.5 - phi2 / 24.0, 1.0 / 6.0 - phi2 / 120.0
        else:
            phi = math.sqrt(phi2)
            a, b = (1.0 - math.cos(phi)) / phi2, (phi - math.sin(phi)) / (phi2 * phi)
    if pose.size < 0:  # never: the pose read after the branches
        a = np.nan
    return a, b


@njit(cache=True, error_model="numpy", inline="always")
def _column_step(r: tuple, u: tuple, L: float, dr: tuple, dv: tuple
                 ) -> tuple[float, float, float, float, float, float]:
    """The step of a column ``[u; r x u]`` (force, moment) of a cable of length ``L``
    whose arm steps by ``dr`` and whose vector by ``dv``: ``du = (dv - u (u . dv)) / L``
    and ``dr x u + r x du``."""
    r0, r1, r2 = r
    u0, u1, u2 = u
    dr0, dr1, dr2 = dr
    dv0, dv1, dv2 = dv
    ud = u0 * dv0 + u1 * dv1 + u2 * dv2
    du0, du1, du2 = (dv0 - u0 * ud) / L, (dv1 - u1 * ud) / L, (dv2 - u2 * ud) / L
    m0 = (dr1 * u2 - dr2 * u1) + (r1 * du2 - r2 * du1)
    m1 = (dr2 * u0 - dr0 * u2) + (r2 * du0 - r0 * du2)
    m2 = (dr0 * u1 - dr1 * u0) + (r0 * du1 - r1 * du0)
    return du0, du1, du2, m0, m1, m2


@njit(cache=True, error_model="numpy", inline="always")
def point_column(kind: int, anchors: NDArray, attachments: NDArray, pose: NDArray,
                 R: tuple, i: int, c: int, attachment: bool, out: NDArray) -> None:
    """``out`` (n,): the derivative of column ``i`` of the structure matrix by coordinate
    ``c`` of cable ``i``'s drawing point (base frame) or, with ``attachment``, of its
    attachment (platform frame), at a pose whose rotation is ``R`` (row by row)."""
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = R
    r0, r1, r2, v0, v1, v2 = arm_and_vector(R, platform_position(kind, pose), anchors,
                                            attachments, i)
    L = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    u0, u1, u2 = v0 / L, v1 / L, v2 / L
    dr0 = dr1 = dr2 = 0.0
    if attachment:  # r = R a moves by R e_c, the cable's vector the other way
        dr0 = R00 if c == 0 else (R01 if c == 1 else R02)
        dr1 = R10 if c == 0 else (R11 if c == 1 else R12)
        dr2 = R20 if c == 0 else (R21 if c == 1 else R22)
        dv0, dv1, dv2 = -dr0, -dr1, -dr2
    else:
        dv0, dv1, dv2 = 1.0 if c == 0 else 0.0, 1.0 if c == 1 else 0.0, 1.0 if c == 2 else 0.0
    du0, du1, du2, m0, m1, m2 = _column_step((r0, r1, r2), (u0, u1, u2), L,
                                             (dr0, dr1, dr2), (dv0, dv1, dv2))
    for k in range(out.size):
        out[k] = _kept(kind, k, du0, du1, du2, m0, m1, m2)
    if (anchors.size | attachments.size | pose.size | out.size) < 0:
        out[0] = np.nan  # never: the arrays read after the branches


@njit(cache=True, error_model="numpy", inline="always")
def pose_terms(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                weight: float, pose: NDArray, T: NDArray, yu: NDArray, dAT: NDArray,
                dAy: NDArray, db: NDArray) -> None:
    """For each pose coordinate ``j``: ``dAT[:, j] = dA_j T`` (n), ``dAy[:, j] = dA_j' yu``
    (m) and ``db[:, j]`` (n), the derivatives of the columns and of the required
    wrench ``b = -(w_g + w)``."""
    n, m = dAT.shape[0], anchors.shape[0]
    R = rotation(kind, pose)
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = R
    position = platform_position(kind, pose)
    c0 = R00 * com[0] + R01 * com[1] + R02 * com[2]
    c1 = R10 * com[0] + R11 * com[1] + R12 * com[2]
    c2 = R20 * com[0] + R21 * com[1] + R22 * com[2]
    a, b = _left_coefficients(kind, pose)
    for k in range(n):
        for j in range(n):
            dAT[k, j] = 0.0
    for i in range(m):  # each cable's vector once, then its column's step by each j
        r0, r1, r2, v0, v1, v2 = arm_and_vector(R, position, anchors, attachments, i)
        L = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        u0, u1, u2 = v0 / L, v1 / L, v2 / L
        for j in range(n):
            t0, t1, t2, w0, w1, w2 = _step(kind, j, pose, a, b)
            dr0, dr1, dr2 = w1 * r2 - w2 * r1, w2 * r0 - w0 * r2, w0 * r1 - w1 * r0
            du0, du1, du2, m0, m1, m2 = _column_step(
                (r0, r1, r2), (u0, u1, u2), L, (dr0, dr1, dr2),
                (-t0 - dr0, -t1 - dr1, -t2 - dr2))
            if kind == 3:  # all six rows, written out (a tuple read at a loop index
                Ti = T[i]  # is a store and a load per entry)
                dAT[0, j] += du0 * Ti
                dAT[1, j] += du1 * Ti
                dAT[2, j] += du2 * Ti
                dAT[3, j] += m0 * Ti
                dAT[4, j] += m1 * Ti
                dAT[5, j] += m2 * Ti
                dAy[i, j] = (du0 * yu[0] + du1 * yu[1] + du2 * yu[2] + m0 * yu[3]
                             + m1 * yu[4] + m2 * yu[5])
            else:
                total = 0.0
                for k in range(n):
                    col = _kept(kind, k, du0, du1, du2, m0, m1, m2)
                    dAT[k, j] += col * T[i]
                    total += col * yu[k]
                dAy[i, j] = total
    for j in range(n):
        # d((R c) x f) = (omega x R c) x f with f = (0, 0, -weight); b takes it negated.
        w0, w1, w2 = _step(kind, j, pose, a, b)[3:]
        e0, e1 = w1 * c2 - w2 * c1, w2 * c0 - w0 * c2
        g0, g1 = e1 * weight, -e0 * weight
        for k in range(n):
            db[k, j] = _kept(kind, k, 0.0, 0.0, 0.0, g0, g1, 0.0)
    if (anchors.size | attachments.size | com.size | pose.size | T.size | yu.size
            | dAT.size | dAy.size | db.size) < 0:
        db[0, 0] = np.nan  # never: the arrays read after the branches
