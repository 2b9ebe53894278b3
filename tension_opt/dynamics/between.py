"""The dense check of a timing between its grid points, and the checks it adds.

Between grid points a timing moves with constant ``s''`` (:mod:`tension_opt.dynamics.intervals`).
:func:`between_check` measures its capacity margin and its motion limits' excess at
points of every interval: its start, :data:`BETWEEN_SAMPLES` evenly spaced points or
more (at most the path's length over :data:`BETWEEN_PATH` apart), the last its end;
and, where the margin's curvature lets it dip below the tolerance between two of them
though it does not at either, points between them, as close as the curvature asks (up
to :data:`BISECTIONS` times).
Those first points are the same in every round of a timing (:class:`SampleBank`, their
facet rows computed once, :mod:`tension_opt.dynamics.point_rows`); the margins are then
a few products per point. Where the facets do not describe the robot (too many, or a
structure matrix of lower rank), the margins are solved (:func:`margin_solve`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.intervals import PathModel
from tension_opt.dynamics.path import PathStages
from tension_opt.dynamics.point_rows import PointRows, facets_fit, point_rows
from tension_opt.problem.form import typical_tension
from tension_opt.tolerances import FEASIBILITY_TOL
from tension_opt.workspace.margin import margin_solve

__all__ = ["BETWEEN_PATH", "BETWEEN_SAMPLES", "BISECTIONS", "BUMP_POINTS", "MOTION_TOL",
           "PIECE_PARTS",
           "Between", "SampleBank", "between_check", "sample_bank"]

#: Points checked in each interval between grid points (evenly spaced, its end included),
#: or more where they would be further apart than the path's length over BETWEEN_PATH.
BETWEEN_SAMPLES, BETWEEN_PATH = 4, 2000
#: Times the pieces between neighbouring points of an interval may be cut where the
#: margin's curvature lets it dip below the tolerance between them, and into at most how
#: many parts at a time (:func:`between_check`).
BISECTIONS, PIECE_PARTS = 4, 64
#: Most points added across one bump of a violation in a round of checks.
BUMP_POINTS = 32
#: Relative excess of a velocity or acceleration limit that a check tolerates.
MOTION_TOL = 1e-6


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
class SampleBank:
    """Points of the intervals with the path there, and their facet rows (or None: the
    margins are solved).

    Attributes
    ----------
    owner : ndarray of int, shape (P,)
    s : ndarray, shape (P,)
    points : PathStages
    rows : PointRows or None
    """

    owner: NDArray
    s: NDArray
    points: PathStages
    rows: PointRows | None


def _bank(model: PathModel, owner: NDArray, s: NDArray, facets: bool) -> SampleBank:
    pts = model.at(s)
    rows = point_rows(pts, s - model.stages.s[owner]) if facets else None
    return SampleBank(owner, s, pts, rows)


def sample_bank(model: PathModel, samples: int = BETWEEN_SAMPLES,
                spacing: float | None = None) -> SampleBank:
    """The first points of :func:`between_check` (module docstring): ``samples`` an
    interval or more, at most ``spacing`` apart (default: the path's length over
    :data:`BETWEEN_PATH`)."""
    owner, s = _samples(model.stages.s, samples,
                        spacing or model.spline.length / BETWEEN_PATH)
    return _bank(model, owner, s, facets_fit(model.stages.A))


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


def _measure(bank: SampleBank, grid: NDArray, x: NDArray, u: NDArray, v_max: NDArray,
             a_max: NDArray) -> _Samples:
    """Capacity margin, its tolerance and the motion limits' excess of the timing at the
    points of ``bank``."""
    owner, s, pts = bank.owner, bank.s, bank.points
    us, xk = u[owner], x[owner]
    xs = np.maximum(xk + 2.0 * (s - grid[owner]) * us, 0.0)
    if bank.rows is not None:
        margin = bank.rows.margin(us, xk)
        tol = FEASIBILITY_TOL * bank.rows.typical(us, xk)
    else:
        W = pts.wrenches(us, xs)
        ones = np.ones_like(pts.lb)
        margin = margin_solve(pts.A, W, pts.lb, ones, pts.ub, ones)[0]
        tol = FEASIBILITY_TOL * typical_tension(pts.A, W, pts.lb)
    vel, acc = pts.motion(us, xs)
    with np.errstate(invalid="ignore", divide="ignore"):
        excess = np.maximum((np.abs(vel) / v_max).max(axis=1),
                            (np.abs(acc) / a_max).max(axis=1)) - 1.0
    return _Samples(owner, s, margin, tol, np.maximum(np.nan_to_num(excess, nan=0.0), 0.0))


def _dips(p: _Samples) -> tuple[NDArray, NDArray]:
    """Pieces between neighbouring points of an interval whose margin may dip below the
    tolerance between them though it does not at either end: the lower end less
    ``kappa h^2 / 8``, ``kappa`` the larger positive second divided difference at its
    ends. Returns the pieces (their first point) and into how many parts each is cut
    so that, curved as estimated, it cannot (2 to :data:`PIECE_PARTS`)."""
    same = p.owner[1:] == p.owner[:-1]
    h = np.diff(p.s)
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.diff(p.margin) / h
        curv = 2.0 * np.diff(slope) / (h[:-1] + h[1:])
    curv = np.where(same[:-1] & same[1:] & np.isfinite(curv), np.maximum(curv, 0.0), 0.0)
    kappa = np.maximum(np.concatenate([[0.0], curv]), np.concatenate([curv, [0.0]]))
    ok = p.margin >= -p.tol
    low = np.minimum(p.margin[:-1], p.margin[1:])
    tol = np.minimum(p.tol[:-1], p.tol[1:])
    with np.errstate(invalid="ignore"):
        split = np.flatnonzero(same & ok[:-1] & ok[1:] & (low - kappa * h**2 / 8.0 < -tol))
    # Parts short enough that the dip below the lower end stays within it plus the tolerance.
    with np.errstate(invalid="ignore", divide="ignore"):
        step = np.sqrt(8.0 * (low[split] + tol[split]) / kappa[split])
    parts = np.clip(np.ceil(h[split] / np.maximum(step, 1e-300)), 2, PIECE_PARTS)
    return split, np.nan_to_num(parts, nan=2.0).astype(int)


def between_check(model: PathModel, x: NDArray, u: NDArray, v_max: NDArray,
                  a_max: NDArray, bank: SampleBank | None = None,
                  deadline: Deadline | None = None) -> Between:
    """Check the timing ``x, u`` (K,) over each interval (module docstring) at the
    points of ``bank`` (default: :func:`sample_bank`) and between two of them where the
    margin's curvature lets it dip below the tolerance between them.

    A point is outside the tolerances where its capacity margin is below
    ``-FEASIBILITY_TOL`` times its typical tension, or a velocity or acceleration
    exceeds its limit by more than :data:`MOTION_TOL` (relative). ``deadline`` is
    checked between the rounds of points.
    """
    deadline = deadline or Deadline()
    bank = bank or sample_bank(model)
    grid = model.stages.s
    K = grid.size
    p = _measure(bank, grid, x, u, v_max, a_max)
    for _ in range(BISECTIONS):
        deadline.check()
        split, parts = _dips(p)
        if not split.size:
            break
        piece = np.repeat(split, parts - 1)
        first = np.concatenate([[0], np.cumsum(parts - 1)[:-1]])
        frac = (np.arange(piece.size) - np.repeat(first, parts - 1) + 1) / np.repeat(parts,
                                                                                   parts - 1)
        at = p.s[piece] + frac * (p.s[piece + 1] - p.s[piece])
        more = _bank(model, p.owner[piece], at, bank.rows is not None)
        p = p.join(_measure(more, grid, x, u, v_max, a_max))
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
