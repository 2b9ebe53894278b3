"""The linear program of one grid point of a path's timing, in ``(u, x, T)``.

At grid point ``k`` of :class:`~tension_opt.dynamics.path.PathStages` the variables are
the path acceleration ``u = s''``, the squared path speed ``x = s'^2`` and the tensions
scaled by a typical tension ``sigma_k`` (the static wrench's largest component), so the
solver sees numbers of order one::

    A_k T = a_k u + b_k x + c_k,   t_min + slack <= T <= t_max - slack,
    0 <= x <= x_max,k (velocity limits),   |V_k u + C_k x| <= a_max,
    x + 2 ds_k u within the next point's range (optional).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.lp import solve_lp
from tension_opt.dynamics.path import PathStages

__all__ = ["StageLP"]


class StageLP:
    """The linear programs of one path's grid points in ``z = (u, x, T / sigma_k)``.

    Parameters
    ----------
    stages : PathStages
    v_max, a_max : ndarray, shape (n,)
        Limits of the velocity and acceleration coordinates (inf: none).
    slack : float
        The tensions stay this fraction of ``sigma_k`` inside their bounds, so that the
        timing's wrenches are strictly feasible (a wrench on the boundary of the
        feasible set is held by a single, degenerate tension vector).
    """

    def __init__(self, stages: PathStages, v_max: NDArray, a_max: NDArray,
                 slack: float = 0.0) -> None:
        self.stages = stages
        self.m = stages.A.shape[2]
        # Per-point tension scale: the LPs see tensions of order one.
        self.sigma = np.maximum(np.abs(stages.c).max(axis=1), 1.0)
        gap = np.minimum(slack * self.sigma[:, None], 0.5 * (stages.ub - stages.lb))
        self.lb, self.ub = stages.lb + gap, stages.ub - gap
        with np.errstate(divide="ignore"):
            self.x_max = np.min((v_max / np.abs(stages.V)) ** 2, axis=1)
        self.a_max = a_max
        self.count = 0

    def solve(self, k: int, objective: tuple[float, float],
              x_range: tuple[float, float], next_range: tuple[float, float] | None
              ) -> tuple[str, NDArray | None]:
        """Minimise ``objective . (u, x)`` at point ``k`` with ``x`` in ``x_range`` and,
        if given, ``x + 2 ds_k u`` in ``next_range``.

        Returns
        -------
        outcome : {"optimal", "infeasible", "unbounded", "error"}
        z : ndarray, shape (2 + m,) or None
            ``(u, x, T)`` with ``T`` in N.
        """
        st, m, sig = self.stages, self.m, self.sigma[k]
        cost = np.zeros(2 + m)
        cost[:2] = objective
        rows = [np.hstack([-st.a[k][:, None] / sig, -st.b[k][:, None] / sig, st.A[k]])]
        lo, hi = [st.c[k] / sig], [st.c[k] / sig]
        limited = np.flatnonzero(np.isfinite(self.a_max))
        if len(limited):  # |V u + C x| <= a_max
            rows.append(np.hstack([st.V[k, limited, None], st.C[k, limited, None],
                                   np.zeros((len(limited), m))]))
            lo.append(-self.a_max[limited])
            hi.append(self.a_max[limited])
        if next_range is not None and k + 1 < st.K:  # x + 2 ds u within next_range
            rows.append(np.concatenate([[2.0 * (st.s[k + 1] - st.s[k]), 1.0],
                                        np.zeros(m)])[None])
            lo.append(np.array([next_range[0]]))
            hi.append(np.array([next_range[1]]))
        col_lo = np.concatenate([[-np.inf, x_range[0]], self.lb[k] / sig])
        col_hi = np.concatenate([[np.inf, min(x_range[1], self.x_max[k])], self.ub[k] / sig])
        if col_lo[1] > col_hi[1]:
            return "infeasible", None
        self.count += 1
        outcome, z = solve_lp(cost, np.vstack(rows), np.concatenate(lo), np.concatenate(hi),
                              col_lo, col_hi)
        if z is not None:
            z[2:] *= sig
        return outcome, z
