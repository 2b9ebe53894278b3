"""The scaled dense QP of one pose for DAQP, and the judgement of DAQP's answer, compiled.

The problem handed to DAQP is the one the ``qpsolvers:daqp`` backend builds
(:func:`tension_opt.certify.scaling.scaled_batch`: tensions over the pose's typical tension,
equilibrium rows over their norms, objective over its largest Hessian entry), laid out
as DAQP takes it: ``m`` simple bounds, then ``n`` equality rows. The answer is judged
as :meth:`tension_opt.distribution.solution.TensionSolution.from_form` judges it, with DAQP's own
multipliers: optimal only when the equilibrium residual and bound violation are within
the feasibility tolerance and the certificate's primal residual, dual residual and
duality gap are within the accuracy target (:mod:`tension_opt.certify.certificate`). A pose
that misses any of these is left to the numpy path, whose certificate may estimate
better multipliers, so that a status never claims more than the numpy path would.

Only quadratic objectives without min-max terms or extra rows are covered (an LP needs
the two-stage tie-break of :class:`tension_opt.backends.base.Backend`).

:func:`solve_pose` builds the QP, calls DAQP's C solver and judges its answer in one
compiled call (:mod:`tension_opt.kernels.daqp_native`); where that is not available
(another daqp version), :class:`DaqpPose` calls ``daqp.solve`` between the compiled
steps, with the same answer.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from tension_opt.kernels import daqp_native
from tension_opt.kernels.closed_form import (
    CODE_BAD_INPUT,
    CODE_FALLBACK,
    HEADER,
    form_terms,
    judge,
    plain,
    pose_scales,
)
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into
from tension_opt.kernels.scaling import pose_scaling
from tension_opt.tolerances import ROW_FLOOR, UB_SHARE

__all__ = ["BIG", "LINEAR_CAP", "DaqpPose", "objective_factor", "qp_build", "qp_judge",
           "qp_problem", "qp_size", "qp_verdict", "qp_views", "scale_objective",
           "sequence_pose", "sequence_size", "sequence_verdict", "solve_pose",
           "solve_sequence"]

#: DAQP's infinity.
BIG = 1e30
#: Largest linear term of the scaled QP handed to the solver. A term far above the
#: quadratic one (a min-norm ``reference`` of 1e18 N: about 1e15 against 1) is beyond
#: DAQP's arithmetic: it called feasible poses infeasible. Such an objective is handed
#: over divided by a power of two (:func:`objective_factor`), which moves no optimum and
#: is exact; the multipliers are multiplied back before the certificate is measured.
LINEAR_CAP = 2.0**20


@njit(cache=True, error_model="numpy", inline="always")
def objective_factor(f: NDArray) -> float:
    """The power of two DAQP's objective (``H``, ``f``) is multiplied by before it is
    solved: 1 where the largest linear term ``|f_i|`` is at most :data:`LINEAR_CAP`, else
    the one that brings it within (numpy reference:
    :func:`tension_opt.backends.qpsolvers_backend.objective_factors`)."""
    largest = 0.0
    for i in range(f.size):
        largest = max(largest, abs(f[i]))
    factor = 1.0
    if largest > LINEAR_CAP and math.isfinite(largest):
        factor = 2.0 ** -math.ceil(math.log2(largest / LINEAR_CAP))
    if f.size < 0:  # never: f read after the branch (see tension_opt.kernels)
        factor = np.nan
    return factor


@njit(cache=True, error_model="numpy", inline="always")
def scale_objective(H: NDArray, f: NDArray, lam: NDArray, by: float) -> None:
    """Multiply DAQP's objective (the diagonal of ``H``, ``f``) and the multipliers
    ``lam`` by ``by`` (a power of two, exact), in place: before the solve with
    :func:`objective_factor`, after it with its inverse."""
    for i in range(f.size if by != 1.0 else 0):
        H[i, i] *= by
        f[i] *= by
    for j in range(lam.size if by != 1.0 else 0):
        lam[j] *= by


@njit(cache=True, error_model="numpy")
def qp_problem(data: NDArray, pose: NDArray, wrench: NDArray, prev: NDArray,
               has_prev: bool, work: NDArray, qp: NDArray) -> tuple[int, float]:
    """Write the scaled QP of one pose in DAQP's layout.

    Parameters
    ----------
    data : ndarray
        The problem (:func:`tension_opt.kernels.closed_form.pack`).
    pose, wrench : ndarray, shape (n,)
    prev : ndarray, shape (m,)
        Previous tensions (N), used where ``has_prev``.
    work : ndarray
        At least ``n m + 2 n + 4 m`` floats, kept for :func:`qp_judge`.
    qp : ndarray, shape (qp_size(m, n),)
        DAQP's arrays end to end (:func:`qp_views`): the diagonal Hessian (m, m) (only
        its diagonal is written), ``f`` (m,), the scaled equilibrium rows (n, m), and
        ``upper``, ``lower`` (m + n,) (bounds, then the right-hand sides of the
        equations).

    Returns
    -------
    tuple
        ``(code, scale)``: code 0 (ready), ``CODE_FALLBACK`` (a degenerate pose, an
        LP) or ``CODE_BAD_INPUT``; the reference tension (N), as
        :meth:`~tension_opt.problem.form.StandardForm.scaling` gives it
        (:func:`~tension_opt.kernels.scaling.pose_scaling`).
    """
    m, n = int(data[1]), int(data[2])
    for i in range(n):
        if not (math.isfinite(pose[i]) and math.isfinite(wrench[i])):
            return CODE_BAD_INPUT, np.nan
    H, f, Ad, upper, lower = qp_views(qp, m, n)
    A = work[:n * m].reshape((n, m))
    b = work[n * m:n * m + n]
    o = n * m + n
    q, c, lb, ub = work[o:o + m], work[o + m:o + 2 * m], work[o + 2 * m:o + 3 * m], \
        work[o + 3 * m:o + 4 * m]
    anchors = data[HEADER:HEADER + 3 * m].reshape((m, 3))
    attachments = data[HEADER + 3 * m:HEADER + 6 * m].reshape((m, 3))
    terms = data[HEADER + 6 * m:HEADER + 12 * m].reshape((6, m))
    if geometry_into(int(data[0]), anchors, attachments, data[8:HEADER], data[3], data[4],
                     pose, wrench, A, b) != GEOMETRY_OK:
        return CODE_FALLBACK, np.nan
    form_terms(terms[0], terms[1], terms[3], terms[4], data[5], terms[5], prev, has_prev,
           q, c, lb, ub)
    return qp_build(A, b, q, c, lb, ub, work[o + 4 * m:o + 4 * m + n], H, f, Ad, upper,
                    lower)


@njit(cache=True, error_model="numpy", inline="always")
def qp_build(A: NDArray, b: NDArray, q: NDArray, c: NDArray, lb: NDArray, ub: NDArray,
             rows: NDArray, H: NDArray, f: NDArray, Ad: NDArray, upper: NDArray,
             lower: NDArray) -> tuple[int, float]:
    """The scaled QP of a pose's form (``A`` (n, m), ``b`` (n,), ``q, c, lb, ub``
    (m,)) written into DAQP's arrays (:func:`qp_views`; ``rows`` (n,) gets the rows'
    factors); ``(code, scale)`` as :func:`qp_problem`."""
    n, m = A.shape
    s, top, quadratic = pose_scaling(A, b, lb, ub, q, c, 0.0, UB_SHARE, ROW_FLOOR, rows)
    # (Loops that run only for a QP, and one return: see tension_opt.kernels.)
    for i in range(m if quadratic else 0):
        H[i, i] = q[i] / top
        f[i] = c[i] / top / s
        upper[i] = min(ub[i] / s, BIG)
        lower[i] = max(lb[i] / s, -BIG)
    for k in range(n if quadratic else 0):
        for i in range(m):
            Ad[k, i] = A[k, i] * rows[k]
        upper[m + k] = lower[m + k] = b[k] * rows[k] / s
    return (0 if quadratic else CODE_FALLBACK), (s if quadratic else np.nan)


@njit(cache=True)
def qp_size(m: int, n: int) -> int:
    """Floats of DAQP's arrays for ``m`` cables and ``n`` degrees of freedom."""
    return m * m + m + n * m + 2 * (m + n)


