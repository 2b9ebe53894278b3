"""Coupled sag inverse kinematics of one pose, compiled, for control loops:
:class:`CoupledIK`.

The numpy reference is :func:`catenary.inverse_kinematics` with ``model="coupled"``
(:class:`catenary.coupled.CoupledSolver`, whose module docstring describes the
iteration). Here one compiled call runs that whole iteration for one pose, with the
same steps, safeguards and stopping rule: the catenaries by
:func:`catenary.solve.kernels.solve_length_one`, the linearised problems by
:func:`tension_opt.kernels.closed_form.solve_form` (the compiled closed form of
``backend="closed_form"``), the multipliers by a small Gaussian elimination.

A stream of poses starts each pose from the previous pose's tensions and multipliers
(``warm_start``), which saves iterations and reaches the same fixed point within the
stopping tolerance; where that does not converge, the pose is solved again from the
straight-line distribution, as the reference. Where the kernel cannot go on as the
reference would (a straight-line distribution that is not optimal, from which the
reference starts a capacity-margin search; a catenary left to the numpy solver; a
step to halve; a singular linearisation) it starts from the robot's home answer, and
if that does not converge either, :func:`catenary.inverse_kinematics` answers, as it
does every problem and robot the kernel does not cover.

Status: ``converged`` only where the iteration settled *and* the certificate holds:
the catenary end forces balance the load to :data:`CERT_TOL` of the load scale
(``max(||b||, largest t_min)``) and the lowest and highest tension along every cable
lie within the bounds to the same tolerance; a settled pose that fails it is reported
``inaccurate``. The other statuses are the reference's.
"""

from __future__ import annotations

import math
import threading
from typing import Any, ClassVar

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.kernels import closed_form as cf
from tension_opt.kernels.arrays import writable
from tension_opt.kernels.first_use import announce
from tension_opt.kernels.geometry import (
    GEOMETRY_OK,
    arm_and_vector,
    geometry_into,
    platform_position,
    rotation,
)
from tension_opt.problem.form import TensionProblem, as_problem
from tension_opt.status import STATUS_DTYPE, Status
from tension_opt.tolerances import accuracy_target

from .errors import InvalidCableError
from .geometry import cable_data
from .inverse import CERT_TOL, InverseKinematicsResult, inverse_kinematics
from .solve.kernels import CONVERGED as CATENARY_OK
from .solve.kernels import solve_length_one, spans_one

__all__ = ["CERT_TOL", "CoupledIK", "coupled_pose"]

#: Codes of :func:`coupled_pose`.
SETTLED, INFEASIBLE, MAX_ITER, UNCERTIFIED, BAD_INPUT, FALLBACK = 0, 1, 2, 3, 8, 9
_STATUS = {SETTLED: Status.CONVERGED, INFEASIBLE: Status.INFEASIBLE,
           MAX_ITER: Status.MAX_ITER, UNCERTIFIED: Status.INACCURATE}
#: Restarts and catenary solver settings of :class:`catenary.coupled.CoupledSolver`.
MAX_RESTARTS, _CAT_RTOL, _CAT_ITER = 6, 1e-9, 30
#: Columns of the per-cable geometry: x, z, chord, e_h (2), arm R a (3).
_GEO = 8


@njit(cache=True, error_model="numpy")
def add_wrench(kind: int, out: NDArray, f0: float, f1: float, f2: float, r0: float,
               r1: float, r2: float) -> None:
    """Add the rows of the wrench of force ``f`` at arm ``r`` (``f``, ``r x f``) that the
    robot kind keeps (point3: force; spatial6: force and moment) to ``out`` (n,)."""
    out[0] += f0
    out[1] += f1
    out[2] += f2
    if kind == 3:
        out[3] += r1 * f2 - r2 * f1
        out[4] += r2 * f0 - r0 * f2
        out[5] += r0 * f1 - r1 * f0


