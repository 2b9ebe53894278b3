"""Jacobians of optimal tensions by the wrench, the pose, the tension bounds and the
cables' points, compiled, pose by pose.

The reference is :class:`tension_opt.distribution.sensitivity.KktSystem` on a problem
without rows (no min-max term) whose objective is linear (every Hessian entry zero) or
has a positive Hessian everywhere: the package's ``min_sum``, ``min_norm``,
``centered`` and ``pinv``. With the active set fixed, the bound-active tensions do not
move and the free ones ``F`` solve the reduced KKT system (``Ar`` the equilibrium rows
over their norms, ``Q`` and ``c`` the form's Hessian diagonal and cost)::

    linear:    Ar_F dT_F = dbr                         (a vertex: |F| = n)
    quadratic: S dy = -(dbr + Ar_F Q_F^-1 r),  dT_F = -Q_F^-1 (r + Ar_F' dy),
               S = Ar_F Q_F^-1 Ar_F'

with ``dbr = rows * (db - dA T)`` and ``r = dA_F' y`` (``dA``, ``db`` zero for the
wrench, whose ``db`` is ``-e_j``). A bound ``t_min_j`` or ``t_max_j`` moves cable ``j``
by one where it is the active bound (``dbr = -rows * A_j``, ``r`` zero) and, for the
centred objective (whose cost ``c_j = -q_j (t_min_j + t_max_j) / 2`` follows the
bounds), a free cable ``j``'s cost by ``r_j = -q_j / 2``. A drawing point or an
attachment moves its own cable's column alone (``dbr = -rows * dA_i T_i``,
``r_i = dA_i' y``: :func:`tension_opt.kernels.derivatives.point_column`). This is the
full KKT matrix
of the reference eliminated block by block, so the derivatives agree to rounding.

The per-pose statuses are the reference's: the active set from the certificate's
multipliers and the distance to the bounds (:data:`ACTIVE_TOL`,
:data:`MULTIPLIER_TOL`, in the pose's reference tensions), ``"degenerate"`` where strict
complementarity fails or the KKT point's multipliers have the wrong sign,
``"non_unique"`` for a face of optima, ``"not_optimal"`` where the KKT point of the
active set is not the solution. Singularity is judged on the reduced matrix (``Ar_F``,
or ``S``), whose 1-norm condition number must stay below :data:`COND_MAX`; the reference
judges the full matrix, whose condition number is of the same order (equal for the
linear case up to the identity blocks, the square of ``Ar_F``'s for the quadratic
one), so the two can differ only on poses within a few orders of the limit.

The derivative of the columns and of the required wrench by the pose is
:func:`tension_opt.kernels.derivatives.pose_terms`. A point robot on four cables runs
its common poses side by side (:mod:`tension_opt.kernels.sensitivity_lanes`), and
:func:`jacobian_one` differentiates the pose the real-time kernel just solved.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.closed_form import HEADER
from tension_opt.kernels.derivatives import point_column, pose_terms
from tension_opt.kernels.distributor import matrix_at, vector_at
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into, rotation
from tension_opt.kernels.scaling import pose_scaling
from tension_opt.kernels.sensitivity_lanes import REDO, lane_jacobians
from tension_opt.tolerances import (
    ROW_FLOOR,
    SENSITIVITY_ACTIVE_TOL,
    SENSITIVITY_COND_MAX,
    SENSITIVITY_MULTIPLIER_TOL,
    UB_SHARE,
)

__all__ = ["ACTIVE_TOL", "ATTACHMENT_POINTS", "COND_MAX", "DRAWING_POINTS", "MOVES_TARGET",
           "MULTIPLIER_TOL", "NON_UNIQUE", "POSE", "T_MAX", "T_MIN", "WRENCH", "columns",
           "jacobian_one", "jacobian_poses", "pose_jacobian", "work_floats"]

#: What a Jacobian is taken with respect to: the external wrench, the pose, the lower and
#: the upper tension bounds, the drawing points and the attachment points.
WRENCH, POSE, T_MIN, T_MAX, DRAWING_POINTS, ATTACHMENT_POINTS = 0, 1, 2, 3, 8, 9
#: Added to ``T_MIN`` or ``T_MAX``: the bounds also move the objective's cost (centred).
MOVES_TARGET = 4
#: Statuses, in the order of :data:`tension_opt.distribution.sensitivity.SENSITIVITY_STATUSES`.
_OK, _NON_UNIQUE, _DEGENERATE, _NOT_OPTIMAL = 0, 1, 2, 3
NON_UNIQUE = _NON_UNIQUE
#: The reference's tolerances (:mod:`tension_opt.distribution.sensitivity`).
ACTIVE_TOL = SENSITIVITY_ACTIVE_TOL
MULTIPLIER_TOL = SENSITIVITY_MULTIPLIER_TOL
COND_MAX = SENSITIVITY_COND_MAX


@njit(cache=True)
def columns(wrt: int, m: int, n: int) -> int:
    """Columns of one pose's Jacobian by ``wrt``: ``n`` by the wrench or the pose, ``m``
    by a bound, ``3 m`` by the points (cable ``i``'s coordinate ``c`` at ``3 i + c``)."""
    what = wrt & ~MOVES_TARGET
    return n if what <= POSE else (m if what <= T_MAX else 3 * m)


@njit(cache=True, error_model="numpy", inline="always")
def _norm1(M: NDArray, r: int) -> float:
    """1-norm (largest column sum of magnitudes) of the leading (r, r) block; inf where
    an entry is NaN."""
    norm = 0.0
    for j in range(r):
        total = 0.0
        for i in range(r):
            total += abs(M[i, j])
        norm = max(norm, total) if total == total else np.inf
    if M.size < 0:  # never: M read after the branches
        norm = np.nan
    return norm


@njit(cache=True, error_model="numpy", inline="always")
def _invert(M: NDArray, Minv: NDArray, r: int) -> float:
    """``Minv = M^-1`` for the leading (r, r) block, by Gauss-Jordan elimination with
    partial pivoting (``M`` overwritten); returns the 1-norm condition number (inf for a
    singular or non-finite matrix)."""
    norm = _norm1(M, r)
    for i in range(r):
        for j in range(r):
            Minv[i, j] = 1.0 if i == j else 0.0
    ok = math.isfinite(norm)
    for col in range(r):
        if not ok:
            break
        pivot = col
        for row in range(col + 1, r):
            if abs(M[row, col]) > abs(M[pivot, col]):
                pivot = row
        if M[pivot, col] == 0.0:
            ok = False
            break
        if pivot != col:
            for j in range(r):
                M[col, j], M[pivot, j] = M[pivot, j], M[col, j]
                Minv[col, j], Minv[pivot, j] = Minv[pivot, j], Minv[col, j]
        inv = 1.0 / M[col, col]
        for j in range(r):
            M[col, j] *= inv
            Minv[col, j] *= inv
        for row in range(r):
            f = M[row, col]
            if row != col and f != 0.0:
                for j in range(r):
                    M[row, j] -= f * M[col, j]
                    Minv[row, j] -= f * Minv[col, j]
    cond = norm * _norm1(Minv, r) if ok else np.inf
    if (M.size | Minv.size) < 0:  # never: the arrays read after the branches
        cond = np.nan
    return cond


@njit(cache=True, nogil=True, error_model="numpy")
def jacobian_poses(data: NDArray, poses: NDArray, wrenches: NDArray, T: NDArray,
                   z: NDArray, y: NDArray, solved: NDArray, unique: NDArray, wrt: int,
                   J: NDArray, codes: NDArray, side_by_side: bool = True) -> None:
    """Jacobians of the optimal tensions of independent poses (see the module docstring).

    Parameters
    ----------
    data : ndarray
        :func:`tension_opt.distribution.packing.pack_certified` of the robot and
        problem solved (no min-max term).
    poses : ndarray, shape (N, n)
    wrenches : ndarray, shape (N, n) or (1, n)
        External wrench besides gravity (N, N m), per pose or one for all.
    T : ndarray, shape (N, m)
        Optimal tensions (N).
    z, y : ndarray, shapes (N, m) and (N, n)
        The certificate's bound multipliers (scaled: ``< 0`` lower, ``> 0`` upper) and
        equation multipliers (their finiteness alone is read).
    solved, unique : ndarray of bool, shape (N,)
        Poses with a certified optimum (differentiated where its tensions and
        multipliers are finite); poses whose optimum is unique.
    wrt : int
        :data:`WRENCH`, :data:`POSE`, :data:`T_MIN` or :data:`T_MAX` (plus
        :data:`MOVES_TARGET` for the centred objective), :data:`DRAWING_POINTS` or
        :data:`ATTACHMENT_POINTS`.
    J : ndarray, shape (N, m, :func:`columns`)
        Written: ``dT / d wrt`` (NaN where the status is not ``"ok"``).
    codes : ndarray of int8, shape (N,)
        Written: the statuses' codes.
    side_by_side : bool
        False: every pose by the pose-by-pose loop, also for a point robot on four
        cables, whose common poses otherwise run side by side
        (:mod:`tension_opt.kernels.sensitivity_lanes`; the tests compare the two).
    """
    m, n = int(data[1]), int(data[2])
    # Work arrays made once and handed to the loop (see tension_opt.kernels).
    floats, free = np.empty(work_floats(m, n)), np.empty(m, dtype=np.int64)
    work, views = _carve(floats.ctypes.data, m, n), _problem_at(data.ctypes.data, m)
    lanes = int(data[0]) == 0 and m == 4 and n == 3 and wrt & ~MOVES_TARGET <= T_MAX
    if not (side_by_side and lanes):
        _loop(data, views, poses, wrenches, T, z, y, solved, unique, wrt, J, codes, free,
              work)
    else:  # a point robot on four cables: blocks of poses side by side, then the rest
        anchors, attachments, _, q, c, lb, ub = views
        top_lb = top_ub = 0.0
        for i in range(m):
            top_lb = max(top_lb, abs(lb[i])) if math.isfinite(lb[i]) else top_lb
            top_ub = max(top_ub, abs(ub[i])) if math.isfinite(ub[i]) else top_ub
        if lane_jacobians(data, (anchors, attachments, q, c, lb, ub), poses, wrenches, T,
                          z, y, solved, unique, wrt, J, codes,
                          (top_lb, top_ub, UB_SHARE, ROW_FLOOR)):
            one = wrenches.shape[0] == 1
            for p in range(poses.shape[0]):
                if codes[p] == REDO:
                    _loop(data, views, poses[p:p + 1], wrenches if one else wrenches[p:p + 1],
                          T[p:p + 1], z[p:p + 1], y[p:p + 1], solved[p:p + 1],
                          unique[p:p + 1], wrt, J[p:p + 1], codes[p:p + 1], free, work)
    if (floats.size | data.size) < 0:  # never: the buffers read after their views' last use
        J[0, 0, 0] = np.nan


@njit(cache=True, error_model="numpy", inline="always")
def _problem_at(d: int, m: int) -> tuple[NDArray, ...]:
    """What the loop reads of the packed problem at address ``d``: anchors, attachments
    (m, 3), centre of mass (3,) and ``q, c, lb, ub`` (m,) (the layout of
    :func:`~tension_opt.kernels.certified.problem_views`), owning nothing."""
    o = HEADER + 6 * m
    return (matrix_at(d, HEADER, m, 3), matrix_at(d, HEADER + 3 * m, m, 3),
            vector_at(d, 8, 3), vector_at(d, o, m), vector_at(d, o + m, m),
            vector_at(d, o + 3 * m, m), vector_at(d, o + 4 * m, m))


@njit(cache=True)
def work_floats(m: int, n: int) -> int:
    """Floats of work space of one pose's Jacobian (:func:`_carve`)."""
    return 8 * n + 6 * m + 2 * n * m + 3 * m * m + 4 * n * n


@njit(cache=True, error_model="numpy", inline="always")
def _carve(address: int, m: int, n: int) -> tuple[NDArray, ...]:
    """The work arrays over the buffer of :func:`work_floats` floats at ``address``,
    owning nothing (no reference counts: see
    :func:`tension_opt.kernels.distributor.vector_at`; the caller keeps the buffer
    alive), in this order: ``pose, wrench, b, rows, y, yu, g, dy`` (n), ``bound, e, x,
    Tp, zp, iq`` (m), ``A`` (n, m), ``dAy`` (m, n), ``Jp`` (m, 3 m), ``Mf, Minv, dAT,
    db`` (n, n)."""
    nm, nn, o = n * m, n * n, 8 * n
    p = o + 6 * m
    q = p + 2 * nm + 3 * m * m
    a = address
    return (vector_at(a, 0, n), vector_at(a, n, n), vector_at(a, 2 * n, n),
            vector_at(a, 3 * n, n), vector_at(a, 4 * n, n), vector_at(a, 5 * n, n),
            vector_at(a, 6 * n, n), vector_at(a, 7 * n, n), vector_at(a, o, m),
            vector_at(a, o + m, m), vector_at(a, o + 2 * m, m), vector_at(a, o + 3 * m, m),
            vector_at(a, o + 4 * m, m), vector_at(a, o + 5 * m, m), matrix_at(a, p, n, m),
            matrix_at(a, p + nm, m, n),
            matrix_at(a, p + 2 * nm, m, 3 * m), matrix_at(a, q, n, n),
            matrix_at(a, q + nn, n, n), matrix_at(a, q + 2 * nn, n, n),
            matrix_at(a, q + 3 * nn, n, n))


@njit(cache=True, error_model="numpy", inline="always")
def inverted(q: NDArray, iq: NDArray) -> NDArray:
    """``iq = 1 / q`` (infinite where ``q`` is zero), written and returned: the kernels
    multiply by it (a division costs several multiplications)."""
    for i in range(q.size):
        iq[i] = 1.0 / q[i] if q[i] != 0.0 else np.inf
    return iq


@njit(cache=True, error_model="numpy", inline="always")
def finite(T: NDArray, z: NDArray, y: NDArray) -> bool:
    """Whether a pose's tensions and multipliers are all finite (the numpy path's
    ``Multipliers.known`` and finite tensions)."""
    ok = True
    for v in T:
        ok = ok and abs(v) < np.inf
    for v in z:
        ok = ok and abs(v) < np.inf
    for v in y:
        ok = ok and abs(v) < np.inf
    return ok


@njit(cache=True, error_model="numpy", inline="always")
def _active(T: NDArray, z: NDArray, lb: NDArray, ub: NDArray, s: float, free: NDArray,
            bound: NDArray) -> tuple[bool, int]:
    """The active set of one pose (the reference's rule): ``bound`` written with the
    active bound's value (NaN where free), ``free`` with the free cables first; returns
    whether strict complementarity fails, and the number of free cables."""
    nfree, bad = 0, False
    for i in range(T.size):
        x = T[i] / s
        near_lo, near_hi = x - lb[i] / s <= ACTIVE_TOL, ub[i] / s - x <= ACTIVE_TOL
        lo = near_lo and z[i] < -MULTIPLIER_TOL
        hi = near_hi and z[i] > MULTIPLIER_TOL and not lo
        active = lo or hi
        strong = abs(z[i]) > MULTIPLIER_TOL
        if (near_lo and near_hi) or ((near_lo or near_hi or strong) and not active):
            bad = True
        bound[i] = lb[i] if lo else (ub[i] if hi else np.nan)
        if not active:
            free[nfree] = i
            nfree += 1
    if (T.size | z.size | lb.size | ub.size | free.size | bound.size) < 0:
        bad = True  # never: the arrays read after the branches
    return bad, nfree


@njit(cache=True, error_model="numpy", inline="always")
def _reduced(A: NDArray, rows: NDArray, iq: NDArray, free: NDArray, nfree: int,
             linear: bool, Mf: NDArray, Minv: NDArray) -> float:
    """The reduced matrix (``Ar_F``, square, or ``S``) inverted into ``Minv``; its 1-norm
    condition number (inf where the active set cannot fix a point)."""
    n = Mf.shape[0]
    cond = np.inf
    if linear and nfree == n:
        for k in range(n):
            for col in range(n):
                Mf[k, col] = rows[k] * A[k, free[col]]
        cond = _invert(Mf, Minv, n)
    elif not linear and nfree >= n:  # S is symmetric: its upper triangle, mirrored
        for k in range(n):
            for col in range(k, n):
                total = 0.0
                for a in range(nfree):
                    i = free[a]
                    total += A[k, i] * A[col, i] * iq[i]
                Mf[k, col] = Mf[col, k] = rows[k] * rows[col] * total
        cond = _invert(Mf, Minv, n)
    if (A.size | rows.size | iq.size | free.size | Mf.size | Minv.size) < 0:
        cond = np.nan  # never: the arrays read after the branches
    return cond


@njit(cache=True, error_model="numpy", inline="always")
def _kkt_point(A: NDArray, b: NDArray, rows: NDArray, iq: NDArray, c: NDArray, lb: NDArray,
               T: NDArray, s: float, free: NDArray, nfree: int, bound: NDArray,
               linear: bool, Minv: NDArray, y: NDArray, g: NDArray, x: NDArray
               ) -> tuple[bool, bool]:
    """The KKT point of the active set: ``y`` (over the row-scaled equations) written;
    returns whether an active bound's multiplier has the wrong sign, and whether the
    point is not the solution ``T`` (beyond ten times :data:`ACTIVE_TOL`)."""
    n, m = A.shape
    for k in range(n):
        total = b[k]
        for i in range(m):
            if bound[i] == bound[i]:
                total -= A[k, i] * bound[i]
        g[k] = rows[k] * total
    if linear:  # Ar_F' y = -c_F
        for k in range(n):
            total = 0.0
            for a in range(n):
                total -= Minv[a, k] * c[free[a]]
            y[k] = total
    _reduced_solve(A, rows, iq, free, nfree, linear, Minv, g, c, y, x)
    moved = False
    for a in range(nfree):
        if not abs(x[a] - T[free[a]]) / s <= 10 * ACTIVE_TOL:
            moved = True
    signs = False
    for i in range(m):
        if bound[i] == bound[i]:
            zi = bound[i] / iq[i] + c[i]  # q_i bound_i (iq infinite: q zero)
            for k in range(n):
                zi += rows[k] * A[k, i] * y[k]
            zi = -zi
            if (bound[i] == lb[i] and not zi < 0.0) or (bound[i] != lb[i] and not zi > 0.0):
                signs = True
    if (A.size | b.size | rows.size | iq.size | c.size | lb.size | T.size | free.size
            | bound.size | Minv.size | y.size | g.size | x.size) < 0:
        signs = True  # never: the arrays read after the branches
    return signs, moved


@njit(cache=True, error_model="numpy", inline="always")
def _reduced_solve(A: NDArray, rows: NDArray, iq: NDArray, free: NDArray, nfree: int,
                   linear: bool, Minv: NDArray, g: NDArray, e: NDArray, y: NDArray,
                   x: NDArray) -> None:
    """The free tensions ``x`` (``nfree``) of the reduced KKT system whose equations'
    right-hand side is ``g`` (n, row-scaled; overwritten) and whose stationarity's is
    ``-e`` (m): ``x = Ar_F^-1 g`` (linear), else ``S y = -(g + Ar_F Q^-1 e)`` and
    ``x = -Q^-1 (e + Ar_F' y)`` with ``y`` written."""
    n = Minv.shape[0]
    if linear:
        for a in range(n):
            total = 0.0
            for k in range(n):
                total += Minv[a, k] * g[k]
            x[a] = total
    else:
        for k in range(n):
            for a in range(nfree):
                i = free[a]
                g[k] += rows[k] * A[k, i] * e[i] * iq[i]
        for k in range(n):
            total = 0.0
            for col in range(n):
                total -= Minv[k, col] * g[col]
            y[k] = total
        for a in range(nfree):
            i = free[a]
            total = e[i]
            for k in range(n):
                total += rows[k] * A[k, i] * y[k]
            x[a] = -total * iq[i]
    if (A.size | rows.size | iq.size | free.size | Minv.size | g.size | e.size | y.size
            | x.size) < 0:
        x[0] = np.nan  # never: the arrays read after the branches


@njit(cache=True, nogil=True, error_model="numpy")
def _loop(data: NDArray, views: tuple[NDArray, ...], poses: NDArray, wrenches: NDArray,
          T: NDArray, z: NDArray, ym: NDArray, solved: NDArray, unique: NDArray, wrt: int,
          J: NDArray, codes: NDArray, free: NDArray, work: tuple[NDArray, ...]) -> None:
    """The loop of :func:`jacobian_poses` over its poses (``views`` of ``data`` and the
    work arrays as arguments: as the certified pass's loop)."""
    pose, wrench, b, rows, y, yu, g, dy, bound, e, x, Tp, zp, iq, A, dAy, Jp, Mf, Minv, \
        dAT, db = work
    anchors, attachments, com, q, c, lb, ub = views
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    inverted(q, iq)
    for i in range(n):
        wrench[i] = wrenches[0, i]
    for p in range(poses.shape[0]):
        for i in range(n):
            pose[i] = poses[p, i]
            if wrenches.shape[0] > 1:
                wrench[i] = wrenches[p, i]
        for i in range(m):
            Tp[i], zp[i] = T[p, i], z[p, i]  # copies: a view per pose costs more
        status = _NOT_OPTIMAL
        if solved[p] and finite(Tp, zp, ym[p]) and geometry_into(
                kind, anchors, attachments, com, data[3], data[4], pose, wrench, A,
                b) == GEOMETRY_OK:
            status = pose_jacobian(kind, data[3], anchors, attachments, com, pose, A, b, iq, c,
                                   lb, ub, Tp, zp, wrt, rows, free, bound, Mf, Minv, y, yu,
                                   dAT, dAy, db, g, e, dy, x, Jp)
            if not unique[p]:
                status = _NON_UNIQUE
        codes[p] = status
        for i in range(m):
            for j in range(J.shape[2]):
                J[p, i, j] = Jp[i, j] if status == _OK else np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def jacobian_one(data: NDArray, pose: NDArray, T: NDArray, work: NDArray, offset: int,
                 unique: bool, wrt: int, J: NDArray, floats: NDArray, free: NDArray) -> int:
    """:func:`jacobian_poses` of one pose the real-time kernel
    (:func:`tension_opt.kernels.distributor.certified_one`) solved optimal, from what it
    leaves in its work array ``work``: the pose's form (``A, b, q, c, lb, ub`` at its
    start) and the bound multipliers at ``offset``
    (:func:`tension_opt.kernels.distributor.multipliers_offset`). ``T`` (m,): its
    tensions; ``J`` (m, n), or (m, m) by a bound, written; ``floats``
    (:func:`work_floats`) and ``free`` (m, int64): this thread's work. Returns the
    status code (:data:`NON_UNIQUE` where the optimum is not ``unique``)."""
    m, n = int(data[1]), int(data[2])
    _, _, _, rows, y, yu, g, dy, bound, e, x, _, _, iq, _, dAy, _, Mf, Minv, dAT, db = _carve(
        floats.ctypes.data, m, n)
    # The pose's form where certified_one left it (distributor._views' layout), and the
    # robot's points in data, as views owning nothing.
    w, o = work.ctypes.data, n * m + n
    A, b = matrix_at(w, 0, n, m), vector_at(w, n * m, n)
    q, c, lb, ub = (vector_at(w, o, m), vector_at(w, o + m, m), vector_at(w, o + 2 * m, m),
                    vector_at(w, o + 3 * m, m))
    anchors, attachments, com = _problem_at(data.ctypes.data, m)[:3]
    # The caller's arrays as views owning nothing too: no reference counts in the call.
    status = pose_jacobian(int(data[0]), data[3], anchors, attachments, com,
                           vector_at(pose.ctypes.data, 0, n), A, b, inverted(q, iq), c, lb, ub,
                           vector_at(T.ctypes.data, 0, m), vector_at(w, offset, m), wrt, rows,
                           free, bound, Mf, Minv, y, yu, dAT, dAy, db, g, e, dy, x,
                           matrix_at(J.ctypes.data, 0, m, J.shape[1]))
    if not unique:
        status = _NON_UNIQUE
    if status != _OK:
        for i in range(m):
            for j in range(J.shape[1]):
                J[i, j] = np.nan
    if (data.size | work.size | floats.size | pose.size | T.size | J.size) < 0:
        status = -1  # never: the buffers read after their views' last use (they own nothing)
    return status


@njit(cache=True, nogil=True, error_model="numpy")
def pose_jacobian(kind: int, weight: float, anchors: NDArray, attachments: NDArray,
                  com: NDArray, pose: NDArray, A: NDArray, b: NDArray, iq: NDArray, c: NDArray,
                  lb: NDArray, ub: NDArray, T: NDArray, z: NDArray, wrt: int, rows: NDArray,
                  free: NDArray, bound: NDArray, Mf: NDArray, Minv: NDArray, y: NDArray,
                  yu: NDArray, dAT: NDArray, dAy: NDArray, db: NDArray, g: NDArray,
                  e: NDArray, dy: NDArray, x: NDArray, Jp: NDArray) -> int:
    """The Jacobian ``Jp`` (m, n; (m, m) by a bound) of one pose (written where the
    status is ``"ok"``) and
    its status code, from the robot's data, the pose's form (``A, b, c, lb, ub``, and ``iq``
    one over the Hessian's entries, infinite where zero), its
    optimal tensions ``T`` and scaled bound multipliers ``z``; ``rows`` to ``x``: work
    (:func:`_carve`). One compiled function, called by the batch's loop and by the
    one-pose kernel alike (inlined into both, it doubled their compile time at no
    measured gain); at most 30 arguments, which CPython passes one by one."""
    n, m = A.shape
    linear = True
    for i in range(m):
        linear = linear and iq[i] == np.inf
    # The reference tension depends on A, b and the bounds only (iq stands in for q,
    # whose only use there is a scale this kernel does not read).
    s = pose_scaling(A, b, lb, ub, iq, c, 0.0, UB_SHARE, ROW_FLOOR, rows)[0]
    bad, nfree = _active(T, z, lb, ub, s, free, bound)
    cond = _reduced(A, rows, iq, free, nfree, linear, Mf, Minv)
    status = _DEGENERATE if bad else _OK
    if not cond <= COND_MAX:
        status = _NON_UNIQUE if linear and nfree > n else _DEGENERATE
    else:
        signs, moved = _kkt_point(A, b, rows, iq, c, lb, T, s, free, nfree, bound, linear,
                                  Minv, y, g, x)
        if signs:
            status = _DEGENERATE
        elif status == _OK and moved:
            status = _NOT_OPTIMAL
    if status == _OK:
        for k in range(n):
            yu[k] = rows[k] * y[k]
        if wrt == POSE:
            pose_terms(kind, anchors, attachments, com, weight, pose, T, yu, dAT, dAy, db)
        _derivative(A, rows, iq, free, nfree, linear, Minv, wrt, dAT, dAy, db, g, e, dy, x,
                    Jp, lb, bound, T, yu, (kind, anchors, attachments, pose))
    if (anchors.size | attachments.size | com.size | pose.size | A.size
            | b.size | iq.size | c.size | lb.size | ub.size | T.size | z.size | rows.size
            | free.size | bound.size | Mf.size | Minv.size | y.size | yu.size | dAT.size
            | dAy.size | db.size | g.size | e.size | dy.size | x.size | Jp.size) < 0:
        status = -1  # never: the arrays read after the branches
    return status


@njit(cache=True, error_model="numpy", inline="always")
def _derivative(A: NDArray, rows: NDArray, iq: NDArray, free: NDArray, nfree: int,
                linear: bool, Minv: NDArray, wrt: int, dAT: NDArray, dAy: NDArray,
                db: NDArray, g: NDArray, e: NDArray, dy: NDArray, x: NDArray, Jp: NDArray,
                lb: NDArray, bound: NDArray, T: NDArray, yu: NDArray, robot: tuple) -> None:
    """``Jp`` (m, :func:`columns`) of one pose from its reduced inverse, column by column
    (``bound``: the active bound's value per cable, NaN where free; ``yu``: the row-scaled
    multipliers; ``robot``: kind, anchors, attachments and the pose, for the points)."""
    n, m = A.shape
    what = wrt & ~MOVES_TARGET
    bounds, points = T_MIN <= what <= T_MAX, what >= DRAWING_POINTS
    kind, anchors, attachments, pose = robot
    R = rotation(kind, pose)
    dcol = dAT[0]  # scratch (n,): dAT is the pose's alone
    for j in range(columns(wrt, m, n)):
        # A bound moves its cable where it is the active one (its side: lb or not).
        moved = 0.0
        if bounds and bound[j] == bound[j]:
            moved = 1.0 if (bound[j] == lb[j]) == (what == T_MIN) else 0.0
        if points:  # column j // 3 moves with its point's coordinate j % 3
            point_column(kind, anchors, attachments, pose, R, j // 3, j % 3,
                         what == ATTACHMENT_POINTS, dcol)
        for k in range(n):
            if what == POSE:
                g[k] = rows[k] * (db[k, j] - dAT[k, j])
            elif what == WRENCH:
                g[k] = -rows[k] if k == j else 0.0
            elif bounds:
                g[k] = -rows[k] * A[k, j] * moved
            else:
                g[k] = -rows[k] * dcol[k] * T[j // 3]
        for i in range(m):
            e[i] = dAy[i, j] if what == POSE else 0.0  # r = dA' y
        if points:
            total = 0.0
            for k in range(n):
                total += dcol[k] * yu[k]
            e[j // 3] = total
        if wrt & MOVES_TARGET:  # the centred cost -q (lb + ub) / 2 of cable j
            e[j] = -0.5 / iq[j]
        _reduced_solve(A, rows, iq, free, nfree, linear, Minv, g, e, dy, x)
        for i in range(m):
            Jp[i, j] = 0.0
        for a in range(nfree):
            Jp[free[a], j] = x[a]
        if moved:
            Jp[j, j] = 1.0
    if (A.size | rows.size | iq.size | free.size | Minv.size | dAT.size | dAy.size | db.size
            | g.size | e.size | dy.size | x.size | Jp.size | lb.size | bound.size | T.size
            | yu.size | anchors.size | attachments.size | pose.size) < 0:
        Jp[0, 0] = np.nan  # never: the arrays read after the branches