@njit(cache=True)
def qp_views(qp: NDArray, m: int, n: int) -> tuple[NDArray, NDArray, NDArray, NDArray,
                                                   NDArray]:
    """``(H, f, A, upper, lower)`` as views of one array (see :func:`qp_problem`)."""
    o = m * m
    return (qp[:o].reshape((m, m)), qp[o:o + m], qp[o + m:o + m + n * m].reshape((n, m)),
            qp[o + m + n * m:o + 2 * m + n * m + n], qp[o + 2 * m + n * m + n:])


@njit(cache=True, error_model="numpy")
def qp_judge(data: NDArray, work: NDArray, qp: NDArray, x: NDArray, lam: NDArray,
             s: float, target: float, T: NDArray, sense: NDArray, warm: bool
             ) -> tuple[int, float, float, float, float]:
    """Tensions ``T = s x`` (m,) of DAQP's scaled solution ``x``, and whether they are
    certified optimal with DAQP's multipliers ``lam`` (bounds, then equations).

    With ``warm``, the bounds active at this answer (a nonzero multiplier) are marked
    in DAQP's ``sense`` (m + n,) as the working set the next pose starts from.
    Returns ``(code, residual, primal, dual, gap)``: code 0 (optimal) or
    ``CODE_FALLBACK`` (the numpy path judges the pose); the equilibrium residual
    ``||A T - b||`` (N, N m); the certificate's primal residual, dual residual and
    relative duality gap (:mod:`tension_opt.certify.certificate`; NaN where not
    measured).
    """
    m, n = int(data[1]), int(data[2])
    H, f, Ad, upper, _ = qp_views(qp, m, n)
    for i in range(m):  # DAQP's types: 1 active, + 2 at the lower bound
        sense[i] = 0 if not warm or lam[i] == 0.0 else (3 if lam[i] < 0.0 else 1)
    A = work[:n * m].reshape((n, m))
    b = work[n * m:n * m + n]
    o = n * m + n
    lb, ub = work[o + 2 * m:o + 3 * m], work[o + 3 * m:o + 4 * m]
    return qp_verdict(A, b, lb, ub, data[6], H, f, Ad, upper, x, lam, s, target, T)


