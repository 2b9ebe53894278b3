"""The coupled sag model: catenary end forces that balance the load, by sequential convex
programming.

The coupled model of :func:`catenary.inverse_kinematics` parameterises cable ``i`` by
its tension ``t_i`` at the platform and the direction ``d_i`` of its end force there,
so that the wrench balance is linear in ``t`` for fixed directions: ``A(d) t = b``,
column ``[d_i; (R a_i) x d_i]``. :class:`CoupledSolver` starts from given tensions
(the straight-line distribution) and, every iteration, for all unconverged poses at
once,

1. solves the catenary of every cable through its attachment and anchor with
   platform-end tension ``t_i`` (:func:`catenary.solve_length`, ``end="A"``) and
   linearises its platform force in ``t_i`` (:func:`~catenary.geometry.force_slope`);
2. maps the tension bounds to the platform end: ``t_min`` bounds the lowest tension
   along the cable, ``t_max`` the highest, so the bounds on ``t_i`` are shifted by
   ``t_i - T_low,i`` and ``t_i - T_high,i`` of the current catenary;
3. solves the linearised distribution problem with the objective through a
   ``tension_opt`` backend, with a diagonal curvature term of the Lagrangian (an SQP
   step, kept convex);
4. halves the step where the new tension holds no taut catenary.

It stops when ``t`` changes less than ``tol`` relative to the largest tension. At
that fixed point the catenaries carrying ``t`` have the directions used in the
balance, so their end forces balance the load exactly, within the bounds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot, TensionProblem
from tension_opt.backends import Backend
from tension_opt.problem.form import StandardForm
from tension_opt.problem.objectives import get_objective
from tension_opt.status import Status, status_array

from .errors import InvalidCableError
from .geometry import (
    CablePlanes,
    extreme_tensions,
    force_slope,
    platform_forces,
    taut_catenaries,
)

__all__ = ["CatenarySolution", "CoupledSolver"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class CatenarySolution:
    """Catenaries of every cable of a batch of poses, and how they were found.

    The result of :class:`CoupledSolver` (and of the thesis convention of
    :func:`catenary.inverse_kinematics`).

    Attributes
    ----------
    H, V_A, V_B : ndarray, shape (N, m)
        Horizontal tension and vertical end forces of each catenary (N), of the last
        iterate that holds a taut catenary; NaN where none was found.
    L0 : ndarray, shape (N, m)
        Unstretched lengths (m).
    tensions : ndarray, shape (N, m)
        Tensions the catenaries were solved for (N): platform end in the coupled
        model, drawing point in the thesis convention.
    status : ndarray of str, shape (N,)
        ``Status.CONVERGED``; ``Status.INFEASIBLE`` (no tensions within the bounds
        balance the load, or the pose was not attempted); ``"catenary_failed"`` (no
        taut catenary carries the tension); ``Status.MAX_ITER``.
    iterations : ndarray of int, shape (N,)
        Linearised subproblems solved per pose.
    catenary_iterations : ndarray of int, shape (N, m)
        Iterations of the single-cable solver, summed over the subproblems.
    """

    H: FloatArray
    V_A: FloatArray
    V_B: FloatArray
    L0: FloatArray
    tensions: FloatArray
    status: NDArray[np.str_]
    iterations: NDArray[np.int64]
    catenary_iterations: NDArray[np.int64]

    @property
    def success(self) -> NDArray[np.bool_]:
        """Boolean mask of the poses solved, shape (N,)."""
        return np.asarray(self.status == Status.CONVERGED, dtype=bool)


class CoupledSolver:
    """Sequential convex programming of the coupled model for one batch of poses.

    Built once per batch; :meth:`solve` runs the iteration (see the module docstring)
    and keeps the state of the batch while it runs: the current platform-end tensions
    ``tensions`` (N, m), their catenaries ``cables`` (4, N, m) (``H, V_A, V_B, L0``),
    the multipliers of the equilibrium rows ``multipliers`` (N, n), ``status`` (N,),
    ``iterations`` (N,), ``catenary_iterations`` (N, m) and ``restarts`` (N,).

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Validated poses (m, rad).
    planes : CablePlanes
        Their cable planes (:func:`~catenary.geometry.cable_planes`).
    problem : TensionProblem
        Objective and bounds; the bounds apply to the lowest and highest tension along
        each cable. Smoothing and rate limits are not supported.
    backend : Backend
        Solves the linearised problems.
    required : ndarray, shape (N, n)
        Wrench the cables must apply (``robot.required_wrench``) (N, N m).
    cable : (float, float)
        Weight per length ``w`` (N/m) > 0 and axial stiffness ``EA`` (N).
    tol : float
        Stop when the tensions change less than ``tol`` relative to the largest.
    max_iter : int
        Iteration limit.
    options : dict, optional
        Passed to the backend.

    Raises
    ------
    InvalidCableError
        For a problem with smoothing or a rate limit.
    """

    #: Restarts from doubled tensions of a pose whose linearisation has no solution.
    MAX_RESTARTS: ClassVar[int] = 6
    #: Step halvings that look for a tension holding a taut catenary.
    HALVINGS: ClassVar[int] = 30

    def __init__(self, robot: CableRobot, poses: FloatArray, planes: CablePlanes,
                 problem: TensionProblem, backend: Backend, required: FloatArray,
                 cable: tuple[float, float], *, tol: float = 1e-10, max_iter: int = 50,
                 options: dict[str, Any] | None = None) -> None:
        if problem.is_sequential:
            raise InvalidCableError(
                "the coupled model solves poses independently: smoothing and rate limits "
                "are not supported (use a problem without them)"
            )
        self.robot, self.poses, self.planes = robot, poses, planes
        self.problem, self.backend, self.required = problem, backend, required
        self.w, self.EA = cable
        self.tol, self.max_iter = tol, max_iter
        self.options = dict(options or {})
        self.lb, self.ub = problem.bounds(robot, poses.shape[0])
        # Whether the objective takes tension bounds (the pseudo-inverse does not).
        self.bounded = get_objective(problem.objective).bounded
        self._reset(np.full((poses.shape[0], robot.m), np.nan))

    def _reset(self, start: FloatArray) -> None:
        N, m = start.shape
        self.tensions = np.array(start, dtype=float)
        self.cables = np.full((4, N, m), np.nan)
        self.multipliers = np.zeros((N, self.robot.dof))
        self.status = status_array(N, Status.INFEASIBLE)
        self.iterations = np.zeros(N, np.int64)
        self.catenary_iterations = np.zeros((N, m), np.int64)
        self.restarts = np.zeros(N, np.int64)

    def solve(self, start: FloatArray, attempt: NDArray[np.bool_]) -> CatenarySolution:
        """Run the iteration from platform-end tensions ``start`` (N, m) (N).

        Only the poses ``attempt`` (N,) are solved; the others stay
        ``Status.INFEASIBLE``.
        """
        self._reset(start)
        active = self._begin(np.flatnonzero(attempt))
        for _ in range(self.max_iter):
            if active.size == 0:
                break
            active = self._iterate(active)
        H, V_A, V_B, L0 = self.cables
        return CatenarySolution(H, V_A, V_B, L0, self.tensions.copy(), self.status.copy(),
                                self.iterations.copy(), self.catenary_iterations.copy())

    # ------------------------------------------------------------------- steps
    def _catenaries(self, sel: NDArray[np.intp], tens: FloatArray) -> NDArray[np.bool_]:
        """Solve the cables of poses ``sel`` at platform tensions ``tens`` (k, m); True
        where all of a pose's cables have a taut catenary (then kept in ``cables``)."""
        c = taut_catenaries(self.planes.x[sel], self.planes.z[sel], tens, self.w, self.EA,
                            "A")
        self.catenary_iterations[sel] += c.iterations
        good: NDArray[np.bool_] = np.all(c.converged, axis=1)
        self.cables[:, sel[good]] = np.stack([c.H[good], c.V_A[good], c.V_B[good],
                                              c.L0[good]])
        return good

    def _begin(self, idx: NDArray[np.intp]) -> NDArray[np.intp]:
        """Catenaries and multipliers of the start; returns the poses to iterate."""
        good = self._catenaries(idx, self.tensions[idx])
        self.status[idx[~good]] = Status.CATENARY_FAILED
        self.status[idx[good]] = Status.MAX_ITER
        active = idx[good]
        # Multipliers of the equilibrium rows, first from the straight-line problem.
        if active.size:
            A0 = self.robot.structure_matrices(self.poses[active])
            form0 = self.problem.standard_form_from(self.robot, A0, self.required[active])
            self.multipliers[active] = _multipliers(form0, self.tensions[active])
        return active

    def _iterate(self, active: NDArray[np.intp]) -> NDArray[np.intp]:
        """One linearised subproblem for the poses ``active``; returns those left."""
        Ta = self.tensions[active]
        form = self._subproblem(active, Ta)
        raw = self.backend.solve(form, **self.options)
        self.iterations[active] += 1
        solved = (raw.status == Status.OPTIMAL) | (raw.status == Status.INACCURATE)
        pending = (self._restart(active[~solved]) if not solved.all()
                   else np.zeros(0, np.intp))
        self.multipliers[active[solved]] = _multipliers(
            form.subset(np.flatnonzero(solved)), raw.tensions[solved]
        )
        active, Ta, step = active[solved], Ta[solved], raw.tensions[solved] - Ta[solved]
        failed = self._safeguard(active, Ta, step)
        self.status[active[failed]] = Status.CATENARY_FAILED
        active, Ta, step = active[~failed], Ta[~failed], step[~failed]
        self.tensions[active] = Ta + step
        change = np.abs(step).max(axis=1) / np.abs(Ta).max(axis=1)
        done = change <= self.tol
        self.status[active[done]] = Status.CONVERGED
        return np.sort(np.concatenate([active[~done], pending]))

    def _subproblem(self, active: NDArray[np.intp], Ta: FloatArray) -> StandardForm:
        """The distribution problem linearised at tensions ``Ta`` (k, m), with curvature."""
        sub = self.planes.subset(active)
        h, va, vb, l0 = self.cables[:, active]
        # Linearised platform force of each cable in its platform-end tension:
        # f(t) ~ f(Ta) + f'(Ta) (t - Ta). Equilibrium: sum f'(Ta) t = b - sum (f - f' Ta).
        force = platform_forces(sub, h, va)
        slope = force_slope(sub, h, va, vb, l0, self.w, self.EA)
        W1 = self.robot.cable_wrenches(slope, sub.arms)  # (k, m, n)
        A = np.ascontiguousarray(np.swapaxes(W1, 1, 2))
        offset = self.robot.cable_wrenches(force - slope * Ta[..., None], sub.arms).sum(axis=1)
        problem = self.problem
        if self.bounded:
            low, high = extreme_tensions(h, va, vb)
            problem = problem.with_(t_min=self.lb[active] + (Ta - low),
                                    t_max=self.ub[active] + (Ta - high))
        form = problem.standard_form_from(self.robot, A, self.required[active] - offset)
        curv = self._curvature(active, sub, Ta, W1, form)
        return replace(form, q=form.q + curv, c=form.c - curv * Ta)

    def _curvature(self, active: NDArray[np.intp], sub: CablePlanes, Ta: FloatArray,
                   W1: FloatArray, form: StandardForm) -> FloatArray:
        """Curvature of the Lagrangian along each tension, (k, m) (N^-1).

        The constraint's second derivative by a forward difference of the slope: a
        diagonal SQP Hessian, kept convex. Without it the LP steps of min-sum can cycle
        between vertices when the optimum of the curved problem is not at a vertex.
        """
        dT = 1e-6 * Ta
        near = taut_catenaries(sub.x, sub.z, Ta + dT, self.w, self.EA, "A")
        with np.errstate(invalid="ignore"):
            slope2 = force_slope(sub, *near[:4], self.w, self.EA)
            W2 = (self.robot.cable_wrenches(slope2, sub.arms) - W1) / dT[..., None]
            curv = np.einsum("kn,kmn->km", self.multipliers[active], W2)
        curv = np.where(np.isfinite(curv), np.maximum(curv, 0.0), 0.0)
        # Curvature too small to change the objective at the scale of the tensions is
        # dropped (keeps LPs linear where the cables are nearly straight).
        scale = form.typical_tension()[:, None]
        size = (np.abs(form.c) * scale + form.q * scale**2).max(axis=1, keepdims=True)
        return np.where(curv * scale**2 > 1e-12 * size, curv, 0.0)

    def _restart(self, fail: NDArray[np.intp]) -> NDArray[np.intp]:
        """Poses whose linearised problem has no solution; returns those restarted.

        A linearisation far from the solution (low tensions, deep sag) may have no
        feasible point although the pose has one: such poses restart from doubled
        tensions (straighter cables), a few times before they count as infeasible.
        """
        retry = fail[self.restarts[fail] < self.MAX_RESTARTS]
        self.restarts[retry] += 1
        good = self._catenaries(retry, 2.0 * self.tensions[retry])
        self.tensions[retry[good]] *= 2.0
        self.status[np.setdiff1d(fail, retry[good])] = Status.INFEASIBLE
        return retry[good]

    def _safeguard(self, active: NDArray[np.intp], Ta: FloatArray,
                   step: FloatArray) -> NDArray[np.bool_]:
        """Halve ``step`` (k, m) in place where ``Ta + step`` holds no taut catenary;
        returns the poses where no halving helped, (k,) of bool."""
        trial = np.ones(active.size, bool)
        for _ in range(self.HALVINGS):
            sel = np.flatnonzero(trial)
            if sel.size == 0:
                break
            good = self._catenaries(active[sel], Ta[sel] + step[sel])
            trial[sel[good]] = False
            step[sel[~good]] *= 0.5
        return trial


def _multipliers(form: StandardForm, T: FloatArray) -> FloatArray:
    """Multipliers ``lam`` (k, n) of the equilibrium rows at a solution ``T`` (k, m).

    From the stationarity of the free tensions (not at a bound, not at the maximum of a
    min-max objective): ``q T + c + A^T lam = 0`` on those cables, in the least-squares
    sense (minimum norm when they are fewer than the rows).
    """
    scale = form.typical_tension()[:, None]
    tol = 1e-7 * scale
    free = ~((T <= form.lb + tol) | (T >= form.ub - tol))
    if form.minmax is not None:
        vals = T * form.minmax
        free &= vals < vals.max(axis=1, keepdims=True) - tol
    grad = form.q * T + form.c
    AF = form.A * free[:, None, :]
    M = np.einsum("kim,kjm->kij", AF, AF)
    reg = 1e-12 * np.trace(M, axis1=1, axis2=2)[:, None, None] + 1e-300
    M = M + reg * np.eye(M.shape[1])
    rhs = -np.einsum("kim,km->ki", AF, np.where(free, grad, 0.0))
    return np.linalg.solve(M, rhs[..., None])[..., 0]
