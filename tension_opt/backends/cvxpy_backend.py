"""Backend ``cvxpy[:SOLVER]``: a cvxpy problem compiled once with Parameters, re-solved per pose.

The problem is the scaled one every generic backend solves (:mod:`tension_opt.certify.scaling`:
tensions over a reference tension, equilibrium rows over their norms, objective of
order one, a min-max term as an explicit epigraph variable) and is DPP-compliant, so
cvxpy canonicalises it once per structure (sizes, objective kind, pattern of finite
bounds) and each pose only updates parameter values. The constraints' dual values
are the multipliers of the solution's certificate.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import (
    Backend,
    RawResult,
    note_error,
    note_time_limit,
    objective_powers,
    pose_loop_result,
)
from tension_opt.backends.settings import (
    quiet_solvers,
    solver_options,
    time_limit_of,
    with_objective_scale,
)
from tension_opt.certify.certificate import Multipliers, certify
from tension_opt.certify.scaling import ScaledBatch, scaled_batch
from tension_opt.errors import BackendNotAvailableError
from tension_opt.problem.form import StandardForm
from tension_opt.status import Status
from tension_opt.tolerances import DEFAULT_TARGET, accuracy_target

try:
    import cvxpy as cp
except ImportError:  # pragma: no cover - cvxpy is a runtime dependency
    cp = None  # type: ignore[assignment]

#: Solvers that take linear programs only.
LP_ONLY = {"SCIPY", "GLOP", "CBC", "GLPK"}
#: Share of the accuracy target a joint solve of several poses asks for: at the target
#: itself about a third of the study's min-norm poses missed it alone under Clarabel and
#: were solved again one by one (3.6x the time of a joint solve at 1e-2 of the target).
JOINT_SHARE = 1e-2
#: The share once a joint solve of a call has left poses above the target: the rest of
#: the call's chunks ask for this one. On 400 study poses (min-norm, Clarabel), 1e-2
#: left 11 poses to be solved again alone (36 solves in all), 1e-3 one (26 solves) for
#: half an iteration more per solve. Where 1e-2 leaves none (min-sum, min-max, CoGiRo;
#: OSQP, SCS, PIQP), those iterations would be spent for nothing, hence only after a miss.
TIGHT_JOINT_SHARE = 1e-3
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

    def __init__(self, batch: ScaledBatch, extra: int, lb_mask: NDArray,
                 ub_mask: NDArray) -> None:
        K, m = lb_mask.shape
        n = batch.Aeq.shape[1]
        x = cp.Variable((K, m))
        self.A = [cp.Parameter((n, m)) for _ in range(K)]
        self.b = cp.Parameter((K, n))
        self.c = cp.Parameter((K, m))
        self.equations = [self.A[k] @ x[k] == self.b[k] for k in range(K)]
        constraints: list[Any] = list(self.equations)
        self.lb = cp.Parameter(int(lb_mask.sum())) if lb_mask.any() else None
        self.ub = cp.Parameter(int(ub_mask.sum())) if ub_mask.any() else None
        self.lb_mask, self.ub_mask = lb_mask, ub_mask
        self.lower = self.upper = None
        if self.lb is not None:
            self.lower = x[np.nonzero(lb_mask)] >= self.lb
            constraints.append(self.lower)
        if self.ub is not None:
            self.upper = x[np.nonzero(ub_mask)] <= self.ub
            constraints.append(self.upper)
        self.G: list[Any] | None = None
        self.h = None
        self.rows: list[Any] = []
        if extra:
            self.G = [cp.Parameter((extra, m)) for _ in range(K)]
            self.h = cp.Parameter((K, extra))
            self.rows = [self.G[k] @ x[k] <= self.h[k] for k in range(K)]
            constraints += self.rows
        objective = cp.sum(cp.multiply(self.c, x))
        self.q = None
        if batch.P[:, :m].any():
            # A parametrised diagonal Hessian, so QP-capable solvers get it as P (not a cone).
            self.q = cp.Parameter((K, m), nonneg=True)
            objective = objective + 0.5 * cp.sum(cp.multiply(self.q, cp.square(x)))
        self.tau = self.epigraph = None
        self.t = None
        if batch.epigraph is not None:  # t >= (v_i / vmax) x_i, costing tau per pose
            self.t = cp.Variable(K)
            self.tau = cp.Parameter(K, nonneg=True)
            weights = np.broadcast_to(batch.epigraph, (K, m))
            self.epigraph = cp.multiply(weights, x) <= cp.reshape(self.t, (K, 1), order="C")
            constraints.append(self.epigraph)
            objective = objective + cp.sum(cp.multiply(self.tau, self.t))
        self.x = x
        self.problem = cp.Problem(cp.Minimize(objective), constraints)

    def load(self, call: _Call, rows: NDArray) -> None:
        """Set the parameters to the poses ``rows`` (length K) of ``call.batch``."""
        batch, m, extra = call.batch, call.batch.m, call.extra
        for k, i in enumerate(rows):
            self.A[k].value = batch.Aeq[i, :, :m]
        self.b.value = batch.beq[rows]
        self.c.value = batch.c[rows, :m]
        if self.lb is not None:
            self.lb.value = batch.lb[rows, :m][self.lb_mask]
        if self.ub is not None:
            self.ub.value = batch.ub[rows, :m][self.ub_mask]
        if self.q is not None:
            self.q.value = batch.P[rows, :m]
        if self.tau is not None:
            self.tau.value = batch.c[rows, m]
        if self.G is not None and self.h is not None:
            for k, i in enumerate(rows):
                self.G[k].value = batch.G[i, :extra, :m]
            self.h.value = batch.h[rows, :extra]

    def duals(self, batch: ScaledBatch, extra: int) -> Multipliers | None:
        """The multipliers of the last solve (K poses), or None where cvxpy has none.

        cvxpy's dual of ``A x == b`` has the certificate's sign; those of inequalities
        are >= 0 (a lower bound's enters ``z`` negated).
        """
        K, m = self.lb_mask.shape
        k_all, g = batch.k, batch.G.shape[1]
        try:
            y = np.array([np.asarray(e.dual_value, dtype=float) for e in self.equations])
            z = np.zeros((K, m))
            if self.lower is not None:
                z[self.lb_mask] -= np.asarray(self.lower.dual_value, dtype=float).ravel()
            if self.upper is not None:
                z[self.ub_mask] += np.asarray(self.upper.dual_value, dtype=float).ravel()
            mu = np.zeros((K, g))
            if extra:
                mu[:, :extra] = [np.asarray(r.dual_value, dtype=float) for r in self.rows]
            if self.epigraph is not None:
                mu[:, extra:] = np.asarray(self.epigraph.dual_value, dtype=float)
        except (TypeError, ValueError):  # a solver that returned no duals
            return None
        if k_all > m:
            z = np.concatenate([z, np.zeros((K, 1))], axis=1)
        return Multipliers(y.reshape(K, -1), mu, z)


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
        installed = _installed()
        solver = solver.upper() if solver else ("CLARABEL" if "CLARABEL" in installed
                                                else installed[0])
        if solver in NOT_SOLVERS:
            raise BackendNotAvailableError(
                f"cvxpy's {solver} differentiates a cone program and is no solver to "
                f"choose: name one of {installed}")
        if solver not in installed:
            raise BackendNotAvailableError(
                f"cvxpy solver {solver!r} is not installed (installed: {installed}); "
                "pip install 'tension-opt[solvers]'"
            )
        self.solver = solver
        self.name = f"cvxpy:{solver}"

    @property
    def version(self) -> str:
        return f"cvxpy {cp.__version__}"

    def unsupported(self, form: StandardForm) -> str | None:
        if self.solver in LP_ONLY and not form.is_linear:
            return f"{self.name} solves linear programs only"
        if self.solver in _NO_LP and not (form.q > 0).all():
            return f"{self.name} is a QP solver unsuited to LPs (zero Hessian); use a QP objective"
        return None

    def rejected_options(self, user: Mapping[str, Any]) -> str | None:
        # cvxpy's DAQP and ProxQP interfaces drop the option names they do not pass on.
        known: tuple[str, ...] | None = None
        if self.solver == "DAQP":
            from cvxpy.reductions.solvers.qp_solvers.daqp_qpif import DAQP

            known = tuple(DAQP.ALLOWED_SOLVER_OPTS)
        elif self.solver == "PROXQP":
            known = _PROXQP_OPTIONS
        unknown = [] if known is None else sorted(set(map(str, user)) - set(known))
        if unknown:
            return f"cvxpy's {self.solver} ignores {unknown}; it takes {sorted(known or ())}"
        return None

    def _compiled(self, call: _Call, lb_mask: NDArray, ub_mask: NDArray) -> tuple[
            _Compiled, float]:
        batch = call.batch
        key = (self.solver, batch.Aeq.shape[1], batch.m, bool(batch.P[:, :batch.m].any()),
               None if batch.epigraph is None else batch.epigraph.tobytes(), call.extra,
               lb_mask.shape, lb_mask.tobytes(), ub_mask.tobytes())
        cache = _cache()
        if key in cache:
            return cache[key], 0.0
        t0 = time.perf_counter()
        compiled = _Compiled(batch, call.extra, lb_mask, ub_mask)
        cache[key] = compiled
        return compiled, time.perf_counter() - t0

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        """Solve chunks of ``batch_size`` poses per cvxpy solve (16, or 1 at a target
        tighter than the default).

        A joint solve asks for :data:`JOINT_SHARE` of the target (its stopping test
        measures the chunk as a whole, so a looser one leaves single poses above the
        target), and for :data:`TIGHT_JOINT_SHARE` once a chunk of the call has left
        poses above it. A chunk whose joint solve is not optimal (an infeasible pose in it,
        say), and each pose of a chunk whose joint answer misses the accuracy target on
        its own, is solved again pose by pose, so statuses and accuracy stay per pose.
        Iterations are those of the solve that produced the pose.
        """
        t_setup = time.perf_counter()
        batch = scaled_batch(form)
        target = accuracy_target(options.get("accuracy"))
        extra = 0 if form.G is None else form.G.shape[1]
        limit, user = time_limit_of(options), options.get("solver_options")
        settings = [solver_options(self.solver, accuracy, limit, user, interface="cvxpy")
                    for accuracy in (target, JOINT_SHARE * target, TIGHT_JOINT_SHARE * target)]
        call = _Call(batch, extra, np.isfinite(batch.lb[:, :batch.m]),
                     np.isfinite(batch.ub[:, :batch.m]), bool(options.get("warm_start", False)),
                     settings[0], target, settings[1:], limit,
                     objective_powers(self.solver, form, batch), user)
        # Joint stopping criteria loosen per-pose accuracy: tight targets go pose by pose.
        default_k = 1 if target < DEFAULT_TARGET else 16
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
        batch = call.batch
        N, m = batch.N, batch.m
        T, status, iters = pose_loop_result(N, m)
        duals = Multipliers.unknown(batch)
        extras: dict[str, Any] = {}
        has_iters = True
        compile_time = 0.0
        joint = call.joint_settings[0]
        for start in range(0, N, K):
            # The last chunk is padded with its own last pose to keep one compiled size.
            rows = np.minimum(np.arange(start, start + K), N - 1)
            again: Sequence[int] = range(start, min(start + K, N))
            if K > 1:
                compiled, dt = self._compiled(call, call.lb_fin[rows], call.ub_fin[rows])
                compile_time += dt
                noted = extras.pop("errors", None)  # the poses of earlier chunks
                st, count, x = self._run(compiled, call, rows, extras, joint)
                if st == Status.OPTIMAL and x is not None:
                    real = rows[: min(K, N - start)]
                    T[real] = x[: len(real)] * batch.scale[real, None]
                    status[real] = st
                    has_iters &= count is not None
                    iters[real] = count or 0
                    found = compiled.duals(batch, call.extra)
                    if found is not None:
                        duals.put(real, found.subset(slice(0, len(real))))
                    again = self._missed(call, T, duals, real)
                    if again:  # the poses of this call need more of a joint solve
                        joint = call.joint_settings[1]
                extras.pop("errors", None)  # the poses say for themselves below
                if noted:
                    extras["errors"] = noted
            for i in again:
                one = np.array([i])
                compiled, dt = self._compiled(call, call.lb_fin[one], call.ub_fin[one])
                compile_time += dt
                st, count, x = self._run(compiled, call, one, extras, call.settings)
                status[i] = st
                has_iters &= count is not None
                iters[i] = count or 0
                if x is not None and st in (Status.OPTIMAL, Status.INACCURATE):
                    T[i] = x[0] * batch.scale[i]
                    found = compiled.duals(batch, call.extra)
                    if found is not None:
                        duals.put(one, found)
        return RawResult(T, status, iters if has_iters else None, compile_time, 0.0,
                         extras=extras, multipliers=duals)

    def _missed(self, call: _Call, T: NDArray, duals: Multipliers, rows: NDArray
                ) -> list[int]:
        """Poses ``rows`` of a joint solve whose answers miss the target on their own."""
        sub = call.batch.subset(rows)
        certificate = certify(sub, sub.lift(T[rows]), duals.subset(rows), call.target)
        return [int(i) for i in rows[~certificate.certified]]

    def _run(self, compiled: _Compiled, call: _Call, rows: NDArray, extras: dict[str, Any],
             settings: dict[str, Any]) -> tuple[Status, int | None, NDArray | None]:
        """One cvxpy solve of the poses ``rows``; stopped by the time limit without an
        answer, ``MAX_ITER`` with a message for the first of them."""
        if call.powers is not None:  # the objective of these poses, scaled for the solver
            power = int(np.rint(call.powers[rows].mean()))
            settings = with_objective_scale(self.solver, settings, power, call.user)
        start = time.perf_counter()
        try:
            compiled.load(call, rows)
            compiled.problem.solve(solver=self.solver, warm_start=call.warm, **settings)
        except Exception as error:  # a solver's failure on these poses
            note_error(extras, int(rows[0]), error)
            return self._timed(call, start, extras, rows, Status.SOLVER_ERROR), None, None
        stats = compiled.problem.solver_stats
        status = self._timed(call, start, extras, rows,
                             _STATUS.get(compiled.problem.status, Status.SOLVER_ERROR))
        return status, None if stats is None else stats.num_iters, compiled.x.value

    @staticmethod
    def _timed(call: _Call, start: float, extras: dict[str, Any], rows: NDArray,
               status: Status) -> Status:
        """``status`` of a solve begun at ``start``, told apart if it ran out of time."""
        if (call.limit is None or status in (Status.OPTIMAL, Status.INFEASIBLE)
                or time.perf_counter() - start < call.limit):
            return status
        extras.get("errors", {}).pop(int(rows[0]), None)  # the time limit, not its echo
        return note_time_limit(extras, int(rows[0]), call.limit, status)


@dataclass(frozen=True)
class _Call:
    """What every solve of one :meth:`CvxpyBackend.solve_stage` call shares."""

    #: The scaled batch, and how many of its rows of ``G`` are extra rows of the form
    #: (the rest are the epigraph rows of a min-max term).
    batch: ScaledBatch
    extra: int
    lb_fin: NDArray
    ub_fin: NDArray
    warm: bool
    settings: dict[str, Any]
    target: float
    #: Options of a joint solve of several poses: at :data:`JOINT_SHARE` of the target,
    #: then at :data:`TIGHT_JOINT_SHARE`.
    joint_settings: list[dict[str, Any]]
    #: Seconds per solve (None: no limit).
    limit: float | None = None
    #: Per pose, the power of two the solver scales the objective by
    #: (:func:`~tension_opt.backends.settings.objective_scales`), None for none.
    powers: NDArray | None = None
    #: The caller's own solver options.
    user: Mapping[str, Any] | None = None


#: Names cvxpy lists among its solvers that are no solver to choose: DIFFCP is the layer
#: that differentiates a cone program (over SCS), installed for the sensitivity tests.
NOT_SOLVERS = frozenset({"DIFFCP"})


def _installed() -> list[str]:
    return [s for s in cp.installed_solvers() if s not in NOT_SOLVERS]


def available() -> list[str]:
    """Registry names of the installed cvxpy solvers."""
    if cp is None:
        return []
    return [f"cvxpy:{s}" for s in _installed()]


def make(solver: str | None) -> Backend:
    """The cvxpy backend of ``solver`` (default: Clarabel)."""
    return CvxpyBackend(solver)
