"""The design criteria's common ground: a criterion's value and gradient, the soft
maximum, the argument checks, and the optimal tensions of a batch with their Jacobians
by the robot's points (:mod:`catenary.design.criteria` says what the criteria are).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot

from ..errors import InvalidDesignError
from .cable_weight import HalfWeight
from .space import RobotGradient

__all__ = ["Criterion", "CriterionValue", "OverPoses", "Tensions", "checked_poses",
           "positive", "soft_max", "solve_tensions", "through_tensions", "unbounded",
           "unheld"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class CriterionValue:
    """A criterion evaluated on one robot.

    Attributes
    ----------
    value : float
        The smooth value (the criterion's unit) that an optimiser follows.
    plain : float
        The plain value (the exact maximum, the count of feasible points times their
        cell volume, ...).
    gradient : RobotGradient or None
        Of ``value``; None for a numerically differentiated criterion.
    skipped : int
        Poses whose tension Jacobian does not exist, left out of the gradient.
    infeasible : int
        Poses without optimal tensions (the value is NaN for a criterion over a path).
    """

    value: float
    plain: float
    gradient: RobotGradient | None
    skipped: int = 0
    infeasible: int = 0


def soft_max(values: FloatArray, temperature: float) -> tuple[float, FloatArray]:
    """Log-sum-exp ``t log sum exp(v / t)`` of finite ``values`` and its gradient (the
    softmax weights, same shape): at least ``max(v)`` and at most ``max(v) + t log(n)``."""
    top = float(values.max())
    e = np.exp((values - top) / temperature)
    total = float(e.sum())
    return top + temperature * float(np.log(total)), e / total


class Criterion:
    """A scalar of a robot over poses (module notes).

    Attributes
    ----------
    name, unit : str
    numeric : bool
        True where the optimiser differentiates by finite differences.
    """

    name = "criterion"
    unit = ""
    numeric = False

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        """The criterion on ``robot``."""
        raise NotImplementedError

    def with_material(self, material: str | None) -> Criterion:
        """This criterion for cables of catalogue ``material`` (the optimiser calls it
        with its space's material); most criteria read the robot alone."""
        return self

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, unit={self.unit!r})"


def unheld(m: int, infeasible: int) -> CriterionValue:
    """The value of a criterion whose robot cannot hold ``infeasible`` of its poses."""
    return CriterionValue(np.nan, np.nan, RobotGradient.zeros(m), 0, infeasible)


def checked_poses(poses: ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(poses, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or len(arr) == 0 or not np.isfinite(arr).all():
        raise InvalidDesignError(f"{name} must be finite poses of shape (N, n), N >= 1, got "
                                 f"shape {arr.shape}")
    return arr


def positive(value: float, name: str) -> float:
    if not (np.isfinite(value) and value > 0):
        raise InvalidDesignError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


class OverPoses(Criterion):
    """A criterion over poses whose tensions come from a distribution ``objective``."""

    def __init__(self, poses: ArrayLike, objective: Any, name: str = "poses") -> None:
        self.poses = checked_poses(poses, name)
        self.objective = objective


@dataclass(frozen=True, eq=False)
class Tensions:
    """Optimal tensions of a batch and their Jacobians by the robot's points."""

    tensions: FloatArray          # (N, m), NaN where not optimal
    ok: NDArray[np.bool_]         # (N,) Jacobian exists
    optimal: NDArray[np.bool_]    # (N,)
    d_anchors: FloatArray         # (N, m, m, 3), zero where not ok
    d_attachments: FloatArray     # (N, m, m, 3)
    d_t_max: FloatArray           # (N, m, m)
    d_wrench: FloatArray | None   # (N, m, n) where an external wrench was given


def solve_tensions(robot: CableRobot, poses: FloatArray, objective: Any,
              wrench: FloatArray | None = None) -> Tensions:
    sol = tension_opt.distribute(robot, poses, objective, wrench=wrench)
    optimal = np.asarray(sol.success, dtype=bool)
    kw = {"robot": robot, "poses": poses, "wrench": wrench}
    d_a = sol.jacobian("drawing_points", **kw)
    d_b = sol.jacobian("attachment_points", **kw)
    ok = d_a.ok & d_b.ok & optimal
    d_tmax = np.zeros((len(poses), robot.m, robot.m))
    if np.isfinite(np.asarray(robot.t_max, dtype=float)).any():
        d_t = sol.jacobian("t_max", **kw)
        ok &= d_t.ok
        d_tmax = d_t.jacobian
    d_w = None
    if wrench is not None:
        got = sol.jacobian("wrench", **kw)
        ok &= got.ok
        d_w = got.jacobian

    def clean(j: FloatArray) -> FloatArray:
        return np.where(ok.reshape((-1,) + (1,) * (j.ndim - 1)), j, 0.0)

    tensions = np.where(optimal[:, None], sol.tensions, np.nan)
    return Tensions(tensions, ok, optimal, clean(d_a.jacobian), clean(d_b.jacobian),
                     clean(d_tmax), None if d_w is None else clean(d_w))


def through_tensions(state: Tensions, weights: FloatArray,
                      half: HalfWeight | None = None) -> RobotGradient:
    """The gradient of ``sum(weights * T)`` (weights (N, m)) through the tensions, and
    through the cables' half weights on the platform where ``half`` gave the wrench."""
    g = np.where(state.ok[:, None], weights, 0.0)
    grad = RobotGradient(np.einsum("ka,kaic->ic", g, state.d_anchors),
                         np.einsum("ka,kaic->ic", g, state.d_attachments), 0.0,
                         np.einsum("ka,kai->i", g, state.d_t_max))
    if half is not None and state.d_wrench is not None:
        grad = grad + half.wrench_gradient(np.einsum("ka,kan->kn", g, state.d_wrench))
    return grad


def unbounded(robot: CableRobot) -> CableRobot:
    """``robot`` without upper tension bounds: the tensions a load demands."""
    return robot.with_(t_max=np.inf)
