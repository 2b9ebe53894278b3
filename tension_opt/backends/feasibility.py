"""What a solver's silent failure means: infeasible poses told apart from real errors.

Some solvers answer an infeasible problem with a bare failure: HiGHS through qpsolvers
returns no solution and no status, DAQP has exit flags for cycling and non-convexity
that an infeasible min-max or equal-bound problem also raises. Such poses would read
``solver_error`` where every other backend says ``infeasible``. :func:`settle_failures`
decides them by a feasibility LP on the pose's scaled problem (HiGHS through scipy,
an exact simplex with its own infeasibility certificate): ``infeasible`` where it
proves that no tension set in equilibrium lies within the bounds, ``solver_error``
otherwise. A pose whose failure came with a message keeps it and its status.

A solver may also call a problem ``unbounded`` that cannot be: with finite lower
bounds (every tension problem has them) and each variable either in a positive
quadratic term or of a cost that is not negative (min-max weights too), the objective
is bounded below on the box. Such a verdict (seen from Clarabel on references of
1e18 N) is decided by the same LP: ``infeasible`` where proven, else ``solver_error``
with a message saying why.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from tension_opt.status import Status

if TYPE_CHECKING:
    from tension_opt.problem.form import StandardForm

__all__ = ["settle_failures"]

#: Exit status of :func:`scipy.optimize.linprog` for a problem shown infeasible.
_LINPROG_INFEASIBLE = 2


def settle_failures(form: StandardForm, raw: Any, max_errors: int = 10) -> None:
    """Relabel ``INFEASIBLE`` the poses of ``raw`` (a backend's
    :class:`~tension_opt.backends.base.RawResult` on ``form``) that failed as
    ``SOLVER_ERROR`` without a message, or were called ``UNBOUNDED`` on an objective
    bounded below, where a feasibility LP proves them infeasible; the second kind are
    ``SOLVER_ERROR`` otherwise, with a message while ``extras["errors"]`` holds fewer
    than ``max_errors`` (in place)."""
    errors: dict[Any, Any] = raw.extras.get("errors", {})
    status = np.asarray(raw.status)
    silent = [int(i) for i in np.flatnonzero(status == Status.SOLVER_ERROR)
              if int(i) not in errors]
    impossible = [int(i) for i in np.flatnonzero(status == Status.UNBOUNDED)
                  if _bounded_below(form, int(i))]
    for pose in impossible:
        raw.status[pose], raw.tensions[pose] = Status.SOLVER_ERROR, np.nan
    poses = silent + impossible
    if not poses:
        return
    from scipy.optimize import linprog

    from tension_opt.certify.scaling import scaled_batch

    batch = scaled_batch(form.subset(np.array(poses)))
    rows = batch.G.shape[1] > 0
    for j, pose in enumerate(poses):
        result = linprog(np.zeros(batch.k), A_ub=batch.G[j] if rows else None,
                         b_ub=batch.h[j] if rows else None, A_eq=batch.Aeq[j],
                         b_eq=batch.beq[j], bounds=np.column_stack([batch.lb[j], batch.ub[j]]),
                         method="highs")
        if result.status == _LINPROG_INFEASIBLE:
            raw.status[pose] = Status.INFEASIBLE
            raw.tensions[pose] = np.nan
        elif pose in impossible:
            messages = raw.extras.setdefault("errors", {})
            if len(messages) < max_errors:
                messages.setdefault(pose, "the solver said unbounded, but the objective is "
                                    "bounded below on the bounds and a tension set in "
                                    "equilibrium within them exists")


def _bounded_below(form: StandardForm, pose: int) -> bool:
    """Whether the objective of ``pose`` is bounded below on its bounds: finite lower
    bounds, each variable in a positive quadratic term or of a cost not negative, and
    min-max weights not negative (see the module docstring)."""
    q, c = form.q[pose], form.c[pose]
    weights_ok = form.minmax is None or bool((np.asarray(form.minmax) >= 0).all())
    return bool(np.isfinite(form.lb[pose]).all() and ((q > 0) | (c >= 0)).all()
                and weights_ok)