@njit(cache=True, error_model="numpy")
def qp_verdict(A: NDArray, b: NDArray, lb: NDArray, ub: NDArray, tol_factor: float,
               H: NDArray, f: NDArray, Ad: NDArray, upper: NDArray, x: NDArray,
               lam: NDArray, s: float, target: float, T: NDArray
               ) -> tuple[int, float, float, float, float]:
    """:func:`qp_judge` of a pose's form (``A``, ``b``, ``lb``, ``ub``; ``tol_factor``
    the feasibility tolerance's factor of the packed problem) and its QP (``H``, ``f``,
    ``Ad``, ``upper``, :func:`qp_views`), without the working set."""
    n, m = A.shape
    for i in range(m):
        if not (math.isfinite(x[i]) and math.isfinite(lam[i])):
            return CODE_FALLBACK, np.nan, np.nan, np.nan, np.nan
        T[i] = x[i] * s
    code, res = judge(A, b, lb, ub, T, tol_factor * pose_scales(A, b, lb)[1])
    if code != 0:
        return CODE_FALLBACK, res, np.nan, np.nan, np.nan
    primal = dual = 0.0
    gap = objective = 0.0
    for k in range(n):
        r = -upper[m + k]
        for i in range(m):
            r += Ad[k, i] * x[i]
        primal = max(primal, abs(r))
        gap += upper[m + k] * lam[m + k]
    for i in range(m):
        lo, hi = lb[i] / s, ub[i] / s
        primal = max(primal, lo - x[i], x[i] - hi)
        # The bound multiplier in its cone (>= 0 only with a finite upper bound, <= 0
        # only with a finite lower one).
        z = min(max(lam[i], -np.inf if math.isfinite(lo) else 0.0),
                np.inf if math.isfinite(hi) else 0.0)
        grad = H[i, i] * x[i] + f[i]
        station = grad + z
        for k in range(n):
            station += Ad[k, i] * lam[m + k]
        dual = max(dual, abs(station))
        gap += grad * x[i] + (hi * z if z > 0.0 else 0.0) + (lo * z if z < 0.0 else 0.0)
        objective += (0.5 * H[i, i] * x[i] + f[i]) * x[i]
    relative = abs(gap) / max(1.0, abs(objective))
    if primal <= target and dual <= target and relative <= target:
        return 0, res, primal, dual, relative
    return CODE_FALLBACK, res, primal, dual, relative


