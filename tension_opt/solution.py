"""Result of a tension distribution: :class:`TensionSolution` and :class:`Status`."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray


class Status(StrEnum):
    """Outcome of one pose or one cable: the one status vocabulary of the toolkit.

    Optimisation (tension distribution, margins) reports ``OPTIMAL``, ``INACCURATE``,
    ``INFEASIBLE``, ``UNBOUNDED``, ``MAX_ITER``, ``SOLVER_ERROR`` or ``NOT_RUN``;
    iterative solvers (catenary, kinematics) ``CONVERGED``, ``NOT_CONVERGED``,
    ``INCONSISTENT`` (no pose meets the lengths), ``SLACK`` (a cable that cannot carry
    the asked tension) or ``INDETERMINATE`` (the data do not fix the answer), besides
    ``INFEASIBLE``. Status arrays are numpy unicode arrays of these values
    (:func:`status_array`); compare them with ``==`` (members are strings).
    """

    OPTIMAL = "optimal"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"
    INACCURATE = "inaccurate"
    MAX_ITER = "max_iter"
    SOLVER_ERROR = "solver_error"
    NOT_RUN = "not_run"
    CONVERGED = "converged"
    NOT_CONVERGED = "not_converged"
    INCONSISTENT = "inconsistent"
    SLACK = "slack"
    INDETERMINATE = "indeterminate"

    def __str__(self) -> str:
        return self.value


@dataclass(eq=False)
class TensionSolution:
    """Tensions of a batch of poses and how they were found.

    Attributes
    ----------
    tensions : ndarray, shape (N, m)
        Cable tensions (N); NaN where the pose has no solution.
    status : ndarray of Status, shape (N,)
    unique : ndarray of bool, shape (N,)
        False where the optimum is not unique (the tie was broken to the minimum
        2-norm among the optima).
    objective : ndarray, shape (N,)
        Objective value as the problem defines it (NaN where not solved).
    residual : ndarray, shape (N,)
        Equilibrium residual ``||A T - b||_2`` (N, N m).
    bound_violation : ndarray, shape (N,)
        Largest violation of ``t_min <= T <= t_max`` (N); 0 when the bounds hold.
    iterations : ndarray of int, shape (N,), or None
        Solver iterations per pose (both stages of a tie-break added); None when the
        solver does not report them; 0 for closed forms.
    infeasibility : ndarray, shape (N,)
        For infeasible poses, where cheap to know: the smallest largest bound
        violation (N) of any tension set in equilibrium; NaN where unknown.
    setup_time : float
        Time to build the problem for the batch (s).
    solve_time : float
        Time in the solver for the whole batch (s).
    backend, solver, solver_version : str
    problem : object
        The :class:`~tension_opt.problems.TensionProblem` solved.
    extras : dict
        Backend-specific information.
    """

    tensions: NDArray
    status: NDArray
    unique: NDArray
    objective: NDArray
    residual: NDArray
    bound_violation: NDArray
    iterations: NDArray | None
    infeasibility: NDArray
    setup_time: float
    solve_time: float
    backend: str
    solver: str
    solver_version: str
    problem: Any = None
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def N(self) -> int:
        """Number of poses."""
        return int(self.tensions.shape[0])

    @property
    def success(self) -> NDArray:
        """Boolean mask of poses solved to optimality, shape (N,)."""
        return np.asarray(self.status == Status.OPTIMAL, dtype=bool)

    @property
    def time_per_pose(self) -> float:
        """``(setup_time + solve_time) / N`` (s)."""
        return (self.setup_time + self.solve_time) / max(self.N, 1)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose: status, tensions ``T1..Tm`` and diagnostics."""
        frame = pd.DataFrame(
            self.tensions, columns=[f"T{i + 1}" for i in range(self.tensions.shape[1])]
        )
        frame.insert(0, "pose", np.arange(self.N))
        frame.insert(1, "status", [str(s) for s in self.status])
        frame["unique"] = self.unique
        frame["objective"] = self.objective
        frame["residual"] = self.residual
        frame["bound_violation"] = self.bound_violation
        frame["iterations"] = (
            pd.array(self.iterations, dtype="Int64") if self.iterations is not None
            else pd.array([None] * self.N, dtype="Int64")
        )
        frame["infeasibility"] = self.infeasibility
        frame["backend"] = self.backend
        return frame

    def __repr__(self) -> str:
        counts = pd.Series([str(s) for s in self.status]).value_counts().to_dict()
        return (
            f"TensionSolution(N={self.N}, m={self.tensions.shape[1]}, backend={self.backend!r}, "
            f"status={counts}, non_unique={int((~self.unique).sum())}, "
            f"max_residual={np.nanmax(self.residual, initial=0.0):.3g})"
        )


#: dtype of status arrays: wide enough for every :class:`Status` value.
STATUS_DTYPE = np.dtype(f"<U{max(len(s.value) for s in Status)}")


def status_array(N: int, fill: Status = Status.OPTIMAL) -> NDArray:
    """Array of ``N`` statuses, all ``fill``, shape (N,) of :data:`STATUS_DTYPE`."""
    return np.full(N, Status(fill).value, dtype=STATUS_DTYPE)