@njit(cache=True, error_model="numpy")
def force_slope_one(x: float, chord: float, H: float, V_A: float, V_B: float, L0: float,
                    w: float, inv_EA: float) -> tuple[float, float, bool]:
    """``(dH/dT_A, dV_A/dT_A, regular)`` of one taut catenary at fixed ends
    (:func:`catenary.geometry.force_slope`); not regular where the span formulas reach
    a limit the numpy path handles."""
    _, _, a, bb, d, _, _, regular = spans_one(H, V_B, L0, w, inv_EA)
    if not regular:
        return np.nan, np.nan, False
    k = 1.0 / math.hypot(H, V_B - w * L0) + inv_EA
    lx, lz = H * k, (V_B - w * L0) * k
    det = a * d - bb * bb
    qx = (d * lx - bb * lz) / det
    qz = (a * lz - bb * lx) / det
    T_A = math.hypot(H, V_A)
    D = (H * qx + V_A * (qz + w)) / T_A
    dH, dV = qx / D, (qz + w) / D
    if w * chord < 1e-7 * T_A:  # sag below the rounding of the length
        phi = math.atan2(V_A, H)
        delta = w * x / (2.0 * T_A)
        dH = math.cos(phi) - delta * math.sin(phi)
        dV = math.sin(phi) + delta * math.cos(phi)
    return dH, dV, True


@njit(cache=True, error_model="numpy")
def cable_planes_into(kind: int, anchors: NDArray, attachments: NDArray, pose: NDArray,
                      geo: NDArray) -> bool:
    """Per cable ``(x, z, chord, e_x, e_y, arm)`` of one pose into ``geo`` (m, 8)
    (:func:`catenary.geometry.cable_planes`); False if a cable is vertical."""
    R, position = rotation(kind, pose), platform_position(kind, pose)
    for i in range(anchors.shape[0]):
        r0, r1, r2, d0, d1, d2 = arm_and_vector(R, position, anchors, attachments, i)
        x = math.hypot(d0, d1)
        if not x > 0.0:
            return False
        geo[i, 0], geo[i, 1], geo[i, 2] = x, d2, math.sqrt(x * x + d2 * d2)
        geo[i, 3], geo[i, 4] = d0 / x, d1 / x
        geo[i, 5], geo[i, 6], geo[i, 7] = r0, r1, r2
    return True


@njit(cache=True, error_model="numpy")
def catenaries_into(geo: NDArray, T: NDArray, w: float, inv_EA: float, cab: NDArray,
                    tmp: NDArray) -> bool:
    """Taut catenaries with platform-end tensions ``T`` (m,): ``cab`` (m, 5) gets
    ``(H, V_B, V_A, L0, iterations so far + these)`` where every cable converged (then
    True); left as it was otherwise. ``tmp`` (m, 5) is scratch."""
    m = T.size
    for i in range(m):
        if solve_length_one(False, geo[i, 0], geo[i, 1], T[i], w, inv_EA, _CAT_RTOL,
                            _CAT_ITER, tmp[i]) != CATENARY_OK:
            return False
    cab[:, :4] = tmp[:, :4]
    cab[:, 4] += tmp[:, 4]
    return True


@njit(cache=True, error_model="numpy")
def multipliers_into(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, q: NDArray,
                     c: NDArray, T: NDArray, lam: NDArray, M: NDArray) -> None:
    """Multipliers ``lam`` (n,) of the equilibrium rows at a solution ``T`` (m,)
    (:func:`catenary.coupled._multipliers` of one pose): least squares on the
    stationarity of the cables off their bounds, ``M`` (n, n + 1) scratch."""
    n, m = A.shape
    tol = 1e-7 * cf.pose_scales(A, b, lb)[0]
    M[:, :] = 0.0
    for i in range(m):
        if T[i] <= lb[i] + tol or T[i] >= ub[i] - tol:
            continue
        g = q[i] * T[i] + c[i]
        for r in range(n):
            M[r, n] -= A[r, i] * g
            for s in range(n):
                M[r, s] += A[r, i] * A[s, i]
    trace = 0.0
    for r in range(n):
        trace += M[r, r]
    for r in range(n):
        M[r, r] += 1e-12 * trace + 1e-300
    gauss_solve(M, lam)


