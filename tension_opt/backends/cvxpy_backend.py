"""Backend ``cvxpy[:SOLVER]``: a cvxpy problem compiled once with Parameters, re-solved per pose.

The problem is built in scaled units (see :mod:`tension_opt.backends.dense`) and is
DPP-compliant, so cvxpy canonicalises it once per structure (sizes, objective kind,
pattern of finite bounds) and each pose only updates parameter values.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import (
    Backend,
    RawResult,
    note_error,
    pose_loop_result,
    quiet_solvers,
)
from tension_opt.backends.dense import scaled_objective, working_scale
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
#: The options cvxpy's ProxQP interface passes on (it drops any other).
_PROXQP_OPTIONS = ("backend", "eps_abs", "eps_rel", "max_iter", "rho", "mu_eq", "mu_in")
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
        if form.minmax is not None:  # unit-scaled weights, as the scaled objective has them
            vmax = float(np.abs(form.minmax).max(initial=0.0)) or 1.0
            weights = np.broadcast_to(form.minmax / vmax, (K, m))
            self.v_scale = cp.Parameter(K, nonneg=True)
            peaks = cp.max(cp.multiply(weights, x), axis=1)
            objective = objective + cp.sum(cp.multiply(self.v_scale, peaks))
        self.x = x
        self.problem = cp.Problem(cp.Minimize(objective), constraints)

    def load(self, call: _Call, rows: NDArray) -> None:
        """Set the parameters to the poses ``rows`` (length K) of ``call.form``."""
        form, s = call.form, call.s[rows]
        lb_mask, ub_mask = call.lb_fin[rows], call.ub_fin[rows]
        for k, i in enumerate(rows):
            self.A[k].value = form.A[i]
        self.b.value = form.b[rows] / s[:, None]
        self.c.value = call.c[rows]
        if self.lb is not None:
            self.lb.value = (form.lb[rows] / s[:, None])[lb_mask]
        if self.ub is not None:
            self.ub.value = (form.ub[rows] / s[:, None])[ub_mask]
        if self.q is not None:
            self.q.value = call.P[rows]
        if self.v_scale is not None:
            self.v_scale.value = call.tau[rows]
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

    Thread safety: per-thread caches. A compiled problem holds the parameter values of
    the call in progress, so each thread keeps its own compiled problems; the solvers
    behind cvxpy build their workspace per solve. One backend instance can therefore be
    called from several threads at once, with the answers of serial calls.
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

    def rejected_options(self, user: Mapping[str, Any]) -> str | None:
        # cvxpy's DAQP and ProxQP interfaces drop the option names they do not pass on.
        known: tuple[str, ...] | None = None
        if self._solver == "DAQP":
            from cvxpy.reductions.solvers.qp_solvers.daqp_qpif import DAQP

            known = tuple(DAQP.ALLOWED_SOLVER_OPTS)
        elif self._solver == "PROXQP":
            known = _PROXQP_OPTIONS
        unknown = [] if known is None else sorted(set(map(str, user)) - set(known))
        if unknown:
            return f"cvxpy's {self._solver} ignores {unknown}; it takes {sorted(known or ())}"
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
        s = working_scale(form)
        call = _Call(form, s, *scaled_objective(form, s)[:3], np.isfinite(form.lb),
                     np.isfinite(form.ub), bool(options.get("warm_start", False)),
                     solver_options(self._solver, options.get("accuracy"),
                                    options.get("time_limit"), options.get("solver_options"),
                                    interface="cvxpy"))
        # Joint stopping criteria loosen per-pose accuracy, so high accuracy goes pose by pose.
        default_k = 1 if options.get("accuracy") == "high" else 16
        K = max(1, min(int(options.get("batch_size") or default_k), form.N))
        setup = time.perf_counter() - t_setup
        t0 = time.perf_counter()
        with quiet_solvers():
            result = self._solve_chunks(call, K)
        elapsed = time.perf_counter() - t0
        compile_time = result.setup_time
        result.setup_time, result.solve_time = setup + compile_time, elapsed - compile_time
        return result

    def _solve_chunks(self, call: _Call, K: int) -> RawResult:
        """Solve the poses of ``call`` in chunks of ``K``; compile time is the setup."""
        N, m = call.form.N, call.form.m
        T, status, iters = pose_loop_result(N, m)
        extras: dict[str, Any] = {}
        has_iters = True
        compile_time = 0.0
        for start in range(0, N, K):
            # The last chunk is padded with its own last pose to keep one compiled size.
            rows = np.minimum(np.arange(start, start + K), N - 1)
            if K > 1:
                compiled, dt = self._compiled(call.form, call.lb_fin[rows], call.ub_fin[rows])
                compile_time += dt
                st, count, x = self._run(compiled, call, rows, extras)
                if st == Status.OPTIMAL and x is not None:
                    real = rows[: min(K, N - start)]
                    T[real] = x[: len(real)] * call.s[real, None]
                    status[real] = st
                    has_iters &= count is not None
                    iters[real] = count or 0
                    continue
                extras.pop("errors", None)  # the poses say for themselves below
            for i in range(start, min(start + K, N)):
                one = np.array([i])
                compiled, dt = self._compiled(call.form, call.lb_fin[one], call.ub_fin[one])
                compile_time += dt
                st, count, x = self._run(compiled, call, one, extras)
                status[i] = st
                has_iters &= count is not None
                iters[i] = count or 0
                if x is not None and st in (Status.OPTIMAL, Status.INACCURATE):
                    T[i] = x[0] * call.s[i]
        return RawResult(T, status, iters if has_iters else None, compile_time, 0.0,
                         extras=extras)

    def _run(self, compiled: _Compiled, call: _Call, rows: NDArray, extras: dict[str, Any]
             ) -> tuple[Status, int | None, NDArray | None]:
        try:
            compiled.load(call, rows)
            compiled.problem.solve(solver=self._solver, warm_start=call.warm, **call.settings)
        except Exception as error:  # a solver's failure on these poses
            note_error(extras, int(rows[0]), error)
            return Status.SOLVER_ERROR, None, None
        stats = compiled.problem.solver_stats
        return (_STATUS.get(compiled.problem.status, Status.SOLVER_ERROR),
                None if stats is None else stats.num_iters, compiled.x.value)


@dataclass(frozen=True)
class _Call:
    """What every solve of one :meth:`CvxpyBackend.solve_stage` call shares."""

    form: StandardForm
    #: Typical tension per pose (N,), and the scaled Hessian, cost (N, m) and min-max
    #: epigraph cost (N,) of :func:`~tension_opt.backends.dense.scaled_objective`.
    s: NDArray
    P: NDArray
    c: NDArray
    tau: NDArray
    lb_fin: NDArray
    ub_fin: NDArray
    warm: bool
    settings: dict[str, Any]


def available() -> list[str]:
    """Registry names of the installed cvxpy solvers."""
    if cp is None:
        return []
    return [f"cvxpy:{s}" for s in cp.installed_solvers()]


def make(solver: str | None) -> Backend:
    """The cvxpy backend of ``solver`` (default: Clarabel)."""
    return CvxpyBackend(solver)
