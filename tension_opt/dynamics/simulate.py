"""Forward simulation of the platform under given cable tensions (open loop).

The cables are straight and massless; each pulls the platform with its tension along
its unit vector. The equations of motion are the Newton-Euler equations of
:mod:`tension_opt.dynamics.wrench` solved for the accelerations::

    M(q) acc = A(q) T(t) - robot.required_wrench(q, wrench) - h(q, vel)

integrated with :func:`scipy.integrate.solve_ivp` over the state (pose coordinates,
velocity coordinates); a rotation vector moves with ``phi' = J(phi)^-1 omega``.
The tensions are interpolated in time between their samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline, interp1d

from tension_opt.checks import as_finite, check_positive
from tension_opt.dynamics.rotation import pose_rates
from tension_opt.dynamics.timed import check_times
from tension_opt.dynamics.wrench import inertia_terms
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.status import Status

__all__ = ["SimulationResult", "simulate"]


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The motion of the platform under the given tensions.

    Attributes
    ----------
    times : ndarray, shape (N,)
        The requested times (s).
    poses : ndarray, shape (N, n)
        Poses at ``times`` (m, rad); NaN after a failure.
    velocities : ndarray, shape (N, n)
        Velocity coordinates at ``times`` (m/s, rad/s).
    status : str
        ``Status.CONVERGED`` when the integrator reached the last time, else
        ``Status.NOT_CONVERGED`` (``message`` says why).
    message : str
        The integrator's message.
    evaluations : int
        Right-hand side evaluations.
    rtol, atol : float
        The integrator's relative and absolute tolerances (state units: m, rad, m/s,
        rad/s).
    """

    times: NDArray
    poses: NDArray
    velocities: NDArray
    status: str
    message: str
    evaluations: int
    rtol: float
    atol: float

    @property
    def success(self) -> bool:
        """Whether the integration reached the last time."""
        return self.status == Status.CONVERGED

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per time: pose and velocity coordinates."""
        frame = pd.DataFrame({"time": self.times})
        for label, arr in (("q", self.poses), ("v", self.velocities)):
            for i in range(arr.shape[1]):
                frame[f"{label}{i}"] = arr[:, i]
        return frame


def _tension_function(times: NDArray, tensions: NDArray, interpolation: str) -> Any:
    if interpolation == "cubic" and times.size >= 3:
        return CubicSpline(times, tensions, axis=0, bc_type="not-a-knot")
    if interpolation in ("linear", "cubic"):
        return interp1d(times, tensions, axis=0, assume_sorted=True)
    raise InvalidInputError(f'interpolation must be "cubic" or "linear", got {interpolation!r}')


def _check_inputs(robot: CableRobot, times: ArrayLike, tensions: ArrayLike,
                  initial_pose: ArrayLike, initial_velocity: ArrayLike
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    t = check_times("times", times)
    T = as_finite("tensions", tensions)
    if T.shape != (t.size, robot.m):
        raise InvalidInputError(
            f"tensions must have shape ({t.size}, {robot.m}), one row per time, got {T.shape}")
    if (T < 0).any():
        k, i = (int(v) for v in np.argwhere(T < 0)[0])
        raise InvalidInputError(
            f"tensions[{k}, {i}] = {T[k, i]!r} is negative: cables can only pull")
    q0 = robot.as_poses(initial_pose)
    if q0.shape[0] != 1:
        raise InvalidInputError(f"initial_pose must be one pose ({robot.dof},), got "
                                f"{np.shape(initial_pose)}")
    v0 = as_finite("initial_velocity", initial_velocity)
    if v0.shape != (robot.dof,):
        raise InvalidInputError(
            f"initial_velocity must have shape ({robot.dof},), got {v0.shape}")
    return t, T, q0[0], v0


class _EquationsOfMotion:
    """The state derivative ``(q', acc)`` of a state ``(q, vel)`` at a time."""

    def __init__(self, robot: CableRobot, tension_at: Any, wrench: NDArray | None) -> None:
        self.robot, self.tension_at, self.wrench = robot, tension_at, wrench
        self.n = robot.dof
        # A platform that does not turn has a constant mass matrix and no velocity terms.
        self.constant = None
        if not robot.pattern.rotates:
            mass, _ = inertia_terms(robot, robot.default_home())
            self.constant = np.linalg.inv(mass[0])

    def derivative(self, time: float, state: NDArray) -> NDArray:
        robot, n = self.robot, self.n
        q, v = state[None, :n], state[None, n:]
        A = robot.structure_from(robot.cable_geometry(q, check=False))[0]
        force = A @ self.tension_at(time) - robot.required_wrench(q, self.wrench)[0]
        if self.constant is not None:
            return np.concatenate([v[0], self.constant @ force])
        mass, bias = inertia_terms(robot, q, v)
        acc = np.linalg.solve(mass[0], force - bias[0])
        return np.concatenate([pose_rates(robot.pattern, q, v)[0], acc])


def simulate(
    robot: CableRobot,
    times: ArrayLike,
    tensions: ArrayLike,
    initial_pose: ArrayLike,
    initial_velocity: ArrayLike,
    *,
    wrench: ArrayLike | None = None,
    interpolation: Literal["cubic", "linear"] = "cubic",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    method: str = "DOP853",
) -> SimulationResult:
    """Integrate the platform's motion under tensions given in time.

    Parameters
    ----------
    robot : CableRobot
        Its inertia must be positive definite for a rotating kind.
    times : array_like, shape (N,)
        Strictly increasing times (s) of the tension samples; the poses are reported
        at these times, from ``times[0]``.
    tensions : array_like, shape (N, m)
        Cable tensions (N) at ``times``, >= 0.
    initial_pose : array_like, shape (n,)
        Pose at ``times[0]`` (m, rad).
    initial_velocity : array_like, shape (n,)
        Velocity coordinates at ``times[0]`` (m/s, rad/s; base-frame angular velocity
        for ``spatial6``).
    wrench : array_like, shape (n,), optional
        Constant external wrench besides gravity (N, N m).
    interpolation : {"cubic", "linear"}
        Tensions between the samples: a not-a-knot cubic spline (smooth, for the
        integrator) or linear.
    rtol, atol : float
        Integrator tolerances (default 1e-10 relative, 1e-12 absolute in m, rad, m/s).
    method : str
        A :func:`scipy.integrate.solve_ivp` method (default ``"DOP853"``, 8th order).

    Returns
    -------
    SimulationResult
        ``poses`` (N, n) and ``velocities`` (N, n) at ``times``.

    Raises
    ------
    InvalidInputError
        On non-increasing or non-finite times, tensions of the wrong shape, negative
        or non-finite tensions, bad initial state or a singular mass matrix.
    """
    t, T, q0, v0 = _check_inputs(robot, times, tensions, initial_pose, initial_velocity)
    check_positive("rtol", rtol)
    check_positive("atol", atol)
    mass, _ = inertia_terms(robot, q0)
    if np.linalg.matrix_rank(mass[0]) < robot.dof:
        raise InvalidInputError(
            "the platform's mass matrix is singular: give the robot a positive definite "
            "inertia (CableRobot(inertia=...)) to simulate its rotation")
    ext = None if wrench is None else as_finite("wrench", wrench)
    if ext is not None and ext.shape != (robot.dof,):
        raise InvalidInputError(f"wrench must have shape ({robot.dof},), got {ext.shape}")
    rhs = _EquationsOfMotion(robot, _tension_function(t, T, interpolation), ext)
    sol = solve_ivp(rhs.derivative, (t[0], t[-1]), np.concatenate([q0, v0]), method=method,
                    t_eval=t, rtol=rtol, atol=atol)
    n = robot.dof
    states = np.full((t.size, 2 * n), np.nan)
    states[: sol.y.shape[1]] = sol.y.T
    status = Status.CONVERGED if sol.status == 0 else Status.NOT_CONVERGED
    return SimulationResult(t, states[:, :n], states[:, n:], str(status), str(sol.message),
                            int(sol.nfev), float(rtol), float(atol))
