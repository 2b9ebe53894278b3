"""Design criteria: scalars of a robot over a set of poses, with their derivatives by the
robot's design numbers (:class:`~catenary.design.space.RobotGradient`).

Each criterion's :meth:`~Criterion.evaluate` gives a :class:`CriterionValue`: the
*smooth* value an optimiser follows, the *plain* value a user reads, and the gradient
of the smooth value. The derivatives are analytic: the tension Jacobians by implicit
differentiation of the KKT conditions (:meth:`tension_opt.TensionSolution.jacobian`)
and the catenary's length partials by the implicit function theorem
(:func:`catenary.sensitivity.length_partials`), chained by hand. Only
:class:`LowestFrequency` is differentiated numerically, by the optimiser
(:attr:`Criterion.numeric`).

Where a plain value is not smooth, the smooth one replaces it, and says how:

- a maximum over poses and cables (:class:`PeakTension`, the longest length of
  :class:`CableMass`) by a log-sum-exp with a ``temperature`` (it exceeds the
  maximum by at most ``temperature * log(count)``);
- the count of feasible grid points (:class:`WorkspaceCoverage`) by a sum of logistic
  functions of each point's load ratio;
- the optimal tensions themselves are smooth only while their active set holds:
  ``min_norm`` (the default here) is smooth where no bound is active, while
  ``min_sum`` jumps between vertices. Poses whose tension Jacobian does not exist (a
  face of optima, a degenerate active set) add nothing to the gradient and are
  counted in :attr:`CriterionValue.skipped`.

Sag in the thesis convention (the tension imposed at the drawing point) changes the
lengths, not the tensions. With ``cable_weight=True`` the tension at the drawing point
is the platform-end tension plus the weight of the cable's height,
``T + w (z_B - z_A)``: exact for an inextensible catenary carrying ``T`` at its lower
end, so a first-order model of the coupled top tension, which the tests compare with
:func:`catenary.inverse_kinematics` (``model="coupled"``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import expit

from tension_opt import CableRobot
from tension_opt.robot.derivatives import column_derivatives

from ..errors import InvalidDesignError
from .base import (
    Criterion,
    CriterionValue,
    OverPoses,
    checked_poses,
    positive,
    soft_max,
    solve_tensions,
    through_tensions,
    unbounded,
    unheld,
)
from .cable_weight import HalfWeight
from .coupled_demand import Demand, coupled_demand
from .space import RobotGradient
from .tension_margin import TensionMargins, tension_margins

__all__ = ["PeakTension", "TensionEnergy", "WorkspaceCoverage"]

FloatArray = NDArray[np.float64]


class PeakTension(OverPoses):
    """The largest tension (N) over a path's poses and the cables, or the largest load
    ratio ``T / t_max`` (``relative=True``), as demanded: solved without upper bounds.

    Parameters
    ----------
    path : array_like, shape (N, n)
        Poses (m, rad).
    objective : str or TensionProblem
        The tension distribution (default ``"min_norm"``, smooth; ``"min_sum"`` for the
        coupled model).
    temperature : float, optional
        Of the log-sum-exp (N, or a ratio for ``relative``); default 1 % of the robot's
        weight (N), or 0.01.
    relative : bool
        The load ratio against each winch's ``t_max`` (finite) instead of newtons.
    cable_weight : bool
        Carry the cables' weight by the half-weight model (module notes): half of
        each cable's weight on the platform, the tension at the drawing point.
    model : {"straight", "coupled"}
        ``"coupled"``: the coupled catenary model's tensions at the drawing points
        (:func:`catenary.inverse_kinematics`, minimum sum), differentiated by
        :func:`catenary.coupled_jacobian`; the cables' weight is then exact and
        ``cable_weight`` does not apply.
    """

    def __init__(self, path: ArrayLike, objective: Any = None,
                 temperature: float | None = None, relative: bool = False,
                 cable_weight: bool = False, model: str = "straight") -> None:
        if model not in ("straight", "coupled"):
            raise InvalidDesignError(f"model must be 'straight' or 'coupled', got {model!r}")
        if model == "coupled" and objective not in (None, "min_sum"):
            raise InvalidDesignError("the coupled model is differentiated at its minimum-sum "
                                     "solution: objective='min_sum' (the default there)")
        default = "min_sum" if model == "coupled" else "min_norm"
        super().__init__(path, default if objective is None else objective, "path")
        self.temperature = None if temperature is None else positive(temperature,
                                                                       "temperature")
        self.relative = bool(relative)
        self.cable_weight = bool(cable_weight)
        self.model = model
        self.name = "peak load ratio" if relative else "peak tension"
        self.unit = "" if relative else "N"

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        m = robot.m
        if self.model == "coupled":
            demand = coupled_demand(robot, P)
        else:
            demand = _straight_demand(robot, P, self.objective, self.cable_weight)
        if demand.infeasible:
            return unheld(m, demand.infeasible)
        load = demand.tensions
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (m,))
        if self.relative:
            if not np.isfinite(t_max).all():
                raise InvalidDesignError("PeakTension(relative=True) needs finite t_max on "
                                         "every winch")
            load = load / t_max
        tau = self.temperature or (0.01 if self.relative else 0.01 * robot.weight)
        value, weights = soft_max(load, tau)
        grad = demand.gradient(weights / t_max if self.relative else weights)
        if self.relative:
            grad = grad + RobotGradient(np.zeros((m, 3)), np.zeros((m, 3)), 0.0,
                                        -(weights * load).sum(axis=0) / t_max)
        return CriterionValue(value, float(load.max()), grad, demand.skipped)


def _straight_demand(robot: CableRobot, P: FloatArray, objective: Any,
                     cable_weight: bool) -> Demand:
    """The tensions the straight model's distribution demands at the drawing points,
    the cables' half weights added with ``cable_weight``."""
    half = HalfWeight(robot, P) if cable_weight else None
    state = solve_tensions(unbounded(robot), P, objective,
                           None if half is None else half.wrench)
    infeasible = int((~state.optimal).sum())
    load = state.tensions if half is None else state.tensions + half.half_height

    def gradient(g: FloatArray) -> RobotGradient:
        grad = through_tensions(state, g, half)
        return grad if half is None else grad + half.height_gradient(g)

    return Demand(load, gradient, int((~state.ok).sum()), infeasible)


