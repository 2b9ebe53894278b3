"""The certified closed form of a four-cable point robot, poses side by side.

:func:`tension_opt.kernels.certified.certified_poses` runs its steps pose by pose; for
the commonest redundant robot (a point platform on four cables: three equations, a
null space of dimension 1) and an objective without a min-max term, :func:`lane_poses`
runs the same steps (:mod:`tension_opt.kernels.certified_lane_steps`) on :data:`LANES` poses at
once, so that the compiler puts one pose in each lane of the vector unit, and writes
the results as the pose-by-pose loop writes them, to the last bit (tests compare them).

A pose that leaves the common path (a cable on its drawing point, data beyond the
float range, a null vector with a zero entry, a pose within the slack of
infeasibility, a certificate that needs the sign-constrained refit, a singular fit)
is marked :data:`REDO`: the caller solves it pose by pose. An infeasible pose is
finished here, its distance to feasibility by
:func:`~tension_opt.kernels.closed_form.point4_distance`, pose by pose as well.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.certified_lane_steps import (
    F_CODE,
    F_DUAL,
    F_GAP,
    F_GOOD,
    F_INFEASIBLE,
    F_N,
    F_OVER,
    F_PRIMAL,
    F_RES,
    F_T,
    F_TP,
    F_UNIQUE,
    F_VALUE,
    F_Y,
    F_Z,
    FIELDS,
    LANES,
    REDO,
    at,
    certify_step,
    estimate_step,
    fmax,
    fmin,
    geometry_step,
    load_block,
    measure_step,
    point4_step,
    turned,
)
from tension_opt.kernels.closed_form import plain, point4_distance

__all__ = ["LANES", "REDO", "lane_poses"]

@njit(cache=True, error_model="numpy")
def _constants(data: NDArray, views: tuple) -> tuple:
    """What the blocks read of the problem, as numbers (tuples the compiler keeps in
    registers): anchors, turned attachment points, ``lb, ub, q, c, w, r``, the scaled
    ``P = q / top`` and ``c / top`` (``pose_scaling``'s ``top``), ``(plain data,
    quadratic)`` and ``(weight, zero length, tolerance factor, largest finite lower
    and upper bound)``."""
    anchors_v, attachments_v, _, qv, cv, _, lbv, ubv, wv, rv = views
    anchors = ((anchors_v[0, 0], anchors_v[0, 1], anchors_v[0, 2]),
               (anchors_v[1, 0], anchors_v[1, 1], anchors_v[1, 2]),
               (anchors_v[2, 0], anchors_v[2, 1], anchors_v[2, 2]),
               (anchors_v[3, 0], anchors_v[3, 1], anchors_v[3, 2]))
    offs = (turned(attachments_v, 0), turned(attachments_v, 1), turned(attachments_v, 2),
            turned(attachments_v, 3))
    lb = (lbv[0], lbv[1], lbv[2], lbv[3])
    ub = (ubv[0], ubv[1], ubv[2], ubv[3])
    q = (qv[0], qv[1], qv[2], qv[3])
    c = (cv[0], cv[1], cv[2], cv[3])
    w = (wv[0], wv[1], wv[2], wv[3])
    r = (rv[0], rv[1], rv[2], rv[3])
    # closed_form.plain's test of the per-cable data (the pose's are the blocks')
    plain_data = plain(np.empty((0, 4)), np.empty(0), lbv, ubv, qv, cv)
    quadratic = False
    top_lb = top_ub = big_q = big_c = 0.0
    for i in range(4):
        quadratic = quadratic or q[i] != 0.0
        if math.isfinite(lb[i]):
            top_lb = fmax(top_lb, abs(lb[i]))
        if math.isfinite(ub[i]):
            top_ub = fmax(top_ub, abs(ub[i]))
        big_q = fmax(big_q, q[i])
        big_c = fmax(big_c, abs(c[i]))
    top = big_q if big_q > 0.0 else (big_c if big_c > 0.0 else 1.0)  # pose_scaling's
    P = (q[0] / top, q[1] / top, q[2] / top, q[3] / top)
    ct = (c[0] / top, c[1] / top, c[2] / top, c[3] / top)
    return (anchors, offs, lb, ub, q, c, w, r, P, ct, (plain_data, quadratic),
            (data[3], data[4], data[6], top_lb, top_ub))


@njit(cache=True, error_model="numpy")
def _nan_row(p: int, rows_out: tuple, measured: tuple) -> None:
    """NaN tensions, multipliers and measures of pose ``p`` (no solution)."""
    T, y, _, z = rows_out
    for i in range(4):
        T[p, i] = z[p, i] = np.nan
    for j in range(3):
        y[p, j] = np.nan
    objective, residual, violation, _, primal, dual, gap = measured
    objective[p] = residual[p] = violation[p] = np.nan
    primal[p] = dual[p] = gap[p] = np.nan


@njit(cache=True, nogil=True, error_model="numpy")
def lane_poses(data: NDArray, views: tuple[NDArray, ...], target: float, code: int,
               poses: NDArray, wrenches: NDArray,
               rows_out: tuple[NDArray, NDArray, NDArray, NDArray],
               flags_out: tuple[NDArray, NDArray],
               measured: tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray,
                               NDArray], ridge: float, ub_share: float,
               row_floor: float) -> int:
    """The certified closed form of a four-cable point robot's poses, :data:`LANES` at
    a time, written as :func:`~tension_opt.kernels.certified.certified_poses` writes
    them; a pose left to the caller gets the code :data:`REDO` (its other results
    unwritten). A hot numerical kernel: the steps of a block, then its results
    written pose by pose.

    Parameters
    ----------
    data, views : ndarray, tuple
        The packed problem and its views, as in
        :func:`~tension_opt.kernels.certified.certified_poses` (a point robot of four
        cables, no min-max term).
    target : float
        Accuracy target of the certificate.
    code : int
        How the objective is evaluated (0 ``sum w T``, 2 ``sum w (T - r)^2``).
    poses : ndarray, shape (N, 3)
    wrenches : ndarray, shape (N, 3) or (1, 3)
    rows_out, flags_out, measured : tuple
        The output arrays of ``certified_poses``.
    ridge, ub_share, row_floor : float
        :data:`tension_opt.certify.certificate.RIDGE`, :data:`tension_opt.problem.form.UB_SHARE`,
        :data:`tension_opt.problem.form.ROW_FLOOR`.

    Returns
    -------
    int
        Poses marked :data:`REDO`.
    """
    T, y, _, z = rows_out
    codes, unique = flags_out
    objective, residual, violation, infeasibility, primal, dual, gap = measured
    lbv, ubv = views[6], views[7]
    anchors, offs, lb, ub, q, c, w, r, P, ct, flags, numbers = _constants(data, views)
    plain_data, quadratic = flags
    weight, zero_length, tol_factor, top_lb, top_ub = numbers
    # The work array on a cache line's start (64 bytes): no vector read of a field
    # spans two lines.
    room = np.empty(FIELDS * LANES + 8)
    skip = (-room.ctypes.data % 64) // 8
    S = room[skip:skip + FIELDS * LANES]
    # An infeasible pose's line where point4 leaves it (particular solution at 9, null
    # vector at 13), and point4_distance's work after it.
    line = np.empty(33)
    N = poses.shape[0]
    redo = 0
    for start in range(0, N, LANES):
        load_block(S, poses, wrenches, start)
        geometry_step(S, anchors, offs, weight, zero_length)
        point4_step(S, lb, ub, q, c, quadratic, top_lb)
        measure_step(S, lb, ub, ct, w, r, code == 0, quadratic, top_lb,
                     top_ub, ub_share, row_floor, tol_factor)
        estimate_step(S, P, ridge)
        certify_step(S, P, target)
        for lane in range(fmin(LANES, N - start)):
            p = start + lane
            if not (plain_data and S[at(F_GOOD, lane)] != 0.0):
                codes[p] = REDO
                redo += 1
            elif S[at(F_INFEASIBLE, lane)] != 0.0:
                for i in range(4):
                    line[9 + i], line[13 + i] = S[at(F_TP + i, lane)], S[at(F_N + i, lane)]
                distance = point4_distance(lbv, ubv, line)
                _nan_row(p, rows_out, measured)
                unique[p], infeasibility[p] = True, distance
                codes[p] = 1
                if math.isnan(distance):  # status "optimal" without tensions: redo
                    codes[p] = REDO
                    redo += 1
            elif S[at(F_CODE, lane)] == float(REDO):
                codes[p] = REDO
                redo += 1
            else:
                for i in range(4):
                    T[p, i] = S[at(F_T + i, lane)]
                    z[p, i] = S[at(F_Z + i, lane)]
                for j in range(3):
                    y[p, j] = S[at(F_Y + j, lane)]
                codes[p] = int(S[at(F_CODE, lane)])
                unique[p] = S[at(F_UNIQUE, lane)] != 0.0
                infeasibility[p] = np.nan
                objective[p], residual[p], violation[p] = (
                    S[at(F_VALUE, lane)], S[at(F_RES, lane)], S[at(F_OVER, lane)])
                primal[p], dual[p], gap[p] = (S[at(F_PRIMAL, lane)], S[at(F_DUAL, lane)],
                                              S[at(F_GAP, lane)])
    return redo
