"""Backend ``qpsolvers:SOLVER``: any QP solver installed for qpsolvers, one pose at a time.

``qpsolvers:daqp`` calls DAQP directly with the same data (the generic qpsolvers path
adds a conversion per call that dominates problems of this size).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from ctypes import c_int
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.base import (
    Backend,
    RawResult,
    SequenceRun,
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
from tension_opt.certify.certificate import Multipliers
from tension_opt.certify.scaling import ScaledBatch, scaled_batch
from tension_opt.errors import BackendNotAvailableError
from tension_opt.kernels.launch import compiled_for
from tension_opt.problem.form import StandardForm
from tension_opt.status import Status
from tension_opt.tolerances import FEASIBILITY_TOL, accuracy_target

try:
    import qpsolvers
except ImportError:  # pragma: no cover - qpsolvers is a runtime dependency
    qpsolvers = None  # type: ignore[assignment]

#: Solvers this backend knows (their options are in :mod:`tension_opt.backends.settings`).
KNOWN = ("daqp", "osqp", "proxqp", "piqp", "clarabel", "highs", "scs", "quadprog")
#: Solvers that need a positive-definite Hessian (no LPs, no epigraph variable).
_NEEDS_PD = {"quadprog"}
#: Proximal QP solvers that crawl on LPs (zero Hessian): ProxQP took about 1 s per pose
#: on the study's min-sum problem at high accuracy, against 0.2 ms for DAQP.
_NO_LP = {"proxqp"}
_DAQP_EXIT = {1: Status.OPTIMAL, 2: Status.OPTIMAL, -1: Status.INFEASIBLE,
              -3: Status.UNBOUNDED, -4: Status.MAX_ITER}
_BIG = 1e30  # DAQP's infinity


#: Solvers left out of the sequence loop: HiGHS's QP multipliers missed the loop's
#: verdict on every pose measured (0 of 90 study and CoGiRo poses, where its answers were
#: optimal), so each pose would be solved twice.
_NO_SEQUENCE = ("highs",)
#: The entry points of the sequence loop's compiled steps (made on first use; threads
#: that make them at once store equal pairs).
_SEQUENCE_ENTRIES: dict[str, tuple[Any, Any]] = {}


def iterations_of(extras: dict[str, Any]) -> int | None:
    """Iteration count from a qpsolvers Solution's extras (None where not reported)."""
    info = extras.get("info")
    for obj in (info, extras):
        if obj is None:
            continue
        for key in ("iter", "iterations", "num_iterations", "iter_count"):
            value = obj.get(key) if isinstance(obj, dict) else getattr(obj, key, None)
            if isinstance(value, int | np.integer):  # the usual report, read directly
                return int(value)
            if value is not None:
                value = np.asarray(value).ravel()
                return int(value[0]) if value.size else None
    return None


def failure_status(extras: dict[str, Any]) -> Status:
    """Status of an unsuccessful qpsolvers solve, from the solver's own status text."""
    text = (str(extras.get("status", "")) + " "
            + str(getattr(extras.get("info"), "status", ""))).lower().replace("_", "")
    if "dualinfeas" in text.replace(" ", ""):
        return Status.UNBOUNDED
    if "infeas" in text:
        return Status.INFEASIBLE
    if any(word in text for word in ("maxiter", "iterations", "timelimit", "time limit")):
        return Status.MAX_ITER
    if "inaccurate" in text or "almostsolved" in text:
        return Status.INACCURATE
    return Status.SOLVER_ERROR


