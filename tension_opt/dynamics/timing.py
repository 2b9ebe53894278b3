"""Time-optimal timing of a path under tension, velocity and acceleration limits.

Along a path ``q(s)`` (:mod:`tension_opt.dynamics.path`) the wrench the cables must
supply is linear in ``u = s''`` and ``x = s'^2``, so at every grid point ``s_k`` the
constraints are linear in ``(u_k, x_k)`` and the tensions ``T_k``::

    A_k T_k = a_k u_k + b_k x_k + c_k,   t_min <= T_k <= t_max,
    x_k |V_kj|^2 <= v_max_j^2,   |V_kj u_k + C_kj x_k| <= a_max_j,   x_k >= 0,

with ``x_{k+1} = x_k + 2 (s_{k+1} - s_k) u_k`` between grid points (the collocation
scheme of TOPP-RA) and rest at both ends. Two solvers:

``"reachability"``
    TOPP-RA (Pham & Pham 2018): a backward pass of linear programs in ``(u, x, T)``
    gives the controllable set ``[K_lo, K_hi]`` of ``x`` at every grid point; a
    forward pass takes the largest ``u`` that stays controllable. Both are LPs solved
    by HiGHS (:mod:`tension_opt.dynamics.lp`), the tensions scaled by a typical
    tension per point.
``"convex"`` (default)
    The convex program of Verscheure et al. (2009): minimise the traversal time
    ``sum 2 ds_k / (sqrt(x_k) + sqrt(x_{k+1}))`` over ``(u, x, T)`` of every point at
    once (cvxpy, Clarabel) (:mod:`tension_opt.dynamics.timing_convex`).

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

from tension_opt.backends.registry import choose_backend
from tension_opt.checks import as_float_array, is_number
from tension_opt.distribution.solution import solution_of
from tension_opt.dynamics.path import PathSpline, PathStages, path_stages
from tension_opt.dynamics.stage_lp import StageLP
from tension_opt.dynamics.timed import TimedTrajectory
from tension_opt.dynamics.timing_convex import convex_timing
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import Objective, TensionProblem, as_problem, typical_tension
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace.margin import margin_solve

__all__ = ["STOP_TOL", "TimingResult", "motion_limits", "time_optimal"]

#: Forward-pass retries, each lowering x_k by this fraction, on a barely infeasible LP.
_RETRIES, _BACKOFF = 8, 1e-7
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


def _controllable_sets(lp: StageLP) -> tuple[NDArray, int | None, str]:
    """Backward pass: ``K`` (K, 2) of controllable ``x``; the first point (from the end)
    where it is empty, or None; and an outcome."""
    K = lp.stages.K
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


def _forward_pass(lp: StageLP, sets: NDArray) -> tuple[NDArray, NDArray, str]:
    """Greedy forward pass: ``x`` (K,), ``u`` (K,) and an outcome."""
    K = lp.stages.K
    ds = np.diff(lp.stages.s)
    x, u = np.zeros(K), np.zeros(K)
    for k in range(K - 1):
        nxt = (sets[k + 1, 0], sets[k + 1, 1])
        for _ in range(_RETRIES):
            outcome, z = lp.solve(k, (-1.0, 0.0), (x[k], x[k]), nxt)
            if outcome != "infeasible" or x[k] == 0.0:
                break
            x[k] *= 1.0 - _BACKOFF  # the LP's tolerance left x_k just outside
        if outcome != "optimal" or z is None:
            return x, u, outcome
        x[k + 1] = min(max(x[k] + 2.0 * ds[k] * z[0], sets[k + 1, 0]), sets[k + 1, 1])
        u[k] = (x[k + 1] - x[k]) / (2.0 * ds[k])
    # At rest at the end: the feasible s'' closest to the last step's.
    _, lo = lp.solve(K - 1, (1.0, 0.0), (0.0, 0.0), None)
    _, hi = lp.solve(K - 1, (-1.0, 0.0), (0.0, 0.0), None)
    low = lo[0] if lo is not None else -np.inf
    high = hi[0] if hi is not None else np.inf
    u[K - 1] = min(max(u[K - 2], low), high) if K > 1 else 0.0
    return x, u, "optimal"


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
        Path speed ``s'`` and acceleration ``s''`` (``s''`` constant up to the next point).
    poses, velocities, accelerations : ndarray, shape (K, n)
        Poses and their velocity coordinates and derivatives at the grid points.
    wrenches : ndarray, shape (K, n)
        Wrench the cables supply, ``structure @ tensions`` (N, N m): the
        Newton-Euler wrench less any external ``wrench``.
    tensions : ndarray, shape (K, m)
        Tensions holding ``wrenches`` chosen by the objective (N); NaN where none.
    status : ndarray of str, shape (K,)
        ``OPTIMAL``; ``INFEASIBLE`` where no timing can pass the point (others
        ``NOT_RUN``); ``UNBOUNDED`` if nothing limits the speed; ``STALLED`` at the
        second of two neighbouring points where ``s'^2`` is zero (within
        :data:`STOP_TOL` of its largest value: the segment would take forever; the
        reachability method's greedy pass can stall where the convex method finds a
        timing); a tension solve's status.
    margin : ndarray, shape (K,)
        Capacity margin of the wrench (N): zero where the tension limits bind.
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


def _reachability(stages: PathStages, v_max: NDArray, a_max: NDArray, slack: float
                  ) -> tuple[NDArray, NDArray, NDArray, str, int | None, int]:
    """TOPP-RA: ``x, u`` (K,), controllable sets (K, 2), outcome, the failing point
    (or None) and the number of LPs."""
    lp = StageLP(stages, v_max, a_max, slack)
    sets, fail, outcome = _controllable_sets(lp)
    x = u = np.full(stages.K, np.nan)
    if fail is None and sets[0, 0] > 1e-9 * max(1.0, sets[0, 1]):
        fail, outcome = 0, "infeasible"  # the path cannot start at rest
    if fail is None:
        x, u, outcome = _forward_pass(lp, sets)
    if outcome != "optimal":
        fail = 0 if fail is None else fail
    return x, u, sets, outcome, fail, lp.count


def _solve(stages: PathStages, vmax: NDArray, amax: NDArray, slack: float, method: str
           ) -> tuple[NDArray, NDArray, NDArray, str, int | None, int, str]:
    """Run ``method``: ``x, u``, controllable sets, outcome, failing point, LP count and
    the method that gave the answer."""
    if method not in ("convex", "reachability"):
        raise InvalidInputError(f'method must be "convex" or "reachability", got {method!r}')
    if method == "convex":
        x, u, outcome = convex_timing(stages, vmax, amax, slack)
        if outcome == "optimal":
            return x, u, np.full((stages.K, 2), np.nan), outcome, None, 0, method
    # Also what tells an unbounded or infeasible path from a convex solver's failure.
    x, u, sets, outcome, fail, count = _reachability(stages, vmax, amax, slack)
    return x, u, sets, outcome, fail, count, (
        "reachability" if method == "reachability" else "convex+reachability")


def _failed_points(stages: PathStages, v_max: NDArray, a_max: NDArray, outcome: str
                   ) -> NDArray:
    """Per-point status of a path without a timing: ``INFEASIBLE`` where no ``(u, x)``
    at all is feasible, the rest ``NOT_RUN`` (``UNBOUNDED`` everywhere if unbounded)."""
    if outcome == "unbounded":
        return status_array(stages.K, Status.UNBOUNDED)
    lp = StageLP(stages, v_max, a_max)
    status = status_array(stages.K, Status.NOT_RUN)
    for k in range(stages.K):
        if lp.solve(k, (0.0, 0.0), (0.0, np.inf), None)[0] == "infeasible":
            status[k] = Status.INFEASIBLE
    if not (status == Status.INFEASIBLE).any() and outcome == "infeasible":
        status[:] = Status.INFEASIBLE  # each point passable alone, the path is not
    elif outcome not in ("infeasible", "optimal"):
        status[status == Status.NOT_RUN] = Status.SOLVER_ERROR
    return status


def _tensions(robot: CableRobot, stages: PathStages, W: NDArray,
              problem: TensionProblem, custom_bounds: bool, backend: Any,
              options: dict[str, Any]) -> tuple[NDArray, NDArray]:
    """Tensions (K, m) holding the wrenches ``W`` (K, n) by the objective, and status.

    ``options["previous"]`` (K, m), if any, are the previous tensions of a smoothed
    objective, each point against its own.
    """
    if custom_bounds:
        problem = problem.with_(t_min=stages.lb, t_max=stages.ub)
    options = dict(options)
    previous = options.pop("previous", None)
    if previous is not None:
        previous = np.broadcast_to(as_float_array("previous", previous), stages.lb.shape)
    form = problem.standard_form_from(robot, stages.A, W, previous)
    chosen = choose_backend(backend, form)
    sol = solution_of(form, chosen.solve(form, **options), chosen)
    return sol.tensions, sol.status


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
        The convex time minimisation through cvxpy (default: the global optimum of the
        discretised problem), or TOPP-RA's greedy passes with HiGHS (module docstring).
        Where the convex solver finds no timing, the reachability passes run and tell
        why (``result.method`` is then ``"convex+reachability"``).
    structure : array_like, shape (K, n, m), optional
        Structure matrices at the grid points replacing the straight-cable ones.
    bounds : (array_like, array_like), each (m,) or (K, m), optional
        Tension bounds at the grid points replacing the robot's (N).
    wrench : array_like, shape (n,) or (K, n), optional
        External wrench besides gravity and inertia (N, N m).
    tension_slack, active_tol : float
        Keep the tensions this fraction of a typical tension (N) inside their bounds,
        beyond the LPs' tolerance (costs as much time, relative), in [0, 0.5);
        relative tolerance for reporting a limit as active, in [0, 1).
    **options
        Passed to the tension backend; ``previous`` (K, m): the tensions a smoothed
        objective stays close to, point by point.

    Returns
    -------
    TimingResult
        ``times``, ``duration``, motion, ``tensions``, per-point ``status``, the margin
        and the active limits. A path that cannot be timed (a point the robot cannot
        hold, no way from rest to rest, or a timing that stops the path: ``STALLED``)
        has ``duration = inf`` and per-point statuses; it raises nothing.

    Raises
    ------
    InvalidInputError
        On a bad path, limits, grid, structure, bounds, method or setting.
    """
    t0 = time.perf_counter()
    _check_fractions(tension_slack=(tension_slack, 0.5), active_tol=(active_tol, 1.0))
    spline = path if isinstance(path, PathSpline) else PathSpline.through(robot, path)
    stages = path_stages(robot, spline, spline.grid(gridpoints), structure=structure,
                         bounds=bounds, wrench=wrench)
    vmax, amax = (motion_limits(k, v, robot.dof) for k, v in (("v_max", v_max),
                                                              ("a_max", a_max)))
    problem = as_problem(objective)
    x, u, sets, outcome, fail, count, used = _solve(stages, vmax, amax, tension_slack, method)
    extras = {"stages": stages, "path": spline, "kind": robot.kind}
    if fail is not None:
        return _no_timing(robot, stages, _failed_points(stages, vmax, amax, outcome), sets,
                          used, count, time.perf_counter() - t0, extras)
    return _timed(robot, stages, x, u, sets, (vmax, amax), problem, bounds is not None,
                  backend, options, active_tol, used, count, t0, extras)


