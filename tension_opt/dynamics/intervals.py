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
  (:func:`tension_opt.dynamics.between.between_check`) found a wrench outside the
  feasible set or a motion limit exceeded, until none is
  (:func:`tension_opt.dynamics.time_optimal`).

:class:`PathModel` evaluates the path anywhere: the robot's own structure matrices,
bounds and dynamics exactly; structure matrices, bounds or an external wrench given at
the grid points (the sag-aware timing's) linearly interpolated between them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.dynamics.path import PathSpline, PathStages, path_stages
from tension_opt.dynamics.point_rows import PointRows, point_rows, tension_gap
from tension_opt.robot import CableRobot

__all__ = ["PathModel", "StageChecks", "grid_checks", "initial_checks", "segment"]


def segment(grid: NDArray, s: NDArray) -> tuple[NDArray, NDArray]:
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
        i, w = segment(g.s, s)
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
    rows : PointRows or None
        The checks' facet rows (:mod:`tension_opt.dynamics.point_rows`) with the
        tensions kept ``slack`` inside their bounds, if computed
        (:meth:`with_rows`); then computed for every check added too.
    slack : float
    """

    owner: NDArray
    offset: NDArray
    points: PathStages
    grid: NDArray
    rows: PointRows | None = None
    slack: float = 0.0

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

    def with_rows(self, slack: float) -> StageChecks:
        """These checks with their facet rows for ``slack``."""
        if self.rows is not None and self.slack == slack:
            return self
        rows = point_rows(self.points, self.offset, tension_gap(self.points, slack))
        return replace(self, rows=rows, slack=slack)

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
        if self.rows is not None:
            more = more.with_rows(self.slack)
        return _merged(self, more)


def _merged(*parts: StageChecks) -> StageChecks:
    """The checks of ``parts``, ordered by owner then offset."""
    owner = np.concatenate([p.owner for p in parts])
    offset = np.concatenate([p.offset for p in parts])
    order = np.lexsort((offset, owner))
    points = PathStages.join(*(p.points for p in parts)).take(order)
    rows = [p.rows for p in parts]
    joined = None if any(r is None for r in rows) else PointRows.join(*rows).take(order)  # type: ignore[arg-type]
    return StageChecks(owner[order], offset[order], points, parts[0].grid, joined,
                       parts[0].slack)


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
    i, w = segment(g.s, knots)
    inside = (w > 1e-9) & (w < 1.0 - 1e-9)
    checks = grid_checks(model)
    if not inside.any():
        return checks
    return checks.with_points(model, i[inside], knots[inside])