@njit(cache=True, error_model="numpy")
def gauss_solve(M: NDArray, x: NDArray) -> None:
    """Solve the augmented system ``M`` (n, n + 1) in place by Gaussian elimination with
    partial pivoting; the solution into ``x`` (n,)."""
    n = M.shape[0]
    for k in range(n):
        p = k + np.argmax(np.abs(M[k:, k]))
        for s in range(k, n + 1):
            M[k, s], M[p, s] = M[p, s], M[k, s]
        for r in range(k + 1, n):
            f = M[r, k] / M[k, k]
            for s in range(k, n + 1):
                M[r, s] -= f * M[k, s]
    for k in range(n - 1, -1, -1):
        acc = M[k, n]
        for s in range(k + 1, n):
            acc -= M[k, s] * x[s]
        x[k] = acc / M[k, k]


@njit(cache=True, error_model="numpy")
def linearise(kind: int, geo: NDArray, cab: NDArray, T: NDArray, b: NDArray,
              terms: NDArray, flags: NDArray, w: float, inv_EA: float, A: NDArray,
              bs: NDArray, lbs: NDArray, ubs: NDArray, q: NDArray, c: NDArray) -> bool:
    """The distribution problem linearised at platform tensions ``T`` (m,)
    (``CoupledSolver._subproblem`` before the curvature): ``A`` (n, m), ``bs`` (n,),
    shifted bounds, ``q``, ``c`` written. ``terms`` (6, m) as :func:`pack`, ``flags``
    ``(bounded, centred)``. False where a slope is left to the numpy path."""
    n, m = A.shape
    for k in range(n):
        bs[k] = 0.0
    for i in range(m):
        H, V_B, V_A, L0 = cab[i, 0], cab[i, 1], cab[i, 2], cab[i, 3]
        dH, dV, ok = force_slope_one(geo[i, 0], geo[i, 2], H, V_A, V_B, L0, w, inv_EA)
        if not ok:
            return False
        ex, ey, r0, r1, r2 = geo[i, 3], geo[i, 4], geo[i, 5], geo[i, 6], geo[i, 7]
        s0, s1, s2 = dH * ex, dH * ey, dV
        for k in range(n):
            A[k, i] = 0.0
        add_wrench(kind, A[:, i], s0, s1, s2, r0, r1, r2)
        t = T[i]
        add_wrench(kind, bs, H * ex - s0 * t, H * ey - s1 * t, V_A - s2 * t, r0, r1, r2)
        lbs[i], ubs[i] = terms[3, i], terms[4, i]
        if flags[0]:
            T_A, T_B = math.hypot(H, V_A), math.hypot(H, V_B)
            low = H if (V_A < 0.0 and V_B > 0.0) else min(T_A, T_B)
            lbs[i] += t - low
            ubs[i] += t - max(T_A, T_B)
        q[i] = terms[0, i]
        c[i] = -0.5 * terms[0, i] * (lbs[i] + ubs[i]) if flags[1] else terms[1, i]
    for k in range(n):
        bs[k] = b[k] - bs[k]
    return True