@njit(cache=True, nogil=True, error_model="numpy")
def solve_pose(data: NDArray, pose: NDArray, wrench: NDArray, prev: NDArray, has_prev: bool,
               target: float, T: NDArray, floats: NDArray, sense: NDArray, structs: NDArray,
               warm: bool) -> tuple[int, float, int, float, float, float]:
    """One pose through DAQP's C solver in one compiled call: :func:`qp_problem`,
    ``daqp_quadprog`` (:func:`~tension_opt.kernels.daqp_native.quadprog`), and
    :func:`qp_judge`.

    Parameters
    ----------
    data, pose, wrench, prev, has_prev
        As :func:`qp_problem`.
    target : float
        Accuracy target of the certificate (:func:`qp_judge`).
    T : ndarray, shape (m,)
        The tensions (N), written.
    floats : ndarray
        DAQP's arrays (``qp_size(m, n)`` floats, :func:`qp_views`), its solution (m,)
        and multipliers (m + n,), then the work space (:func:`qp_problem`), end to end
        (one argument for all three, so that calling costs little).
    sense : ndarray of int32, shape (m + n,)
        DAQP's constraint types: the working set to start from, then (with ``warm``)
        the bounds active at this answer; cleared after a failed solve.
    structs : ndarray of int64
        :func:`~tension_opt.kernels.daqp_native.struct_buffer`'s array.
    warm : bool
        Whether the next pose starts from this one's active bounds.

    Returns
    -------
    tuple
        ``(code, residual, iterations, primal, dual, gap)``: as
        :meth:`DaqpPose.solve`, with DAQP's iterations (-1 when DAQP was not called)
        third.
    """
    m, n = int(data[1]), int(data[2])
    size = qp_size(m, n)
    qp, x, lam = floats[:size], floats[size:size + m], floats[size + m:size + 2 * m + n]
    work = floats[size + 2 * m + n:]
    code, s = qp_problem(data, pose, wrench, prev, has_prev, work, qp)
    if code:
        return code, np.nan, -1, np.nan, np.nan, np.nan
    H, f, Ad, upper, lower = qp_views(qp, m, n)
    factor = objective_factor(f)
    scale_objective(H, f, lam[:0], factor)
    flag, iterations = daqp_native.quadprog(H, f, Ad, upper, lower, sense, x, lam, structs)
    scale_objective(H, f, lam, 1.0 / factor)  # the QP and multipliers as built
    if flag <= 0:  # infeasible, unbounded, iteration cap: the numpy path reports it
        sense[:m] = 0  # and the next pose starts cold
        return CODE_FALLBACK, np.nan, iterations, np.nan, np.nan, np.nan
    code, res, primal, dual, gap = qp_judge(data, work, qp, x, lam, s, target, T, sense,
                                            warm)
    return code, res, iterations, primal, dual, gap


