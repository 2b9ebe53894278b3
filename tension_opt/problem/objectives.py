"""Objectives of tension distribution, one class each.

An objective knows its terms in the standard form every backend solves::

    minimise   1/2 sum_i q_i T_i^2 + c^T T  [+ max_i v_i T_i]

(a diagonal Hessian ``q >= 0``, a linear cost ``c`` and an optional min-max term with
weights ``v``), and how to evaluate itself on tensions, with no constant dropped.

=============  ===============================================  ==========
objective      minimises                                        form
=============  ===============================================  ==========
``min_sum``    ``sum_i w_i T_i``                                LP
``min_norm``   ``sum_i w_i (T_i - r_i)^2`` (r = reference or 0)  QP
``pinv``       ``sum_i T_i^2`` without bounds                    QP
``min_max``    ``max_i w_i T_i``                                LP (epigraph)
``centered``   ``sum_i w_i (T_i - (t_min_i + t_max_i)/2)^2``    QP
=============  ===============================================  ==========

A new LP or QP objective is one subclass of :class:`Objective` listed in
:data:`OBJECTIVES`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from tension_opt.errors import InvalidInputError


@dataclass(frozen=True)
class ObjectiveTerms:
    """An objective's terms for a batch: ``q`` and ``c`` (N, m), min-max weights (m,)."""

    q: NDArray
    c: NDArray
    minmax: NDArray | None = None


class Objective:
    """Base of the objectives. Instances are stateless and compare equal to their name.

    Subclasses set :attr:`name` and :attr:`linear` and implement :meth:`terms` and
    :meth:`evaluate`.
    """

    #: Registry name, e.g. ``"min_sum"``.
    name: ClassVar[str] = ""
    #: Whether the problem is a linear program (its optimum may be non-unique).
    linear: ClassVar[bool] = False
    #: Whether the objective takes tension bounds (the pseudo-inverse does not).
    bounded: ClassVar[bool] = True
    #: Whether the objective uses a reference tension.
    uses_reference: ClassVar[bool] = False

    def terms(self, weights: NDArray, lb: NDArray, ub: NDArray,
              reference: NDArray | None) -> ObjectiveTerms:
        """Terms of the standard form for a batch.

        Parameters
        ----------
        weights : ndarray, shape (m,)
            Positive per-cable weights.
        lb, ub : ndarray, shape (N, m)
            Tension bounds of each pose (N).
        reference : ndarray, shape (N, m), optional
            Reference tensions (N), for objectives that use one.
        """
        raise NotImplementedError

    def evaluate(self, tensions: NDArray, weights: NDArray, lb: NDArray, ub: NDArray,
                 reference: NDArray | None) -> NDArray:
        """Objective value of tensions (N, m), shape (N,) (N or N^2)."""
        raise NotImplementedError

    def check(self, lb: NDArray, ub: NDArray) -> None:
        """Raise :class:`InvalidInputError` if the bounds do not suit the objective."""

    def __eq__(self, other: object) -> bool:
        if isinstance(other, str):
            return self.name == other
        return isinstance(other, Objective) and other.name == self.name

    def __hash__(self) -> int:
        return hash(self.name)

    def __str__(self) -> str:
        return self.name

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    @property
    def value(self) -> str:
        """The objective's name (as the enum members of earlier versions had it)."""
        return self.name


class MinSum(Objective):
    """Minimum weighted sum of tensions ``sum_i w_i T_i`` (LP)."""

    name = "min_sum"
    linear = True

    def terms(self, weights: NDArray, lb: NDArray, ub: NDArray,
              reference: NDArray | None) -> ObjectiveTerms:
        return ObjectiveTerms(np.zeros_like(lb), np.broadcast_to(weights, lb.shape).copy())

    def evaluate(self, tensions: NDArray, weights: NDArray, lb: NDArray, ub: NDArray,
                 reference: NDArray | None) -> NDArray:
        return tensions @ weights