@njit(cache=True, error_model="numpy")
def add_curvature(kind: int, geo: NDArray, T: NDArray, lam: NDArray, w: float,
                  inv_EA: float, A: NDArray, bs: NDArray, lbs: NDArray, q: NDArray,
                  c: NDArray, curv: NDArray, col: NDArray, sol: NDArray) -> bool:
    """Add the diagonal curvature of the Lagrangian to ``q`` and ``c`` (as the
    reference): the slope's forward difference at ``1e-6 T``, clipped at 0, dropped
    where too small to matter. False where a catenary is left to the numpy path."""
    n, m = A.shape
    for i in range(m):
        dT = 1e-6 * T[i]
        if solve_length_one(False, geo[i, 0], geo[i, 1], T[i] + dT, w, inv_EA, _CAT_RTOL,
                            _CAT_ITER, sol) != CATENARY_OK:
            return False
        dH, dV, ok = force_slope_one(geo[i, 0], geo[i, 2], sol[0], sol[2], sol[1], sol[3],
                                     w, inv_EA)
        if not ok:
            return False
        col[:] = 0.0
        add_wrench(kind, col, dH * geo[i, 3], dH * geo[i, 4], dV, geo[i, 5], geo[i, 6],
                   geo[i, 7])
        k_i = 0.0
        for k in range(n):
            k_i += lam[k] * ((col[k] - A[k, i]) / dT)
        curv[i] = max(k_i, 0.0) if math.isfinite(k_i) else 0.0
    scale = cf.pose_scales(A, bs, lbs)[0]
    size = 0.0
    for i in range(m):
        size = max(size, abs(c[i]) * scale + q[i] * scale * scale)
    for i in range(m):
        if curv[i] * scale * scale > 1e-12 * size:
            q[i] += curv[i]
            c[i] -= curv[i] * T[i]
    return True


def work_floats(m: int, n: int) -> int:
    """Floats of work space :func:`coupled_pose` needs for ``m`` cables, ``n`` DOF."""
    return n * m + 2 * n + 6 * m + n * (n + 1) + n + 5 * m + 5 + int(cf.work_size(m, n))


@njit(cache=True, error_model="numpy")
def work_views(work: NDArray, m: int, n: int) -> tuple[NDArray, ...]:
    """The scratch arrays of :func:`coupled_pose` as views of ``work``: ``A`` (n, m),
    ``b``, ``bs`` (n,), ``lbs, ubs, q, c, Tn, curv`` (m,), ``M`` (n, n + 1), ``col``
    (n,), ``tmp`` (m, 5), ``sol`` (5,) and the closed form's work space."""
    A = work[:n * m].reshape((n, m))
    o = n * m + 2 * n
    v = work[o:o + 6 * m].reshape((6, m))
    o += 6 * m
    M = work[o:o + n * (n + 1)].reshape((n, n + 1))
    o += n * (n + 1)
    e = o + n + 5 * m
    return (A, work[n * m:n * m + n], work[n * m + n:n * m + 2 * n], v[0], v[1], v[2], v[3],
            v[4], v[5], M, work[o:o + n], work[o + n:e].reshape((m, 5)), work[e:e + 5],
            work[e + 5:])