def sequence_size(m: int, n: int) -> int:
    """Floats of the work array of :func:`solve_sequence` and :func:`sequence_pose`:
    DAQP's arrays (:func:`qp_views`), the solution (m,) and multipliers (m + n,), the
    pose's terms ``q, c, lb, ub`` (m,) each, the rows' factors (n,) and the scaled
    bounds ``lb / s``, ``ub / s`` (m,) each."""
    return qp_size(m, n) + 9 * m + 2 * n


@njit(cache=True, error_model="numpy", inline="always")
def _pose_qp(A: NDArray, b: NDArray, lb0: NDArray, ub0: NDArray, q0: NDArray,
             c0: NDArray, smoothing: float, rate: NDArray, last: NDArray, has_last: bool,
             k: int, floats: NDArray) -> tuple[int, float]:
    """Pose ``k``'s form smoothed against ``last`` and its scaled QP, written into
    ``floats`` (:func:`sequence_size`); ``(code, scale)`` as :func:`qp_build`, code
    ``CODE_FALLBACK`` also for data beyond the kernels' range (NaN, magnitudes from
    ``closed_form.HUGE``: :func:`~tension_opt.kernels.closed_form.plain`)."""
    _, n, m = A.shape
    size = qp_size(m, n)
    o = size + 2 * m + n
    q, c, lb, ub = floats[o:o + m], floats[o + m:o + 2 * m], floats[o + 2 * m:o + 3 * m], \
        floats[o + 3 * m:o + 4 * m]
    rows = floats[o + 4 * m:o + 4 * m + n]
    lbs, ubs = floats[o + 4 * m + n:o + 5 * m + n], floats[o + 5 * m + n:o + 6 * m + n]
    H, f, Ad, upper, lower = qp_views(floats[:size], m, n)
    form_terms(q0[k], c0[k], lb0[k], ub0[k], smoothing, rate, last, has_last, q, c, lb, ub)
    code, s = CODE_FALLBACK, np.nan
    if plain(A[k], b[k], lb, ub, q, c):  # data the closed form's kernels take too
        code, s = qp_build(A[k], b[k], q, c, lb, ub, rows, H, f, Ad, upper, lower)
    for i in range(m if code == 0 else 0):  # the generic solvers' bounds
        lbs[i], ubs[i] = lb[i] / s, ub[i] / s
    return code, s


@njit(cache=True, error_model="numpy", inline="always")
def _pose_verdict(A: NDArray, b: NDArray, k: int, floats: NDArray, tol_factor: float,
                  target: float, s: float, T: NDArray) -> int:
    """:func:`qp_verdict` of pose ``k`` of :func:`_pose_qp` on the solution and
    multipliers in ``floats`` (bounds, then equations), its tensions into ``T``."""
    _, n, m = A.shape
    size = qp_size(m, n)
    x, lam = floats[size:size + m], floats[size + m:size + 2 * m + n]
    o = size + 2 * m + n
    lb, ub = floats[o + 2 * m:o + 3 * m], floats[o + 3 * m:o + 4 * m]
    H, f, Ad, upper, _ = qp_views(floats[:size], m, n)
    return qp_verdict(A[k], b[k], lb, ub, tol_factor, H, f, Ad, upper, x, lam, s, target,
                      T)[0]


@njit(cache=True, nogil=True, error_model="numpy")
def sequence_pose(A: NDArray, b: NDArray, lb0: NDArray, ub0: NDArray, q0: NDArray,
                  c0: NDArray, smoothing: float, rate: NDArray, last: NDArray,
                  has_last: bool, k: int, floats: NDArray) -> tuple[int, float]:
    """Pose ``k`` of a smoothed sequence as :func:`solve_sequence` builds it, for a
    solver called from Python (the arrays of :func:`solve_sequence`); ``(code,
    scale)``, code 0 where the pose is a QP ready in ``floats``."""
    return _pose_qp(A, b, lb0, ub0, q0, c0, smoothing, rate, last, has_last, k, floats)