class QpsolversBackend(Backend):
    """Any qpsolvers solver, one pose at a time (warm start from the previous pose).

    Thread safety: per-call solver objects. Every pose builds its own problem and
    solver workspace (qpsolvers creates a new OSQP, Clarabel, PIQP, ProxQP, SCS or
    HiGHS instance per solve, and HiGHS keeps one task scheduler per calling thread;
    DAQP and quadprog are plain functions of their arguments), and the instance holds
    no state of a call, so one instance serves several threads at once without a
    lock, with the answers of serial calls.
    """

    warm_start = True

    def __init__(self, solver: str) -> None:
        if qpsolvers is None or solver not in qpsolvers.available_solvers:
            installed = [] if qpsolvers is None else qpsolvers.available_solvers
            raise BackendNotAvailableError(
                f"qpsolvers solver {solver!r} is not installed (installed: {installed}); "
                "pip install 'tension-opt[solvers]'"
            )
        self.solver = solver
        self.name = f"qpsolvers:{solver}"

    @cached_property
    def version(self) -> str:
        if self.solver == "daqp":
            from importlib.metadata import version

            return f"daqp {version('daqp')}"
        return f"qpsolvers {qpsolvers.__version__}"

    def unsupported(self, form: StandardForm) -> str | None:
        if self.solver in _NEEDS_PD and (form.kind != "qp" or not (form.q > 0).all()):
            return f"{self.name} needs a positive-definite Hessian (QP objectives only)"
        if self.solver in _NO_LP and not (form.q > 0).all():
            return f"{self.name} is a QP solver unsuited to LPs (zero Hessian); use a QP objective"
        return None

    def rejected_options(self, user: Mapping[str, Any]) -> str | None:
        # PIQP and HiGHS (through qpsolvers) skip option names they do not know.
        if self.solver == "piqp":
            import piqp

            known = {k for k in dir(piqp.DenseSolver().settings) if not k.startswith("_")}
            unknown = sorted(set(map(str, user)) - known)
            if unknown:
                return f"unknown PIQP setting(s) {unknown}; PIQP takes {sorted(known)}"
        if self.solver == "highs":
            import highspy

            highs = highspy.Highs()
            highs.setOptionValue("output_flag", False)
            bad = [f"{k}={v!r}" for k, v in user.items()
                   if highs.setOptionValue(str(k), v) != highspy.HighsStatus.kOk]
            if bad:
                return (f"HiGHS refuses {', '.join(bad)} (an unknown option name, or a value "
                        "of the wrong type or out of range)")
        return None

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        t0 = time.perf_counter()
        batch = scaled_batch(form)
        limit, user = time_limit_of(options), options.get("solver_options")
        settings = solver_options(self.solver, options.get("accuracy"), limit, user)
        warm = bool(options.get("warm_start", False))
        setup = time.perf_counter() - t0
        if self.solver == "daqp":  # quiet where it calls the Python library (its loop)
            return self._solve_daqp(batch, settings, warm, setup)
        with quiet_solvers():
            powers = objective_powers(self.solver, form, batch)
            per_pose = None if powers is None else [
                with_objective_scale(self.solver, settings, int(p), user) for p in powers]
            return self._solve_generic(batch, settings, warm, setup, limit, per_pose)

    def runs_sequences(self, options: Mapping[str, Any], smoothed: StandardForm,
                       poses: int) -> bool:
        """The smoothed poses of a sequence run in one loop: through DAQP's C solver
        called from compiled code (where :mod:`tension_opt.kernels.daqp_native` can),
        or, for the other solvers, each pose's solver call from Python between two
        compiled steps (its QP built, its answer judged). Not where smoothed poses are
        LPs (a rate limit alone), which the loop leaves to the pose-by-pose path, and
        not below the size rule's count of poses (:func:`compiled_for`)."""
        if self.solver in _NO_SEQUENCE or smoothed.kind != "qp" or not compiled_for(poses):
            return False
        if self.solver != "daqp":
            return True
        from tension_opt.kernels import daqp_native

        return daqp_native.load() is not None

    def solve_sequence(self, base: StandardForm, smoothing: float, rate: NDArray,
                       last: NDArray, start: int, run: SequenceRun,
                       options: Mapping[str, Any]) -> int:
        """:meth:`Backend.solve_sequence` without the per-pose pipeline
        (:func:`tension_opt.kernels.dense_qp.solve_sequence`, or
        :func:`~tension_opt.kernels.dense_qp.sequence_pose` and
        :func:`~tension_opt.kernels.dense_qp.sequence_verdict` around the solver): each
        smoothed pose's QP is the one :meth:`solve_stage` builds for its one-pose form,
        solved cold, and optimal only where the answer is certified with the solver's
        own multipliers (and within the feasibility tolerance). An LP (a pose with
        nothing to smooth against, a rate limit alone) and any pose the loop does not
        certify go back to :meth:`solve`, which then reports what it finds."""
        from tension_opt.kernels import dense_qp

        self.check_solver_options(options)
        settings = solver_options(self.solver, options.get("accuracy"),
                                  time_limit_of(options), options.get("solver_options"))
        target = accuracy_target(options.get("accuracy"))
        tol = max(FEASIBILITY_TOL, 10.0 * target)
        N, m, n = base.N, base.m, base.n
        floats = np.zeros(dense_qp.sequence_size(m, n))
        counts = np.zeros(N, dtype=np.int64)
        arrays = [np.ascontiguousarray(x, dtype=float)
                  for x in (base.A, base.b, base.lb, base.ub, base.q, base.c)]
        rate = np.ascontiguousarray(rate, dtype=float)
        if self.solver == "daqp":
            structs = _native_structs(settings)
            if structs is None:
                return start
            sense = np.zeros(m + n, dtype=c_int)
            sense[m:] = 5  # the equations
            A, b, lb, ub, q, c = arrays
            stop = int(dense_qp.solve_sequence(
                A, b, lb, ub, q, c, float(smoothing), rate, tol, target, last,
                bool(np.isfinite(last).all()), run.tensions, counts, start, floats, sense,
                structs))
        else:
            with quiet_solvers():
                stop = self._generic_sequence(arrays, float(smoothing), rate, last, start,
                                              run, settings, (tol, target), floats, counts)
        if stop > start:
            done = slice(start, stop)
            run.status[done], run.unique[done] = Status.OPTIMAL, True
            if run.iterations is not None:
                run.iterations[done] = counts[done]
        return stop

    def _generic_sequence(self, arrays: list[NDArray], smoothing: float, rate: NDArray,
                          last: NDArray, start: int, run: SequenceRun,
                          settings: dict[str, Any], judged: tuple[float, float],
                          floats: NDArray, counts: NDArray) -> int:
        """The loop of :meth:`solve_sequence` for a solver called from Python: the pose's
        QP as :meth:`_solve_generic` hands it to qpsolvers (the same arrays, no start
        point), its answer judged in compiled code. Returns the first pose left."""
        from tension_opt.kernels import dense_qp
        from tension_opt.kernels.launch import entry_point

        A, b = arrays[0], arrays[1]
        N, n, m = A.shape
        size = dense_qp.qp_size(m, n)
        H, f, Ad, upper, _ = dense_qp.qp_views(floats[:size], m, n)
        x, lam = floats[size:size + m], floats[size + m:size + 2 * m + n]
        o = size + 6 * m + 2 * n
        lbs, ubs = floats[o:o + m], floats[o + m:o + 2 * m]
        has_last = bool(np.isfinite(last).all())
        # Entry points: every argument's type is fixed here (numba's dispatch would cost
        # a tenth of a solve per call).
        entries = _SEQUENCE_ENTRIES.get("steps")
        if entries is None:  # the argument types are always these: made once, as a pair
            entries = (entry_point(dense_qp.sequence_pose, *arrays, smoothing, rate, last,
                                   has_last, start, floats),
                       entry_point(dense_qp.sequence_verdict, A, b, start, floats, *judged,
                                   1.0, run.tensions[0]))
            _SEQUENCE_ENTRIES["steps"] = entries
        pose, verdict = entries
        for k in range(start, N):
            code, s = pose(*arrays, smoothing, rate, last, has_last, k, floats)
            if code:
                return k
            bounded_lb, bounded_ub = bool(np.isfinite(lbs).any()), bool(np.isfinite(ubs).any())
            problem = qpsolvers.Problem(H, f, None, None, Ad, upper[m:],
                                        lbs if bounded_lb else None,
                                        ubs if bounded_ub else None)
            try:
                sol = qpsolvers.solve_problem(problem, solver=self.solver, initvals=None,
                                              **settings)
            except Exception:  # the backend's own call of this pose names the error
                return k
            if not (sol.found and sol.x is not None and np.size(sol.x) == m
                    and np.isfinite(sol.x).all()):
                return k
            y = None if sol.y is None else np.ravel(sol.y)
            z = None if sol.z_box is None else np.ravel(sol.z_box)
            if y is None or y.size != n or (z is None and (bounded_lb or bounded_ub)) or (
                    z is not None and z.size != m):
                return k  # multipliers to estimate: the backend's certificate does it
            x[:] = np.ravel(sol.x)
            lam[:m] = 0.0 if z is None else z
            lam[m:] = y
            if verdict(A, b, k, floats, *judged, s, run.tensions[k]):
                return k
            count = iterations_of(sol.extras or {})
            if count is None:
                run.iterations = None  # as the backend, which then reports none
            else:
                counts[k] = count
            last[:] = run.tensions[k]
            has_last = True
        return N

    def _solve_generic(self, batch: ScaledBatch, settings: dict[str, Any], warm: bool,
                       setup: float, limit: float | None = None,
                       per_pose: list[dict[str, Any]] | None = None) -> RawResult:
        """Pose by pose through qpsolvers, with ``settings`` (or each pose's own,
        ``per_pose``); a pose left unsolved after ``limit`` seconds reads ``MAX_ITER``."""
        N, k = batch.N, batch.k
        x_all, status, iters = pose_loop_result(N, k)
        duals = Multipliers.unknown(batch)
        extras: dict[str, Any] = {}
        has_iters = True
        t0 = time.perf_counter()
        # Which poses have bounds, and the Hessians, for all poses at once (pose by
        # pose, numpy's per-call cost was a fifth of the loop's).
        has_lb, has_ub = np.isfinite(batch.lb).any(axis=1), np.isfinite(batch.ub).any(axis=1)
        H = np.zeros((N, k, k))
        H.reshape(N, k * k)[:, ::k + 1] = batch.P
        c, Aeq, beq, G, h = batch.c, batch.Aeq, batch.beq, batch.G, batch.h
        lb, ub = batch.lb, batch.ub
        rows = G.shape[1] > 0
        found = np.zeros(N, dtype=bool)
        x_prev = None
        for i in range(N):
            problem = qpsolvers.Problem(H[i], c[i], G[i] if rows else None,
                                        h[i] if rows else None, Aeq[i], beq[i],
                                        lb[i] if has_lb[i] else None,
                                        ub[i] if has_ub[i] else None)
            start = time.perf_counter()
            try:
                sol = qpsolvers.solve_problem(problem, solver=self.solver,
                                              initvals=x_prev if warm else None,
                                              **(settings if per_pose is None else per_pose[i]))
            except Exception as error:  # a solver's failure on one pose
                status[i] = Status.SOLVER_ERROR
                note_error(extras, i, error)
                continue
            spent = time.perf_counter() - start
            count = iterations_of(sol.extras or {})
            has_iters &= count is not None
            iters[i] = count or 0
            _keep_duals(duals, i, sol, batch, bool(has_lb[i] or has_ub[i]))
            x = sol.x
            if sol.found and x is not None and np.isfinite(x).all():
                x_all[i], found[i], x_prev = x, True, x
            else:
                status[i] = failure_status(sol.extras or {})
                if status[i] == Status.INACCURATE:  # keep an inaccurate solution's values
                    if sol.x is not None and np.isfinite(sol.x).all():
                        x_all[i] = sol.x
                    else:
                        status[i] = Status.SOLVER_ERROR
                if limit is not None and spent >= limit:  # HiGHS says nothing of it
                    status[i] = note_time_limit(extras, i, limit, status[i])
        status[found] = Status.OPTIMAL
        elapsed = time.perf_counter() - t0
        return RawResult(batch.tensions(x_all), status, iters if has_iters else None, setup,
                         elapsed, extras=extras, multipliers=duals)

    def _solve_daqp(self, batch: ScaledBatch, settings: dict[str, Any], warm: bool,
                    setup: float) -> RawResult:
        t0 = time.perf_counter()
        N, k = batch.N, batch.k
        g, n = batch.G.shape[1], batch.Aeq.shape[1]
        # DAQP layout: k simple bounds, then g inequality rows, then n equality rows.
        rows = np.concatenate([batch.G, batch.Aeq], axis=1)
        upper = np.concatenate([np.minimum(batch.ub, _BIG), batch.h, batch.beq], axis=1)
        lower = np.concatenate([np.maximum(batch.lb, -_BIG), np.full((N, g), -_BIG),
                                batch.beq], axis=1)
        sense = np.zeros(k + g + n, dtype=c_int)
        sense[k + g:] = 5
        # An objective whose linear term is beyond DAQP's arithmetic is handed over
        # divided by a power of two (exact; the multipliers multiplied back below).
        factor = objective_factors(batch.c)
        c = np.array(batch.c) * factor[:, None]
        H = np.zeros((N, k, k))
        H[:, np.arange(k), np.arange(k)] = batch.P * factor[:, None]
        x_all, status, iters = pose_loop_result(N, k)
        lam = np.full((N, k + g + n), np.nan)
        extras: dict[str, Any] = {}
        # Under the size rule's batch size DAQP is called from Python (the same bits as
        # the compiled call, which would compile on a first small call).
        structs = None if warm or not compiled_for(N) else _native_structs(settings)
        setup += time.perf_counter() - t0
        t0 = time.perf_counter()
        if structs is not None:  # every pose in one compiled call of DAQP's C solver
            from tension_opt.kernels.daqp_native import quadprog_batch

            flags = np.zeros(N, dtype=np.int64)
            counts = np.zeros(N, dtype=np.int64)
            quadprog_batch(H, c, rows, upper, lower, sense, x_all, lam, flags, counts,
                           structs)
            iters[:] = counts
            failed = flags <= 0
            x_all[failed], lam[failed] = np.nan, np.nan
        else:
            with quiet_solvers():
                flags = self._daqp_loop(H, c, rows, upper, lower, sense, settings, warm,
                                        x_all, lam, iters, extras)
        good = flags > 0
        status[good] = Status.OPTIMAL
        for j in np.flatnonzero(~good):
            status[j] = _DAQP_EXIT.get(int(flags[j]), Status.SOLVER_ERROR)
        elapsed = time.perf_counter() - t0
        lam /= factor[:, None]
        # DAQP's multipliers: H x + f + A' lam = 0, bounds first (negative at a lower
        # bound), then the inequality rows, then the equations: the certificate's signs.
        duals = Multipliers(lam[:, k + g:], lam[:, k:k + g], lam[:, :k])
        return RawResult(batch.tensions(x_all), status, iters, setup, elapsed, extras=extras,
                         multipliers=duals)

    @staticmethod
    def _daqp_loop(H: NDArray, c: NDArray, rows: NDArray, upper: NDArray, lower: NDArray,
                   sense: NDArray, settings: dict[str, Any], warm: bool, x_all: NDArray,
                   lam: NDArray, iters: NDArray, extras: dict[str, Any]) -> NDArray:
        """``daqp.solve`` pose by pose (warm starts, options the C path does not know);
        returns DAQP's exit flags."""
        import daqp

        N = len(H)
        solve = daqp.solve
        Hs, cs, A, ups, lows = list(H), list(c), list(rows), list(upper), list(lower)
        flags = np.zeros(N, dtype=int)
        # Results go straight into arrays: holding DAQP's per-call outputs (arrays and
        # dicts) until the end of the loop cost as much as the solves themselves.
        x_prev = None
        for i in range(N):
            try:
                x, _, flag, info = solve(Hs[i], cs[i], A[i], ups[i], lows[i], sense,
                                         primal_start=x_prev if warm else None, **settings)
            except Exception as error:  # a solver's failure on one pose
                note_error(extras, i, error)
                continue
            flags[i] = flag
            iters[i] = info["iterations"]
            if flag > 0:
                x_all[i] = x
                lam[i] = info["lam"]
                x_prev = x
        return flags


