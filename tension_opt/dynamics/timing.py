"""Time-optimal timing of a path under tension, velocity and acceleration limits.

Along a path ``q(s)`` (:mod:`tension_opt.dynamics.path`) the wrench the cables must
supply is linear in ``u = s''`` and ``x = s'^2``, so at every point the constraints are
linear in ``(u, x)`` and the tensions ``T``::

    A T = a u + b x + c,   t_min <= T <= t_max,
    x |V_j|^2 <= v_max_j^2,   |V_j u + C_j x| <= a_max_j,   x >= 0.

A timing moves with a constant ``u_k`` from grid point ``s_k`` to the next, so
``x_{k+1} = x_k + 2 (s_{k+1} - s_k) u_k``, from rest to rest. Its constraints hold
along the whole interval, not only at the grid points
(:mod:`tension_opt.dynamics.intervals`): each ``(u_k, x_k)`` is constrained at its
grid point, at the end of its interval (with the path's values there: TOPP-RA's
interpolation scheme), at the spline's knots inside it, and, round by round
(:mod:`tension_opt.dynamics.timing_rounds`), at the points inside where a dense check
(:mod:`tension_opt.dynamics.between`) found the wrench outside the feasible set or a
motion limit exceeded. Two solvers:

``"reachability"``
    TOPP-RA (Pham & Pham 2018): a backward pass of linear programs gives the
    controllable set ``[K_lo, K_hi]`` of ``x`` at every grid point; a forward pass takes
    the largest ``u`` that stays controllable (:mod:`tension_opt.dynamics.reachability`):
    compiled two-variable LPs over the facet rows of the wrench-feasible sets
    (:mod:`tension_opt.dynamics.stage_rows`, :mod:`tension_opt.kernels.reachability`),
    or, where the facets do not describe the robot (too many, or a structure matrix of
    lower rank), LPs over the tensions by HiGHS.
``"convex"`` (default)
    The convex program of Verscheure et al. (2009): minimise the traversal time
    ``sum 2 ds_k / (sqrt(x_k) + sqrt(x_{k+1}))`` over every point at once, by Clarabel
    (:mod:`tension_opt.dynamics.timing_convex`): over the facet rows with cutting planes
    after the reachability method's rounds, or over the tensions; its answer made
    exact by the reachability passes capped by it
    (:func:`~tension_opt.dynamics.reachability.polish`).

The convex program finds the global optimum of the discretised problem. The greedy
forward pass of the reachability scheme is optimal when the largest speed reachable
at the next point grows with the speed at this one; near sharp turns of a coarse grid
it need not (a faster arrival can force a slower next point), and its timing can then
be a few per cent slower; the two agree as the grid is refined.

The time between grid points is ``2 ds_k / (s'_k + s'_{k+1})`` (constant ``s''``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_float_array, is_number
from tension_opt.dynamics.between import Between
from tension_opt.dynamics.deadline import Deadline, OutOfTime
from tension_opt.dynamics.intervals import PathModel, StageChecks, initial_checks
from tension_opt.dynamics.path import PathSpline, PathStages
from tension_opt.dynamics.reachability import failed_points
from tension_opt.dynamics.timed import TimedTrajectory
from tension_opt.dynamics.timing_rounds import refine
from tension_opt.dynamics.timing_tensions import timing_tensions
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import Objective, TensionProblem, as_problem, typical_tension
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace.margin import margin_solve

__all__ = ["STOP_TOL", "TimingResult", "motion_limits", "time_optimal"]

#: ``s'^2`` at or below this share of its largest value along the path counts as zero.
STOP_TOL = 1e-9


def motion_limits(name: str, value: float | ArrayLike | None, n: int) -> NDArray:
    """A velocity or acceleration limit as (n,) positive values (inf: no limit)."""
    if value is None:
        return np.full(n, np.inf)
    arr = as_float_array(name, value)
    try:
        arr = np.array(np.broadcast_to(arr, (n,)))
    except ValueError:
        raise InvalidInputError(f"{name} must be a number or have shape ({n},), "
                                f"got {arr.shape}") from None
    if np.isnan(arr).any() or (arr <= 0).any():
        raise InvalidInputError(f"{name} must be positive (inf for no limit), got {arr}")
    return arr


@dataclass(frozen=True, eq=False)
class TimingResult:
    """The time-optimal timing of a path, per grid point.

    Attributes
    ----------
    s : ndarray, shape (K,)
        Grid of the path parameter (m, rad).
    times : ndarray, shape (K,)
        When each grid point is reached (s); NaN if no timing was found.
    duration : float
        Total time (s); inf if no timing was found.
    sd, sdd : ndarray, shape (K,)
        Path speed ``s'`` and acceleration ``s''`` (``s''`` constant up to the next point;
        at the last point, at rest, the arrival's).
    poses, velocities, accelerations : ndarray, shape (K, n)
        Poses and their velocity coordinates and derivatives at the grid points.
    wrenches : ndarray, shape (K, n)
        Wrench the cables supply, ``structure @ tensions`` (N, N m): the
        Newton-Euler wrench less any external ``wrench``.
    tensions : ndarray, shape (K, m)
        Tensions holding ``wrenches`` chosen by the objective (N); NaN where none.
    status : ndarray of str, shape (K,)
        ``OPTIMAL``; ``INACCURATE`` where the motion from the point to the next leaves
        the feasible wrenches or a motion limit (see ``margin_between``);
        ``INFEASIBLE`` where no timing can pass the point (others
        ``NOT_RUN``); ``UNBOUNDED`` if nothing limits the speed; ``STALLED`` at the
        second of two neighbouring points where ``s'^2`` is zero (within
        :data:`STOP_TOL` of its largest value: the segment would take forever; the
        reachability method's greedy pass can stall where the convex method finds a
        timing); a tension solve's status.
    margin : ndarray, shape (K,)
        Capacity margin of the wrench (N): zero where the tension limits bind.
    margin_between : ndarray, shape (K - 1,)
        The smallest capacity margin (N) from each grid point to the next, of the
        wrench the timing needs there (its ``s''`` kept up to the next point), checked
        at the interval's ends and at evenly spaced points of it, more where the
        margin's curvature asks (:func:`~tension_opt.dynamics.intervals.between_check`);
        NaN without a timing.
    margin_between_s : ndarray, shape (K - 1,)
        Where each is (m, rad).
    active_tension : ndarray of bool, shape (K,)
        The tension limits bind (margin within ``active_tol`` of a typical tension).
    active_cables : ndarray of bool, shape (K, m)
        Cables at a bound where the tension limits bind.
    active_velocity, active_acceleration : ndarray of bool, shape (K, n)
        Velocity or acceleration coordinates at their limits.
    controllable : ndarray, shape (K, 2)
        Controllable set ``[K_lo, K_hi]`` of ``s'^2`` (reachability method).
    method : str
    lp_count : int
        Linear programs solved.
    solve_time : float
        Wall-clock time (s).
    extras : dict
        ``stages`` (the :class:`~tension_opt.dynamics.path.PathStages`), ``path``.
    """

    s: NDArray
    times: NDArray
    duration: float
    sd: NDArray
    sdd: NDArray
    poses: NDArray
    velocities: NDArray
    accelerations: NDArray
    wrenches: NDArray
    tensions: NDArray
    status: NDArray
    margin: NDArray
    margin_between: NDArray
    margin_between_s: NDArray
    active_tension: NDArray
    active_cables: NDArray
    active_velocity: NDArray
    active_acceleration: NDArray
    controllable: NDArray
    method: str
    lp_count: int
    solve_time: float
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Whether a timing was found with tensions at every point."""
        return bool((self.status == Status.OPTIMAL).all())

    @property
    def min_margin_between(self) -> float:
        """The smallest capacity margin between the grid points (N); NaN without a timing."""
        if not np.isfinite(self.margin_between).any():
            return float("nan")
        return float(np.nanmin(self.margin_between))

    @property
    def min_margin_between_at(self) -> float:
        """Where :attr:`min_margin_between` is (m, rad); NaN without a timing."""
        if not np.isfinite(self.margin_between).any():
            return float("nan")
        return float(self.margin_between_s[np.nanargmin(self.margin_between)])

    @property
    def trajectory(self) -> TimedTrajectory:
        """The timed grid points as a :class:`TimedTrajectory` (needs :attr:`success`)."""
        if not self.success:
            raise InvalidInputError("no timing was found: see the result's status")
        kind = self.extras["kind"]
        return TimedTrajectory(self.times, self.poses, self.velocities, self.accelerations, kind)

    def limit(self) -> NDArray:
        """What binds at each point: ``"tension"``, ``"velocity"``, ``"acceleration"``
        (joined by ``+``) or ``""``, shape (K,) of str."""
        parts = [np.where(self.active_tension, "tension", ""),
                 np.where(self.active_velocity.any(axis=1), "velocity", ""),
                 np.where(self.active_acceleration.any(axis=1), "acceleration", "")]
        return np.array(["+".join(p for p in row if p) for row in zip(*parts, strict=True)])

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per grid point: s, time, speed, margin, binding limit."""
        frame = pd.DataFrame({"s": self.s, "time": self.times, "sd": self.sd,
                              "sdd": self.sdd, "status": self.status,
                              "margin": self.margin, "limit": self.limit()})
        for i in range(self.tensions.shape[1]):
            frame[f"T{i}"] = self.tensions[:, i]
        return frame


def time_optimal(
    robot: CableRobot,
    path: ArrayLike | PathSpline,
    v_max: float | ArrayLike | None = None,
    a_max: float | ArrayLike | None = None,
    *,
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str = "auto",
    gridpoints: int | ArrayLike | None = None,
    method: Literal["convex", "reachability"] = "convex",
    structure: ArrayLike | None = None,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    wrench: ArrayLike | None = None,
    tension_slack: float = 1e-6,
    active_tol: float = 1e-5,
    time_limit: float | None = None,
    **options: Any,
) -> TimingResult:
    """The fastest timing of a path from rest to rest within the tension limits.

    Parameters
    ----------
    robot : CableRobot
    path : array_like, shape (N, n), or PathSpline
        Poses in order (m, rad); the path is the cubic spline through them.
    v_max, a_max : float or array_like, shape (n,), optional
        Limits of each velocity coordinate (m/s, rad/s) and of its derivative (m/s^2,
        rad/s^2); ``inf`` or None for none.
    objective, backend
        Choose the reported tensions, as in :func:`tension_opt.distribute`.
    gridpoints : int or array_like, optional
        Grid of ``s``, 3 to 100000 points (``PathSpline.grid``): the poses' own
        (default), a count of evenly spaced ones, or the values.
    method : {"convex", "reachability"}
        The convex time minimisation (default: the global optimum of the discretised
        problem), or TOPP-RA's greedy passes (module docstring). Where the convex
        solver finds no timing, the reachability passes run and tell why
        (``result.method`` is then ``"convex+reachability"``).
    structure, bounds, wrench : array_like, optional
        Structure matrices (K, n, m) and tension bounds (each (m,) or (K, m), N) at the
        grid points replacing the robot's; external wrench besides gravity and inertia
        ((n,) or (K, n), N, N m). Interpolated linearly between the grid points.
    tension_slack, active_tol : float
        Keep the tensions this fraction of the tension scale (``check_limits`` of
        :mod:`~tension_opt.dynamics.stage_lp`) inside their bounds, beyond the LPs'
        tolerance (costs as much time, relative), in [0, 0.5); relative tolerance for
        reporting a limit as active, in [0, 1).
    time_limit : float, optional
        Seconds the whole call may take (default: none). A timing not found by then is
        none: ``duration = inf``, every point ``MAX_ITER``, ``extras["stopped"] =
        "time_limit"``; the tension solve of a timing found gets the time left.
    **options
        Passed to the tension backend; ``previous`` (K, m): the tensions a smoothed
        objective stays close to.

    Returns
    -------
    TimingResult
        ``times``, ``duration``, motion, ``tensions``, per-point ``status``, the margin
        at and between the grid points and the active limits. A motion still outside
        the feasible wrenches (margin below ``-FEASIBILITY_TOL`` times the typical
        tension) or a motion limit between grid points after the rounds of checks
        (``timing_rounds.BETWEEN_ROUNDS``) is ``INACCURATE`` there, its figures kept. A
        path that cannot be timed (a point the robot cannot hold, no way from rest to
        rest, a timing that stops the path: ``STALLED``) has ``duration = inf``.

    Raises
    ------
    InvalidInputError
        On a bad path, limits, grid, structure, bounds, method, setting or time limit.
    """
    t0 = time.perf_counter()
    _check_settings(method, tension_slack=(tension_slack, 0.5), active_tol=(active_tol, 1.0))
    spline = path if isinstance(path, PathSpline) else PathSpline.through(robot, path)
    model = PathModel.build(robot, spline, spline.grid(gridpoints), structure=structure,
                            bounds=bounds, wrench=wrench)
    run = _Run(robot, model, *_limits(robot, v_max, a_max), tension_slack, method,
               as_problem(objective), bounds is not None, backend, options, active_tol, t0,
               Deadline.after(time_limit, t0), {"path": spline, "kind": robot.kind})
    return _rounds(run, initial_checks(model))


def _limits(robot: CableRobot, v_max: float | ArrayLike | None,
            a_max: float | ArrayLike | None) -> tuple[NDArray, NDArray]:
    return motion_limits("v_max", v_max, robot.dof), motion_limits("a_max", a_max, robot.dof)


def _rounds(run: _Run, checks: StageChecks) -> TimingResult:
    """The rounds of the timing (:func:`~tension_opt.dynamics.timing_rounds.refine`) and
    its result; no timing, every point ``MAX_ITER``, where the time limit passes
    first."""
    run.extras["stages"] = run.model.stages
    K = run.model.stages.K
    try:
        r = refine(run.model, checks, run.vmax, run.amax, run.slack, run.method,
                   run.deadline)
        run.extras["checks"] = r.checks
        if r.fail is not None or r.between is None:
            status = failed_points(r.checks, run.vmax, run.amax, r.outcome, run.deadline,
                                   r.compiled)
            return _no_timing(run, status, r.sets, r.method, r.count)
    except OutOfTime:
        run.extras.setdefault("checks", checks)
        run.extras["stopped"] = "time_limit"
        return _no_timing(run, status_array(K, Status.MAX_ITER), np.full((K, 2), np.nan),
                          run.method, 0)
    return _timed(run, r.x, r.u, r.sets, r.between, r.method, r.count)


@dataclass(frozen=True, eq=False)
class _Run:
    """What a call of :func:`time_optimal` computes its result from."""

    robot: CableRobot
    model: PathModel
    vmax: NDArray
    amax: NDArray
    slack: float
    method: str
    problem: TensionProblem
    custom_bounds: bool
    backend: Any
    options: dict[str, Any]
    active_tol: float
    t0: float
    deadline: Deadline
    extras: dict[str, Any]


def _check_settings(method: str, **given: tuple[object, float]) -> None:
    """A known ``method``, and each setting ``name=(value, top)`` a number in
    ``[0, top)``, or the package's error naming it."""
    if method not in ("convex", "reachability"):
        raise InvalidInputError(f'method must be "convex" or "reachability", got {method!r}')
    for name, (value, top) in given.items():
        if not (is_number(value) and 0.0 <= float(value) < top):  # type: ignore[arg-type]
            raise InvalidInputError(f"{name} must be a number in [0, {top}), got {value!r}")


