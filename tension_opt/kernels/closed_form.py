"""The exact closed form of one pose, compiled: problem terms, null space, optimum,
status; and the same over a batch of poses (in parallel) or a sequence (in order,
each pose smoothed against the answer before); and over the poses of a standard form
(:func:`solve_forms`, the closed-form backend's kernel behind the plain
:func:`tension_opt.distribute`).

The reference is :class:`tension_opt.backends.closed_form.ClosedFormBackend` with the
status rule of :meth:`tension_opt.distribution.solution.TensionSolution.from_form`: a pose is
optimal only with finite tensions whose equilibrium residual and bound violation are
within ``max(FEASIBILITY_TOL, 10 * target)`` of the form's tolerance scale (the dual
measures of the certificate hold by construction for an exact closed form).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from tension_opt.kernels.affine import null_space, null_space_work
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into
from tension_opt.kernels.lowdim import (
    FEAS_TOL,
    FLAT_TOL,
    LP,
    MINMAX,
    QP,
    infeasibility_1d,
    lowdim_work,
    lp_2d,
    qp_2d,
    solve_1d,
)
from tension_opt.tolerances import FEASIBILITY_TOL

__all__ = ["CODE_BAD_INPUT", "CODE_FALLBACK", "CODE_STATUS", "HEADER", "HUGE", "form_pose",
           "form_terms", "judge", "pack", "pack_problem", "plain", "point4", "point4_distance",
           "pose_scales", "solve_batch", "solve_batch_serial", "solve_form", "solve_forms",
           "solve_forms_sequence", "solve_forms_serial", "solve_one", "solve_sequence", "work_size"]

#: Status codes of the kernels and the :class:`~tension_opt.status.Status` values
#: they stand for; :data:`CODE_FALLBACK` asks for the numpy path (singular or badly
#: conditioned structure matrix, zero-length cable).
CODE_STATUS = ("optimal", "infeasible", "unbounded", "inaccurate", "solver_error")
CODE_FALLBACK = 9
#: Code of :func:`solve_one` for a pose or wrench that is not finite (the caller raises).
CODE_BAD_INPUT = 8
#: Floats before the per-cable data in :func:`pack`'s array.
HEADER = 11
#: Poses per work space of a parallel batch (:func:`solve_batch`).
CHUNK = 256


@njit(cache=True)
def work_size(m: int, n: int) -> int:
    """Floats of work space one pose needs (:func:`solve_one`) for ``m`` cables and
    ``n`` degrees of freedom."""
    own = n * m + n + 7 * m
    return own + max(null_space_work(m, n), lowdim_work(m), 4 * m)


def pack(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray, weight: float,
         zero_length: float, smoothing: float, tol_factor: float, minmax: bool,
         terms: NDArray) -> NDArray:
    """Everything about a problem that does not change between poses, in one array
    (one argument for the compiled call, so that calling costs little).

    Parameters
    ----------
    kind : int
        :data:`tension_opt.kernels.geometry.KIND_CODES` of the robot.
    anchors, attachments : ndarray, shape (m, 3)
        Drawing points (base frame) and attachment points (platform frame) (m).
    com : ndarray, shape (3,)
        Centre of mass in the platform frame (m).
    weight, zero_length, smoothing, tol_factor : float
        Platform weight (N), cable length (m) at or below which a cable is on its
        drawing point, smoothing weight, factor of the feasibility tolerance.
    minmax : bool
        Whether the objective is min-max (``v`` its weights).
    terms : ndarray, shape (6, m)
        ``q0, c0, v, lb0, ub0, rate`` (the problem's terms without smoothing; ``rate``
        ``inf`` for no rate limit).

    Returns
    -------
    ndarray, shape (HEADER + 12 m,)
    """
    m = anchors.shape[0]
    n = {0: 3, 1: 2, 2: 3, 3: 6}[int(kind)]
    header = [kind, m, n, weight, zero_length, smoothing, tol_factor, float(minmax),
              *np.asarray(com, dtype=float)]
    return np.ascontiguousarray(np.concatenate([
        np.array(header, dtype=float), np.asarray(anchors, dtype=float).ravel(),
        np.asarray(attachments, dtype=float).ravel(), np.asarray(terms, dtype=float).ravel()]))


def pack_problem(robot: Any, problem: Any, target: float) -> NDArray:
    """:func:`pack` of a robot and a problem whose per-cable data are one row (the
    kernels' condition: no per-pose bounds or reference), judged at accuracy ``target``.

    Parameters
    ----------
    robot : tension_opt.CableRobot
        A robot of a kind in :data:`tension_opt.kernels.geometry.KIND_CODES`.
    problem : tension_opt.TensionProblem
    target : float
        Accuracy target (:func:`tension_opt.certify.certificate.accuracy_target`).
    """
    from tension_opt.kernels.geometry import robot_kind_code

    m = robot.m
    lb, ub = problem.bounds(robot, 1)
    reference = None
    if problem.objective.uses_reference and problem.reference is not None:
        reference = np.broadcast_to(problem.reference, (1, m)).astype(float)
    terms = problem.objective.terms(problem.cable_weights(m), lb, ub, reference)
    rate = np.full(m, np.inf) if problem.rate_limit is None else np.broadcast_to(
        np.asarray(problem.rate_limit, dtype=float), (m,))
    minmax = terms.minmax is not None
    v = np.ones(m) if not minmax else terms.minmax / np.abs(terms.minmax).max()  # unit_minmax
    stacked = np.stack([terms.q[0], terms.c[0], v, lb[0], ub[0], rate])
    return pack(robot_kind_code(robot), robot.anchors, robot.attachments, robot.com,
                robot.mass * robot.g, 1e-12 * max(1.0, float(np.abs(robot.anchors).max())),
                float(problem.smoothing), max(FEASIBILITY_TOL, 10.0 * target), minmax,
                stacked)


@njit(cache=True, error_model="numpy", inline="always")
def form_terms(q0: NDArray, c0: NDArray, lb0: NDArray, ub0: NDArray, smoothing: float,
           rate: NDArray, prev: NDArray, has_prev: bool, q: NDArray, c: NDArray,
           lb: NDArray, ub: NDArray) -> None:
    """The pose's form (``TensionProblem.standard_form_from``): smoothing adds
    ``2 s`` to ``q`` and ``-2 s prev`` to ``c``; a rate limit tightens the bounds."""
    for i in range(q0.size):
        q[i], c[i], lb[i], ub[i] = q0[i], c0[i], lb0[i], ub0[i]
        if has_prev:
            if smoothing:
                q[i] += 2.0 * smoothing
                c[i] += -2.0 * smoothing * prev[i]
            if math.isfinite(rate[i]):
                lb[i] = max(lb[i], prev[i] - rate[i])
                ub[i] = min(ub[i], prev[i] + rate[i])


@njit(cache=True, error_model="numpy", inline="always")
def pose_scales(A: NDArray, b: NDArray, lb: NDArray) -> tuple[float, float]:
    """``(typical tension, tolerance scale)`` of the pose
    (:func:`~tension_opt.problem.affine.typical_tension`, ``StandardForm.tolerance_scale``)."""
    n, m = A.shape
    col = 0.0
    for j in range(m):
        s = 0.0
        for i in range(n):
            s += A[i, j] * A[i, j]
        col = max(col, math.sqrt(s))
    bn = 0.0
    for i in range(n):
        bn += b[i] * b[i]
    bn = math.sqrt(bn)
    top_lb = 0.0
    for i in range(m):
        if math.isfinite(lb[i]):
            top_lb = max(top_lb, abs(lb[i]))
    typical = max(max(bn / max(col, 1e-300), top_lb), 1e-12)
    return typical, max(max(bn, top_lb), 1e-12)


@njit(cache=True, error_model="numpy", inline="always")
def judge(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, T: NDArray, tol: float
           ) -> tuple[int, float]:
    """Status code (0 optimal, 3 inaccurate, 4 solver error) and equilibrium residual
    of solved tensions."""
    n, m = A.shape
    for i in range(m):
        if not math.isfinite(T[i]):
            T[:] = np.nan
            return 4, np.nan
    res = 0.0
    for k in range(n):
        r = -b[k]
        for i in range(m):
            r += A[k, i] * T[i]
        res += r * r
    res = math.sqrt(res)
    violation = 0.0
    for i in range(m):
        violation = max(violation, max(lb[i] - T[i], T[i] - ub[i]))
    return (0 if res <= tol and violation <= tol else 3), res


@njit(cache=True, error_model="numpy")
def solve_form(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
               v: NDArray, minmax: bool, tol_factor: float, T: NDArray, work: NDArray
               ) -> tuple[int, bool, float, float]:
    """Closed form of one pose's form: tensions written to ``T`` (m,); returns
    ``(code, unique, residual, infeasibility)`` (codes :data:`CODE_STATUS`, or
    :data:`CODE_FALLBACK` for the numpy path). ``work`` holds the null space and the
    enumeration's temporaries (:func:`work_size`)."""
    n, m = A.shape
    r = m - n
    quadratic = False
    for i in range(m):
        quadratic = quadratic or q[i] != 0.0
    kind = MINMAX if minmax else (QP if quadratic else LP)
    if (minmax and (quadratic or r != 1)) or r < 1 or r > 2:
        return CODE_FALLBACK, True, np.nan, np.nan
    T0 = work[:m]
    Z = work[m:m + m * r].reshape((m, r))
    rest = work[3 * m:]
    if not null_space(A, b, T0, Z, rest):
        return CODE_FALLBACK, True, np.nan, np.nan
    typical, tol_scale = pose_scales(A, b, lb)
    infeas = np.nan
    if r == 1:
        code, unique, infeas = solve_1d(T0, Z[:, 0], lb, ub, q, c, v, kind, typical, T, rest)
    else:
        if kind == QP:
            z0, z1, feasible = qp_2d(T0, Z, lb, ub, q, c, typical, rest)
            unique = True
        else:
            z0, z1, feasible, unique = lp_2d(T0, Z, lb, ub, c, typical, rest)
        code = 0 if feasible else 1
        for i in range(m):
            T[i] = T0[i] + Z[i, 0] * z0 + Z[i, 1] * z1 if feasible else np.nan
    if code != 0:
        return code, unique, np.nan, infeas
    code, res = judge(A, b, lb, ub, T, tol_factor * tol_scale)
    return code, unique, res, infeas


@njit(cache=True, error_model="numpy")
def solve_one(data: NDArray, pose: NDArray, wrench: NDArray, prev: NDArray,
              has_prev: bool, work: NDArray, T: NDArray) -> tuple[int, bool, float, float]:
    """Geometry, form and closed form of one pose, allocating nothing.

    Parameters
    ----------
    data : ndarray
        The problem (:func:`pack`).
    pose : ndarray, shape (n,)
    wrench : ndarray, shape (n,)
        External wrench besides gravity (N, N m); zeros for none.
    prev : ndarray, shape (m,)
        Previous tensions (N), used where ``has_prev`` (smoothing, rate limit).
    work : ndarray
        At least :func:`work_size` floats, owned by the calling thread.
    T : ndarray, shape (m,)
        Tensions (N), written.

    Returns
    -------
    tuple
        ``(code, unique, residual, infeasibility)``: :data:`CODE_STATUS` index,
        :data:`CODE_FALLBACK` (the numpy path decides) or :data:`CODE_BAD_INPUT` (a
        pose or wrench that is not finite).
    """
    anchors, attachments, terms, A = _views(data, work)
    return _solve_viewed(data, anchors, attachments, terms, A, pose, wrench, prev,
                         has_prev, work, T)


@njit(cache=True, error_model="numpy")
def _views(data: NDArray, work: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The 2-D views of :func:`solve_one`'s data and work space: anchors and
    attachments (m, 3), the objective's terms (6, m) and the structure matrix (n, m).
    Made once per call or batch chunk: a reshaped view costs about as much as the
    arithmetic of a pose."""
    m, n = int(data[1]), int(data[2])
    return (data[HEADER:HEADER + 3 * m].reshape((m, 3)),
            data[HEADER + 3 * m:HEADER + 6 * m].reshape((m, 3)),
            data[HEADER + 6 * m:HEADER + 12 * m].reshape((6, m)),
            work[:n * m].reshape((n, m)))


@njit(cache=True, error_model="numpy", inline="always")
def _solve_viewed(data: NDArray, anchors: NDArray, attachments: NDArray, terms: NDArray,
                  A: NDArray, pose: NDArray, wrench: NDArray, prev: NDArray,
                  has_prev: bool, work: NDArray, T: NDArray
                  ) -> tuple[int, bool, float, float]:
    """:func:`solve_one` with the views of :func:`_views` (``A`` a view of ``work``)."""
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    for i in range(n):
        if not (math.isfinite(pose[i]) and math.isfinite(wrench[i])):
            return CODE_BAD_INPUT, True, np.nan, np.nan
    b = work[n * m:n * m + n]
    o = n * m + n
    q, c, lb, ub = work[o:o + m], work[o + m:o + 2 * m], work[o + 2 * m:o + 3 * m], \
        work[o + 3 * m:o + 4 * m]
    if geometry_into(kind, anchors, attachments, data[8:HEADER], data[3], data[4], pose,
                     wrench, A, b) != GEOMETRY_OK:
        return CODE_FALLBACK, True, np.nan, np.nan
    form_terms(terms[0], terms[1], terms[3], terms[4], data[5], terms[5], prev, has_prev,
               q, c, lb, ub)
    minmax, rest = data[7] != 0.0, work[o + 4 * m:]
    if n == 3 and m == 4 and not minmax:  # as the numpy path: its shortcut first
        quadratic = False
        for i in range(m):
            quadratic = quadratic or q[i] != 0.0
        settled, unique, off = point4(A, b, lb, ub, q, c, quadratic, T, rest)
        infeas = point4_distance(lb, ub, rest) if off else np.nan
        if settled and not math.isnan(infeas):
            return 1, True, np.nan, infeas
        if settled:
            tol_scale = pose_scales(A, b, lb)[1]
            code, res = judge(A, b, lb, ub, T, data[6] * tol_scale)
            return code, unique, res, np.nan
    return solve_form(A, b, lb, ub, q, c, terms[2], minmax, data[6], T, rest)


@njit(cache=True, error_model="numpy")
def _batch_chunk(j: int | np.int64, data: NDArray, poses: NDArray, wrenches: NDArray,
                 prev: NDArray, has_prev: bool, T: NDArray, info: NDArray, codes: NDArray) -> None:
    """Chunk ``j`` (:data:`CHUNK` poses) of :func:`solve_batch`, with its own work space."""
    N, m, n = poses.shape[0], int(data[1]), int(data[2])
    work = np.empty(work_size(m, n))
    anchors, attachments, terms, A = _views(data, work)
    for k in range(j * CHUNK, min(N, (j + 1) * CHUNK)):
        w = wrenches[k] if wrenches.shape[0] > 1 else wrenches[0]
        p = prev[k] if prev.shape[0] > 1 else prev[0]
        code, unique, res, infeas = _solve_viewed(data, anchors, attachments, terms, A,
                                                  poses[k], w, p, has_prev, work, T[k])
        codes[k] = code
        info[k, 0], info[k, 1], info[k, 2] = 1.0 if unique else 0.0, res, infeas


@njit(cache=True, error_model="numpy", parallel=True)
def solve_batch(data: NDArray, poses: NDArray, wrenches: NDArray, prev: NDArray,
                has_prev: bool, T: NDArray, info: NDArray, codes: NDArray) -> None:
    """:func:`solve_one` over poses (N, n) in parallel, each pose independent.

    ``wrenches`` (N, n) or (1, n) (one for every pose), ``prev`` (N, m) or (1, m);
    ``T`` (N, m), ``info`` (N, 3) ``(unique, residual, infeasibility)`` and ``codes``
    (N,) written. Work space is allocated once per chunk of :data:`CHUNK` poses.
    """
    for j in prange((poses.shape[0] + CHUNK - 1) // CHUNK):
        # An int64 index, as the serial kernel's: one compiled chunk serves both (a
        # prange index is unsigned, and compiling another costs seconds).
        _batch_chunk(np.int64(j), data, poses, wrenches, prev, has_prev, T, info, codes)


@njit(cache=True, error_model="numpy")
def solve_batch_serial(data: NDArray, poses: NDArray, wrenches: NDArray, prev: NDArray,
                       has_prev: bool, T: NDArray, info: NDArray, codes: NDArray) -> None:
    """:func:`solve_batch` in the calling thread (the same arithmetic per pose)."""
    for j in range((poses.shape[0] + CHUNK - 1) // CHUNK):
        _batch_chunk(j, data, poses, wrenches, prev, has_prev, T, info, codes)


@njit(cache=True, error_model="numpy")
def solve_sequence(data: NDArray, poses: NDArray, wrenches: NDArray, last: NDArray,
                   has_last: bool, T: NDArray, info: NDArray, codes: NDArray,
                   start: int, work: NDArray) -> int:
    """Poses ``start, start + 1, ...`` in order, each smoothed against the last optimal
    tensions (``last`` (m,), updated in place; unsmoothed while there are none).
    Stops at a pose that needs the numpy path and returns its index (N when done).
    ``wrenches`` (N, n) or (1, n)."""
    anchors, attachments, terms, A = _views(data, work)
    for k in range(start, poses.shape[0]):
        w = wrenches[k] if wrenches.shape[0] > 1 else wrenches[0]
        code, unique, res, infeas = _solve_viewed(data, anchors, attachments, terms, A,
                                                  poses[k], w, last, has_last, work, T[k])
        codes[k] = code
        info[k, 0], info[k, 1], info[k, 2] = 1.0 if unique else 0.0, res, infeas
        if code >= CODE_BAD_INPUT:
            return k
        if code == 0:
            last[:] = T[k]
            has_last = True
    return poses.shape[0]


#: Largest magnitude of the data of a pose the form kernels take (beyond it, squares
#: overflow where the numpy path rescales: that pose goes to the numpy path).
HUGE = 1e150


@njit(cache=True, error_model="numpy", inline="always")
def plain(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray
          ) -> bool:
    """Whether a pose's data are all of magnitude below :data:`HUGE` (bounds may be
    infinite) and not NaN (one return: see tension_opt.kernels)."""
    ok = True
    for i in range(A.shape[0]):
        ok = ok and abs(b[i]) < HUGE
        for j in range(A.shape[1]):
            ok = ok and abs(A[i, j]) < HUGE
    for j in range(q.size):
        ok = ok and abs(q[j]) < HUGE and abs(c[j]) < HUGE
        ok = ok and (abs(lb[j]) < HUGE or lb[j] == -np.inf) and (abs(ub[j]) < HUGE
                                                                 or ub[j] == np.inf)
    return ok


@njit(cache=True, error_model="numpy", inline="always")
def point4(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
           quadratic: bool, T: NDArray, work: NDArray) -> tuple[bool, bool, bool]:
    """Four cables, three equations (LP or QP): the numpy path's shortcut
    (``ClosedFormBackend._solve_point4``), tensions written to ``T``; returns
    ``(settled, unique, infeasible)``. A particular solution comes from cables 1-3 by
    Cramer's rule and the null vector from the same cross products. A pose with no
    feasible tension is settled here (NaN tensions; its distance to feasibility is
    :func:`point4_distance`, on this line: the numpy path finds the same line by the
    general path, to rounding), save within the general path's slack; poses with cables
    1-3 nearly coplanar, or a cable that does not move along the null vector, are not
    settled (the general path answers them). ``work``: 17 + 4 m floats."""
    u = A  # columns u_i = A[:, i]; work: C_j = u2 x u3, u3 x u1, u1 x u2 (cables from one),
    # the particular solution and the null vector at offsets 0, 9 and 13 (no views).
    for j in range(3):
        a, e = (j + 1) % 3, (j + 2) % 3
        work[3 * j] = u[1, a] * u[2, e] - u[2, a] * u[1, e]
        work[3 * j + 1] = u[2, a] * u[0, e] - u[0, a] * u[2, e]
        work[3 * j + 2] = u[0, a] * u[1, e] - u[1, a] * u[0, e]
    det = u[0, 0] * work[0] + u[1, 0] * work[1] + u[2, 0] * work[2]
    settled, unique, t = abs(det) > 1e-9, True, np.nan
    work[12] = 0.0
    for j in range(3):
        C0, C1, C2 = work[3 * j], work[3 * j + 1], work[3 * j + 2]
        work[9 + j] = (b[0] * C0 + b[1] * C1 + b[2] * C2) / det
        work[13 + j] = u[0, 3] * C0 + u[1, 3] * C1 + u[2, 3] * C2
    work[16] = -det
    top = max(max(abs(work[13]), abs(work[14])), max(abs(work[15]), abs(work[16])))
    lo, hi, nn = -np.inf, np.inf, 0.0
    for i in range(4):
        ni, Ti = work[13 + i], work[9 + i]
        settled = settled and abs(ni) > 1e-9 * top
        nn += ni * ni
        r_lb, r_ub = (lb[i] - Ti) / ni, (ub[i] - Ti) / ni
        if ni > 0:
            lo, hi = max(lo, r_lb), min(hi, r_ub)
        else:
            lo, hi = max(lo, r_ub), min(hi, r_lb)
    infeasible = settled and not lo <= hi
    if infeasible:
        # Infeasible unless within the general path's slack (its interval is in units of
        # a unit null vector): then its distance is that of this line, found here
        # without the general path's QR (a few times the cost of a feasible pose).
        typical = pose_scales(A, b, lb)[0]
        settled = not (math.isnan(lo - hi) or (lo - hi) * math.sqrt(nn) <= FEAS_TOL * typical)
        if settled:
            T[:] = np.nan
    elif settled and quadratic:
        num = den = 0.0
        for i in range(4):
            num += (q[i] * work[9 + i] + c[i]) * work[13 + i]
            den += q[i] * work[13 + i] * work[13 + i]
        t = -num / den
        settled = not math.isnan(t)  # numpy's clip keeps a NaN, which sends the pose on
        t = min(max(t, lo), hi)
    elif settled:
        slope = cc = tn = 0.0
        for i in range(4):
            slope += c[i] * work[13 + i]
            cc += c[i] * c[i]
            tn += work[9 + i] * work[13 + i]
        flat = abs(slope) <= FLAT_TOL * math.sqrt(cc * nn)
        t = min(max(-tn / nn, lo), hi) if flat else (lo if slope > 0 else hi)
        unique = not flat or lo == hi
    if settled and not infeasible:
        settled = math.isfinite(t)
        for i in range(4 if settled else 0):
            T[i] = work[9 + i] + t * work[13 + i]
    if (A.size | b.size | lb.size | ub.size | q.size | c.size | T.size | work.size) < 0:
        settled = False  # never: the arrays read once more (tension_opt.kernels)
    return settled, unique if settled else True, settled and infeasible


@njit(cache=True, error_model="numpy")
def point4_distance(lb: NDArray, ub: NDArray, work: NDArray) -> float:
    """Distance to feasibility (N) of a pose :func:`point4` found infeasible, on its line
    (``work`` as it left it); a call kept out of the inlined step (see tension_opt.kernels)."""
    return infeasibility_1d(work[9:13], work[13:17], lb, ub, work[17:])


@njit(cache=True, error_model="numpy", inline="always")
def form_pose(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
              v: NDArray, minmax: bool, quadratic: bool, tol_factor: float, T: NDArray,
              work: NDArray) -> tuple[int, bool, float]:
    """One pose's form as :func:`solve_forms` solves it (data within :data:`HUGE`):
    the four-cable shortcut first, as the numpy path, then :func:`solve_form`; returns
    ``(code, unique, infeasibility)``."""
    n, m = A.shape
    settled, code, unique, infeas = False, CODE_FALLBACK, True, np.nan
    if n == 3 and m == 4 and not minmax:
        settled, unique, off = point4(A, b, lb, ub, q, c, quadratic, T, work)
        infeas = point4_distance(lb, ub, work) if off else np.nan
        code = 0 if math.isnan(infeas) else 1
    if not settled:
        code, unique, _, infeas = solve_form(A, b, lb, ub, q, c, v, minmax, tol_factor, T,
                                             work)
    if (A.size | b.size | lb.size | ub.size | q.size | c.size | v.size | T.size
            | work.size) < 0:  # never: the arrays read once more (see point4)
        code = CODE_FALLBACK
    return code, unique, infeas


@njit(cache=True, error_model="numpy")
def _forms_chunk(j: int | np.int64, A: NDArray, b: NDArray, lb: NDArray, ub: NDArray,
                 q: NDArray, c: NDArray, v: NDArray, minmax: bool, quadratic: bool,
                 tol_factor: float, T: NDArray, info: NDArray, codes: NDArray) -> None:
    """Poses ``j * CHUNK ...`` of :func:`solve_forms`, with one work space."""
    N, n, m = A.shape
    work = np.empty(work_size(m, n))
    for k in range(j * CHUNK, min(N, (j + 1) * CHUNK)):
        vk = v[k] if v.shape[0] > 1 else v[0]
        own = False  # whether the pose is as quadratic as its batch
        for i in range(m):
            own = own or q[k, i] != 0.0
        code, unique, infeas = CODE_FALLBACK, True, np.nan
        if own == quadratic and plain(A[k], b[k], lb[k], ub[k], q[k], c[k]):
            code, unique, infeas = form_pose(A[k], b[k], lb[k], ub[k], q[k], c[k], vk,
                                             minmax, quadratic, tol_factor, T[k], work)
        codes[k] = code
        info[k, 0], info[k, 1] = 1.0 if unique else 0.0, infeas


@njit(cache=True, error_model="numpy", parallel=True)
def solve_forms(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray, c: NDArray,
                v: NDArray, minmax: bool, quadratic: bool, tol_factor: float, T: NDArray,
                info: NDArray, codes: NDArray) -> None:
    """:func:`solve_form` over the poses of a standard form, in parallel over chunks of
    :data:`CHUNK` poses (one work space per chunk).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lb, ub, q, c : ndarray, shape (N, m)
        The form's arrays (``StandardForm``).
    v : ndarray, shape (N, m) or (1, m)
        Min-max weights (any row where ``minmax`` is False).
    minmax, quadratic : bool
        The form's kind: min-max; a quadratic term in some pose. A pose whose own ``q``
        disagrees with ``quadratic``, or with data of magnitude :data:`HUGE` or more,
        is left to the numpy path.
    tol_factor : float
        Factor of the feasibility check of :func:`judge`.
    T : ndarray, shape (N, m)
        Tensions (N), written.
    info : ndarray, shape (N, 2)
        ``(unique, infeasibility)`` per pose, written.
    codes : ndarray of int, shape (N,)
        :data:`CODE_STATUS` index per pose, or :data:`CODE_FALLBACK`, written.
    """
    chunks = (A.shape[0] + CHUNK - 1) // CHUNK
    for j in prange(chunks):
        _forms_chunk(np.int64(j), A, b, lb, ub, q, c, v, minmax, quadratic, tol_factor, T, info,
                     codes)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_forms_serial(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray,
                       c: NDArray, v: NDArray, minmax: bool, quadratic: bool,
                       tol_factor: float, T: NDArray, info: NDArray, codes: NDArray
                       ) -> None:
    """:func:`solve_forms` in the calling thread (the same arithmetic per pose)."""
    for j in range((A.shape[0] + CHUNK - 1) // CHUNK):
        _forms_chunk(j, A, b, lb, ub, q, c, v, minmax, quadratic, tol_factor, T, info,
                     codes)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_forms_sequence(A: NDArray, b: NDArray, lb0: NDArray, ub0: NDArray, q0: NDArray,
                         c0: NDArray, smoothing: float, rate: NDArray, tol_factor: float,
                         last: NDArray, has_last: bool, T: NDArray, info: NDArray,
                         codes: NDArray, start: int) -> int:
    """Poses ``start, start + 1, ...`` of a sequence (``distribute``'s ``A`` (N, n, m)
    and ``b`` (N, n), unsmoothed terms ``lb0 ... c0`` (N, m)), each smoothed against
    ``last`` (m,) as its one-pose form (:func:`form_terms`) and solved as
    :func:`solve_forms` solves that form; ``last`` takes the tensions of every pose
    reported optimal (codes 0 and 3). Writes ``T``, ``info`` (unique, infeasibility) and
    ``codes``; stops at a pose the numpy path or another backend must answer (data
    beyond :data:`HUGE`, codes from the solver error on): returns its index (N if none)."""
    N, n, m = A.shape
    work = np.empty(4 * m + work_size(m, n))
    q, c, lb, ub, rest = work[:m], work[m:2 * m], work[2 * m:3 * m], work[3 * m:4 * m], \
        work[4 * m:]
    v = np.ones(m)
    minmax = v.size < 0  # False, but not the literal (which compiles solve_form again)
    for k in range(start, N):
        form_terms(q0[k], c0[k], lb0[k], ub0[k], smoothing, rate, last, has_last, q, c, lb,
                   ub)
        if not plain(A[k], b[k], lb, ub, q, c):
            return k
        quadratic = False
        for i in range(m):
            quadratic = quadratic or q[i] != 0.0
        code, unique, infeas = form_pose(A[k], b[k], lb, ub, q, c, v, minmax, quadratic,
                                         tol_factor, T[k], rest)
        if code >= 4:
            return k
        codes[k] = code
        info[k, 0], info[k, 1] = 1.0 if unique else 0.0, infeas
        if code == 0 or code == 3:
            last[:] = T[k]
            has_last = True
    return N
