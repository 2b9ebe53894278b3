"""Where the constraints of a timing hold: the grid points, the ends of the intervals
between them, and points inside.

Between grid points ``k`` and ``k + 1`` a timing moves with the constant path
acceleration ``u_k`` (:mod:`tension_opt.dynamics.timing`), so its squared path speed is
``x(s) = x_k + 2 (s - s_k) u_k`` and the wrench it needs at ``s`` is::

    w(s) = a(s) u_k + b(s) x(s) + c(s) = (a(s) + 2 d b(s)) u_k + b(s) x_k + c(s),

``d = s - s_k``: linear in the grid point's own ``(u_k, x_k)``, as are its squared
velocities ``V(s)^2 x(s)`` and its accelerations ``(V(s) + 2 d C(s)) u_k + C(s) x_k``.
A constraint anywhere in the interval is therefore a constraint of grid point ``k``: a
*check* ``(k, d)`` (:class:`StageChecks`). A timing checks

- every grid point (``d = 0``);
- the end of every interval (``d = s_{k+1} - s_k``, with the path's values at
  ``s_{k+1}``: TOPP-RA's "interpolation" discretisation), so that the constant ``u_k``
  is feasible at both ends of the interval it drives;
- every knot of the path's spline inside an interval: the spline's third derivative
  jumps there, so the wrench bends, and a violation between the ends would shrink only
  like the interval, not like its square;
- the points inside the intervals where a dense check of the timing
  (:func:`between_check`) found a wrench outside the feasible set or a motion limit
  exceeded, until none is (:func:`tension_opt.dynamics.time_optimal`).

:class:`PathModel` evaluates the path anywhere: the robot's own structure matrices,
bounds and dynamics exactly; structure matrices, bounds or an external wrench given at
the grid points (the sag-aware timing's) linearly interpolated between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.path import PathSpline, PathStages, path_stages
from tension_opt.problem.form import typical_tension
from tension_opt.robot import CableRobot
from tension_opt.tolerances import FEASIBILITY_TOL
from tension_opt.workspace.margin import margin_solve

__all__ = ["BETWEEN_PATH", "BETWEEN_SAMPLES", "BISECTIONS", "BUMP_POINTS", "MOTION_TOL",
           "Between", "PathModel", "StageChecks", "between_check", "grid_checks",
           "initial_checks"]

#: Points checked in each interval between grid points (evenly spaced, its end included),
#: or more where they would be further apart than the path's length over BETWEEN_PATH.
BETWEEN_SAMPLES, BETWEEN_PATH = 8, 2000
#: Times two neighbouring points of an interval may be halved where the margin's
#: curvature lets it dip below the tolerance between them (:func:`between_check`).
BISECTIONS = 6
#: Most points added across one bump of a violation in a round of checks.
BUMP_POINTS = 32
#: Relative excess of a velocity or acceleration limit that a check tolerates.
MOTION_TOL = 1e-6


def _segment(grid: NDArray, s: NDArray) -> tuple[NDArray, NDArray]:
    """Interval index (clipped to the last one) and fraction along it of each ``s``."""
    i = np.clip(np.searchsorted(grid, s, side="right") - 1, 0, grid.size - 2)
    return i, (s - grid[i]) / (grid[i + 1] - grid[i])


def _lerp(values: NDArray, i: NDArray, w: NDArray) -> NDArray:
    """Per-grid-point ``values`` (K, ...) linearly interpolated at ``(i, w)``; where one
    end is infinite (an absent upper bound), the finite one."""
    lo, hi = values[i], values[i + 1]
    shape = (-1,) + (1,) * (values.ndim - 1)
    with np.errstate(invalid="ignore"):
        mixed = lo + w.reshape(shape) * (hi - lo)
    finite = np.isfinite(lo) & np.isfinite(hi)
    return np.where(lo == hi, lo, np.where(finite, mixed, np.where(np.isfinite(lo), lo, hi)))


@dataclass(frozen=True, eq=False)
class PathModel:
    """A path's dynamics at its grid and anywhere along it.

    Attributes
    ----------
    robot : CableRobot
    spline : PathSpline
    stages : PathStages
        At the grid points.
    structure : bool
        Structure matrices were given at the grid points (interpolated between them).
    external : ndarray, shape (K, n), or None
        The external wrench at the grid points (N, N m), if one was given.
    """

    robot: CableRobot
    spline: PathSpline
    stages: PathStages
    structure: bool
    external: NDArray | None

    @classmethod
    def build(cls, robot: CableRobot, spline: PathSpline, s: NDArray, *,
              structure: ArrayLike | None = None,
              bounds: tuple[ArrayLike, ArrayLike] | None = None,
              wrench: ArrayLike | None = None) -> PathModel:
        """The model of ``spline`` on the grid ``s`` (arguments of :func:`path_stages`)."""
        stages = path_stages(robot, spline, s, structure=structure, bounds=bounds,
                             wrench=wrench)
        external = None if wrench is None else robot.required_wrench(stages.poses) - stages.c
        return cls(robot, spline, stages, structure is not None, external)

    def at(self, s: NDArray) -> PathStages:
        """The path's stages at the values ``s`` (anywhere from 0 to its length)."""
        g = self.stages
        i, w = _segment(g.s, s)
        return path_stages(
            self.robot, self.spline, s,
            structure=_lerp(g.A, i, w) if self.structure else None,
            bounds=(_lerp(g.lb, i, w), _lerp(g.ub, i, w)),
            wrench=None if self.external is None else _lerp(self.external, i, w))


