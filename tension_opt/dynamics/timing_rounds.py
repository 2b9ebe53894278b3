"""Rounds of a timing: solve, check between the grid points, add what failed, again.

Each round solves the timing over its checks (:mod:`tension_opt.dynamics.intervals`) by
the chosen method, then checks it densely between the grid points
(:func:`~tension_opt.dynamics.between.between_check`); the points found outside the
tolerances become checks of the next round, up to :data:`BETWEEN_ROUNDS` rounds. The
convex method, where the compiled passes describe the robot, first runs the rounds of
the reachability method (milliseconds each): they find most of the checks the path
needs, and the convex program (tens of milliseconds or more) then runs once or twice.
"""

from __future__ import annotations

from dataclasses import dataclass

from numpy.typing import NDArray

from tension_opt.dynamics.between import Between, SampleBank, between_check, sample_bank
from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.intervals import PathModel, StageChecks
from tension_opt.dynamics.reachability import polish, reachability
from tension_opt.dynamics.stage_rows import stage_rows
from tension_opt.dynamics.timing_convex import convex_rows_timing, convex_timing

__all__ = ["BETWEEN_ROUNDS", "Refined", "refine"]

#: Rounds of checks added between grid points.
BETWEEN_ROUNDS = 8


@dataclass(frozen=True, eq=False)
class Refined:
    """The last round of a timing.

    Attributes
    ----------
    checks : StageChecks
    x, u : ndarray, shape (K,)
    sets : ndarray, shape (K, 2)
        Controllable sets of ``s'^2`` (NaN where not computed).
    between : Between or None
        The dense check of ``x, u``; None without a timing.
    outcome : str
    fail : int or None
        The point where the timing failed, or None.
    count : int
        LPs solved.
    method : str
        The method that gave the answer.
    compiled : bool
        Whether the compiled passes ran.
    """

    checks: StageChecks
    x: NDArray
    u: NDArray
    sets: NDArray
    between: Between | None
    outcome: str
    fail: int | None
    count: int
    method: str
    compiled: bool


def _solve(checks: StageChecks, limits: tuple[NDArray, NDArray, float], method: str,
           deadline: Deadline, compiled: bool, ref: tuple[NDArray, NDArray] | None
           ) -> tuple[NDArray, NDArray, NDArray, str, int | None, int, str]:
    """Run ``method``: ``x, u``, controllable sets, outcome, failing point, LP count and
    the method that gave the answer. The convex program over the checks' rows starts
    from ``ref``, a feasible timing of the checks before."""
    if method == "convex":
        if compiled and ref is not None:
            rows = stage_rows(checks, *limits)
            x, u, outcome = convex_rows_timing(rows, checks.grid, *ref, deadline)
        else:
            x, u, outcome = convex_timing(checks, *limits, deadline=deadline)
        if outcome == "optimal":
            x, u, sets, outcome, count = polish(checks, x, *limits, deadline, compiled)
            if outcome == "optimal":
                return x, u, sets, outcome, None, count, method
    # Also what tells an unbounded or infeasible path from a convex solver's failure.
    x, u, sets, outcome, fail, count = reachability(checks, *limits, deadline, compiled)
    return x, u, sets, outcome, fail, count, (
        "reachability" if method == "reachability" else "convex+reachability")


def _rounds(model: PathModel, checks: StageChecks, limits: tuple[NDArray, NDArray, float],
            method: str, deadline: Deadline, bank: SampleBank,
            ref: tuple[NDArray, NDArray] | None = None) -> Refined:
    compiled = bank.rows is not None
    count = 0
    for rounds in range(BETWEEN_ROUNDS + 1):
        x, u, sets, outcome, fail, lps, used = _solve(checks, limits, method, deadline,
                                                      compiled, ref)
        count += lps
        if fail is not None:
            return Refined(checks, x, u, sets, None, outcome, fail, count, used, compiled)
        ref = (x, u)
        between = between_check(model, x, u, limits[0], limits[1], bank, deadline)
        if not between.bad.any() or rounds == BETWEEN_ROUNDS:
            break
        checks = checks.with_points(model, between.owner, between.at)
    return Refined(checks, x, u, sets, between, outcome, None, count, used, compiled)


def refine(model: PathModel, checks: StageChecks, v_max: NDArray, a_max: NDArray,
           slack: float, method: str, deadline: Deadline) -> Refined:
    """The rounds of a timing (module docstring) from ``checks``.

    Raises
    ------
    OutOfTime
        Once ``deadline`` has passed.
    """
    limits = (v_max, a_max, slack)
    bank = sample_bank(model)
    if bank.rows is not None:  # the compiled passes: the checks' rows kept round to round
        checks = checks.with_rows(slack)
    deadline.check()
    if method == "convex" and bank.rows is not None:
        first = _rounds(model, checks, limits, "reachability", deadline, bank)
        if first.fail is not None:  # no timing at all: the convex program cannot help
            return first
        checks = first.checks
        last = _rounds(model, checks, limits, method, deadline, bank, (first.x, first.u))
        return Refined(last.checks, last.x, last.u, last.sets, last.between, last.outcome,
                       last.fail, first.count + last.count, last.method, last.compiled)
    return _rounds(model, checks, limits, method, deadline, bank)