@njit(cache=True, error_model="numpy")
def coupled_pose(data: NDArray, params: NDArray, pose: NDArray, wrench: NDArray,
                 T: NDArray, lam: NDArray, warm: bool, geo: NDArray, cab: NDArray,
                 work: NDArray) -> tuple[int, int]:
    """The coupled sequential convex programming of one pose (hot numerical kernel:
    one compiled loop over the iterations, kept whole so that no state crosses into
    Python).

    Parameters
    ----------
    data, params : ndarray
        The problem (:func:`tension_opt.kernels.closed_form.pack`); ``w`` (N/m),
        ``1/EA`` (1/N), ``tol``, ``max_iter``, bounded, centred.
    pose, wrench : ndarray, shape (n,)
    T : ndarray, shape (m,)
        Platform-end tensions (N): the start where ``warm`` (else the straight-line
        distribution is computed into it); the last iterate on return.
    lam : ndarray, shape (n,)
        Multipliers of the equilibrium rows: the start where ``warm``; the last.
    geo, cab : ndarray, shapes (m, 8) and (m, 5)
        Written: cable planes (:func:`cable_planes_into`) and catenaries
        (:func:`catenaries_into`).
    work : ndarray
        At least :func:`work_floats` floats.

    Returns
    -------
    (code, iterations)
        ``SETTLED``, ``INFEASIBLE``, ``MAX_ITER``, ``BAD_INPUT`` or ``FALLBACK`` (the
        reference decides), and the linearised problems solved.
    """
    kind, m, n = int(data[0]), int(data[1]), int(data[2])
    w, inv_EA, tol, max_iter = params[0], params[1], params[2], int(params[3])
    flags = params[4:6] != 0.0
    for k in range(n):
        if not (math.isfinite(pose[k]) and math.isfinite(wrench[k])):
            return BAD_INPUT, 0
    anchors = data[cf.HEADER:cf.HEADER + 3 * m].reshape((m, 3))
    attachments = data[cf.HEADER + 3 * m:cf.HEADER + 6 * m].reshape((m, 3))
    terms = data[cf.HEADER + 6 * m:cf.HEADER + 12 * m].reshape((6, m))
    A, b, bs, lbs, ubs, q, c, Tn, curv, M, col, tmp, sol, cf_work = work_views(work, m, n)
    if geometry_into(kind, anchors, attachments, data[8:cf.HEADER], data[3], data[4], pose,
                     wrench, A, b) != GEOMETRY_OK:
        return FALLBACK, 0
    if not cable_planes_into(kind, anchors, attachments, pose, geo):
        return FALLBACK, 0
    if not warm:
        if cf.solve_one(data, pose, wrench, terms[2], False, cf_work, T)[0] != 0:
            return FALLBACK, 0  # the reference starts from the margin search
        multipliers_into(A, b, terms[3], terms[4], terms[0], terms[1], T, lam, M)
    cab[:, 4] = 0.0
    if not catenaries_into(geo, T, w, inv_EA, cab, tmp):
        return FALLBACK, 0
    restarts, its = 0, 0
    for _ in range(max_iter):
        its += 1
        if not (linearise(kind, geo, cab, T, b, terms, flags, w, inv_EA, A, bs, lbs, ubs, q,
                          c) and add_curvature(kind, geo, T, lam, w, inv_EA, A, bs, lbs, q,
                                               c, curv, col, sol)):
            return FALLBACK, its
        # No min-max term: a bool that is not the literal False (which would compile
        # solve_form a second time).
        code = cf.solve_form(A, bs, lbs, ubs, q, c, terms[2], Tn.size < 0, data[6], Tn,
                             cf_work)[0]
        if code == cf.CODE_FALLBACK:
            return FALLBACK, its
        if code != 0 and code != 3:  # no solution of the linearisation: restart
            if restarts >= MAX_RESTARTS:
                return INFEASIBLE, its
            restarts += 1
            for i in range(m):
                Tn[i] = 2.0 * T[i]
            if not catenaries_into(geo, Tn, w, inv_EA, cab, tmp):
                return FALLBACK, its
            T[:] = Tn
            continue
        multipliers_into(A, bs, lbs, ubs, q, c, Tn, lam, M)
        if not catenaries_into(geo, Tn, w, inv_EA, cab, tmp):
            return FALLBACK, its  # the reference halves the step
        big, top = 0.0, 0.0
        for i in range(m):
            big, top = max(big, abs(Tn[i] - T[i])), max(top, abs(T[i]))
        T[:] = Tn
        if big / top <= tol:
            return SETTLED, its
    return MAX_ITER, its