@dataclass(frozen=True, eq=False)
class StageChecks:
    """The points where each grid point's ``(u_k, x_k)`` is constrained (module docstring).

    Attributes
    ----------
    owner : ndarray of int, shape (J,)
        The grid point whose ``(u, x)`` each check constrains, non-decreasing.
    offset : ndarray, shape (J,)
        ``d = s - s_owner`` (m, rad): 0 at the grid point itself.
    points : PathStages
        The path at the checks (J points).
    grid : ndarray, shape (K,)
        The grid of ``s``.
    """

    owner: NDArray
    offset: NDArray
    points: PathStages
    grid: NDArray

    @property
    def K(self) -> int:
        """Grid points."""
        return int(self.grid.size)

    @property
    def starts(self) -> NDArray:
        """Checks of grid point ``k``: ``starts[k]:starts[k + 1]``, shape (K + 1,)."""
        return np.searchsorted(self.owner, np.arange(self.K + 1))

    def wrench_u(self) -> NDArray:
        """The wrench's coefficient of ``u_owner``, ``a + 2 d b``, shape (J, n)."""
        return self.points.a + 2.0 * self.offset[:, None] * self.points.b

    def accel_u(self) -> NDArray:
        """The accelerations' coefficient of ``u_owner``, ``V + 2 d C``, shape (J, n)."""
        return self.points.V + 2.0 * self.offset[:, None] * self.points.C

    def with_points(self, model: PathModel, owner: NDArray, s: NDArray) -> StageChecks:
        """These checks and the points ``s`` of the intervals ``owner`` (those within a
        millionth of their interval of a check, or of each other, left out)."""
        offset = s - self.grid[owner]
        order = np.lexsort((offset, owner))
        owner, offset = owner[order], offset[order]
        width = np.diff(self.grid)[np.minimum(owner, self.K - 2)]
        near = np.zeros(owner.size, bool)
        near[1:] = (owner[1:] == owner[:-1]) & (np.diff(offset) <= 1e-6 * width[1:])
        # The closest existing check of the same grid point on either side.
        key = owner * 2.0 + offset / (2.0 * width)  # owner, then offset, as one number
        mine = self.owner * 2.0 + self.offset / (2.0 * np.diff(self.grid)[
            np.minimum(self.owner, self.K - 2)])
        i = np.clip(np.searchsorted(mine, key), 1, max(mine.size - 1, 1))
        gap = np.minimum(np.abs(mine[i] - key), np.abs(mine[i - 1] - key))
        keep = ~near & (gap * 2.0 > 1e-6)
        if not keep.any():
            return self
        at = self.grid[owner[keep]] + offset[keep]
        more = StageChecks(owner[keep], offset[keep], model.at(at), self.grid)
        return _merged(self, more)


def _merged(*parts: StageChecks) -> StageChecks:
    """The checks of ``parts``, ordered by owner then offset."""
    owner = np.concatenate([p.owner for p in parts])
    offset = np.concatenate([p.offset for p in parts])
    order = np.lexsort((offset, owner))
    points = PathStages.join(*(p.points for p in parts)).take(order)
    return StageChecks(owner[order], offset[order], points, parts[0].grid)


def grid_checks(model: PathModel) -> StageChecks:
    """Every grid point and the end of every interval (TOPP-RA's interpolation scheme)."""
    g = model.stages
    K = g.K
    grid = StageChecks(np.arange(K), np.zeros(K), g, g.s)
    ends = StageChecks(np.arange(K - 1), np.diff(g.s), g.take(np.arange(1, K)), g.s)
    return _merged(grid, ends)