@njit(cache=True, nogil=True, error_model="numpy")
def sequence_verdict(A: NDArray, b: NDArray, k: int, floats: NDArray, tol_factor: float,
                     target: float, s: float, T: NDArray) -> int:
    """The verdict of :func:`solve_sequence` on a solution and multipliers written into
    ``floats`` (:func:`sequence_size`) by a solver called from Python: 0 (certified
    optimal, ``T`` (m,) written) or ``CODE_FALLBACK``."""
    return _pose_verdict(A, b, k, floats, tol_factor, target, s, T)


@njit(cache=True, nogil=True, error_model="numpy")
def solve_sequence(A: NDArray, b: NDArray, lb0: NDArray, ub0: NDArray, q0: NDArray,
                   c0: NDArray, smoothing: float, rate: NDArray, tol_factor: float,
                   target: float, last: NDArray, has_last: bool, T: NDArray,
                   iterations: NDArray, start: int, floats: NDArray, sense: NDArray,
                   structs: NDArray) -> int:
    """Poses ``start, start + 1, ...`` of a smoothed sequence through DAQP's C solver,
    each as the ``qpsolvers:daqp`` backend solves its one-pose form.

    Each pose's form is smoothed against ``last`` (``form_terms``, as
    :func:`tension_opt.kernels.closed_form.solve_forms_sequence` does), scaled and laid
    out as :func:`qp_problem` does, solved cold (as a batch of one pose starts), and
    judged by :func:`qp_verdict`; ``last`` then takes its tensions. The run stops at the
    first pose this does not settle (an LP, data beyond the kernels' range, DAQP without a
    solution, an answer the verdict does not certify), for the backend to solve on its
    own form, and returns its index (N when done).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
    b : ndarray, shape (N, n)
    lb0, ub0, q0, c0 : ndarray, shape (N, m)
        The unsmoothed forms of the poses.
    smoothing : float
    rate : ndarray, shape (m,)
        Rate limits (N), ``inf`` where none.
    tol_factor, target : float
        Feasibility tolerance factor and accuracy target (:func:`qp_verdict`).
    last : ndarray, shape (m,)
        Tensions (N) the first pose is smoothed against (read where ``has_last``),
        written with each certified pose's.
    T : ndarray, shape (N, m)
        Tensions (N), written for the poses settled.
    iterations : ndarray of int64, shape (N,)
        DAQP's iterations, written for the poses settled.
    floats : ndarray
        Zeros, :func:`sequence_size` floats.
    sense : ndarray of int32, shape (m + n,)
        DAQP's constraint types: bounds free (0), equations 5.
    structs : ndarray of int64
        :func:`~tension_opt.kernels.daqp_native.struct_buffer`'s array.
    """
    N, n, m = A.shape
    size = qp_size(m, n)
    x, lam = floats[size:size + m], floats[size + m:size + 2 * m + n]
    H, f, Ad, upper, lower = qp_views(floats[:size], m, n)
    for k in range(start, N):
        code, s = _pose_qp(A, b, lb0, ub0, q0, c0, smoothing, rate, last, has_last, k,
                           floats)
        if code:
            return k
        sense[:m] = 0  # cold, as a batch of one pose starts
        factor = objective_factor(f)
        scale_objective(H, f, lam[:0], factor)
        flag, count = daqp_native.quadprog(H, f, Ad, upper, lower, sense, x, lam, structs)
        scale_objective(H, f, lam, 1.0 / factor)
        if flag <= 0 or _pose_verdict(A, b, k, floats, tol_factor, target, s, T[k]):
            return k
        iterations[k] = count
        last[:] = T[k]
        has_last = True
    return N


