"""The answer of a :class:`~tension_opt.distribution.distributor.Distributor` call."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.status import Status
from tension_opt.tolerances import accuracy_target

__all__ = ["RealtimeResult"]

_NAN = float("nan")


@dataclass(eq=False, slots=True)
class RealtimeResult:
    """Answer of a :class:`Distributor` call.

    Attributes
    ----------
    tensions : ndarray, shape (m,) or (N, m)
        Cable tensions (N), NaN where the pose has no solution; (m,) for one pose.
    status : Status or ndarray of Status values, shape (N,)
        As :attr:`tension_opt.TensionSolution.status` (a member for one pose).
    unique : bool or ndarray of bool, shape (N,)
        False where the optimum was a tie broken to the minimum 2-norm.
    residual : float or ndarray, shape (N,)
        Equilibrium residual ``||A T - b||`` (N, N m); NaN where not solved.
    infeasibility : float or ndarray, shape (N,)
        For infeasible poses where known, the smallest largest bound violation (N).
    compiled : bool or ndarray of bool, shape (N,)
        Whether the compiled kernel answered (else the numpy path did).
    primal_residual, dual_residual, duality_gap : float or ndarray, shape (N,)
        The certificate, as :attr:`tension_opt.TensionSolution.primal_residual` ...
        (scaled measures; NaN where there is no solution): ``optimal`` only where all
        three are within the accuracy target.
    jacobian : ndarray, shape (m, n) ((m, m) by a bound), or None
        From :meth:`Distributor.with_jacobian`: ``dT / d wrt`` (NaN where the status
        is not ``"ok"``); None from a plain call.
    jacobian_status : str or None
        Its status, one of :class:`~tension_opt.distribution.sensitivity.Sensitivity`'s.
    """

    tensions: NDArray
    status: Any
    unique: Any
    residual: Any
    infeasibility: Any
    compiled: Any
    primal_residual: Any = _NAN
    dual_residual: Any = _NAN
    duality_gap: Any = _NAN
    jacobian: Any = None
    jacobian_status: Any = None

    @property
    def success(self) -> Any:
        """Whether the pose (each pose) was solved to optimality."""
        return np.asarray(self.status == Status.OPTIMAL) if np.ndim(self.status) else (
            self.status == Status.OPTIMAL)

    def certified(self, accuracy: object = None) -> Any:
        """Whether the certificate of the pose (each pose) meets the target of
        ``accuracy`` (default 1e-7, as :func:`tension_opt.distribute`'s option;
        NaN fails)."""
        t = accuracy_target(accuracy)
        ok = (np.asarray(self.primal_residual) <= t) & (np.asarray(self.dual_residual) <= t) \
            & (np.asarray(self.duality_gap) <= t)
        return ok if np.ndim(self.status) else bool(ok)