def objective_factors(c: NDArray) -> NDArray:
    """Per pose, the power of two DAQP's objective is multiplied by before it is solved:
    1 where the scaled problem's largest linear term ``|c_i|`` is at most
    :data:`~tension_opt.kernels.dense_qp.LINEAR_CAP`, else the one that brings it within
    (the numpy reference of :func:`tension_opt.kernels.dense_qp.objective_factor`).

    Parameters
    ----------
    c : ndarray, shape (N, k)
        Linear terms of the scaled problems.

    Returns
    -------
    ndarray, shape (N,)
    """
    from tension_opt.kernels.dense_qp import LINEAR_CAP

    largest = np.abs(c).max(axis=1, initial=0.0)
    over = np.isfinite(largest) & (largest > LINEAR_CAP)
    exponent = np.ceil(np.log2(np.where(over, largest, LINEAR_CAP) / LINEAR_CAP))
    return np.where(over, np.exp2(-exponent), 1.0)


def _keep_duals(duals: Multipliers, i: int, sol: Any, batch: ScaledBatch, bounded: bool
                ) -> None:
    """Store a qpsolvers Solution's multipliers of pose ``i`` (its convention,
    ``P x + q + G'z + A'y + z_box = 0``, is the certificate's); a pose whose solver
    left some out stays unknown (its multipliers are then estimated). ``bounded``:
    whether the pose had a finite bound (else the solver was given none)."""
    parts: list[Any] = []
    for value, size in ((sol.y, batch.Aeq.shape[1]), (sol.z, batch.G.shape[1]),
                        (sol.z_box, batch.k)):
        if size == 0 or (value is None and size == batch.k and not bounded):
            parts.append(0.0)  # no such rows, or no bounds were passed
            continue
        if value is None:
            return
        flat = (value if type(value) is np.ndarray else np.asarray(value, dtype=float)).ravel()
        if flat.size != size:
            return
        parts.append(flat)
    duals.y[i], duals.mu[i], duals.z[i] = parts


def _native_structs(settings: dict[str, Any]) -> NDArray | None:
    """The struct array of DAQP's C solver with ``settings``
    (:mod:`tension_opt.kernels.daqp_native`), or None where it is not available (then
    ``daqp.solve`` runs)."""
    from tension_opt.kernels import daqp_native

    native = daqp_native.load()
    return None if native is None else daqp_native.struct_buffer(native, settings)


def available() -> list[str]:
    """Registry names of the installed qpsolvers solvers this package knows."""
    if qpsolvers is None:
        return []
    return [f"qpsolvers:{s}" for s in sorted(qpsolvers.available_solvers) if s in KNOWN]


def make(solver: str | None) -> Backend:
    """The qpsolvers backend of ``solver`` (default: DAQP)."""
    return QpsolversBackend(solver or "daqp")
