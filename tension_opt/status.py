"""The one status vocabulary of the toolkit and its arrays."""

from __future__ import annotations

from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

__all__ = ["STATUS_DTYPE", "Status", "status_array"]


class Status(StrEnum):
    """Outcome of one pose or one cable: the one status vocabulary of the toolkit.

    Optimisation (tension distribution, margins) reports ``OPTIMAL``, ``INACCURATE``,
    ``INFEASIBLE``, ``UNBOUNDED``, ``MAX_ITER``, ``SOLVER_ERROR`` or ``NOT_RUN``;
    iterative solvers (catenary, kinematics) ``CONVERGED``, ``NOT_CONVERGED``,
    ``INCONSISTENT`` (no pose meets the lengths), ``SLACK`` (a cable that cannot carry
    the asked tension), ``INDETERMINATE`` (the data do not fix the answer),
    ``STALLED`` (no further progress), ``SINGULAR`` (a singular Newton system) or
    ``CATENARY_FAILED`` (no taut catenary carries the tension), besides
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
    STALLED = "stalled"
    SINGULAR = "singular"
    CATENARY_FAILED = "catenary_failed"

    def __str__(self) -> str:
        return self.value


#: dtype of status arrays: wide enough for every :class:`Status` value.
STATUS_DTYPE = np.dtype(f"<U{max(len(s.value) for s in Status)}")


def status_array(shape: int | tuple[int, ...], fill: Status = Status.OPTIMAL) -> NDArray:
    """Array of statuses, all ``fill``, of the given shape (usually (N,)) and
    :data:`STATUS_DTYPE`."""
    return np.full(shape, Status(fill).value, dtype=STATUS_DTYPE)