def initial_checks(model: PathModel) -> StageChecks:
    """:func:`grid_checks` and the spline's knots inside the intervals."""
    g = model.stages
    knots = model.spline.s[1:-1]
    i, w = _segment(g.s, knots)
    inside = (w > 1e-9) & (w < 1.0 - 1e-9)
    checks = grid_checks(model)
    if not inside.any():
        return checks
    return checks.with_points(model, i[inside], knots[inside])


@dataclass(frozen=True, eq=False)
class Between:
    """A timing checked between its grid points (:func:`between_check`).

    Attributes
    ----------
    margin : ndarray, shape (K - 1,)
        The smallest capacity margin (N) of each interval's checked points.
    s : ndarray, shape (K - 1,)
        Where it is.
    excess : ndarray, shape (K - 1,)
        The largest relative excess of a velocity or acceleration limit in each interval
        (``|v| / v_max - 1``; 0 where none is exceeded).
    bad : ndarray of bool, shape (K - 1,)
        Intervals with a point outside the tolerances.
    owner, at : ndarray, shape (P,)
        The points to check next: in each bad interval, those furthest outside the
        tolerances among their neighbours (interval, s).
    """

    margin: NDArray
    s: NDArray
    excess: NDArray
    bad: NDArray
    owner: NDArray
    at: NDArray


def _samples(grid: NDArray, samples: int, spacing: float) -> tuple[NDArray, NDArray]:
    """Interval and ``s`` of the points checked: in each interval its start, ``samples``
    evenly spaced points or more, at most ``spacing`` apart, and its end."""
    ds = np.diff(grid)
    count = np.maximum(samples, np.ceil(ds / spacing)).astype(int) + 1
    owner = np.repeat(np.arange(grid.size - 1), count)
    first = np.concatenate([[0], np.cumsum(count)[:-1]])
    rank = np.arange(owner.size) - first[owner]  # 0 .. count - 1
    s = grid[owner] + ds[owner] * rank / (count[owner] - 1)
    ends = rank == count[owner] - 1
    s[ends] = grid[1:]  # the ends exactly
    return owner, s


@dataclass(frozen=True, eq=False)
class _Samples:
    """Points of the intervals and the timing's figures there, ordered by ``s``."""

    owner: NDArray
    s: NDArray
    margin: NDArray
    tol: NDArray
    excess: NDArray

    def join(self, other: _Samples) -> _Samples:
        order = np.argsort(np.concatenate([self.s, other.s]), kind="stable")
        return _Samples(*(np.concatenate([getattr(self, k), getattr(other, k)])[order]
                          for k in ("owner", "s", "margin", "tol", "excess")))


def _measure(model: PathModel, x: NDArray, u: NDArray, v_max: NDArray, a_max: NDArray,
             owner: NDArray, s: NDArray) -> _Samples:
    """Capacity margin, its tolerance and the motion limits' excess of the timing at the
    points ``s`` of the intervals ``owner``."""
    pts = model.at(s)
    us = u[owner]
    xs = np.maximum(x[owner] + 2.0 * (s - model.stages.s[owner]) * us, 0.0)
    W = pts.wrenches(us, xs)
    ones = np.ones_like(pts.lb)
    margin = margin_solve(pts.A, W, pts.lb, ones, pts.ub, ones)[0]
    tol = FEASIBILITY_TOL * typical_tension(pts.A, W, pts.lb)
    vel, acc = pts.motion(us, xs)
    with np.errstate(invalid="ignore"):
        excess = np.maximum((np.abs(vel) / v_max).max(axis=1),
                            (np.abs(acc) / a_max).max(axis=1)) - 1.0
    return _Samples(owner, s, margin, tol, np.maximum(np.nan_to_num(excess, nan=0.0), 0.0))


def _dips(p: _Samples) -> NDArray:
    """Pieces between neighbouring points of an interval (P - 1,) whose margin may dip
    below the tolerance between them though it does not at either end: the lower end
    less ``kappa h^2 / 8``, ``kappa`` the larger positive second divided difference at
    its ends."""
    same = p.owner[1:] == p.owner[:-1]
    h = np.diff(p.s)
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.diff(p.margin) / h
        curv = 2.0 * np.diff(slope) / (h[:-1] + h[1:])
    curv = np.where(same[:-1] & same[1:] & np.isfinite(curv), np.maximum(curv, 0.0), 0.0)
    kappa = np.maximum(np.concatenate([[0.0], curv]), np.concatenate([curv, [0.0]]))
    ok = p.margin >= -p.tol
    low = np.minimum(p.margin[:-1], p.margin[1:]) - kappa * h**2 / 8.0
    with np.errstate(invalid="ignore"):
        return same & ok[:-1] & ok[1:] & (low < -np.minimum(p.tol[:-1], p.tol[1:]))


