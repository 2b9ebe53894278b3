"""Backend ``scipy:highs``: LPs through :func:`scipy.optimize.linprog` (HiGHS), per pose.

linprog solves linear programs only (min-sum, min-max); ties of non-unique optima are
broken exactly on the optimal face when that face is at most two-dimensional.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import scipy
from scipy.optimize import linprog

from tension_opt.backends.base import MAX_ERRORS, Backend, RawResult, note_error, pose_loop_result
from tension_opt.backends.settings import solver_options, time_limit_of
from tension_opt.certify.certificate import Multipliers
from tension_opt.certify.scaling import scaled_batch
from tension_opt.errors import BackendNotAvailableError
from tension_opt.problem.form import StandardForm
from tension_opt.status import Status

_LINPROG_STATUS = {0: Status.OPTIMAL, 1: Status.MAX_ITER, 2: Status.INFEASIBLE,
                   3: Status.UNBOUNDED, 4: Status.INACCURATE}


class ScipyHighsBackend(Backend):
    """HiGHS through scipy's linprog, one pose at a time.

    Thread safety: per-call solver objects. Each :func:`~scipy.optimize.linprog` call
    builds its own HiGHS instance (HiGHS keeps one task scheduler per calling thread)
    and the backend holds no state of a call, so one instance serves several threads
    at once without a lock, with the answers of serial calls. linprog only warns about
    options it does not know; such ``solver_options`` are refused before the batch
    (:meth:`~tension_opt.backends.base.Backend.check_solver_options`).
    """

    name = "scipy:highs"
    solver = "highs"

    @property
    def version(self) -> str:
        return f"scipy {scipy.__version__}"

    def unsupported(self, form: StandardForm) -> str | None:
        if not form.is_linear:
            return "scipy:highs solves linear programs only (min_sum, min_max)"
        return None

    def solve_stage(self, form: StandardForm, **options: Any) -> RawResult:
        t0 = time.perf_counter()
        batch = scaled_batch(form)
        settings = solver_options("highs", options.get("accuracy"), time_limit_of(options),
                                  options.get("solver_options"), interface="scipy")
        N, k = batch.N, batch.k
        x_all, status, iters = pose_loop_result(N, k)
        duals = Multipliers.unknown(batch)
        extras: dict[str, Any] = {}
        setup = time.perf_counter() - t0
        t0 = time.perf_counter()
        for i in range(N):
            bounds = np.stack([np.where(np.isfinite(batch.lb[i]), batch.lb[i], -np.inf),
                               batch.ub[i]], axis=1)
            G = batch.G[i] if batch.G.shape[1] else None
            h = batch.h[i] if batch.G.shape[1] else None
            try:
                res = linprog(batch.c[i], A_ub=G, b_ub=h, A_eq=batch.Aeq[i],
                              b_eq=batch.beq[i], bounds=bounds, method="highs",
                              options=settings)
            except Exception as error:  # a solver's failure on one pose
                status[i] = Status.SOLVER_ERROR
                note_error(extras, i, error)
                continue
            status[i] = _LINPROG_STATUS.get(res.status, Status.SOLVER_ERROR)
            iters[i] = int(getattr(res, "nit", 0) or 0)
            if res.status == 1:  # an iteration or the time limit: linprog says which
                errors = extras.setdefault("errors", {})
                if len(errors) < MAX_ERRORS:
                    errors[i] = f"HiGHS stopped: {res.message}"
            if res.status == 0:
                x_all[i] = res.x
                _keep_duals(duals, i, res, G is not None)
        elapsed = time.perf_counter() - t0
        return RawResult(batch.tensions(x_all), status, iters, setup, elapsed, extras=extras,
                         multipliers=duals)


def _keep_duals(duals: Multipliers, i: int, res: Any, rows: bool) -> None:
    """Store linprog's marginals of pose ``i`` in the certificate's convention: linprog
    has ``c = A_eq' l_eq + A_ub' l_ub + l_lower + l_upper`` (sensitivities), the
    certificate ``c + A'y + G'mu + z = 0``, so every multiplier changes sign."""
    try:
        duals.y[i] = -np.asarray(res.eqlin.marginals, dtype=float)
        if rows:
            duals.mu[i] = -np.asarray(res.ineqlin.marginals, dtype=float)
        duals.z[i] = -(np.asarray(res.lower.marginals, dtype=float)
                       + np.asarray(res.upper.marginals, dtype=float))
    except (AttributeError, TypeError, ValueError):  # no marginals: estimated instead
        duals.y[i], duals.z[i] = np.nan, np.nan


def available() -> list[str]:
    """Registry names of this family: scipy is a core dependency."""
    return ["scipy:highs"]


def make(solver: str | None) -> Backend:
    """The scipy HiGHS backend (``scipy`` or ``scipy:highs``)."""
    if solver not in (None, "highs"):
        raise BackendNotAvailableError(f"scipy offers 'scipy:highs' only, got 'scipy:{solver}'")
    return ScipyHighsBackend()