def _check_fractions(**given: tuple[object, float]) -> None:
    """Each setting ``name=(value, top)`` a number in ``[0, top)``, or the package's
    error naming it."""
    for name, (value, top) in given.items():
        if not (is_number(value) and 0.0 <= float(value) < top):  # type: ignore[arg-type]
            raise InvalidInputError(f"{name} must be a number in [0, {top}), got {value!r}")


def _no_timing(robot: CableRobot, stages: PathStages, status: NDArray, sets: NDArray,
               method: str, count: int, elapsed: float, extras: dict[str, Any]
               ) -> TimingResult:
    K, n, m = stages.K, robot.dof, robot.m
    nan = np.full(K, np.nan)
    return TimingResult(
        stages.s, nan, float("inf"), nan, nan, stages.poses, np.full((K, n), np.nan),
        np.full((K, n), np.nan), np.full((K, n), np.nan), np.full((K, m), np.nan), status,
        nan, np.zeros(K, bool), np.zeros((K, m), bool), np.zeros((K, n), bool),
        np.zeros((K, n), bool), sets, method, count, elapsed, extras)


def _timed(robot: CableRobot, stages: PathStages, x: NDArray, u: NDArray, sets: NDArray,
           limits: tuple[NDArray, NDArray], problem: TensionProblem, custom_bounds: bool,
           backend: Any, options: dict[str, Any], active_tol: float, method: str,
           count: int, t0: float, extras: dict[str, Any]) -> TimingResult:
    """The result of a timing ``x, u``: times, motion, tensions and active limits."""
    x = np.maximum(x, 0.0)
    sd = np.sqrt(x)
    # Zero to the LPs' tolerance: the path would stop there, and a segment between two
    # such points take forever (or, from rounding, millions of seconds).
    stopped = x <= STOP_TOL * max(float(x.max(initial=0.0)), np.finfo(float).tiny)
    stalls = stopped[:-1] & stopped[1:]
    if stalls.any():  # no timing
        status = status_array(stages.K, Status.NOT_RUN)
        status[1:][stalls] = Status.STALLED
        return _no_timing(robot, stages, status, sets, method, count,
                          time.perf_counter() - t0, extras)
    dt = 2.0 * np.diff(stages.s) / (sd[:-1] + sd[1:])
    times = np.concatenate([[0.0], np.cumsum(dt)])
    vel, acc = stages.motion(u, x)
    W = stages.wrenches(u, x)
    T, status = _tensions(robot, stages, W, problem, custom_bounds, backend, options)
    ones = np.ones_like(stages.lb)
    margin, _, _, _ = margin_solve(stages.A, W, stages.lb, ones, stages.ub, ones, "auto")
    typical = typical_tension(stages.A, W, stages.lb)
    tight = active_tol * typical[:, None]
    active = margin <= active_tol * typical
    cables = active[:, None] & ((T - stages.lb <= tight) | (stages.ub - T <= tight))
    vmax, amax = limits
    return TimingResult(
        stages.s, times, float(times[-1]), sd, u, stages.poses, vel, acc, W, T, status,
        margin, active, cables, np.abs(vel) >= vmax * (1 - active_tol),
        np.abs(acc) >= amax * (1 - active_tol), sets, method, count,
        time.perf_counter() - t0, extras)
