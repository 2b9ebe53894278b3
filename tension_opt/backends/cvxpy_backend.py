"""Backend ``cvxpy[:SOLVER]``: a cvxpy problem compiled once with Parameters, re-solved per pose.

The problem is built in scaled units (see :mod:`tension_opt.backends._dense`) and is
DPP-compliant, so cvxpy canonicalises it once per structure (sizes, objective kind,
pattern of finite bounds) and each pose only updates parameter values.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import Backend, RawResult, pose_loop_result, register
from tension_opt.errors import BackendNotAvailableError
from tension_opt.problems import StandardForm
from tension_opt.solution import Status

try:
    import cvxpy as cp
except ImportError:  # pragma: no cover - cvxpy is a runtime dependency
    cp = None

#: Solver options for accuracy="high", in each solver's own names (as cvxpy passes them).
HIGH_ACCURACY: dict[str, dict[str, Any]] = {
    "CLARABEL": {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10},
    "OSQP": {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iter": 200000, "polish": True},
    "SCS": {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iters": 200000},
    "PIQP": {"eps_abs": 1e-10, "eps_rel": 1e-11, "eps_duality_gap_abs": 1e-10,
             "eps_duality_gap_rel": 1e-10},
    "PROXQP": {"eps_abs": 1e-10, "eps_rel": 0.0},
    "DAQP": {"primal_tol": 1e-10},
    "HIGHS": {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
    "ECOS": {"abstol": 1e-10, "reltol": 1e-10, "feastol": 1e-10},
    "SCIPY": {"scipy_options": {"primal_feasibility_tolerance": 1e-10,
                                "dual_feasibility_tolerance": 1e-10}},
}
#: Options always passed: ProxQP otherwise runs millions of iterations on an infeasible pose.
ALWAYS: dict[str, dict[str, Any]] = {"PROXQP": {"max_iter": 200}}
#: Solvers that take linear programs only.
_LP_ONLY = {"SCIPY", "GLOP", "CBC", "GLPK"}
#: QP solvers unsuited to LPs: PROXQP failed on a quarter of the study's min-sum poses.
_NO_LP = {"PROXQP"}
_STATUS = {
    "optimal": Status.OPTIMAL,
    "optimal_inaccurate": Status.INACCURATE,
    "infeasible": Status.INFEASIBLE,
    "infeasible_inaccurate": Status.INFEASIBLE,
    "unbounded": Status.UNBOUNDED,
    "unbounded_inaccurate": Status.UNBOUNDED,
    "user_limit": Status.MAX_ITER,
}


class _Compiled:
    """One parametrised cvxpy problem and its parameters."""

    def __init__(self, form: StandardForm, lb_mask: NDArray, ub_mask: NDArray) -> None:
        n, m = form.n, form.m
        x = cp.Variable(m)
        self.A = cp.Parameter((n, m))
        self.b = cp.Parameter(n)
        self.c = cp.Parameter(m)
        constraints = [self.A @ x == self.b]
        self.lb = cp.Parameter(int(lb_mask.sum())) if lb_mask.any() else None
        self.ub = cp.Parameter(int(ub_mask.sum())) if ub_mask.any() else None
        if self.lb is not None:
            constraints.append(x[np.flatnonzero(lb_mask)] >= self.lb)
        if self.ub is not None:
            constraints.append(x[np.flatnonzero(ub_mask)] <= self.ub)
        self.G = self.h = None
        if form.G is not None:
            self.G = cp.Parameter(form.G.shape[1:])
            self.h = cp.Parameter(form.G.shape[1])
            constraints.append(self.G @ x <= self.h)
        objective = self.c @ x
        self.sqrt_q = None
        if form.q.any():
            self.sqrt_q = cp.Parameter(m, nonneg=True)
            objective = objective + 0.5 * cp.sum_squares(cp.multiply(self.sqrt_q, x))
        self.v = None
        if form.minmax is not None:
            self.v = cp.Parameter(m, nonneg=True)
            self.v_scale = cp.Parameter(nonneg=True)
            objective = objective + self.v_scale * cp.max(cp.multiply(self.v, x))
        self.x = x
        self.problem = cp.Problem(cp.Minimize(objective), constraints)


_CACHE: dict[tuple[Any, ...], _Compiled] = {}


class CvxpyBackend(Backend):
    """Any installed cvxpy solver; the problem is compiled once and re-solved per pose."""

    warm_start = True

    def __init__(self, solver: str | None) -> None:
        if cp is None:
            raise BackendNotAvailableError("cvxpy is not installed: pip install cvxpy")
        installed = cp.installed_solvers()
        solver = solver.upper() if solver else ("CLARABEL" if "CLARABEL" in installed
                                                else installed[0])
        if solver not in installed:
            raise BackendNotAvailableError(
                f"cvxpy solver {solver!r} is not installed (installed: {installed}); "
                "pip install 'tension-opt[solvers]'"
            )
        self._solver = solver
        self.name = f"cvxpy:{solver}"

    @property
    def solver(self) -> str:
        return self._solver

    @property
    def version(self) -> str:
        return f"cvxpy {cp.__version__}"

    def unsupported(self, form: StandardForm) -> str | None:
        if self._solver in _LP_ONLY and not form.is_linear:
            return f"{self.name} solves linear programs only"
        if self._solver in _NO_LP and not (form.q > 0).all():
            return f"{self.name} is a QP solver unsuited to LPs (zero Hessian); use a QP objective"
        return None

    def _compiled(self, form: StandardForm, lb_mask: NDArray, ub_mask: NDArray) -> tuple[
            _Compiled, float]:
        key = (self._solver, form.n, form.m, form.kind, form.q.any(), form.minmax is not None,
               None if form.G is None else form.G.shape[1:], lb_mask.tobytes(),
               ub_mask.tobytes())
        if key in _CACHE:
            return _CACHE[key], 0.0
        t0 = time.perf_counter()
        compiled = _Compiled(form, lb_mask, ub_mask)
        _CACHE[key] = compiled
        return compiled, time.perf_counter() - t0

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        t_setup = time.perf_counter()
        N, m = form.N, form.m
        s = form.scale()
        sigma = s**2 if form.q.any() else s
        settings = dict(HIGH_ACCURACY.get(self._solver, {})) if options.get(
            "accuracy") == "high" else {}
        settings = {**ALWAYS.get(self._solver, {}), **settings,
                    **options.get("solver_options", {})}
        warm = bool(options.get("warm_start", False))
        lb_fin, ub_fin = np.isfinite(form.lb), np.isfinite(form.ub)
        T, status, iters = pose_loop_result(N, m)
        has_iters = True
        compile_time = 0.0
        setup = time.perf_counter() - t_setup
        t0 = time.perf_counter()
        for i in range(N):
            compiled, dt = self._compiled(form, lb_fin[i], ub_fin[i])
            compile_time += dt
            compiled.A.value = form.A[i]
            compiled.b.value = form.b[i] / s[i]
            compiled.c.value = form.c[i] * s[i] / sigma[i]
            if compiled.lb is not None:
                compiled.lb.value = form.lb[i][lb_fin[i]] / s[i]
            if compiled.ub is not None:
                compiled.ub.value = form.ub[i][ub_fin[i]] / s[i]
            if compiled.sqrt_q is not None:
                compiled.sqrt_q.value = np.sqrt(form.q[i] * s[i] ** 2 / sigma[i])
            if compiled.v is not None:
                compiled.v.value = form.minmax
                compiled.v_scale.value = s[i] / sigma[i]
            if compiled.G is not None:
                compiled.G.value = form.G[i]
                compiled.h.value = form.h[i] / s[i]
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    compiled.problem.solve(solver=self._solver, warm_start=warm, **settings)
            except Exception:
                status[i] = Status.SOLVER_ERROR
                continue
            status[i] = _STATUS.get(compiled.problem.status, Status.SOLVER_ERROR)
            stats = compiled.problem.solver_stats
            count = None if stats is None else stats.num_iters
            has_iters &= count is not None
            iters[i] = count or 0
            if status[i] in (Status.OPTIMAL, Status.INACCURATE) and compiled.x.value is not None:
                T[i] = compiled.x.value * s[i]
        elapsed = time.perf_counter() - t0
        return RawResult(T, status, iters if has_iters else None, setup + compile_time,
                         elapsed - compile_time)


def _available() -> list[str]:
    if cp is None:
        return []
    return [f"cvxpy:{s}" for s in cp.installed_solvers()]


register("cvxpy", lambda solver: CvxpyBackend(solver), _available)