class DaqpPose:
    """One thread's DAQP workspace for the poses of one problem: DAQP's arrays (views
    of one array, written in place by :func:`qp_problem`), the work space, and the
    constraint types, in which the bounds active at the last answer mark the working
    set DAQP starts the next pose from (unless ``warm`` is False).

    DAQP's C solver is called from the compiled :func:`solve_pose` when
    :func:`tension_opt.kernels.daqp_native.load` finds it (with its result arrays and
    structs kept here); otherwise ``daqp.solve`` is called as the ``qpsolvers:daqp``
    backend calls it (a ``daqp.Model`` updated per pose cost more here: its update alone
    took most of a solve). Both give the same answer, bit for bit.

    Parameters
    ----------
    m, n : int
        Cables and degrees of freedom.
    settings : dict
        DAQP settings (``primal_tol`` ...), as the ``qpsolvers:daqp`` backend passes.
    warm : bool
        Whether to start each pose from the previous pose's active set.
    work : int
        Floats of work space (:func:`tension_opt.kernels.closed_form.work_size`).

    Attributes
    ----------
    iterations : int
        DAQP's iterations on the last pose it solved.
    native : bool
        Whether DAQP's C solver is called from compiled code.
    """

    def __init__(self, m: int, n: int, settings: dict[str, float], warm: bool,
                 work: int) -> None:
        size = qp_size(m, n)
        # DAQP's arrays, its solution and multipliers, the work space (solve_pose).
        self.floats = np.zeros(size + 2 * m + n + work)
        self.qp, self.work = self.floats[:size], self.floats[size + 2 * m + n:]
        self.H, self.f, self.Ad, self.upper, self.lower = qp_views(self.qp, m, n)
        self.sense = np.zeros(m + n, dtype=np.intc)
        self.sense[m:] = 5  # equality rows
        self.settings = dict(settings)
        self.warm = warm
        self.iterations = 0
        c_solver = daqp_native.load()
        self._structs = None if c_solver is None else daqp_native.struct_buffer(
            c_solver, self.settings)
        self.native = self._structs is not None
        if self.native:
            from tension_opt.kernels.launch import entry_point

            # Called with contiguous float64 vectors only (see solve).
            vector = np.zeros(1)
            self._solve_pose = entry_point(solve_pose, vector, vector, vector, vector, False,
                                           0.0, vector, self.floats, self.sense,
                                           self._structs, warm)
        else:
            import daqp

            self._solve: Any = daqp.solve

    def solve(self, data: NDArray, pose: NDArray, wrench: NDArray, prev: NDArray,
              has_prev: bool, target: float, T: NDArray
              ) -> tuple[int, float, float, float, float]:
        """Tensions of one pose written to ``T`` (m,); returns ``(code, residual, primal,
        dual, gap)``: code 0 (certified optimal), ``CODE_FALLBACK`` or
        ``CODE_BAD_INPUT``, the equilibrium residual (N, N m) and the certificate's three
        measures with DAQP's multipliers (NaN where not measured). ``data``,
        ``pose``, ``wrench``, ``prev`` and ``T`` are contiguous float64 vectors (the
        compiled call checks no type)."""
        if self._structs is not None:
            code, res, iterations, primal, dual, gap = self._solve_pose(
                data, pose, wrench, prev, bool(has_prev), float(target), T, self.floats,
                self.sense, self._structs, self.warm)
            if iterations >= 0:
                self.iterations = iterations
            return code, res, primal, dual, gap
        code, s = qp_problem(data, pose, wrench, prev, has_prev, self.work, self.qp)
        if code:
            return code, np.nan, np.nan, np.nan, np.nan
        factor = float(objective_factor(self.f))
        x, _, flag, info = self._solve(self.H * factor, self.f * factor, self.Ad, self.upper,
                                       self.lower, self.sense, **self.settings)
        self.iterations = info["iterations"]
        if flag <= 0:  # infeasible, unbounded, iteration cap: the numpy path reports it
            self.sense[:len(T)] = 0  # and the next pose starts cold
            return CODE_FALLBACK, np.nan, np.nan, np.nan, np.nan
        return qp_judge(data, self.work, self.qp, x, info["lam"] / factor, s, target, T,
                        self.sense, self.warm)
