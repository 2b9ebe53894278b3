"""Timed trajectories and the distribution of their dynamic tensions.

A :class:`TimedTrajectory` is poses sampled in time with their velocities and
accelerations in the velocity coordinates of :mod:`tension_opt.dynamics.wrench`
(for ``spatial6`` the base-frame angular velocity and acceleration, computed from the
rotation vector's derivatives). Build one from waypoints and durations
(:meth:`TimedTrajectory.from_waypoints`: scipy splines or rest-to-rest quintic
segments) or from poses and their times (:meth:`TimedTrajectory.from_path`);
:func:`distribute_trajectory` distributes the tensions that move the platform along it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import make_interp_spline

from tension_opt.checks import as_finite, check_positive
from tension_opt.distribution.entry import distribute
from tension_opt.distribution.solution import TensionSolution
from tension_opt.dynamics.rotation import twist_rates
from tension_opt.dynamics.trajectory import smooth_jointly
from tension_opt.dynamics.wrench import inertia_wrench, required_wrench
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import Objective, TensionProblem, as_problem
from tension_opt.robot import CableRobot

__all__ = ["MAX_SAMPLES", "TimedTrajectory", "check_times", "distribute_trajectory"]

#: Most samples of a trajectory made with a step ``dt`` (each holds a pose, its velocity
#: and acceleration, and later its tensions).
MAX_SAMPLES = 10_000_000

Method = Literal["quintic", "cubic", "rest"]


def _end_conditions(degree: int, n: int) -> tuple[list[tuple[int, NDArray]], ...]:
    """Spline end conditions: zero velocity and acceleration at both ends for the
    quintic, zero velocity for the cubic (a cubic cannot also fix the acceleration)."""
    orders = (1, 2) if degree == 5 else (1,)
    ends = [(k, np.zeros(n)) for k in orders]
    return ends, list(ends)


def check_times(name: str, times: ArrayLike, minimum: int = 2) -> NDArray:
    """``times`` as a finite, strictly increasing (N,) array of at least ``minimum``."""
    t = as_finite(name, times)
    if t.ndim != 1 or t.size < minimum:
        raise InvalidInputError(
            f"{name} must be a 1-D array of at least {minimum} times (s), got shape {t.shape}")
    if (np.diff(t) <= 0).any():
        k = int(np.argmax(np.diff(t) <= 0))
        raise InvalidInputError(
            f"{name} must be strictly increasing: {name}[{k + 1}] = {t[k + 1]!r} does not "
            f"follow {name}[{k}] = {t[k]!r}")
    return t


@dataclass(frozen=True, eq=False)
class TimedTrajectory:
    """Poses of one robot kind sampled in time, with velocities and accelerations.

    Attributes
    ----------
    times : ndarray, shape (N,)
        Strictly increasing sample times (s).
    poses : ndarray, shape (N, n)
        Poses (m, rad).
    velocities, accelerations : ndarray, shape (N, n)
        Velocity coordinates and their derivatives (m/s, rad/s; m/s^2, rad/s^2), see
        :mod:`tension_opt.dynamics.wrench`.
    kind : str
        The robot kind of the poses.
    """

    times: NDArray
    poses: NDArray
    velocities: NDArray
    accelerations: NDArray
    kind: str

    def __post_init__(self) -> None:
        t = check_times("times", self.times, minimum=1)
        arrays = {}
        for name in ("poses", "velocities", "accelerations"):
            arr = as_finite(name, getattr(self, name))
            if arr.ndim != 2 or arr.shape[0] != t.size:
                raise InvalidInputError(
                    f"{name} must have shape ({t.size}, n), one row per time, got {arr.shape}")
            arrays[name] = arr
        shapes = {a.shape for a in arrays.values()}
        if len(shapes) != 1:
            raise InvalidInputError(f"poses, velocities and accelerations differ in shape: "
                                    f"{sorted(shapes)}")
        # Not made read-only: scipy's rotation routines reject read-only buffers.
        for name, arr in (("times", t), *arrays.items()):
            object.__setattr__(self, name, arr)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.times[-1] - self.times[0])

    @property
    def N(self) -> int:
        """Number of samples."""
        return int(self.times.size)

    def check_robot(self, robot: CableRobot) -> None:
        """Raise unless the trajectory's poses are of ``robot``'s kind."""
        if robot.kind != self.kind or robot.dof != self.poses.shape[1]:
            raise InvalidInputError(
                f"the trajectory has {self.kind} poses; the robot is {robot.kind}")

    def required_wrench(self, robot: CableRobot) -> NDArray:
        """The wrench the cables must supply at every sample, (N, n) (N, N m)."""
        self.check_robot(robot)
        return required_wrench(robot, self.poses, self.velocities, self.accelerations)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per sample: time, pose, velocity and acceleration."""
        n = self.poses.shape[1]
        frame = pd.DataFrame({"time": self.times})
        for label, arr in (("q", self.poses), ("v", self.velocities),
                           ("a", self.accelerations)):
            for i in range(n):
                frame[f"{label}{i}"] = arr[:, i]
        return frame

    # ---------------------------------------------------------------- builders
    @classmethod
    def from_functions(cls, robot: CableRobot, times: ArrayLike,
                       evaluate: Callable[[NDArray, int], NDArray]) -> TimedTrajectory:
        """Sample pose functions of time: ``evaluate(t, k)`` is the k-th time
        derivative (k = 0, 1, 2) of the pose coordinates at times ``t``, shape (N, n).

        Rotation-vector derivatives become angular velocities and accelerations.
        """
        t = check_times("times", times, minimum=1)
        q = robot.as_poses(evaluate(t, 0))
        v, a = twist_rates(robot.pattern, q, as_finite("velocities", evaluate(t, 1)),
                           as_finite("accelerations", evaluate(t, 2)))
        return cls(t, q, v, a, robot.kind)

    @classmethod
    def from_waypoints(cls, robot: CableRobot, waypoints: ArrayLike, durations: ArrayLike,
                       *, method: Method = "quintic", dt: float = 0.01,
                       times: ArrayLike | None = None) -> TimedTrajectory:
        """A trajectory through waypoints, starting and ending at rest.

        Parameters
        ----------
        robot : CableRobot
        waypoints : array_like, shape (K, n)
            Poses to pass through (m, rad), K >= 2; rotation vectors are interpolated
            as coordinates.
        durations : array_like, shape (K - 1,)
            Time of each segment (s), positive.
        method : {"quintic", "cubic", "rest"}
            ``"quintic"``: one C4 quintic spline through every waypoint with zero
            velocity and acceleration at both ends. ``"cubic"``: one C2 cubic spline
            with zero velocity at both ends. ``"rest"``: straight segments in pose
            coordinates, each a rest-to-rest quintic ``10 s^3 - 15 s^4 + 6 s^5`` (zero
            velocity and acceleration at every waypoint).
        dt : float
            Sampling step (s); the samples are evenly spaced from 0 to the total time.
        times : array_like, optional
            Sample times (s) instead of the even grid, within ``[0, sum(durations)]``.
        """
        w = robot.as_poses(waypoints)
        if w.shape[0] < 2:
            raise InvalidInputError(f"waypoints must hold at least 2 poses, got {w.shape[0]}")
        d = as_finite("durations", durations)
        if d.shape != (w.shape[0] - 1,) or (d <= 0).any():
            raise InvalidInputError(
                f"durations must be {w.shape[0] - 1} positive times (s), one per segment, "
                f"got {d.tolist() if d.size < 20 else d.shape}")
        knots = np.concatenate([[0.0], np.cumsum(d)])
        t = _sample_times(knots[-1], dt, times)
        if method == "rest":
            return cls.from_functions(robot, t, _rest_to_rest(knots, w))
        degree = {"quintic": 5, "cubic": 3}.get(method)
        if degree is None:
            raise InvalidInputError(f'method must be "quintic", "cubic" or "rest", got {method!r}')
        spline = make_interp_spline(knots, w, k=degree, bc_type=_end_conditions(degree, w.shape[1]))
        return cls.from_functions(robot, t, lambda s, k: spline(s, k))

    @classmethod
    def from_path(cls, robot: CableRobot, poses: ArrayLike, times: ArrayLike, *,
                  method: Literal["quintic", "cubic"] = "quintic") -> TimedTrajectory:
        """A trajectory through ``poses`` reached at ``times`` (a path and its timing),
        sampled at those times; at rest at both ends (see :meth:`from_waypoints`)."""
        t = check_times("times", times)
        return cls.from_waypoints(robot, poses, np.diff(t), method=method, times=t - t[0])


