"""The one status vocabulary of the toolkit and its arrays."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["STATUS_DTYPE", "STATUS_TABLE", "Status", "StatusCodes", "status_array",
           "status_codes"]


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
    (:func:`status_array`); compare them with ``==`` (members are strings). A large
    batch may hold them as one-byte codes until they are read (:class:`StatusCodes`).
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


#: Every :class:`Status` value in the order of its code (:class:`StatusCodes`): the
#: compiled kernels' codes 0-3 are optimal, infeasible, unbounded and inaccurate.
STATUS_TABLE = np.array([s.value for s in Status], dtype=STATUS_DTYPE)
STATUS_TABLE.setflags(write=False)  # every decoding reads it


@dataclass(frozen=True, eq=False)
class StatusCodes:
    """Statuses of a batch held as one-byte codes into :data:`STATUS_TABLE` (1 byte a
    pose where a status array takes 60), for a result that decodes them only when its
    statuses are read.

    Attributes
    ----------
    codes : ndarray of int8, shape (N,)
        Indices into :data:`STATUS_TABLE`.
    """

    codes: NDArray

    def decode(self) -> NDArray:
        """The status array, shape (N,), of :data:`STATUS_DTYPE`."""
        return np.take(STATUS_TABLE, self.codes)

    def equal_to(self, status: Status) -> NDArray:
        """Boolean mask of the poses whose status is ``status``, shape (N,)."""
        return np.asarray(self.codes == _CODE_OF[Status(status)], dtype=bool)


_CODE_OF = {Status(value): code for code, value in enumerate(STATUS_TABLE)}


def status_codes(status: ArrayLike) -> NDArray:
    """The :class:`StatusCodes` codes (int8, same shape) of an array of status values.

    Raises
    ------
    ValueError
        If a value is not a :class:`Status`.
    """
    status = np.asarray(status, dtype=STATUS_DTYPE)
    codes = np.full(status.shape, -1, dtype=np.int8)
    for value in np.unique(status):
        if value not in _CODE_OF:
            raise ValueError(f"{str(value)!r} is not a Status value")
        codes[status == value] = _CODE_OF[Status(value)]
    return codes
