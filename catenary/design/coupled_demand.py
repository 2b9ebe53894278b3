"""The tensions a path demands of a robot, and their gradients by its design numbers,
in the coupled catenary model (:class:`catenary.design.criteria.PeakTension` with
``model="coupled"``).

The coupled model's minimum-sum tensions at the drawing points
(:func:`catenary.inverse_kinematics`) are differentiated by
:func:`catenary.coupled_sensitivity.coupled_jacobians` by the drawing points, the
attachment points, the weight per length and ``EA``. The cable diameter moves both of the last two:
``w`` and ``EA`` scale with ``d^2``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot

from ..coupled_sensitivity import coupled_jacobians
from ..geometry import cable_data
from ..inverse import inverse_kinematics
from .base import unbounded
from .space import RobotGradient

__all__ = ["COUPLED_TOL", "Demand", "coupled_demand"]

FloatArray = NDArray[np.float64]

#: Convergence of the coupled solves (relative change of the tensions).
COUPLED_TOL = 1e-12


@dataclass(frozen=True, eq=False)
class Demand:
    """Tensions demanded at the drawing points over a path and their gradient.

    Attributes
    ----------
    tensions : ndarray, shape (N, m)
        (N); NaN where the robot cannot hold the pose.
    gradient : callable
        ``gradient(g)`` is the :class:`RobotGradient` of ``sum(g * tensions)``.
    skipped : int
        Poses without a derivative, left out of the gradient.
    infeasible : int
        Poses the robot cannot hold.
    """

    tensions: FloatArray
    gradient: Callable[[FloatArray], RobotGradient]
    skipped: int
    infeasible: int


def coupled_demand(robot: CableRobot, poses: FloatArray) -> Demand:
    """The coupled model's :class:`Demand` of ``poses`` (N, n), without upper bounds."""
    free = unbounded(robot)
    w, EA = cable_data(free)
    solved = inverse_kinematics(free, poses, "coupled", "min_sum", tol=COUPLED_TOL)
    infeasible = int((solved.status != "converged").sum())
    m = robot.m
    if infeasible:
        return Demand(solved.tensions, lambda g: RobotGradient.zeros(m), 0, infeasible)
    jac = coupled_jacobians(free, poses, ("drawing_points", "attachment_points",
                                          "weight_per_length", "EA"), result=solved)
    ok = np.logical_and.reduce([j.ok for j in jac.values()])
    d = robot.cable.diameter if robot.cable is not None else 1.0

    def gradient(g: FloatArray) -> RobotGradient:
        g = np.where(ok[:, None], g, 0.0)

        def by(wrt: str) -> FloatArray:
            return np.nan_to_num(jac[wrt].tensions)

        by_w = float(np.einsum("ka,ka->", g, by("weight_per_length")[..., 0]))
        by_EA = float(np.einsum("ka,ka->", g, by("EA")[..., 0])) if np.isfinite(EA) else 0.0
        diameter = 2.0 / d * (by_w * w + (by_EA * EA if np.isfinite(EA) else 0.0))
        return RobotGradient(np.einsum("ka,kaic->ic", g, by("drawing_points")),
                             np.einsum("ka,kaic->ic", g, by("attachment_points")),
                             diameter, np.zeros(m))

    return Demand(solved.tensions, gradient, int((~ok).sum()), 0)
