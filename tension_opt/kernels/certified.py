"""The certified closed form of independent poses, compiled: per pose, geometry, the
exact closed form, and everything
:meth:`tension_opt.distribution.solution.TensionSolution.from_form`
measures of it, written straight into the arrays of a whole batch.

The reference is the path of the plain :func:`tension_opt.distribute` on the compiled
closed form: :meth:`tension_opt.robot.CableRobot.equilibrium`, the problem's
:class:`~tension_opt.problem.form.StandardForm`,
:meth:`tension_opt.backends.closed_form.ClosedFormBackend.solve` and
:meth:`TensionSolution.from_form <tension_opt.distribution.solution.TensionSolution.from_form>` (the
objective, equilibrium residual, bound violation, the certificate on
:func:`tension_opt.certify.scaling.scaled_batch` with multipliers from the cheap dual solve, and
the status judged by both). Each step is the one-pose function the batch kernels of
that step run (:func:`~tension_opt.kernels.geometry.geometry_into`,
:func:`~tension_opt.kernels.closed_form.form_pose` (its steps),
:func:`~tension_opt.kernels.scaling.pose_scaled`,
:func:`~tension_opt.kernels.certificate.pose_estimate`,
:func:`~tension_opt.kernels.certificate.pose_measures`), so the answers agree to rounding.

A pose whose cheap dual solve leaves it uncertified though its tensions are primal
feasible gets the sign-constrained refit of :func:`tension_opt.certify.certificate.certify`
here too (:func:`tension_opt.kernels.refit.pose_refit`). A pose the kernel does not
settle gets a code for the caller to solve it by that path: :data:`CODE_FALLBACK` (a
pose the closed-form kernel hands to the numpy path, or whose refit is singular) or
:data:`CODE_GEOMETRY` (a cable on its drawing point, lengths or wrench beyond the float
range: the path raises the package's error for these).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels.certificate import pose_estimate, pose_measures
from tension_opt.kernels.certified_lanes import REDO, lane_poses
from tension_opt.kernels.closed_form import (
    CODE_FALLBACK,
    HEADER,
    plain,
    point4,
    point4_distance,
    pose_scales,
    solve_form,
    work_size,
)
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into
from tension_opt.kernels.refit import pose_refit, refit_work_size
from tension_opt.kernels.scaling import pose_scaled, safe_norm_of
from tension_opt.status import STATUS_TABLE
from tension_opt.tolerances import FEASIBILITY_TOL, RIDGE, ROW_FLOOR, UB_SHARE

__all__ = ["CODE_FALLBACK", "CODE_GEOMETRY", "DISTANCE", "LINEAR", "MAX", "STATUS_VALUES",
           "certified_poses", "problem_views"]

#: Code of a pose whose geometry the kernel flags (see the module docstring).
CODE_GEOMETRY = 8
#: Status values of the kernel's codes 0-3 (optimal, infeasible, unbounded, inaccurate).
STATUS_VALUES = STATUS_TABLE[:4]
#: How the objective is evaluated (:meth:`tension_opt.problem.form.TensionProblem.evaluate`):
#: ``sum_i w_i T_i``, ``max_i w_i T_i``, ``sum_i (T_i - r_i)^2 w_i``.
LINEAR, MAX, DISTANCE = 0, 1, 2


@njit(cache=True, error_model="numpy", inline="always")
def _measured(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, T: NDArray, code: int,
              w: NDArray, r: NDArray, work: NDArray) -> tuple[float, float, float]:
    """Equilibrium residual ``||A T - b||`` (N, N m), bound violation (N) and objective
    of finite tensions ``T`` (``StandardForm.equilibrium_residual``,
    ``bound_violation``, ``objective_value``); ``work`` (n,) floats."""
    n, m = A.shape
    total = 0.0
    for k in range(n):
        e = -b[k]
        for i in range(m):
            e += A[k, i] * T[i]
        work[k] = e
        total += e * e
    residual = math.sqrt(total)
    if not math.isfinite(residual):  # squares beyond the float range: measured rescaled
        residual = safe_norm_of(work)
    violation = 0.0
    value = -np.inf if code == MAX else 0.0
    for i in range(m):
        violation = max(violation, max(lb[i] - T[i], T[i] - ub[i]))
        if code == LINEAR:
            value += T[i] * w[i]
        elif code == MAX:
            value = max(value, T[i] * w[i])
        else:
            d = T[i] - r[i]
            value += d * d * w[i]
    if (A.size | b.size | lb.size | ub.size | T.size | w.size | r.size | work.size) < 0:
        value = np.nan  # never: the arrays read once more (see tension_opt.kernels)
    return residual, violation, value


@njit(cache=True, error_model="numpy", inline="always")
def _lifted(T: NDArray, s: float, G: NDArray, x: NDArray) -> bool:
    """Scaled variables ``x`` of tensions ``T`` (``ScaledBatch.lift``; the epigraph
    variable of a min-max term the smallest that holds, its weights the diagonal of
    ``G``); False where they are not finite."""
    m = T.size
    finite = True
    for i in range(m):
        x[i] = T[i] / s
        finite = finite and math.isfinite(x[i])
    if x.size > m:
        top = -np.inf
        for i in range(m):
            top = max(top, x[i] * G[i, i])
        x[m] = top
    return finite


@njit(cache=True, error_model="numpy", inline="always")
def _put(T: NDArray, y: NDArray, mu: NDArray, z: NDArray, p: int, Tw: NDArray,
         yw: NDArray, muw: NDArray, zw: NDArray, solved: bool) -> None:
    """Row ``p`` of the batch's tensions and multipliers: the pose's (``solved``), else
    NaN."""
    for i in range(T.shape[1]):
        T[p, i] = Tw[i] if solved else np.nan
    for j in range(y.shape[1]):
        y[p, j] = yw[j] if solved else np.nan
    for j in range(mu.shape[1]):
        mu[p, j] = muw[j] if solved else np.nan
    for i in range(z.shape[1]):
        z[p, i] = zw[i] if solved else np.nan


@njit(cache=True, error_model="numpy", inline="always")
def _in_cones(lbs: NDArray, ubs: NDArray, mu: NDArray, z: NDArray) -> None:
    """``mu >= 0``; ``z_i >= 0`` only with a finite upper bound, ``<= 0`` only with a
    finite lower one (NaN kept, as numpy's ``maximum`` and ``clip``)."""
    for j in range(mu.size):
        if mu[j] < 0.0:
            mu[j] = 0.0
    for i in range(z.size):
        if z[i] < 0.0 and not math.isfinite(lbs[i]):
            z[i] = 0.0
        elif z[i] > 0.0 and not math.isfinite(ubs[i]):
            z[i] = 0.0


@njit(cache=True, error_model="numpy")
def problem_views(data: NDArray) -> tuple[NDArray, ...]:
    """Views of :func:`pack_certified`'s array: anchors and attachments (m, 3), centre
    of mass (3,), ``q, c, v, lb, ub`` and the objective's ``w`` and ``r`` (m,)."""
    m = int(data[1])
    terms = data[HEADER + 6 * m:HEADER + 12 * m].reshape((6, m))
    o = HEADER + 12 * m
    return (data[HEADER:HEADER + 3 * m].reshape((m, 3)),
            data[HEADER + 3 * m:HEADER + 6 * m].reshape((m, 3)), data[8:HEADER], terms[0],
            terms[1], terms[2], terms[3], terms[4], data[o + 3:o + 3 + m],
            data[o + 3 + m:o + 3 + 2 * m])


@njit(cache=True, nogil=True, error_model="numpy")
def certified_poses(data: NDArray, poses: NDArray, wrenches: NDArray, T: NDArray,
                    codes: NDArray, unique: NDArray, objective: NDArray, residual: NDArray,
                    violation: NDArray, infeasibility: NDArray, primal: NDArray,
                    dual: NDArray, gap: NDArray, y: NDArray, mu: NDArray, z: NDArray,
                    side_by_side: bool = True) -> int:
    """Geometry, closed form, diagnostics and certificate of independent poses.

    The steps of each pose run in one pass (:func:`_poses`) on work arrays allocated
    once per call, so that nothing per pose leaves the caches but its results. A point
    robot on four cables without a min-max term runs them on blocks of poses side by
    side (:func:`tension_opt.kernels.certified_lanes.lane_poses`, the same answers to the last
    bit, about 5x faster), the poses it leaves pose by pose.

    Parameters
    ----------
    data : ndarray
        :func:`pack_certified`.
    poses : ndarray, shape (N, n)
    wrenches : ndarray, shape (N, n) or (1, n)
        External wrench besides gravity (N, N m), per pose or one for all.
    T : ndarray, shape (N, m)
        Tensions (N), written (NaN where there is no solution).
    codes : ndarray of int8, shape (N,)
        Written: 0-3 the status (:data:`STATUS_VALUES`), or :data:`CODE_FALLBACK`,
        :data:`CODE_GEOMETRY` for a pose the caller solves otherwise (whose other
        results are left unwritten).
    unique, objective, residual, violation, infeasibility, primal, dual, gap : ndarray
        Shape (N,), written: the fields of a
        :class:`~tension_opt.distribution.solution.TensionSolution` (NaN where unknown).
    y, mu, z : ndarray, shapes (N, n), (N, g), (N, k)
        The certificate's multipliers (in their cones), written.
    side_by_side : bool
        False: every pose by :func:`_poses` (the reference the tests compare the
        blocks with).

    Returns
    -------
    int
        Poses left to the caller.
    """
    m, n = int(data[1]), int(data[2])
    k, g = z.shape[1], mu.shape[1]
    # Work arrays, made once and handed to the loop as arguments (the loop then takes no
    # new reference to any array: see tension_opt.kernels).
    work = (np.empty(n), np.empty(n), np.empty((n, m)), np.empty(n), np.empty(n),
            np.empty(m), np.empty(work_size(m, n)), np.empty(n), np.empty(k), np.empty(k),
            np.empty((n, k)), np.empty(n), np.empty((g, k)), np.empty(g), np.empty(k),
            np.empty(k), np.empty(k), np.empty(n), np.empty(g), np.empty(k),
            np.empty((k, n + g)), np.empty((n + g, n + g)), np.empty(n + g), np.empty(k),
            np.empty(k), np.empty(k), np.empty(refit_work_size(n, g, k)))
    views = problem_views(data)
    rows_out, flags_out = (T, y, mu, z), (codes, unique)
    measured = (objective, residual, violation, infeasibility, primal, dual, gap)
    if not (side_by_side and int(data[0]) == 0 and m == 4 and n == 3 and data[7] == 0.0):
        return _poses(data, views, poses, wrenches, rows_out, flags_out, measured, work)
    # A point robot on four cables, no min-max term: blocks of poses side by side, the
    # poses they leave pose by pose.
    o = HEADER + 12 * m
    if not lane_poses(data, views, data[o], int(data[o + 1]), poses, wrenches, rows_out,
                      flags_out, measured, RIDGE, UB_SHARE, ROW_FLOOR):
        return 0
    left = 0
    for p in range(poses.shape[0]):
        if codes[p] == REDO:
            left += _poses(data, views, poses[p:p + 1],
                           wrenches[p:p + 1] if wrenches.shape[0] > 1 else wrenches, (
                               T[p:p + 1], y[p:p + 1], mu[p:p + 1], z[p:p + 1]),
                           (codes[p:p + 1], unique[p:p + 1]),
                           (objective[p:p + 1], residual[p:p + 1], violation[p:p + 1],
                            infeasibility[p:p + 1], primal[p:p + 1], dual[p:p + 1],
                            gap[p:p + 1]), work)
    return left


@njit(cache=True, nogil=True, error_model="numpy")
def _poses(data: NDArray, views: tuple[NDArray, ...], poses: NDArray, wrenches: NDArray,
           rows_out: tuple[NDArray, NDArray, NDArray, NDArray],
           flags_out: tuple[NDArray, NDArray],
           measured: tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray, NDArray],
           work: tuple[NDArray, ...]) -> int:
    """The loop of :func:`certified_poses` over its poses: ``views`` of ``data``
    (anchors, attachments, centre of mass, ``q, c, v, lb, ub``, the objective's ``w``
    and ``r``) and the work arrays come as arguments (numba's references to arrays made
    here would be counted at every inlined step that reads them).

    A hot numerical kernel: each pose's steps in one pass, on work arrays allocated
    once, writing only its results.
    """
    T, y, mu, z = rows_out
    codes, unique = flags_out
    objective, residual, violation, infeasibility, primal, dual, gap = measured
    pose, wrench, A, b, e, Tw, rest, rows, P, cs, Aeq, beq, G, h, lbs, ubs, x, yw, muw, \
        zw, B, H, u, grad, shrink, station, refit = work
    anchors, attachments, com, q, c, v, lb, ub, w, r = views
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    o = HEADER + 12 * m
    target, code, vmax = data[o], int(data[o + 1]), data[o + 2]
    minmax, tol_factor = data[7] != 0.0, data[6]
    quadratic = False
    for i in range(m):
        quadratic = quadratic or q[i] != 0.0
    four = n == 3 and m == 4 and not minmax  # form_pose's shortcut
    for i in range(n):
        wrench[i] = wrenches[0, i]
    left, again = 0, False
    for p in range(poses.shape[0]):
        for i in range(n):
            pose[i] = poses[p, i]
            if wrenches.shape[0] > 1:
                wrench[i] = wrenches[p, i]
        if geometry_into(kind, anchors, attachments, com, data[3], data[4], pose, wrench,
                         A, b) != GEOMETRY_OK:
            codes[p], left = CODE_GEOMETRY, left + 1
            continue
        # form_pose, its calls made here, out of the inlined steps (a call inside one
        # keeps the reference counts of its arrays: see tension_opt.kernels).
        status, once, infeas, settled, off = CODE_FALLBACK, True, np.nan, False, False
        ok = plain(A, b, lb, ub, q, c)
        if ok and four:
            settled, once, off = point4(A, b, lb, ub, q, c, quadratic, Tw, rest)
        if off:
            infeas = point4_distance(lb, ub, rest)
        if settled:
            status = 0 if math.isnan(infeas) else 1
        elif ok:
            status, once, _, infeas = solve_form(A, b, lb, ub, q, c, v, minmax,
                                                 FEASIBILITY_TOL, Tw, rest)
        solved = status == 0 or status == 3
        for i in range(m):  # a "solution" that is not finite goes to the caller
            if solved and not math.isfinite(Tw[i]):
                status = CODE_FALLBACK
        if status > 3:
            codes[p], left = CODE_FALLBACK, left + 1
            continue
        unique[p], infeasibility[p] = once, infeas
        if not solved:  # infeasible or unbounded: no tensions, nothing to measure
            _put(T, y, mu, z, p, Tw, yw, muw, zw, False)
            objective[p] = residual[p] = violation[p] = np.nan
            primal[p] = dual[p] = gap[p] = np.nan
            codes[p] = status
            continue
        res, over, value = _measured(A, b, lb, ub, Tw, code, w, r, e)
        # The certificate (certify_form): the pose's scaled problem, its multipliers by
        # the cheap dual solve, the three measures.
        s = pose_scaled(A, b, lb, ub, q, c, v, vmax, UB_SHARE, ROW_FLOOR, rows, P, cs, Aeq,
                        beq, G, h, lbs, ubs, again)
        again = True  # every pose has the same terms
        if not _lifted(Tw, s, G, x):  # scaled tensions beyond the float range
            codes[p], left = CODE_FALLBACK, left + 1
            continue
        pose_estimate(P, cs, Aeq, G, h, lbs, ubs, x, RIDGE, yw, muw, zw, B, H, u, grad,
                      shrink)
        first, second, third = pose_measures(P, cs, Aeq, beq, G, h, lbs, ubs, x, yw, muw,
                                             zw, station)
        met = first <= target and second <= target and third <= target
        if first <= target and not met:  # the sign-constrained refit of certify
            first, second, third, kept = pose_refit(P, cs, Aeq, beq, G, h, lbs, ubs, x, yw,
                                                    muw, zw, (first, second, third),
                                                    station, refit)
            if kept < 0:  # a singular fit: the numpy path's
                codes[p], left = CODE_FALLBACK, left + 1
                continue
            met = first <= target and second <= target and third <= target
        _in_cones(lbs, ubs, muw, zw)
        _put(T, y, mu, z, p, Tw, yw, muw, zw, True)
        tol = tol_factor * pose_scales(A, b, lb)[1]
        codes[p] = 0 if met and res <= tol and over <= tol else 3
        objective[p], residual[p], violation[p] = value, res, over
        primal[p], dual[p], gap[p] = first, second, third
    return left
