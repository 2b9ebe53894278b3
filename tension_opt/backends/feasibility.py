"""What a solver's silent failure means: infeasible poses told apart from real errors.

Some solvers answer an infeasible problem with a bare failure: HiGHS through qpsolvers
returns no solution and no status, DAQP has exit flags for cycling and non-convexity
that an infeasible min-max or equal-bound problem also raises. Such poses would read
``solver_error`` where every other backend says ``infeasible``. :func:`settle_failures`
decides them by a feasibility LP on the pose's scaled problem (HiGHS through scipy,
an exact simplex with its own infeasibility certificate): ``infeasible`` where it
proves that no tension set in equilibrium lies within the bounds, ``solver_error``
otherwise. A pose whose failure came with a message keeps it and its status.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from tension_opt.solution import Status

if TYPE_CHECKING:
    from tension_opt.problems import StandardForm

__all__ = ["settle_failures"]

#: Exit status of :func:`scipy.optimize.linprog` for a problem shown infeasible.
_LINPROG_INFEASIBLE = 2


def settle_failures(form: StandardForm, raw: Any) -> None:
    """Relabel ``INFEASIBLE`` the poses of ``raw`` (a backend's
    :class:`~tension_opt.backends.base.RawResult` on ``form``) that failed as
    ``SOLVER_ERROR`` without a message where a feasibility LP proves them infeasible
    (in place)."""
    errors: dict[Any, Any] = raw.extras.get("errors", {})
    silent = [int(i) for i in np.flatnonzero(np.asarray(raw.status) == Status.SOLVER_ERROR)
              if int(i) not in errors]
    if not silent:
        return
    from scipy.optimize import linprog

    from tension_opt.scaled import scaled_batch

    batch = scaled_batch(form.subset(np.array(silent)))
    rows = batch.G.shape[1] > 0
    for j, pose in enumerate(silent):
        result = linprog(np.zeros(batch.k), A_ub=batch.G[j] if rows else None,
                         b_ub=batch.h[j] if rows else None, A_eq=batch.Aeq[j],
                         b_eq=batch.beq[j], bounds=np.column_stack([batch.lb[j], batch.ub[j]]),
                         method="highs")
        if result.status == _LINPROG_INFEASIBLE:
            raw.status[pose] = Status.INFEASIBLE
            raw.tensions[pose] = np.nan
