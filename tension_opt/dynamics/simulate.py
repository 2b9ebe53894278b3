"""Forward simulation of the platform under given cable tensions (open loop).

The cables are straight and massless; each pulls the platform with its tension along
its unit vector. The equations of motion are the Newton-Euler equations of
:mod:`tension_opt.dynamics.wrench` solved for the accelerations::

    M(q) acc = A(q) T(t) - robot.required_wrench(q, wrench) - h(q, vel)

integrated with :func:`scipy.integrate.solve_ivp` over the state (pose coordinates,
velocity coordinates); a rotation vector moves with ``phi' = J(phi)^-1 omega``.
The tensions are interpolated in time between their samples, by default with a
shape-preserving cubic (PCHIP) that never leaves the range of two neighbouring
samples, so the simulated cables keep the bounds the samples keep.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline, PchipInterpolator, interp1d

from tension_opt.checks import as_finite, check_positive
from tension_opt.dynamics.rotation import pose_rates
from tension_opt.dynamics.timed import check_times
from tension_opt.dynamics.wrench import inertia_terms
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import typical_tension
from tension_opt.robot import CableRobot
from tension_opt.status import Status
from tension_opt.tolerances import FEASIBILITY_TOL

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
    tension_at : callable
        The tensions the simulation applied (N) at a time or an array of times (s),
        shape (m,) or (len(times), m), between ``times[0]`` and ``times[-1]``: the
        interpolant of the given tensions, with rounding below zero clipped to 0.
    """

    times: NDArray
    poses: NDArray
    velocities: NDArray
    status: str
    message: str
    evaluations: int
    rtol: float
    atol: float
    tension_at: Callable[[Any], NDArray]

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


_INTERPOLATIONS = ("pchip", "linear", "cubic")


def _tension_function(times: NDArray, tensions: NDArray, interpolation: str) -> Any:
    if interpolation not in _INTERPOLATIONS:
        raise InvalidInputError(
            f"interpolation must be one of {list(_INTERPOLATIONS)}, got {interpolation!r}")
    if interpolation == "pchip" and times.size >= 3:
        return PchipInterpolator(times, tensions, axis=0, extrapolate=False)
    if interpolation == "cubic" and times.size >= 3:
        return CubicSpline(times, tensions, axis=0, bc_type="not-a-knot")
    return interp1d(times, tensions, axis=0, assume_sorted=True)