def _sample_times(total: float, dt: float, times: ArrayLike | None) -> NDArray:
    if times is not None:
        t = check_times("times", times, minimum=1)
        if t[0] < 0 or t[-1] > total * (1 + 1e-12):
            raise InvalidInputError(f"times must lie within [0, {total}] s")
        return t
    check_positive("dt", dt)
    steps = total / dt
    if not steps <= MAX_SAMPLES - 1:  # also a duration so long that it overflows
        raise InvalidInputError(
            f"dt = {dt:g} s over {total:g} s gives more than {MAX_SAMPLES:.0e} samples: "
            "give a larger dt (or the times to sample)")
    count = int(np.ceil(steps - 1e-9)) + 1
    return np.linspace(0.0, total, max(count, 2))


def _rest_to_rest(knots: NDArray, waypoints: NDArray) -> Callable[[NDArray, int], NDArray]:
    """Pose derivatives of straight rest-to-rest quintic segments between waypoints."""
    def evaluate(t: NDArray, k: int) -> NDArray:
        seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
        d = knots[seg + 1] - knots[seg]
        s = np.clip((t - knots[seg]) / d, 0.0, 1.0)
        blend = (s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2 / d,
                 60 * s * (1 - s) * (1 - 2 * s) / d**2)[k]
        step = waypoints[seg + 1] - waypoints[seg]
        return (waypoints[seg] if k == 0 else 0.0) + blend[:, None] * step
    return evaluate


