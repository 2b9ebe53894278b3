"""Design criteria of the cables' lengths in the thesis convention: the sag correction
and the cables' mass (:mod:`catenary.design.criteria` says how they are smoothed and
differentiated).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot

from ..errors import InvalidDesignError
from ..geometry import cable_data, cable_planes
from ..sensitivity import length_partials
from .base import (
    CriterionValue,
    OverPoses,
    Tensions,
    positive,
    soft_max,
    solve_tensions,
    through_tensions,
    unheld,
)
from .space import RobotGradient

__all__ = ["CableMass", "SagCorrection"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class _Lengths:
    """Sag lengths of the thesis convention over a batch and their partials."""

    L0: FloatArray          # (N, m)
    straight: FloatArray    # (N, m)
    state: Tensions
    d_x: FloatArray
    d_z: FloatArray
    d_T: FloatArray
    d_w: FloatArray
    d_EA: FloatArray
    e_h: FloatArray         # (N, m, 3)
    unit: FloatArray        # (N, m, 3) along the cable, toward the drawing point
    rotation: FloatArray    # (N, 3, 3)
    w: float
    EA: float


def _lengths(robot: CableRobot, poses: FloatArray, objective: Any) -> _Lengths:
    w, EA = cable_data(robot)
    if not w > 0:
        raise InvalidDesignError("the sag criteria need cables with weight (robot.cable)")
    state = solve_tensions(robot, poses, objective)
    planes = cable_planes(robot, poses)
    part = length_partials(planes.x, planes.z, np.where(state.optimal[:, None],
                                                        state.tensions, 1.0), w, EA)
    straight = planes.chord
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.concatenate([planes.e_h[..., :2] * (planes.x / straight)[..., None],
                               (planes.z / straight)[..., None]], axis=-1)
    return _Lengths(part.L0, straight, state, part.d_x, part.d_z, part.d_T, part.d_w,
                    part.d_EA, planes.e_h, unit, np.asarray(planes.rotation), w, EA)


def _length_gradient(lengths: _Lengths, robot: CableRobot, g_sag: FloatArray,
                     g_straight: FloatArray) -> RobotGradient:
    """Gradient of ``sum(g_sag * L0 + g_straight * L_straight)`` (weights (N, m))."""
    s = lengths
    ok = s.state.ok[:, None]
    g_sag = np.where(ok, g_sag, 0.0)
    g_straight = np.where(ok, g_straight, 0.0)
    # By the cable vector v = D - (p + R a): L0 through its spans, the chord directly.
    d_v = (g_sag * s.d_x)[..., None] * s.e_h
    d_v[..., 2] += g_sag * s.d_z
    d_v += g_straight[..., None] * s.unit
    grad = through_tensions(s.state, g_sag * s.d_T)
    anchors = grad.anchors + d_v.sum(axis=0)
    attachments = grad.attachments - np.einsum("kac,kcj->aj", d_v, s.rotation)
    d = robot.cable.diameter if robot.cable is not None else 0.0
    d_EA = 0.0 if not np.isfinite(s.EA) else float((g_sag * s.d_EA).sum()) * 2.0 * s.EA / d
    diameter = float((g_sag * s.d_w).sum()) * 2.0 * s.w / d + d_EA
    return RobotGradient(anchors, attachments, diameter, grad.t_max)


class SagCorrection(OverPoses):
    """The mean over poses of ``sum_i (L0_i - L_straight_i)`` (m): how much cable the
    sag (and stretch) asks beyond the straight lines, in the thesis convention
    (:func:`catenary.inverse_kinematics`, ``model="thesis"``).

    Parameters
    ----------
    poses : array_like, shape (N, n)
    objective : str or TensionProblem
        Default ``"min_norm"``; solved with the robot's bounds.
    """

    name = "sag correction"
    unit = "m"

    def __init__(self, poses: ArrayLike, objective: Any = "min_norm") -> None:
        super().__init__(poses, objective)

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        s = _lengths(robot, P, self.objective)
        N, m = s.L0.shape
        infeasible = int((~s.state.optimal).sum())
        if infeasible:
            return unheld(m, infeasible)
        value = float((s.L0 - s.straight).sum() / N)
        g = np.full((N, m), 1.0 / N)
        return CriterionValue(value, value, _length_gradient(s, robot, g, -g),
                              int((~s.state.ok).sum()))


class CableMass(OverPoses):
    """The mass (kg) of the cables: each cable as long as its longest sag length over
    the poses (thesis convention), at the cable's linear mass.

    Parameters
    ----------
    poses : array_like, shape (N, n)
        The poses the cables must reach (a path, or a grid's corners).
    objective : str or TensionProblem
        Default ``"min_norm"``.
    temperature : float
        Of the log-sum-exp over poses (m), default 0.05.
    """

    name = "cable mass"
    unit = "kg"

    def __init__(self, poses: ArrayLike, objective: Any = "min_norm",
                 temperature: float = 0.05) -> None:
        super().__init__(poses, objective)
        self.temperature = positive(temperature, "temperature")

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        s = _lengths(robot, P, self.objective)
        N, m = s.L0.shape
        infeasible = int((~s.state.optimal).sum())
        if infeasible:
            return unheld(m, infeasible)
        assert robot.cable is not None  # _lengths checked it
        mu = robot.cable.linear_mass
        longest = np.empty(m)
        g = np.empty((N, m))
        for i in range(m):  # m cables, a few: each its own soft maximum over the poses
            longest[i], g[:, i] = soft_max(s.L0[:, i], self.temperature)
        grad = _length_gradient(s, robot, mu * g, np.zeros((N, m)))
        d = robot.cable.diameter
        grad = RobotGradient(grad.anchors, grad.attachments,
                             grad.diameter + 2.0 * mu / d * float(longest.sum()), grad.t_max)
        return CriterionValue(mu * float(longest.sum()), mu * float(s.L0.max(axis=0).sum()),
                              grad, int((~s.state.ok).sum()))