def _no_timing(run: _Run, status: NDArray, sets: NDArray, method: str, count: int
               ) -> TimingResult:
    stages = run.model.stages
    K, n, m = stages.K, run.robot.dof, run.robot.m
    nan = np.full(K, np.nan)
    return TimingResult(
        stages.s, nan, float("inf"), nan, nan, stages.poses, np.full((K, n), np.nan),
        np.full((K, n), np.nan), np.full((K, n), np.nan), np.full((K, m), np.nan), status,
        nan, nan[1:], nan[1:], np.zeros(K, bool), np.zeros((K, m), bool),
        np.zeros((K, n), bool), np.zeros((K, n), bool), sets, method, count,
        time.perf_counter() - run.t0, run.extras)


def _timed(run: _Run, x: NDArray, u: NDArray, sets: NDArray, between: Between, method: str,
           count: int) -> TimingResult:
    """The result of a timing ``x, u``: times, motion, tensions and active limits."""
    stages = run.model.stages
    x = np.maximum(x, 0.0)
    sd = np.sqrt(x)
    # Zero to the LPs' tolerance: the path would stop there, and a segment between two
    # such points take forever (or, from rounding, millions of seconds).
    stopped = x <= STOP_TOL * max(float(x.max(initial=0.0)), np.finfo(float).tiny)
    stalls = stopped[:-1] & stopped[1:]
    if stalls.any():  # no timing
        status = status_array(stages.K, Status.NOT_RUN)
        status[1:][stalls] = Status.STALLED
        return _no_timing(run, status, sets, method, count)
    dt = 2.0 * np.diff(stages.s) / (sd[:-1] + sd[1:])
    times = np.concatenate([[0.0], np.cumsum(dt)])
    vel, acc = stages.motion(u, x)
    W = stages.wrenches(u, x)
    options = run.options
    if run.deadline.limited:  # the time left, a little at least
        options = {**options, "time_limit": max(run.deadline.remaining(), 1e-3)}
    T, status = timing_tensions(run.robot, stages, W, run.problem, run.custom_bounds,
                                not run.model.structure, run.backend, options)
    # Outside the feasible set (or a motion limit) between grid points after the last
    # round of checks: the figures stand, not as optimal.
    status[:-1][between.bad & (status[:-1] == Status.OPTIMAL)] = Status.INACCURATE
    margin = _grid_margin(run.extras["checks"], stages, W, u, x)
    typical = typical_tension(stages.A, W, stages.lb)
    tight = run.active_tol * typical[:, None]
    active = margin <= run.active_tol * typical
    cables = active[:, None] & ((T - stages.lb <= tight) | (stages.ub - T <= tight))
    return TimingResult(
        stages.s, times, float(times[-1]), sd, u, stages.poses, vel, acc, W, T, status,
        margin, between.margin, between.s, active, cables,
        np.abs(vel) >= run.vmax * (1 - run.active_tol),
        np.abs(acc) >= run.amax * (1 - run.active_tol), sets, method, count,
        time.perf_counter() - run.t0, run.extras)


def _grid_margin(checks: StageChecks, stages: PathStages, W: NDArray, u: NDArray,
                 x: NDArray) -> NDArray:
    """Capacity margin (N) of the wrenches ``W`` (K, n) at the grid points: from the
    checks' facet rows where they have them (the grid points' own, ``offset == 0``: a
    few products), else solved (:func:`~tension_opt.workspace.margin.margin_solve`)."""
    rows = checks.rows
    mine = np.flatnonzero(checks.offset == 0.0)
    if rows is not None and mine.size == stages.K and (checks.owner[mine] == np.arange(
            stages.K)).all():
        return rows.take(mine).margin(u, x)
    ones = np.ones_like(stages.lb)
    return margin_solve(stages.A, W, stages.lb, ones, stages.ub, ones, "auto")[0]
