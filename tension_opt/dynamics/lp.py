"""Small dense linear programs by HiGHS, through highspy when installed, else scipy.

The time-optimal timing solves a few linear programs per grid point, each with a
handful of variables: the per-call overhead of :func:`scipy.optimize.linprog`
(input checks and conversions) dominates there, so the model goes to ``highspy``
directly when it is installed (the ``solvers`` extra). Both run the same solver.
"""

from __future__ import annotations

import os
import sys
import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog

__all__ = ["TOLERANCE", "solve_lp"]

#: HiGHS primal and dual feasibility tolerance of these LPs (in their scaled units).
TOLERANCE = 1e-10

highspy: Any
try:  # optional: the fast path
    import highspy
except ImportError:  # pragma: no cover - exercised without the solvers extra
    highspy = None

_FIRST = threading.Lock()
_greeted = False


def _new_highs() -> Any:
    """A silent ``highspy.Highs``. The first one a process makes prints HiGHS's banner
    to the standard output file descriptor before any option can be set; it goes to
    the null device (once, under a lock)."""
    global _greeted
    if not _greeted:
        with _FIRST:
            if not _greeted:
                sys.stdout.flush()
                saved = os.dup(1)
                try:
                    with open(os.devnull, "w") as null:
                        os.dup2(null.fileno(), 1)
                        highspy.Highs()
                finally:
                    os.dup2(saved, 1)
                    os.close(saved)
                _greeted = True
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    return h


def solve_lp(cost: NDArray, rows: NDArray, row_lo: NDArray, row_hi: NDArray,
             col_lo: NDArray, col_hi: NDArray) -> tuple[str, NDArray | None]:
    """Minimise ``cost . z`` s.t. ``row_lo <= rows z <= row_hi``, ``col_lo <= z <= col_hi``.

    Infinite entries of the bounds mean none (equal bounds an equality).

    Returns
    -------
    outcome : {"optimal", "infeasible", "unbounded", "error"}
    z : ndarray or None
    """
    if highspy is not None:
        return _highspy(cost, rows, row_lo, row_hi, col_lo, col_hi)
    eq = row_lo == row_hi
    upper, lower = ~eq & np.isfinite(row_hi), ~eq & np.isfinite(row_lo)
    A_ub = np.vstack([rows[upper], -rows[lower]])
    b_ub = np.concatenate([row_hi[upper], -row_lo[lower]])
    bounds = [(None if np.isneginf(lo) else lo, None if np.isposinf(hi) else hi)
              for lo, hi in zip(col_lo, col_hi, strict=True)]
    res = linprog(cost, A_ub=A_ub if len(b_ub) else None, b_ub=b_ub if len(b_ub) else None,
                  A_eq=rows[eq] if eq.any() else None, b_eq=row_lo[eq] if eq.any() else None,
                  bounds=bounds, method="highs",
                  options={"primal_feasibility_tolerance": TOLERANCE,
                           "dual_feasibility_tolerance": TOLERANCE})
    outcome = {0: "optimal", 2: "infeasible", 3: "unbounded"}.get(res.status, "error")
    return outcome, (np.asarray(res.x) if outcome == "optimal" else None)


def _highspy(cost: NDArray, rows: NDArray, row_lo: NDArray, row_hi: NDArray,
             col_lo: NDArray, col_hi: NDArray) -> tuple[str, NDArray | None]:
    inf = highspy.kHighsInf
    h = _new_highs()
    h.setOptionValue("primal_feasibility_tolerance", TOLERANCE)
    h.setOptionValue("dual_feasibility_tolerance", TOLERANCE)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = len(cost), len(row_lo)
    lp.col_cost_ = np.asarray(cost, dtype=float)
    lp.col_lower_ = np.clip(col_lo, -inf, inf)
    lp.col_upper_ = np.clip(col_hi, -inf, inf)
    lp.row_lower_ = np.clip(row_lo, -inf, inf)
    lp.row_upper_ = np.clip(row_hi, -inf, inf)
    nz = rows != 0
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=0))]).astype(np.int32)
    lp.a_matrix_.index_ = np.nonzero(nz.T)[1].astype(np.int32)
    lp.a_matrix_.value_ = rows.T[nz.T].astype(float)
    h.passModel(lp)
    h.run()
    status = h.getModelStatus()
    if status == highspy.HighsModelStatus.kOptimal:
        return "optimal", np.array(h.getSolution().col_value)
    if status == highspy.HighsModelStatus.kInfeasible:
        return "infeasible", None
    if status in (highspy.HighsModelStatus.kUnbounded,
                  highspy.HighsModelStatus.kUnboundedOrInfeasible):
        return _unbounded_or_infeasible(cost, rows, row_lo, row_hi, col_lo, col_hi, status)
    return "error", None


def _unbounded_or_infeasible(cost: NDArray, rows: NDArray, row_lo: NDArray, row_hi: NDArray,
                             col_lo: NDArray, col_hi: NDArray, status: object
                             ) -> tuple[str, NDArray | None]:
    """Tell unbounded from infeasible: a zero objective is feasible or not."""
    if status == highspy.HighsModelStatus.kUnbounded:
        return "unbounded", None
    outcome, _ = _highspy(np.zeros_like(cost), rows, row_lo, row_hi, col_lo, col_hi)
    return ("unbounded", None) if outcome == "optimal" else ("infeasible", None)