def _check_inputs(robot: CableRobot, times: ArrayLike, tensions: ArrayLike,
                  initial_pose: ArrayLike, initial_velocity: ArrayLike
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    t = check_times("times", times)
    T = as_finite("tensions", tensions)
    if T.shape != (t.size, robot.m):
        raise InvalidInputError(
            f"tensions must have shape ({t.size}, {robot.m}), one row per time, got {T.shape}")
    q0 = robot.as_poses(initial_pose)
    if q0.shape[0] != 1:
        raise InvalidInputError(f"initial_pose must be one pose ({robot.dof},), got "
                                f"{np.shape(initial_pose)}")
    v0 = as_finite("initial_velocity", initial_velocity)
    if v0.shape != (robot.dof,):
        raise InvalidInputError(
            f"initial_velocity must have shape ({robot.dof},), got {v0.shape}")
    return t, T, q0[0], v0


def _check_body(robot: CableRobot, pose: NDArray, wrench: ArrayLike | None) -> NDArray | None:
    """The external wrench checked (None without one); a singular mass matrix refused."""
    mass, _ = inertia_terms(robot, pose)
    if np.linalg.matrix_rank(mass[0]) < robot.dof:
        raise InvalidInputError(
            "the platform's mass matrix is singular: give the robot a positive definite "
            "inertia (CableRobot(inertia=...)) to simulate its rotation")
    ext = None if wrench is None else as_finite("wrench", wrench)
    if ext is not None and ext.shape != (robot.dof,):
        raise InvalidInputError(f"wrench must have shape ({robot.dof},), got {ext.shape}")
    return ext


def _pulling(robot: CableRobot, tensions: NDArray, pose: NDArray,
             wrench: NDArray | None) -> NDArray:
    """The tensions with rounding below zero clipped to 0; a real push refused.

    A tension is rounding when it is above ``-FEASIBILITY_TOL`` times its sample's
    tension scale, the tolerance of a solution's certificate on its bounds: the larger
    of the sample's largest tension and the typical tension of the initial pose (the
    tension that holds its static wrench, or the largest lower bound,
    :func:`tension_opt.problem.form.typical_tension`)."""
    if not (tensions < 0).any():
        return tensions
    A = robot.structure_matrices(pose[None])
    lb = np.broadcast_to(robot.t_min, (1, robot.m))
    static = typical_tension(A, robot.required_wrench(pose[None], wrench), lb)
    scale = np.maximum(np.abs(tensions).max(axis=1), static[0])
    tol = FEASIBILITY_TOL * scale[:, None]
    pushes = tensions < -tol
    if pushes.any():
        k, i = (int(v) for v in np.argwhere(pushes)[0])
        raise InvalidInputError(
            f"tensions[{k}, {i}] = {float(tensions[k, i])!r} is negative beyond rounding "
            f"(-{float(tol[k, 0]):.3g} N, {FEASIBILITY_TOL:g} of the sample's tension "
            f"scale): cables can only pull")
    return np.maximum(tensions, 0.0)


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
    interpolation: Literal["pchip", "linear", "cubic"] = "pchip",
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
        Cable tensions (N) at ``times``, >= 0. A tension below zero by less than
        ``FEASIBILITY_TOL`` (1e-6) of its sample's tension scale (the larger of the
        sample's largest tension and the initial pose's typical tension) is rounding,
        as a solution's certificate allows it, and is taken as 0.
    initial_pose : array_like, shape (n,)
        Pose at ``times[0]`` (m, rad).
    initial_velocity : array_like, shape (n,)
        Velocity coordinates at ``times[0]`` (m/s, rad/s; base-frame angular velocity
        for ``spatial6``).
    wrench : array_like, shape (n,), optional
        Constant external wrench besides gravity (N, N m).
    interpolation : {"pchip", "linear", "cubic"}
        Tensions between the samples. ``"pchip"`` (default): scipy's
        :class:`~scipy.interpolate.PchipInterpolator`, a shape-preserving piecewise
        cubic with continuous first derivative; it is monotone between two samples and
        never leaves their range, so tensions that keep their bounds at the samples
        keep them in between (no cable pushes). ``"linear"`` keeps them too.
        ``"cubic"``: a not-a-knot cubic spline (twice differentiable), which overshoots
        where the tensions turn sharply: between samples it can leave the bounds and
        make a cable push (by 870 N on the study robot's min_sum crossing). PCHIP's
        second derivative jumps at the samples, so the 8th-order integrator takes
        about ten times the steps it takes on the spline.
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
        On non-increasing or non-finite times, tensions of the wrong shape, tensions
        negative beyond rounding or non-finite, bad initial state, an unknown
        interpolation or a singular mass matrix.
    """
    t, T, q0, v0 = _check_inputs(robot, times, tensions, initial_pose, initial_velocity)
    check_positive("rtol", rtol)
    check_positive("atol", atol)
    ext = _check_body(robot, q0, wrench)
    T = _pulling(robot, T, q0, ext)
    tension_at = _tension_function(t, T, interpolation)
    rhs = _EquationsOfMotion(robot, tension_at, ext)
    sol = solve_ivp(rhs.derivative, (t[0], t[-1]), np.concatenate([q0, v0]), method=method,
                    t_eval=t, rtol=rtol, atol=atol)
    n = robot.dof
    states = np.full((t.size, 2 * n), np.nan)
    states[: sol.y.shape[1]] = sol.y.T
    status = Status.CONVERGED if sol.status == 0 else Status.NOT_CONVERGED
    return SimulationResult(t, states[:, :n], states[:, n:], str(status), str(sol.message),
                            int(sol.nfev), float(rtol), float(atol), tension_at)