@njit(cache=True, error_model="numpy")
def certify(kind: int, geo: NDArray, cab: NDArray, A: NDArray, b: NDArray, lb: NDArray,
            ub: NDArray, forces: NDArray, total: NDArray) -> tuple[float, float, float]:
    """Platform forces ``forces`` (m, 3) of the catenaries ``cab``, and
    ``(equilibrium residual, largest bound violation along a cable, load scale)``
    (N, N m): ``||sum of the cable wrenches - b||``, the violation of ``[lb, ub]`` (m,)
    by the lowest and highest tension along each cable, ``max(||b||, largest lb)``."""
    total[:] = 0.0
    violation = 0.0
    for i in range(geo.shape[0]):
        H, V_B, V_A = cab[i, 0], cab[i, 1], cab[i, 2]
        f0, f1 = H * geo[i, 3], H * geo[i, 4]
        forces[i, 0], forces[i, 1], forces[i, 2] = f0, f1, V_A
        add_wrench(kind, total, f0, f1, V_A, geo[i, 5], geo[i, 6], geo[i, 7])
        T_A, T_B = math.hypot(H, V_A), math.hypot(H, V_B)
        low = H if (V_A < 0.0 and V_B > 0.0) else min(T_A, T_B)
        violation = max(violation, lb[i] - low, max(T_A, T_B) - ub[i])
    res = 0.0
    for k in range(b.size):
        res += (total[k] - b[k]) ** 2
    return math.sqrt(res), violation, cf.pose_scales(A, b, lb)[1]


@njit(cache=True, error_model="numpy")
def solve_pose(data: NDArray, params: NDArray, pose: NDArray, wrench: NDArray, T: NDArray,
               lam: NDArray, warm: bool, geo: NDArray, cab: NDArray, forces: NDArray,
               work: NDArray) -> tuple[int, int, float]:
    """:func:`coupled_pose`, then the platform forces ``forces`` (m, 3) and the
    certificate: ``(code, iterations, residual)``, ``SETTLED`` turned ``UNCERTIFIED``
    where the residual or a bound violation exceeds :data:`CERT_TOL` of the load."""
    m, n = int(data[1]), int(data[2])
    code, its = coupled_pose(data, params, pose, wrench, T, lam, warm, geo, cab, work)
    if code != SETTLED and code != MAX_ITER:
        return code, its, np.nan
    terms = data[cf.HEADER + 6 * m:cf.HEADER + 12 * m].reshape((6, m))
    A, b, _, _, _, _, _, _, _, _, total, _, _, _ = work_views(work, m, n)
    res, violation, scale = certify(int(data[0]), geo, cab, A, b, terms[3], terms[4], forces,
                                    total)
    if code == SETTLED and not (res <= CERT_TOL * scale and violation <= CERT_TOL * scale):
        code = UNCERTIFIED
    return code, its, res


