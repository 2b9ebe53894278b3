"""TOPP-RA's reachability passes (Pham & Pham 2018) over the stage LPs of a path.

A backward pass of linear programs gives the controllable set ``[K_lo, K_hi]`` of
``x = s'^2`` at every grid point; a forward pass takes the largest ``u = s''`` that
stays controllable. The LPs are two-variable LPs over each grid point's rows in
``(u, x)`` (:mod:`tension_opt.dynamics.stage_rows`, compiled:
:mod:`tension_opt.kernels.reachability`) where the facets of the wrench-feasible sets
describe the robot, else LPs in ``(u, x, T)`` by HiGHS
(:class:`~tension_opt.dynamics.stage_lp.StageLP`, the reference the compiled passes
are tested against). The greedy forward pass is optimal when the largest
speed reachable at the next point grows with the speed at this one; near sharp turns of
a coarse grid it need not be (a faster arrival can force a slower next point).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.stage_lp import StageLP
from tension_opt.dynamics.stage_rows import stage_rows
from tension_opt.status import Status, status_array

__all__ = ["CHUNK", "controllable_sets", "failed_points", "forward_pass", "polish",
           "reachability"]

#: Forward-pass retries, each lowering x_k by this fraction, on a barely infeasible LP.
_RETRIES, _BACKOFF = 8, 1e-7
#: Grid points per call of a compiled pass (the clock is read between calls).
CHUNK = 512


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


class _Compiled:
    """The passes of :mod:`tension_opt.kernels.reachability` over the checks' rows, in
    chunks of :data:`CHUNK` grid points with the clock read between them."""

    def __init__(self, checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float,
                 deadline: Deadline) -> None:
        self.rows = stage_rows(checks, v_max, a_max, slack)
        self.grid = checks.grid
        self.deadline = deadline
        self.count = 0

    def sets(self) -> tuple[NDArray, int | None, str]:
        """As :func:`controllable_sets`."""
        from tension_opt.kernels import reachability as kernel  # loads numba
        r, K = self.rows, self.grid.size
        sets = np.full((K, 2), np.nan)
        k = K - 1
        while k >= 0:
            self.deadline.check()
            k_to = max(k - CHUNK + 1, 0)
            fail, _ = kernel.backward_pass(r.rows, r.rhs, r.start, r.x_top, self.grid, sets,
                                           k, k_to)
            self.count += 2 * (k - k_to + 1)
            if fail >= 0:
                return sets, fail, "infeasible"
            k = k_to - 1
        return sets, None, "optimal"

    def forward(self, sets: NDArray, cap: NDArray | None = None
                ) -> tuple[NDArray, NDArray, str]:
        """As :func:`forward_pass`."""
        from tension_opt.kernels import reachability as kernel  # loads numba
        r, K = self.rows, self.grid.size
        top = sets[:, 1] if cap is None else np.minimum(sets[:, 1],
                                                        np.maximum(cap, sets[:, 0]))
        x, u = np.zeros(K), np.zeros(K)
        for k0 in range(0, K - 1, CHUNK):
            self.deadline.check()
            k1 = min(k0 + CHUNK, K - 1)
            fail, code = kernel.forward_pass(r.rows, r.rhs, r.start, self.grid, sets,
                                             np.ascontiguousarray(top), x, u, k0, k1,
                                             _RETRIES, _BACKOFF)
            self.count += k1 - k0
            if fail >= 0:
                return x, u, "unbounded" if code == kernel.UNBOUNDED else "infeasible"
        u[K - 1] = u[K - 2]  # at rest at the end: the arrival's s''
        return x, u, "optimal"


class _Highs:
    """The passes over :class:`StageLP` (HiGHS), the reference."""

    def __init__(self, checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float,
                 deadline: Deadline) -> None:
        self.lp = StageLP(checks, v_max, a_max, slack, deadline)

    @property
    def count(self) -> int:
        return self.lp.count

    def sets(self) -> tuple[NDArray, int | None, str]:
        return controllable_sets(self.lp)

    def forward(self, sets: NDArray, cap: NDArray | None = None
                ) -> tuple[NDArray, NDArray, str]:
        return forward_pass(self.lp, sets, cap)


def _passes(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float,
            deadline: Deadline | None, compiled: bool) -> _Compiled | _Highs:
    kind = _Compiled if compiled else _Highs
    return kind(checks, v_max, a_max, slack, deadline or Deadline())


def reachability(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float,
                 deadline: Deadline | None = None, compiled: bool = False
                 ) -> tuple[NDArray, NDArray, NDArray, str, int | None, int]:
    """TOPP-RA: ``x, u`` (K,), controllable sets (K, 2), outcome, the failing point
    (or None) and the number of LPs; ``compiled``: by the two-variable LPs of the
    checks' rows (:mod:`tension_opt.kernels.reachability`; the checks' facets must fit,
    :func:`~tension_opt.dynamics.point_rows.facets_fit`), else by HiGHS."""
    passes = _passes(checks, v_max, a_max, slack, deadline, compiled)
    sets, fail, outcome = passes.sets()
    x = u = np.full(checks.K, np.nan)
    if fail is None and sets[0, 0] > 1e-9 * max(1.0, sets[0, 1]):
        fail, outcome = 0, "infeasible"  # the path cannot start at rest
    if fail is None:
        x, u, outcome = passes.forward(sets)
    if outcome != "optimal":
        fail = 0 if fail is None else fail
    return x, u, sets, outcome, fail, passes.count


def polish(checks: StageChecks, x: NDArray, v_max: NDArray, a_max: NDArray, slack: float,
           deadline: Deadline | None = None, compiled: bool = False
           ) -> tuple[NDArray, NDArray, NDArray, str, int]:
    """An approximate timing ``x`` (K,) made exact: the reachability passes with ``x``
    as a cap, so that each ``s'^2`` is the largest that the exact LPs allow at or below
    ``x`` (an interior-point solver's answer is feasible and optimal only to its
    tolerance, and the duration is sensitive to a small ``s'^2``). Returns ``x, u``,
    the controllable sets, an outcome and the number of LPs."""
    passes = _passes(checks, v_max, a_max, slack, deadline, compiled)
    sets, fail, outcome = passes.sets()
    if fail is not None:
        return x, np.full(checks.K, np.nan), sets, outcome, passes.count
    x, u, outcome = passes.forward(sets, cap=x)
    return x, u, sets, outcome, passes.count


def failed_points(checks: StageChecks, v_max: NDArray, a_max: NDArray, outcome: str,
                  deadline: Deadline | None = None, compiled: bool = False) -> NDArray:
    """Per-point status of a path without a timing: ``INFEASIBLE`` where no ``(u, x)``
    at all is feasible, the rest ``NOT_RUN`` (``UNBOUNDED`` everywhere if unbounded)."""
    from tension_opt.kernels import reachability as kernel  # loads numba
    if outcome == "unbounded":
        return status_array(checks.K, Status.UNBOUNDED)
    status = status_array(checks.K, Status.NOT_RUN)
    if compiled:
        r = stage_rows(checks, v_max, a_max, 0.0)
        status[~kernel.stage_feasible(r.rows, r.rhs, r.start, r.x_top)] = Status.INFEASIBLE
    else:
        lp = StageLP(checks, v_max, a_max, deadline=deadline)
        for k in range(checks.K):
            if lp.solve(k, (0.0, 0.0), (0.0, np.inf), None)[0] == "infeasible":
                status[k] = Status.INFEASIBLE
    if not (status == Status.INFEASIBLE).any() and outcome == "infeasible":
        status[:] = Status.INFEASIBLE  # each point passable alone, the path is not
    elif outcome not in ("infeasible", "optimal"):
        status[status == Status.NOT_RUN] = Status.SOLVER_ERROR
    return status
