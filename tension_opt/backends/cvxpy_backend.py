"""Backend ``cvxpy[:SOLVER]``: a cvxpy problem compiled once with Parameters, re-solved per pose.

The problem is built in scaled units (see :mod:`tension_opt.backends.dense`) and is
DPP-compliant, so cvxpy canonicalises it once per structure (sizes, objective kind,
pattern of finite bounds) and each pose only updates parameter values.
"""

from __future__ import annotations

import threading
import time
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import Backend, RawResult, pose_loop_result
from tension_opt.backends.settings import solver_options
from tension_opt.errors import BackendNotAvailableError
from tension_opt.problems import StandardForm
from tension_opt.solution import Status

try:
    import cvxpy as cp
except ImportError:  # pragma: no cover - cvxpy is a runtime dependency
    cp = None  # type: ignore[assignment]

#: Solvers that take linear programs only.
LP_ONLY = {"SCIPY", "GLOP", "CBC", "GLPK"}
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
    """One parametrised cvxpy problem holding ``K`` independent poses, and its parameters.

    The objective is a sum over poses, so each block is solved to its own optimum;
    cvxpy's per-solve overhead (about 1 ms) is shared by the ``K`` poses.
    """

    def __init__(self, form: StandardForm, lb_mask: NDArray, ub_mask: NDArray) -> None:
        K, m = lb_mask.shape
        n = form.n
        x = cp.Variable((K, m))
        self.A = [cp.Parameter((n, m)) for _ in range(K)]
        self.b = cp.Parameter((K, n))
        self.c = cp.Parameter((K, m))
        constraints = [self.A[k] @ x[k] == self.b[k] for k in range(K)]
        self.lb = cp.Parameter(int(lb_mask.sum())) if lb_mask.any() else None
        self.ub = cp.Parameter(int(ub_mask.sum())) if ub_mask.any() else None
        if self.lb is not None:
            constraints.append(x[np.nonzero(lb_mask)] >= self.lb)
        if self.ub is not None:
            constraints.append(x[np.nonzero(ub_mask)] <= self.ub)
        self.G: list[Any] | None = None
        self.h = None
        if form.G is not None:
            g = form.G.shape[1]
            self.G = [cp.Parameter((g, m)) for _ in range(K)]
            self.h = cp.Parameter((K, g))
            constraints += [self.G[k] @ x[k] <= self.h[k] for k in range(K)]
        objective = cp.sum(cp.multiply(self.c, x))
        self.q = None
        if form.q.any():
            # A parametrised diagonal Hessian, so QP-capable solvers get it as P (not a cone).
            self.q = cp.Parameter((K, m), nonneg=True)
            objective = objective + 0.5 * cp.sum(cp.multiply(self.q, cp.square(x)))
        self.v_scale = None
        if form.minmax is not None:
            weights = np.broadcast_to(form.minmax, (K, m))
            self.v_scale = cp.Parameter(K, nonneg=True)
            peaks = cp.max(cp.multiply(weights, x), axis=1)
            objective = objective + cp.sum(cp.multiply(self.v_scale, peaks))
        self.x = x
        self.problem = cp.Problem(cp.Minimize(objective), constraints)

    def load(self, form: StandardForm, rows: NDArray, s: NDArray, sigma: NDArray,
             lb_mask: NDArray, ub_mask: NDArray) -> None:
        """Set the parameters to the poses ``rows`` (length K) of ``form``."""
        for k, i in enumerate(rows):
            self.A[k].value = form.A[i]
        self.b.value = form.b[rows] / s[:, None]
        self.c.value = form.c[rows] * (s / sigma)[:, None]
        if self.lb is not None:
            self.lb.value = (form.lb[rows] / s[:, None])[lb_mask]
        if self.ub is not None:
            self.ub.value = (form.ub[rows] / s[:, None])[ub_mask]
        if self.q is not None:
            self.q.value = form.q[rows] * (s**2 / sigma)[:, None]
        if self.v_scale is not None:
            self.v_scale.value = s / sigma
        if self.G is not None and self.h is not None:
            assert form.G is not None and form.h is not None  # compiled from such a form
            for k, i in enumerate(rows):
                self.G[k].value = form.G[i]
            self.h.value = form.h[rows] / s[:, None]


# Compiled problems hold the parameter values of the call in progress, so each thread
# keeps its own: calls from several threads never share a problem.
_THREAD = threading.local()


def _cache() -> dict[tuple[Any, ...], _Compiled]:
    """This thread's compiled problems, by structure."""
    cache = getattr(_THREAD, "cache", None)
    if cache is None:
        cache = _THREAD.cache = {}
    return cache