class MinMax(Objective):
    """Minimum largest weighted tension ``max_i w_i T_i`` (LP in epigraph form)."""

    name = "min_max"
    linear = True

    def terms(self, weights: NDArray, lb: NDArray, ub: NDArray,
              reference: NDArray | None) -> ObjectiveTerms:
        return ObjectiveTerms(np.zeros_like(lb), np.zeros_like(lb), weights)

    def evaluate(self, tensions: NDArray, weights: NDArray, lb: NDArray, ub: NDArray,
                 reference: NDArray | None) -> NDArray:
        return (tensions * weights).max(axis=1)


class _Distance(Objective):
    """``sum_i w_i (T_i - r_i)^2`` toward a per-pose target ``r`` (QP)."""

    def target(self, lb: NDArray, ub: NDArray, reference: NDArray | None) -> NDArray:
        """Target tensions (N, m) of the distance."""
        raise NotImplementedError

    def terms(self, weights: NDArray, lb: NDArray, ub: NDArray,
              reference: NDArray | None) -> ObjectiveTerms:
        w = np.broadcast_to(weights, lb.shape)
        return ObjectiveTerms(2.0 * w, -2.0 * w * self.target(lb, ub, reference))

    def evaluate(self, tensions: NDArray, weights: NDArray, lb: NDArray, ub: NDArray,
                 reference: NDArray | None) -> NDArray:
        return ((tensions - self.target(lb, ub, reference)) ** 2 * weights).sum(axis=1)


class MinNorm(_Distance):
    """Minimum weighted 2-norm, optionally toward a reference (QP)."""

    name = "min_norm"
    uses_reference = True

    def target(self, lb: NDArray, ub: NDArray, reference: NDArray | None) -> NDArray:
        return np.zeros_like(lb) if reference is None else reference


class Centered(_Distance):
    """Closest to the middle of ``[t_min, t_max]`` (QP; needs finite ``t_max``)."""

    name = "centered"

    def target(self, lb: NDArray, ub: NDArray, reference: NDArray | None) -> NDArray:
        return 0.5 * (lb + ub)

    def check(self, lb: NDArray, ub: NDArray) -> None:
        if not np.isfinite(ub).all():
            raise InvalidInputError("the centred objective needs finite t_max for every cable")


class Pinv(Objective):
    """Moore-Penrose pseudo-inverse: minimum ``sum_i T_i^2`` without bounds (QP)."""

    name = "pinv"
    bounded = False

    def terms(self, weights: NDArray, lb: NDArray, ub: NDArray,
              reference: NDArray | None) -> ObjectiveTerms:
        return ObjectiveTerms(np.full(lb.shape, 2.0), np.zeros_like(lb))

    def evaluate(self, tensions: NDArray, weights: NDArray, lb: NDArray, ub: NDArray,
                 reference: NDArray | None) -> NDArray:
        return (tensions**2).sum(axis=1)


#: Every objective by name; a new objective is one class added here.
OBJECTIVES: dict[str, Objective] = {
    cls.name: cls() for cls in (MinSum, MinNorm, Pinv, MinMax, Centered)
}


def get_objective(objective: str | Objective) -> Objective:
    """The objective of a name (or the objective itself).

    Raises
    ------
    InvalidInputError
        For an unknown name, listing the known ones.
    """
    if isinstance(objective, Objective):
        return objective
    if isinstance(objective, str) and objective in OBJECTIVES:
        return OBJECTIVES[objective]
    raise InvalidInputError(
        f"unknown objective {objective!r}; choose one of {list(OBJECTIVES)}")

# The members of the enum that named objectives in earlier versions, for code that
# writes ``Objective.MIN_SUM``.
Objective.MIN_SUM = OBJECTIVES["min_sum"]  # type: ignore[attr-defined]
Objective.MIN_NORM = OBJECTIVES["min_norm"]  # type: ignore[attr-defined]
Objective.PINV = OBJECTIVES["pinv"]  # type: ignore[attr-defined]
Objective.MIN_MAX = OBJECTIVES["min_max"]  # type: ignore[attr-defined]
Objective.CENTERED = OBJECTIVES["centered"]  # type: ignore[attr-defined]
