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

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import expit

import tension_opt
from tension_opt import CableRobot
from tension_opt.robot.derivatives import column_derivatives

from ..errors import InvalidDesignError
from ..geometry import cable_data, cable_planes
from ..materials import breaking_load
from ..response import natural_frequencies
from ..sensitivity import length_partials
from .cable_weight import HalfWeight
from .space import RobotGradient
from .tension_margin import TensionMargins, tension_margins

__all__ = ["CableMass", "CableStrength", "Criterion", "CriterionValue", "LowestFrequency",
           "PeakTension", "SagCorrection", "TensionEnergy", "WorkspaceCoverage", "soft_max"]

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


def _unheld(m: int, infeasible: int) -> CriterionValue:
    """The value of a criterion whose robot cannot hold ``infeasible`` of its poses."""
    return CriterionValue(np.nan, np.nan, RobotGradient.zeros(m), 0, infeasible)


def _poses(poses: ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(poses, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or len(arr) == 0 or not np.isfinite(arr).all():
        raise InvalidDesignError(f"{name} must be finite poses of shape (N, n), N >= 1, got "
                                 f"shape {arr.shape}")
    return arr


def _positive(value: float, name: str) -> float:
    if not (np.isfinite(value) and value > 0):
        raise InvalidDesignError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


class _OverPoses(Criterion):
    """A criterion over poses whose tensions come from a distribution ``objective``."""

    def __init__(self, poses: ArrayLike, objective: Any, name: str = "poses") -> None:
        self.poses = _poses(poses, name)
        self.objective = objective


@dataclass(frozen=True, eq=False)
class _Tensions:
    """Optimal tensions of a batch and their Jacobians by the robot's points."""

    tensions: FloatArray          # (N, m), NaN where not optimal
    ok: NDArray[np.bool_]         # (N,) Jacobian exists
    optimal: NDArray[np.bool_]    # (N,)
    d_anchors: FloatArray         # (N, m, m, 3), zero where not ok
    d_attachments: FloatArray     # (N, m, m, 3)
    d_t_max: FloatArray           # (N, m, m)
    d_wrench: FloatArray | None   # (N, m, n) where an external wrench was given


def _tensions(robot: CableRobot, poses: FloatArray, objective: Any,
              wrench: FloatArray | None = None) -> _Tensions:
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
    return _Tensions(tensions, ok, optimal, clean(d_a.jacobian), clean(d_b.jacobian),
                     clean(d_tmax), None if d_w is None else clean(d_w))


def _through_tensions(state: _Tensions, weights: FloatArray,
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


def _unbounded(robot: CableRobot) -> CableRobot:
    """``robot`` without upper tension bounds: the tensions a load demands."""
    return robot.with_(t_max=np.inf)


class PeakTension(_OverPoses):
    """The largest tension (N) over a path's poses and the cables, or the largest load
    ratio ``T / t_max`` (``relative=True``), as demanded: solved without upper bounds.

    Parameters
    ----------
    path : array_like, shape (N, n)
        Poses (m, rad).
    objective : str or TensionProblem
        The tension distribution (default ``"min_norm"``, smooth).
    temperature : float, optional
        Of the log-sum-exp (N, or a ratio for ``relative``); default 1 % of the robot's
        weight (N), or 0.01.
    relative : bool
        The load ratio against each winch's ``t_max`` (finite) instead of newtons.
    cable_weight : bool
        Carry the cables' weight by the half-weight model (module notes): half of
        each cable's weight on the platform, the tension at the drawing point.
    """

    def __init__(self, path: ArrayLike, objective: Any = "min_norm",
                 temperature: float | None = None, relative: bool = False,
                 cable_weight: bool = False) -> None:
        super().__init__(path, objective, "path")
        self.temperature = None if temperature is None else _positive(temperature,
                                                                        "temperature")
        self.relative = bool(relative)
        self.cable_weight = bool(cable_weight)
        self.name = "peak load ratio" if relative else "peak tension"
        self.unit = "" if relative else "N"

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        half = HalfWeight(robot, P) if self.cable_weight else None
        state = _tensions(_unbounded(robot), P, self.objective,
                          None if half is None else half.wrench)
        m = robot.m
        infeasible = int((~state.optimal).sum())
        if infeasible:
            return _unheld(m, infeasible)
        load = state.tensions if half is None else state.tensions + half.half_height
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (m,))
        if self.relative:
            if not np.isfinite(t_max).all():
                raise InvalidDesignError("PeakTension(relative=True) needs finite t_max on "
                                         "every winch")
            load = load / t_max
        tau = self.temperature or (0.01 if self.relative else 0.01 * robot.weight)
        value, weights = soft_max(load, tau)
        g = weights / t_max if self.relative else weights
        grad = _through_tensions(state, g, half)
        if half is not None:
            grad = grad + half.height_gradient(g)
        if self.relative:
            grad = grad + RobotGradient(np.zeros((m, 3)), np.zeros((m, 3)), 0.0,
                                        -(weights * load).sum(axis=0) / t_max)
        return CriterionValue(value, float(load.max()), grad, int((~state.ok).sum()))


class TensionEnergy(_OverPoses):
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
        state = _tensions(robot, P, self.objective)
        N, m = state.tensions.shape
        infeasible = int((~state.optimal).sum())
        if infeasible:
            return _unheld(m, infeasible)
        T = state.tensions
        value = float((T * T).sum() / N)
        return CriterionValue(value, value, _through_tensions(state, 2.0 * T / N),
                              int((~state.ok).sum()))


class WorkspaceCoverage(Criterion):
    """The wrench-feasible volume (m^3) of a grid of poses, each worth ``cell_volume``,
    made smooth (module notes); maximise it.

    Each pose's tension margin ``s`` (:mod:`catenary.design.tension_margin`) is the
    largest fraction of every cable's half-range that tensions holding the pose keep
    from both bounds: the pose is feasible exactly where ``s >= 0``. The smooth value is
    ``cell_volume * sum sigma(s / temperature)``, the plain value counts ``s >= 0``.

    With ``cable_weight`` (default) the cables weigh by the half-weight model
    (:mod:`catenary.design.cable_weight`): the platform carries half of each cable's
    weight, ``t_max`` bounds the tension at the drawing point (``T + w dz / 2``) and
    ``t_min`` the one at the attachment (``T - w dz / 2``), as the coupled catenary
    workspace (:func:`catenary.sag_workspace`) bounds each cable's highest and lowest
    tension. Without it, the straight-cable workspace
    (:func:`tension_opt.workspace.wrench_feasible_workspace`), point for point.

    The margins are optimal values of linear programs, differentiated by the envelope
    theorem through their multipliers; where those are not unique, the gradient is a
    subgradient.

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
        self.poses = _poses(poses, "poses")
        self.cell_volume = _positive(cell_volume, "cell_volume")
        self.temperature = _positive(temperature, "temperature")
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
        if half is None:
            return tension_margins(A, robot.required_wrench(P), t_min, t_max), None
        return tension_margins(A, robot.required_wrench(P, half.wrench),
                               t_min + half.half_height, t_max - half.half_height), half

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
        grad = RobotGradient(anchors, attachments, 0.0, d_up.sum(axis=0))
        if half is not None:
            # b = -(w_g + wrench): ds/d wrench = d_matrix; the bounds move with w dz / 2.
            grad = grad + half.wrench_gradient(y) + half.height_gradient(d_lo - d_up)
        return CriterionValue(self.cell_volume * float(weight.sum()),
                              self.cell_volume * float((s >= -1e-9).sum()), grad, 0,
                              int((~solved).sum()))


@dataclass(frozen=True, eq=False)
class _Lengths:
    """Sag lengths of the thesis convention over a batch and their partials."""

    L0: FloatArray          # (N, m)
    straight: FloatArray    # (N, m)
    state: _Tensions
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
    state = _tensions(robot, poses, objective)
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
    grad = _through_tensions(s.state, g_sag * s.d_T)
    anchors = grad.anchors + d_v.sum(axis=0)
    attachments = grad.attachments - np.einsum("kac,kcj->aj", d_v, s.rotation)
    d = robot.cable.diameter if robot.cable is not None else 0.0
    d_EA = 0.0 if not np.isfinite(s.EA) else float((g_sag * s.d_EA).sum()) * 2.0 * s.EA / d
    diameter = float((g_sag * s.d_w).sum()) * 2.0 * s.w / d + d_EA
    return RobotGradient(anchors, attachments, diameter, grad.t_max)


class SagCorrection(_OverPoses):
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
            return _unheld(m, infeasible)
        value = float((s.L0 - s.straight).sum() / N)
        g = np.full((N, m), 1.0 / N)
        return CriterionValue(value, value, _length_gradient(s, robot, g, -g),
                              int((~s.state.ok).sum()))


class CableMass(_OverPoses):
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
        self.temperature = _positive(temperature, "temperature")

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        P = robot.as_poses(self.poses)
        s = _lengths(robot, P, self.objective)
        N, m = s.L0.shape
        infeasible = int((~s.state.optimal).sum())
        if infeasible:
            return _unheld(m, infeasible)
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


class CableStrength(Criterion):
    """The load of the most loaded winch's cable over its breaking load,
    ``safety * max_i t_max_i / breaking_load(d)``: bound it by 1 to size the cable for
    its winch (:func:`catenary.breaking_load`, the rope's strength on its nominal
    section).

    Parameters
    ----------
    safety : float
        The safety factor (default 3).
    material : str, optional
        The catalogue material; default: the design space's (set by the optimiser).
    """

    name = "cable strength use"
    unit = ""

    def __init__(self, safety: float = 3.0, material: str | None = None) -> None:
        self.safety = _positive(safety, "safety")
        self.material = material

    def with_material(self, material: str | None) -> Criterion:
        return self if material is None else CableStrength(self.safety, material)

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        if self.material is None or robot.cable is None:
            raise InvalidDesignError("CableStrength needs a catalogue material (material= "
                                     "here or on the DesignSpace) and a robot with a cable")
        d = robot.cable.diameter
        strength = float(breaking_load(self.material, d))
        if not np.isfinite(strength):
            raise InvalidDesignError(f"the catalogue knows no rope strength of "
                                     f"{self.material!r}: choose another material")
        t_max = np.broadcast_to(np.asarray(robot.t_max, dtype=float), (robot.m,))
        top = int(np.argmax(t_max))
        value = self.safety * float(t_max[top]) / strength
        d_t = np.zeros(robot.m)
        d_t[top] = self.safety / strength
        grad = RobotGradient(np.zeros((robot.m, 3)), np.zeros((robot.m, 3)),
                             -2.0 * value / d, d_t)
        return CriterionValue(value, value, grad)


class LowestFrequency(Criterion):
    """The lowest natural frequency (Hz) over poses (:func:`catenary.natural_frequencies`),
    made smooth by a soft minimum; differentiated numerically by the optimiser.

    Parameters
    ----------
    poses : array_like, shape (N, n)
    model : {"coupled", "straight"}
        The stiffness model (default ``"coupled"``).
    temperature : float
        Of the soft minimum (Hz), default 0.01.
    """

    name = "lowest frequency"
    unit = "Hz"
    numeric = True

    def __init__(self, poses: ArrayLike, model: str = "coupled",
                 temperature: float = 0.01) -> None:
        self.poses = _poses(poses, "poses")
        self.model = model
        self.temperature = _positive(temperature, "temperature")

    def evaluate(self, robot: CableRobot) -> CriterionValue:
        f = natural_frequencies(robot, robot.as_poses(self.poses), model=self.model)  # type: ignore[arg-type]
        lowest = f[:, 0]
        bad = ~np.isfinite(lowest)
        if bad.any():
            return CriterionValue(np.nan, np.nan, None, 0, int(bad.sum()))
        value, _ = soft_max(-lowest, self.temperature)
        return CriterionValue(-value, float(lowest.min()), None)