class CoupledIK:
    """``catenary.inverse_kinematics(robot, pose, model="coupled", ...)`` for one pose
    at a time, built once per robot and options, called per pose.

    Parameters
    ----------
    robot, objective, backend, tol, max_iter
        As in :func:`catenary.inverse_kinematics` (no smoothing or rate limit; ``tol``
        the relative change of the tensions to stop at, ``max_iter`` the hard cap).
        ``"auto"`` and ``"closed_form"`` run compiled for point-mass and spatial robots
        with a null space of dimension 1 or 2 and the objectives min-sum, min-norm,
        pseudo-inverse and centred; everything else runs the numpy function.
    warm_start : bool
        Start each pose from the last converged pose's tensions and multipliers (this
        thread's stream); :meth:`reset` forgets them.
    **options
        Backend options, as in :func:`catenary.inverse_kinematics`.

    Calling
    -------
    ``ik(pose, wrench=None)``, a pose (n,) (m, rad) and an external wrench (n,) (N, N m),
    returns the :class:`~catenary.inverse.InverseKinematicsResult` of the pose (arrays
    with a first axis of length 1); the status is the reference's, but ``converged``
    also needs the certificate of the module docstring (else ``inaccurate``).

    Raises
    ------
    InvalidCableError
        For a robot without cable properties, a sequential problem, a bad ``tol`` or
        ``max_iter``, or a pose that is not one vector of ``robot.dof`` numbers.
    """

    #: Kinds the kernel covers (the robot's wrench rows are force, or force and moment).
    KINDS: ClassVar[tuple[str, ...]] = ("point3", "spatial6")

    def __init__(self, robot: CableRobot, objective: str | TensionProblem = "min_sum",
                 backend: str = "auto", *, tol: float = 1e-10, max_iter: int = 50,
                 warm_start: bool = True, **options: Any) -> None:
        self.w, self.EA = cable_data(robot)
        if not (isinstance(tol, float | int) and 0.0 < tol < 1.0):
            raise InvalidCableError(f"tol must be a number in (0, 1); got tol={tol!r}")
        if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1:
            raise InvalidCableError(
                f"max_iter must be a positive integer; got max_iter={max_iter!r}")
        self.robot, self.problem = robot, as_problem(objective)
        if self.problem.is_sequential:
            raise InvalidCableError(
                "the coupled model solves poses independently: smoothing and rate limits "
                "are not supported (use a problem without them)")
        # Checks the problem against the robot (bounds, weights, objective) once.
        self.problem.standard_form(robot, robot.default_home()[None, :])
        self.backend, self.options = backend, dict(options)
        self.tol, self.max_iter, self.warm_start = float(tol), max_iter, bool(warm_start)
        self._local = threading.local()
        announce("coupled sag IK", coupled_pose)
        self._data = self._pack() if self._compiled() else None
        m, n = robot.m, robot.dof
        self._work = work_floats(m, n)
        self._no_wrench = np.zeros(n)
        objective_ = self.problem.objective
        assert not isinstance(objective_, str)  # TensionProblem resolves a name to its Objective
        self._params = np.array([self.w, 0.0 if math.isinf(self.EA) else 1.0 / self.EA,
                                 self.tol, float(max_iter), float(objective_.bounded),
                                 float(objective_.name == "centered")])
        self._seed: tuple[NDArray, NDArray] | None = None
        if self._data is not None:
            bufs = (np.empty(m), np.empty(n), np.empty((m, _GEO)), np.empty((m, 5)),
                    np.empty((m, 3)), np.empty(self._work))
            home = writable(robot.default_home())  # the type every pose has (_vector)
            if self._solve(home, self._no_wrench, None, bufs)[0] == SETTLED:
                self._seed = (bufs[0].copy(), bufs[1].copy())

    def _compiled(self) -> bool:
        """Whether the kernel solves this problem as the reference would."""
        robot, problem = self.robot, self.problem
        objective = problem.objective
        assert not isinstance(objective, str)  # TensionProblem resolves a name to its Objective
        return (self.w > 0.0 and robot.kind in self.KINDS
                and isinstance(self.backend, str) and self.backend in ("auto", "closed_form")
                and not set(self.options) - {"accuracy"} and robot.m - robot.dof in (1, 2)
                and objective.name in ("min_sum", "min_norm", "pinv", "centered")
                and not any(np.ndim(v) > 1 for v in (problem.t_min, problem.t_max,
                                                     problem.reference) if v is not None))

    def _pack(self) -> NDArray:
        """The constant data of the kernels
        (:func:`tension_opt.kernels.closed_form.pack_problem`)."""
        return cf.pack_problem(self.robot, self.problem,
                               accuracy_target(self.options.get("accuracy")))

    def reset(self) -> None:
        """Forget this thread's last pose (the next one starts cold)."""
        self._local.last = None

    def __call__(self, pose: ArrayLike, wrench: ArrayLike | None = None
                 ) -> InverseKinematicsResult:
        """Lengths and forces of one pose (see the class docstring)."""
        p = self._vector("pose", pose)
        w = self._no_wrench if wrench is None else self._vector("wrench", wrench)
        if self._data is None:
            return self._reference(p, wrench)
        m, n = self.robot.m, self.robot.dof
        T, lam = np.empty(m), np.empty(n)
        geo, cab, forces = np.empty((m, _GEO)), np.empty((m, 5)), np.empty((m, 3))
        work = np.empty(self._work)
        last = getattr(self._local, "last", None) if self.warm_start else None
        bufs = (T, lam, geo, cab, forces, work)
        code, its, res = self._solve(p, w, last, bufs) if last is not None else (FALLBACK, 0, 0)
        if code != SETTLED:  # cold: from the straight-line distribution
            code, its, res = self._solve(p, w, None, bufs)
        if code == FALLBACK and self._seed is not None:  # from the home answer
            code, its, res = self._solve(p, w, self._seed, bufs)
            code = code if code == SETTLED else FALLBACK
        if code == BAD_INPUT:
            self.robot.as_poses(p)  # raises the robot's error naming the pose
            raise InvalidCableError(f"wrench must be finite; got wrench={wrench!r}")
        if code == FALLBACK:
            return self._reference(p, wrench)
        if code == SETTLED:
            self._local.last = (T.copy(), lam.copy())
        return self._result(code, its, res, geo, cab, forces)

    def _solve(self, p: NDArray, w: NDArray, start: tuple[NDArray, NDArray] | None,
               bufs: tuple[NDArray, ...]) -> tuple[int, int, float]:
        """:func:`solve_pose` from ``start`` (tensions, multipliers), or cold if None."""
        T, lam, geo, cab, forces, work = bufs
        if start is not None:
            T[:], lam[:] = start
        data = self._data
        assert data is not None  # called only where the kernel serves the problem
        return solve_pose(data, self._params, p, w, T, lam, start is not None, geo,
                          cab, forces, work)

    def _vector(self, name: str, value: ArrayLike) -> NDArray:
        """``value`` as a float vector of ``robot.dof`` entries, or the error."""
        try:
            # Writable always: a read-only pose is another type to numba, which would
            # compile the whole pose solve a second time for it.
            v = writable(value)
        except (TypeError, ValueError) as exc:
            raise InvalidCableError(f"{name} must be numbers; got {name}={value!r}") from exc
        if v.shape != (self.robot.dof,):
            raise InvalidCableError(
                f"{name} must have shape ({self.robot.dof},) (one pose of this robot); got "
                f"shape {v.shape}: use catenary.inverse_kinematics for a batch of poses")
        return v

    def _result(self, code: int, its: int, res: float, geo: NDArray, cab: NDArray,
                forces: NDArray) -> InverseKinematicsResult:
        """The result of a pose the kernel answered."""
        H, V_B, V_A, L0 = (cab[None, :, k].copy() for k in range(4))
        if code == INFEASIBLE:  # the reference reports no catenaries for it
            H, V_B, V_A, L0 = (np.full_like(H, np.nan) for _ in range(4))
            forces, res = np.full_like(forces, np.nan), np.nan
        return InverseKinematicsResult(
            lengths=L0, straight_lengths=geo[None, :, 2].copy(), tensions=np.hypot(H, V_B),
            tensions_platform=np.hypot(H, V_A), horizontal_tensions=H,
            platform_forces=forces[None], equilibrium_residual=np.array([res]),
            iterations=np.array([its], dtype=np.int64),
            catenary_iterations=cab[None, :, 4].astype(np.int64),
            status=np.array([_STATUS[code]], dtype=STATUS_DTYPE), model="coupled",
            solve_time=0.0, problem=self.problem)

    def _reference(self, p: NDArray, wrench: ArrayLike | None) -> InverseKinematicsResult:
        """The numpy function (which holds its status to the same certificate,
        :func:`catenary.inverse.coupled_certificate`)."""
        result = inverse_kinematics(self.robot, p, "coupled", self.problem, self.backend,
                                    wrench, tol=self.tol, max_iter=self.max_iter,
                                    **self.options)
        if self.warm_start and result.status[0] == Status.CONVERGED:
            self._local.last = None  # no multipliers to continue from
        return result