def between_check(model: PathModel, x: NDArray, u: NDArray, v_max: NDArray,
                  a_max: NDArray, samples: int = BETWEEN_SAMPLES,
                  spacing: float | None = None, deadline: Deadline | None = None
                  ) -> Between:
    """Check the timing ``x, u`` (K,) over each interval: at its start, at ``samples``
    evenly spaced points or more, at most ``spacing`` apart (default: the path's length
    over :data:`BETWEEN_PATH`), the last its end (reached with the interval's ``u``);
    and, up to :data:`BISECTIONS` times, halfway between two of them where the margin's
    curvature lets it dip below the tolerance between them.

    A point is outside the tolerances where its capacity margin is below
    ``-FEASIBILITY_TOL`` times its typical tension, or a velocity or acceleration
    exceeds its limit by more than :data:`MOTION_TOL` (relative). ``deadline`` is
    checked between the rounds of points.
    """
    deadline = deadline or Deadline()
    g = model.stages
    K = g.K
    owner, s = _samples(g.s, samples, spacing or model.spline.length / BETWEEN_PATH)
    p = _measure(model, x, u, v_max, a_max, owner, s)
    for _ in range(BISECTIONS):
        deadline.check()
        split = np.flatnonzero(_dips(p))
        if not split.size:
            break
        p = p.join(_measure(model, x, u, v_max, a_max, p.owner[split],
                            0.5 * (p.s[split] + p.s[split + 1])))
    violation = np.maximum(-p.margin / p.tol, p.excess / MOTION_TOL)
    violation = np.where(np.isnan(p.margin), np.inf, violation)
    key = np.where(np.isnan(p.margin), -np.inf, p.margin)
    low = np.lexsort((key, p.owner))[np.searchsorted(p.owner, np.arange(K - 1))]
    worst = np.full(K - 1, -np.inf)
    np.maximum.at(worst, p.owner, violation)
    top = np.zeros(K - 1)
    np.maximum.at(top, p.owner, p.excess)
    owner, at = _next_checks(p, violation)
    return Between(p.margin[low], p.s[low], top, worst > 1.0, owner, at)


def _next_checks(p: _Samples, violation: NDArray) -> tuple[NDArray, NDArray]:
    """The points to check next (interval, s): across each bump of ``violation`` above 1
    inside an interval (from the last point before it to the first after), points close
    enough that the margin, curved as at the bump's top, cannot dip below the tolerance
    between them (at most :data:`BUMP_POINTS`), and the top of the parabola through the
    bump's highest point and its neighbours."""
    out = violation > 1.0
    same = np.concatenate([[False], p.owner[1:] == p.owner[:-1]])  # same as the previous
    starts = np.flatnonzero(out & ~(np.roll(out, 1) & same))
    owners, points = [], []
    for a in starts.tolist():
        b = a
        while b + 1 < out.size and out[b + 1] and same[b + 1]:
            b += 1
        i = int(a + np.argmax(violation[a:b + 1]))
        left = p.s[a - 1] if same[a] else p.s[a]
        right = p.s[b + 1] if b + 1 < out.size and same[b + 1] else p.s[b]
        top, kappa = _parabola(p, i, same)
        step = np.sqrt(8.0 * p.tol[i] / kappa) if kappa > 0 else (right - left) / 8.0
        count = int(np.clip(np.ceil((right - left) / max(step, 1e-300)), 1, BUMP_POINTS))
        at = np.concatenate([np.linspace(left, right, count + 1)[1:-1], [p.s[i], top]])
        points.append(at)
        owners.append(np.full(at.size, p.owner[i]))
    if not points:
        return np.zeros(0, int), np.zeros(0)
    return np.concatenate(owners), np.concatenate(points)


def _parabola(p: _Samples, i: int, same: NDArray) -> tuple[float, float]:
    """Where the parabola through the margins at points ``i - 1, i, i + 1`` of one
    interval has its bottom, and its curvature (N per unit s squared); ``p.s[i]`` and 0
    where there is no such bottom."""
    if i == 0 or i + 1 >= p.s.size or not (same[i] and same[i + 1]):
        return float(p.s[i]), 0.0
    x0, x1, x2 = p.s[i - 1:i + 2]
    y0, y1, y2 = p.margin[i - 1:i + 2]
    d0, d1 = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
    curv = 2.0 * (d1 - d0) / (x2 - x0)
    if not (np.isfinite(curv) and curv > 0):
        return float(x1), 0.0
    return float(np.clip(0.5 * (x0 + x1) - d0 / curv, x0, x2)), float(curv)