class TensionEnergy(OverPoses):
    """The mean over a path's poses of ``sum_i T_i^2`` (N^2), the tensions' energy.

    Parameters
    ----------
    path : array_like, shape (N, n)
    objective : str or TensionProblem
        Default ``"min_norm"``; solved with the robot's bounds.
    """

    name = "tension energy"
    unit = "N^2"

    def __init__(self, path: ArrayLike, objective: Any = "min_norm") -> None:
        super().__init__(path, objective, "path")

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        state = solve_tensions(robot, P, self.objective)
        N, m = state.tensions.shape
        infeasible = int((~state.optimal).sum())
        if infeasible:
            return unheld(m, infeasible)
        T = state.tensions
        value = float((T * T).sum() / N)
        return CriterionValue(value, value, through_tensions(state, 2.0 * T / N),
                              int((~state.ok).sum()))


class WorkspaceCoverage(Criterion):
    """The wrench-feasible volume (m^3) of a grid of poses, each worth ``cell_volume``,
    made smooth (module notes); maximise it.

    Each pose's tension margin ``s`` (:mod:`catenary.design.tension_margin`) is the
    largest fraction of every cable's half-range ``(t_max - t_min) / 2`` that tensions
    holding the pose keep from both bounds: the pose is feasible exactly where
    ``s >= 0``. The smooth value is
    ``cell_volume * sum sigma(s / temperature)``, the plain value counts ``s >= 0``.

    With ``cable_weight`` (default) the cables weigh by the half-weight model
    (:mod:`catenary.design.cable_weight`): the platform carries half of each cable's
    weight, ``t_max`` bounds the tension at the drawing point (``T + w dz / 2``) and
    ``t_min`` the one at the attachment (``T - w dz / 2``), as the coupled catenary
    workspace (:func:`catenary.sag_workspace`) bounds each cable's highest and lowest
    tension. Without it, the straight-cable workspace
    (:func:`tension_opt.workspace.wrench_feasible_workspace`), point for point.

    The margins are optimal values of linear programs, differentiated by the envelope
    theorem through one optimal pair of tensions and multipliers. Where a grid point's
    LP has several (a symmetric robot, moved off its symmetry by a variable that breaks
    it), the gradient is that pair's and can differ from the derivative along such a
    variable by a few per cent; along variables that keep the symmetry it is exact.

    Parameters
    ----------
    poses : array_like, shape (N, n)
        The grid (m, rad).
    cell_volume : float
        Volume per point (m^3), > 0.
    temperature : float
        Width of the logistic step in margin (default 0.05).
    cable_weight : bool
        Default True.
    """

    name = "workspace volume"
    unit = "m^3"

    def __init__(self, poses: ArrayLike, cell_volume: float, temperature: float = 0.05,
                 cable_weight: bool = True) -> None:
        self.poses = checked_poses(poses, "poses")
        self.cell_volume = positive(cell_volume, "cell_volume")
        self.temperature = positive(temperature, "temperature")
        self.cable_weight = bool(cable_weight)

    def margins(self, robot: CableRobot) -> tuple[TensionMargins, HalfWeight | None]:
        """The grid's :class:`~catenary.design.tension_margin.TensionMargins` and the
        half-weight model it used (None without ``cable_weight``)."""
        P = robot.as_poses(self.poses)
        N, m = len(P), robot.m
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (N, m))
        if not np.isfinite(t_max).all():
            raise InvalidDesignError("WorkspaceCoverage needs finite t_max on every winch: "
                                     "robot.with_(t_max=...)")
        t_min = np.broadcast_to(np.asarray(robot.t_min, dtype=float), (N, m))
        half = HalfWeight(robot, P) if self.cable_weight else None
        A = robot.structure_matrices(P)
        # Half-ranges of the winches' own bounds, so that the margin stays defined where
        # the hanging weights close the range (t_max - h < t_min + h: s < 0).
        d = 0.5 * (t_max - t_min)
        if half is None:
            return tension_margins(A, robot.required_wrench(P), t_min, t_max, d), None
        return tension_margins(A, robot.required_wrench(P, half.wrench),
                               t_min + half.half_height, t_max - half.half_height, d), half

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        got, half = self.margins(robot)
        solved = got.solved
        s = np.where(solved, got.margin, -np.inf)
        weight = np.where(solved, expit(np.where(solved, s, 0.0) / self.temperature), 0.0)
        d_s = self.cell_volume * weight * (1.0 - weight) / self.temperature   # (N,)
        y = got.d_matrix * d_s[:, None]
        yT = np.einsum("kn,ki->kni", y, np.where(solved[:, None], got.tensions, 0.0))
        anchors = np.einsum("kni,kinc->ic", yT, column_derivatives(robot, P, "drawing_points"))
        attachments = np.einsum("kni,kinc->ic", yT,
                                column_derivatives(robot, P, "attachment_points"))
        d_up = d_s[:, None] * got.d_upper                                     # (N, m)
        d_lo = d_s[:, None] * got.d_lower
        by_t_max = (d_up + 0.5 * d_s[:, None] * got.d_half).sum(axis=0)       # d = ... / 2
        grad = RobotGradient(anchors, attachments, 0.0, by_t_max)
        if half is not None:
            # b = -(w_g + wrench): ds/d wrench = d_matrix; the bounds move with w dz / 2.
            grad = grad + half.wrench_gradient(y) + half.height_gradient(d_lo - d_up)
        return CriterionValue(self.cell_volume * float(weight.sum()),
                              self.cell_volume * float((s >= -1e-9).sum()), grad, 0,
                              int((~solved).sum()))
