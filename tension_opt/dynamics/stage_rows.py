"""Each grid point's constraints as rows in ``(u, x)`` alone, for the compiled passes.

A check ``j`` of grid point ``k`` (:class:`~tension_opt.dynamics.intervals.StageChecks`)
needs its wrench inside the wrench-feasible set of its tension bounds kept the slack
inside (:func:`~tension_opt.dynamics.stage_lp.check_limits`): the facet rows of
:mod:`tension_opt.dynamics.point_rows`, moved in by the slack. With the velocity limits
(``x + 2 d_j u <= x_max,j``) and the acceleration limits
(``|(V_j + 2 d_j C_j) u + C_j x| <= a_max``), each scaled to a unit normal, they are the
data of :mod:`tension_opt.kernels.reachability`: the same sets as the LPs over the
tensions of :class:`~tension_opt.dynamics.stage_lp.StageLP`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt.dynamics.intervals import StageChecks
from tension_opt.dynamics.stage_lp import check_limits

__all__ = ["StageRows", "stage_rows"]


@dataclass(frozen=True, eq=False)
class StageRows:
    """Rows ``rows . (u, x) <= rhs`` of every grid point, unit normals.

    Attributes
    ----------
    rows : ndarray, shape (R, 2)
    rhs : ndarray, shape (R,)
    start : ndarray of int, shape (K + 1,)
        Rows of grid point ``k``: ``start[k]:start[k + 1]``.
    x_top : ndarray, shape (K,)
        The largest ``x`` the velocity limits leave at each grid point (inf: none).
    """

    rows: NDArray
    rhs: NDArray
    start: NDArray
    x_top: NDArray


def stage_rows(checks: StageChecks, v_max: NDArray, a_max: NDArray, slack: float
               ) -> StageRows:
    """The rows of ``checks`` (module docstring)."""
    pts, K, own = checks.points, checks.K, checks.owner
    J = own.size
    _, _, _, x_max = check_limits(checks, v_max, slack)
    facets = checks.with_rows(slack).rows
    assert facets is not None and facets.moved is not None
    parts = [(facets.G, facets.g - facets.moved)]
    speed = np.stack([2.0 * checks.offset, np.ones(J)], axis=1)[:, None, :]
    parts.append((speed, x_max[:, None]))
    limited = np.flatnonzero(np.isfinite(a_max))
    if limited.size:
        acc = np.stack([checks.accel_u()[:, limited], pts.C[:, limited]], axis=2)
        bound = np.broadcast_to(a_max[limited], (J, limited.size))
        parts += [(acc, bound), (-acc, bound)]
    rows = np.concatenate([p[0] for p in parts], axis=1)  # (J, F', 2)
    rhs = np.concatenate([p[1] for p in parts], axis=1)
    norm = np.hypot(rows[..., 0], rows[..., 1])
    keep = np.isfinite(rhs) & ((norm > 0) | (rhs < 0))  # a zero row that fails stays
    scale = 1.0 / np.where(norm > 0, norm, 1.0)
    owner = np.broadcast_to(own[:, None], keep.shape)[keep]
    # Each grid point's own velocity limit bounds x directly.
    x_top = np.full(K, np.inf)
    mine = checks.offset == 0.0
    np.minimum.at(x_top, own[mine], x_max[mine])
    return StageRows(np.ascontiguousarray((rows * scale[..., None])[keep]),
                     np.ascontiguousarray((rhs * scale)[keep]),
                     np.searchsorted(owner, np.arange(K + 1)), x_top)
