"""The linear program of one grid point of a path's timing, in ``(u, x, T_1, ..., T_p)``.

At grid point ``k`` the variables are the path acceleration ``u = s''``, the squared
path speed ``x = s'^2`` and one tension vector for each of the grid point's checks
(:class:`~tension_opt.dynamics.intervals.StageChecks`: the point itself, the end of
the interval it drives, points inside), each scaled by its tension scale ``sigma_j``
(:func:`check_limits`) so that the solver sees numbers of order one.
A check ``j`` at ``d_j = s_j - s_k`` reads::

    A_j T_j = (a_j + 2 d_j b_j) u + b_j x + c_j,   t_min + slack <= T_j <= t_max - slack,
    x + 2 d_j u <= x_max,j (velocity limits),   |(V_j + 2 d_j C_j) u + C_j x| <= a_max,

and ``x + 2 ds_k u`` may be asked to lie within the next point's range.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.deadline import Deadline
from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.lp import solve_lp
from tension_opt.dynamics.point_rows import tension_gap, tension_scale

__all__ = ["StageLP", "check_limits"]


def check_limits(checks: StageChecks, v_max: NDArray, slack: float
                 ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The checks' tension scale ``sigma`` (J,)
    (:func:`~tension_opt.dynamics.point_rows.tension_scale`), the tension bounds kept
    ``slack`` times it inside the bounds (J, m) each, and ``x_max`` (J,): the largest
    ``x + 2 d u`` the velocity limits leave at each check (inf: none)."""
    pts = checks.points
    gap = tension_gap(pts, slack)
    with np.errstate(divide="ignore"):
        x_max = np.min((v_max / np.abs(pts.V)) ** 2, axis=1)
    return tension_scale(pts), pts.lb + gap, pts.ub - gap, x_max


class StageLP:
    """The linear programs of one path's grid points over their checks.

    Parameters
    ----------
    checks : StageChecks
    v_max, a_max : ndarray, shape (n,)
        Limits of the velocity and acceleration coordinates (inf: none).
    slack : float
        The tensions stay this fraction of ``sigma_j`` (their tension scale,
        :func:`check_limits`) inside their bounds, so that the
        timing's wrenches are strictly feasible (a wrench on the boundary of the
        feasible set is held by a single, degenerate tension vector).
    deadline : Deadline, optional
        Every LP checks it first (:class:`~tension_opt.dynamics.deadline.OutOfTime`).
    """

    def __init__(self, checks: StageChecks, v_max: NDArray, a_max: NDArray,
                 slack: float = 0.0, deadline: Deadline | None = None) -> None:
        self.checks = checks
        self.deadline = deadline or Deadline()
        self.m = checks.points.A.shape[2]
        self.sigma, self.lb, self.ub, self.x_max = check_limits(checks, v_max, slack)
        self.au, self.vu = checks.wrench_u(), checks.accel_u()
        self.a_max = a_max
        self.starts = checks.starts
        self.count = 0

    def _rows(self, k: int) -> tuple[list[NDArray], list[NDArray], list[NDArray], float]:
        """Equilibrium, acceleration and speed rows of grid point ``k``'s checks, and the
        largest ``x`` its own speed limit leaves."""
        pts, m = self.checks.points, self.m
        js = np.arange(self.starts[k], self.starts[k + 1])
        p, n = js.size, pts.A.shape[1]
        sig = self.sigma[js]
        eq = np.zeros((p, n, 2 + p * m))
        eq[:, :, 0] = -self.au[js] / sig[:, None]
        eq[:, :, 1] = -pts.b[js] / sig[:, None]
        for i, j in enumerate(js):
            eq[i, :, 2 + i * m:2 + (i + 1) * m] = pts.A[j]
        rows, lo = [eq.reshape(p * n, -1)], [(pts.c[js] / sig[:, None]).ravel()]
        hi = [lo[0]]
        limited = np.flatnonzero(np.isfinite(self.a_max))
        if len(limited):  # |(V + 2 d C) u + C x| <= a_max
            acc = np.zeros((p, len(limited), 2 + p * m))
            acc[:, :, 0] = self.vu[js][:, limited]
            acc[:, :, 1] = pts.C[js][:, limited]
            rows.append(acc.reshape(-1, 2 + p * m))
            lo.append(np.tile(-self.a_max[limited], p))
            hi.append(np.tile(self.a_max[limited], p))
        d = self.checks.offset[js]
        own = d == 0.0
        speed = ~own & np.isfinite(self.x_max[js])
        if speed.any():  # x + 2 d u <= x_max
            row = np.zeros((int(speed.sum()), 2 + p * m))
            row[:, 0], row[:, 1] = 2.0 * d[speed], 1.0
            rows.append(row)
            lo.append(np.full(len(row), -np.inf))
            hi.append(self.x_max[js][speed])
        return rows, lo, hi, float(self.x_max[js][own].min(initial=np.inf))

    def solve(self, k: int, objective: tuple[float, float],
              x_range: tuple[float, float], next_range: tuple[float, float] | None
              ) -> tuple[str, NDArray | None]:
        """Minimise ``objective . (u, x)`` at point ``k`` with ``x`` in ``x_range`` and,
        if given, ``x + 2 ds_k u`` in ``next_range``.

        Returns
        -------
        outcome : {"optimal", "infeasible", "unbounded", "error"}
        z : ndarray, shape (2 + m,) or None
            ``(u, x, T)`` with ``T`` the tensions (N) at the grid point itself.
        """
        self.deadline.check()
        rows, lo, hi, x_top = self._rows(k)
        nvar = rows[0].shape[1]
        grid = self.checks.grid
        if next_range is not None and k + 1 < grid.size:  # x + 2 ds u within next_range
            row = np.zeros((1, nvar))
            row[0, 0], row[0, 1] = 2.0 * (grid[k + 1] - grid[k]), 1.0
            rows.append(row)
            lo.append(np.array([next_range[0]]))
            hi.append(np.array([next_range[1]]))
        js = slice(self.starts[k], self.starts[k + 1])
        sig = self.sigma[js, None]
        col_lo = np.concatenate([[-np.inf, x_range[0]], (self.lb[js] / sig).ravel()])
        col_hi = np.concatenate([[np.inf, min(x_range[1], x_top)], (self.ub[js] / sig).ravel()])
        if col_lo[1] > col_hi[1]:
            return "infeasible", None
        self.count += 1
        cost = np.zeros(nvar)
        cost[:2] = objective
        outcome, z = solve_lp(cost, np.vstack(rows), np.concatenate(lo), np.concatenate(hi),
                              col_lo, col_hi)
        if z is None:
            return outcome, None
        return outcome, np.concatenate([z[:2], z[2:2 + self.m] * self.sigma[js][0]])