def distribute_trajectory(
    robot: CableRobot,
    trajectory: TimedTrajectory,
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str = "auto",
    *,
    mode: Literal["pointwise", "penalty", "rate_limit", "joint"] = "pointwise",
    smoothing: float = 1e-3,
    rate_limit: float | ArrayLike | None = None,
    wrench: ArrayLike | None = None,
    previous: ArrayLike | None = None,
    **options: Any,
) -> TensionSolution:
    """Distribute the dynamic tensions along a timed trajectory.

    The cables must supply :func:`~tension_opt.dynamics.required_wrench` at every
    sample; the d'Alembert wrench (:func:`~tension_opt.dynamics.wrench.inertia_wrench`)
    goes to :func:`tension_opt.distribute` (or
    :func:`tension_opt.dynamics.trajectory.smooth_jointly`) as the external wrench, so every
    objective, backend and smoothing option of those applies. At rest the tensions are
    the static ones, exactly.

    Parameters
    ----------
    robot : CableRobot
    trajectory : TimedTrajectory
    objective : str or TensionProblem
        As in :func:`tension_opt.distribute`; a problem's own smoothing or rate limit
        is kept (the samples are solved in order).
    backend : str
        As in :func:`tension_opt.distribute`; for ``mode="joint"`` a sparse QP backend
        (``"auto"``: ``"qpsolvers:clarabel"``).
    mode : {"pointwise", "penalty", "rate_limit", "joint"}
        As in :func:`tension_opt.dynamics.trajectory.solve_trajectory`: each sample alone (or
        as ``objective`` says), ``smoothing * ||T - T_prev||^2``, ``|T - T_prev| <=
        rate_limit`` (N), or one QP over the whole trajectory with weight ``smoothing``.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench besides gravity and inertia (N, N m).
    previous : array_like, shape (m,) or (N, m), optional
        As in :func:`tension_opt.distribute`.
    **options
        Passed to the backend.

    Returns
    -------
    TensionSolution
        Tensions (N, m) and per-sample status.
    """
    if not isinstance(trajectory, TimedTrajectory):
        raise InvalidInputError(
            f"trajectory must be a TimedTrajectory, got {type(trajectory).__name__}")
    trajectory.check_robot(robot)
    p = trajectory.poses
    ext = inertia_wrench(robot, p, trajectory.velocities, trajectory.accelerations)
    if wrench is not None:
        ext = ext + np.broadcast_to(as_finite("wrench", wrench), ext.shape)
    problem = as_problem(objective)
    if mode == "joint":
        return smooth_jointly(robot, p, problem, weight=smoothing,
                              backend="qpsolvers:clarabel" if backend == "auto" else backend,
                              wrench=ext, **options)
    if mode == "penalty":
        problem = problem.with_(smoothing=smoothing)
    elif mode == "rate_limit":
        if rate_limit is None:
            raise InvalidInputError("mode 'rate_limit' needs rate_limit (N)")
        problem = problem.with_(rate_limit=rate_limit)
    elif mode != "pointwise":
        raise InvalidInputError(
            f"unknown mode {mode!r}; choose pointwise, penalty, rate_limit or joint")
    return distribute(robot, p, problem, backend, wrench=ext, previous=previous, **options)