class CvxpyBackend(Backend):
    """Any installed cvxpy solver; the problem is compiled once and re-solved per pose.

    Thread safety: compiled problems are kept per thread, so one backend instance can
    be called from several threads at once.
    """

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
        if self._solver in LP_ONLY and not form.is_linear:
            return f"{self.name} solves linear programs only"
        if self._solver in _NO_LP and not (form.q > 0).all():
            return f"{self.name} is a QP solver unsuited to LPs (zero Hessian); use a QP objective"
        return None

    def _compiled(self, form: StandardForm, lb_mask: NDArray, ub_mask: NDArray) -> tuple[
            _Compiled, float]:
        key = (self._solver, form.n, form.m, form.kind, form.q.any(), form.minmax is not None,
               None if form.minmax is None else form.minmax.tobytes(),
               None if form.G is None else form.G.shape[1:], lb_mask.shape,
               lb_mask.tobytes(), ub_mask.tobytes())
        cache = _cache()
        if key in cache:
            return cache[key], 0.0
        t0 = time.perf_counter()
        compiled = _Compiled(form, lb_mask, ub_mask)
        cache[key] = compiled
        return compiled, time.perf_counter() - t0

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve chunks of ``batch_size`` poses per cvxpy solve (16; 1 at high accuracy).

        A chunk whose joint solve is not optimal (an infeasible pose in it, say) is
        solved again pose by pose, so statuses stay per pose. Iterations are those of
        the solve that produced the pose.
        """
        t_setup = time.perf_counter()
        N, m = form.N, form.m
        s = form.scale()
        sigma = s**2 if form.q.any() else s
        settings = solver_options(self._solver, options.get("accuracy"),
                                  options.get("time_limit"), options.get("solver_options"),
                                  interface="cvxpy")
        warm = bool(options.get("warm_start", False))
        # Joint stopping criteria loosen per-pose accuracy, so high accuracy goes pose by pose.
        default_k = 1 if options.get("accuracy") == "high" else 16
        K = max(1, min(int(options.get("batch_size", default_k)), N))
        lb_fin, ub_fin = np.isfinite(form.lb), np.isfinite(form.ub)
        T, status, iters = pose_loop_result(N, m)
        has_iters = True
        compile_time = 0.0
        setup = time.perf_counter() - t_setup
        t0 = time.perf_counter()
        for start in range(0, N, K):
            # The last chunk is padded with its own last pose to keep one compiled size.
            rows = np.minimum(np.arange(start, start + K), N - 1)
            chunk_ok = False
            if K > 1:
                compiled, dt = self._compiled(form, lb_fin[rows], ub_fin[rows])
                compile_time += dt
                result = self._run(compiled, form, rows, s, sigma, lb_fin, ub_fin, warm,
                                   settings)
                chunk_ok = result[0] == Status.OPTIMAL
            if chunk_ok:
                st, count, x = result
                assert x is not None  # an optimal solve has values
                real = rows[: min(K, N - start)]
                T[real] = x[: len(real)] * s[real, None]
                status[real] = st
                has_iters &= count is not None
                iters[real] = count or 0
                continue
            for i in range(start, min(start + K, N)):
                one = np.array([i])
                compiled, dt = self._compiled(form, lb_fin[one], ub_fin[one])
                compile_time += dt
                st, count, x = self._run(compiled, form, one, s, sigma, lb_fin, ub_fin, warm,
                                         settings)
                status[i] = st
                has_iters &= count is not None
                iters[i] = count or 0
                if x is not None and st in (Status.OPTIMAL, Status.INACCURATE):
                    T[i] = x[0] * s[i]
        elapsed = time.perf_counter() - t0
        return RawResult(T, status, iters if has_iters else None, setup + compile_time,
                         elapsed - compile_time)

    def _run(self, compiled: _Compiled, form: StandardForm, rows: NDArray, s: NDArray,
             sigma: NDArray, lb_fin: NDArray, ub_fin: NDArray, warm: bool,
             settings: dict[str, Any]) -> tuple[Status, int | None, NDArray | None]:
        compiled.load(form, rows, s[rows], sigma[rows], lb_fin[rows], ub_fin[rows])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                compiled.problem.solve(solver=self._solver, warm_start=warm, **settings)
        except Exception:
            return Status.SOLVER_ERROR, None, None
        stats = compiled.problem.solver_stats
        return (_STATUS.get(compiled.problem.status, Status.SOLVER_ERROR),
                None if stats is None else stats.num_iters, compiled.x.value)


def available() -> list[str]:
    """Registry names of the installed cvxpy solvers."""
    if cp is None:
        return []
    return [f"cvxpy:{s}" for s in cp.installed_solvers()]


def make(solver: str | None) -> Backend:
    """The cvxpy backend of ``solver`` (default: Clarabel)."""
    return CvxpyBackend(solver)
