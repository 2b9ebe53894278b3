"""TOPP-RA's reachability passes (Pham & Pham 2018) over the stage LPs of a path.

A backward pass of linear programs in ``(u, x, T)``
(:class:`~tension_opt.dynamics.stage_lp.StageLP`, HiGHS) gives the controllable set
``[K_lo, K_hi]`` of ``x = s'^2`` at every grid point; a forward pass takes the largest
``u = s''`` that stays controllable. The greedy forward pass is optimal when the largest
speed reachable at the next point grows with the speed at this one; near sharp turns of
a coarse grid it need not be (a faster arrival can force a slower next point).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.stage_lp import StageLP
from tension_opt.status import Status, status_array

__all__ = ["controllable_sets", "failed_points", "forward_pass", "polish", "reachability"]

#: Forward-pass retries, each lowering x_k by this fraction, on a barely infeasible LP.
_RETRIES, _BACKOFF = 8, 1e-7


def controllable_sets(lp: StageLP) -> tuple[NDArray, int | None, str]:
    """Backward pass: ``K`` (K, 2) of controllable ``x``; the first point (from the end)
    where it is empty, or None; and an outcome."""
    K = lp.checks.K
    sets = np.full((K, 2), np.nan)
    outcome, _ = lp.solve(K - 1, (0.0, 0.0), (0.0, 0.0), None)  # at rest at the end
    if outcome != "optimal":
        return sets, K - 1, outcome
    sets[K - 1] = 0.0
    for k in range(K - 2, -1, -1):
        nxt = (sets[k + 1, 0], sets[k + 1, 1])
        out_lo, z_lo = lp.solve(k, (0.0, 1.0), (0.0, np.inf), nxt)
        out_hi, z_hi = lp.solve(k, (0.0, -1.0), (0.0, np.inf), nxt)
        if out_lo != "optimal" or z_lo is None or out_hi not in ("optimal", "unbounded"):
            return sets, k, out_lo if out_lo != "optimal" else out_hi
        hi = np.inf if z_hi is None else z_hi[1]
        sets[k] = (max(z_lo[1], 0.0), hi)
    return sets, None, "optimal"


def forward_pass(lp: StageLP, sets: NDArray, cap: NDArray | None = None
                 ) -> tuple[NDArray, NDArray, str]:
    """Greedy forward pass: ``x`` (K,), ``u`` (K,) and an outcome; with ``cap`` (K,),
    ``x`` kept at or below it where the controllable sets allow."""
    K = lp.checks.K
    ds = np.diff(lp.checks.grid)
    x, u = np.zeros(K), np.zeros(K)
    top = sets[:, 1] if cap is None else np.minimum(sets[:, 1], np.maximum(cap, sets[:, 0]))
    for k in range(K - 1):
        nxt = (sets[k + 1, 0], top[k + 1])
        for _ in range(_RETRIES):
            outcome, z = lp.solve(k, (-1.0, 0.0), (x[k], x[k]), nxt)
            if outcome != "infeasible" or x[k] == 0.0:
                break
            x[k] *= 1.0 - _BACKOFF  # the LP's tolerance left x_k just outside
        if outcome != "optimal" or z is None:
            return x, u, outcome
        x[k + 1] = min(max(x[k] + 2.0 * ds[k] * z[0], sets[k + 1, 0]), top[k + 1])
        u[k] = (x[k + 1] - x[k]) / (2.0 * ds[k])
    # At rest at the end, the arrival's s'' (feasible there: the last interval's end).
    u[K - 1] = u[K - 2]
    return x, u, "optimal"


def reachability(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float,
                 deadline: Deadline | None = None
                 ) -> tuple[NDArray, NDArray, NDArray, str, int | None, int]:
    """TOPP-RA: ``x, u`` (K,), controllable sets (K, 2), outcome, the failing point
    (or None) and the number of LPs."""
    lp = StageLP(checks, v_max, a_max, slack, deadline)
    sets, fail, outcome = controllable_sets(lp)
    x = u = np.full(checks.K, np.nan)
    if fail is None and sets[0, 0] > 1e-9 * max(1.0, sets[0, 1]):
        fail, outcome = 0, "infeasible"  # the path cannot start at rest
    if fail is None:
        x, u, outcome = forward_pass(lp, sets)
    if outcome != "optimal":
        fail = 0 if fail is None else fail
    return x, u, sets, outcome, fail, lp.count


def polish(checks: StageChecks, x: NDArray, v_max: NDArray, a_max: NDArray, slack: float,
           deadline: Deadline | None = None) -> tuple[NDArray, NDArray, NDArray, str, int]:
    """An approximate timing ``x`` (K,) made exact: the reachability passes with ``x``
    as a cap, so that each ``s'^2`` is the largest that the exact LPs allow at or below
    ``x`` (an interior-point solver's answer is feasible and optimal only to its
    tolerance, and the duration is sensitive to a small ``s'^2``). Returns ``x, u``,
    the controllable sets, an outcome and the number of LPs."""
    lp = StageLP(checks, v_max, a_max, slack, deadline)
    sets, fail, outcome = controllable_sets(lp)
    if fail is not None:
        return x, np.full(checks.K, np.nan), sets, outcome, lp.count
    x, u, outcome = forward_pass(lp, sets, cap=x)
    return x, u, sets, outcome, lp.count


def failed_points(checks: StageChecks, v_max: NDArray, a_max: NDArray, outcome: str,
                  deadline: Deadline | None = None) -> NDArray:
    """Per-point status of a path without a timing: ``INFEASIBLE`` where no ``(u, x)``
    at all is feasible, the rest ``NOT_RUN`` (``UNBOUNDED`` everywhere if unbounded)."""
    if outcome == "unbounded":
        return status_array(checks.K, Status.UNBOUNDED)
    lp = StageLP(checks, v_max, a_max, deadline=deadline)
    status = status_array(checks.K, Status.NOT_RUN)
    for k in range(checks.K):
        if lp.solve(k, (0.0, 0.0), (0.0, np.inf), None)[0] == "infeasible":
            status[k] = Status.INFEASIBLE
    if not (status == Status.INFEASIBLE).any() and outcome == "infeasible":
        status[:] = Status.INFEASIBLE  # each point passable alone, the path is not
    elif outcome not in ("infeasible", "optimal"):
        status[status == Status.NOT_RUN] = Status.SOLVER_ERROR
    return status
