"""The wrench the cables must supply to move the platform: Newton-Euler.

Velocity coordinates
--------------------
A robot's *velocities* and *accelerations* (N, n) have one entry per pose coordinate:
the linear velocity (m/s) along each position coordinate's base axis, and the angular
velocity (rad/s) about the base axes for the angles: ``omega_z = theta'`` for
``planar3``, the base-frame angular velocity ``omega`` for ``spatial6`` (not the
derivative of its rotation vector; :func:`tension_opt.dynamics.rotation.twist_rates`
converts, and ``rates="pose"`` does it here). Accelerations are their time
derivatives.

Newton-Euler
------------
With the centre of mass at ``r = R c`` from the reference point (``c = robot.com``),
``I_w = R I R^T`` the inertia about the centre of mass (``I = robot.inertia``) and
gravity ``g = (0, 0, -robot.g)``::

    f = m (a_c - g),          a_c = a + alpha x r + omega x (omega x r)
    M = I_w alpha + omega x (I_w omega) + r x f

is the wrench ``(f, M)`` the cables must apply, moments about the reference point,
restricted to the kind's rows: the right-hand side of ``A T = w``, in the convention
of :meth:`tension_opt.CableRobot.required_wrench`, which it equals at rest. It is
affine in the accelerations: ``w = w_static + M(q) acc + h(q, vel)``
(:func:`inertia_terms`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_finite
from tension_opt.dynamics.rotation import twist_rates
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot

__all__ = ["cross", "inertia_terms", "inertia_wrench", "motion_arrays", "required_wrench"]

Rates = Literal["twist", "pose"]


def motion_arrays(robot: CableRobot, poses: ArrayLike, velocities: ArrayLike,
                  accelerations: ArrayLike | None = None, rates: Rates = "twist"
                  ) -> tuple[NDArray, NDArray, NDArray]:
    """Validated poses, velocities and accelerations, each (N, n), in velocity
    coordinates (converted from pose-coordinate derivatives when ``rates="pose"``).

    Velocities and accelerations of shape (n,) apply to every pose; ``accelerations``
    None means zero.

    Raises
    ------
    InvalidInputError
        Naming the argument whose shape or values are wrong, or an unknown ``rates``.
    """
    if rates not in ("twist", "pose"):
        raise InvalidInputError(f'rates must be "twist" or "pose", got {rates!r}')
    p = robot.as_poses(poses)
    out = []
    for name, value in (("velocities", velocities), ("accelerations", accelerations)):
        if value is None:
            out.append(np.zeros_like(p))
            continue
        arr = as_finite(name, value)
        if arr.shape not in ((robot.dof,), p.shape):
            raise InvalidInputError(
                f"{name} must have shape {p.shape} like the poses (or ({robot.dof},)), "
                f"got {arr.shape}")
        out.append(np.array(np.broadcast_to(arr, p.shape)))
    v, a = out
    if rates == "pose":
        v, a = twist_rates(robot.pattern, p, v, a)
    return p, v, a


def inertia_terms(robot: CableRobot, poses: ArrayLike, velocities: ArrayLike | None = None
                  ) -> tuple[NDArray, NDArray]:
    """Mass matrix and velocity terms of the platform's Newton-Euler equations.

    ``required_wrench = robot.required_wrench(poses) + mass @ accelerations + bias``.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n) or (n,)
    velocities : array_like, shape (N, n) or (n,), optional
        Velocity coordinates (module docstring); default zero.

    Returns
    -------
    mass : ndarray, shape (N, n, n)
        ``d w / d acc`` (kg, kg m, kg m^2).
    bias : ndarray, shape (N, n)
        Centripetal and gyroscopic wrench (N, N m), quadratic in the velocities.
    """
    p, v, _ = motion_arrays(robot, poses, np.zeros(robot.dof) if velocities is None
                            else velocities)
    return _newton_euler(robot, p, v)


def _newton_euler(robot: CableRobot, p: NDArray, v: NDArray) -> tuple[NDArray, NDArray]:
    """:func:`inertia_terms` of validated poses and velocities (N, n)."""
    pattern, m = robot.pattern, robot.mass
    St, Sr = pattern.step_maps()  # (3, n): velocity coordinates -> (linear, angular)
    rows = list(pattern.wrench_rows)
    if not Sr.any() and max(rows) < 3:  # a point mass that cannot turn: m a, no bias
        mass = np.broadcast_to(m * St[rows], (len(p), len(rows), St.shape[1])).copy()
        return mass, np.zeros((len(p), len(rows)))
    _, R = pattern.frames(p)
    r = np.einsum("nij,j->ni", R, robot.com)
    I_w = (R @ np.asarray(robot.inertia)) @ np.swapaxes(R, 1, 2)  # einsum: twice the time
    rx = np.zeros((len(p), 3, 3))
    rx[:, 0, 1], rx[:, 0, 2], rx[:, 1, 2] = -r[:, 2], r[:, 1], -r[:, 0]
    rx -= np.swapaxes(rx, 1, 2)
    force = m * St[None] - m * rx @ Sr  # (N, 3, n): f of a unit acceleration
    moment = I_w @ Sr + rx @ force
    mass = np.concatenate([force, moment], axis=1)[:, rows, :]
    omega = v @ Sr.T
    f_bias = m * cross(omega, cross(omega, r))
    m_bias = cross(omega, np.einsum("nij,nj->ni", I_w, omega)) + cross(r, f_bias)
    bias = np.concatenate([f_bias, m_bias], axis=1)[:, rows]
    return mass, bias


def cross(a: NDArray, b: NDArray) -> NDArray:
    """Row-wise cross product of (N, 3) arrays (``np.cross`` without its axis handling,
    which dominates for the small batches of a simulation step)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def inertia_wrench(robot: CableRobot, poses: ArrayLike, velocities: ArrayLike,
                   accelerations: ArrayLike, *, rates: Rates = "twist") -> NDArray:
    """The d'Alembert wrench ``-(mass @ acc + bias)`` (N, N m), shape (N, n).

    As the ``wrench=`` (external wrench besides gravity) of
    :func:`tension_opt.distribute` it makes the equilibrium ``A T = b`` the equation
    of motion: ``b`` is then exactly :func:`required_wrench`.
    """
    p, v, a = motion_arrays(robot, poses, velocities, accelerations, rates)
    mass, bias = _newton_euler(robot, p, v)
    return -(np.einsum("nij,nj->ni", mass, a) + bias)


def required_wrench(robot: CableRobot, poses: ArrayLike, velocities: ArrayLike,
                    accelerations: ArrayLike, *, rates: Rates = "twist",
                    wrench: ArrayLike | None = None) -> NDArray:
    """The wrench the cables must supply (gravity and inertia), shape (N, n).

    Parameters
    ----------
    robot : CableRobot
        Mass, centre of mass ``com`` and inertia ``inertia`` (about the centre of mass,
        platform frame) of the platform.
    poses : array_like, shape (N, n) or (n,)
    velocities, accelerations : array_like, shape (N, n) or (n,)
        Velocity coordinates and their derivatives (m/s, rad/s; m/s^2, rad/s^2): for
        ``spatial6`` the base-frame angular velocity and acceleration (module
        docstring), or with ``rates="pose"`` the pose coordinates' derivatives.
    rates : {"twist", "pose"}
        What ``velocities`` and ``accelerations`` are.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).

    Returns
    -------
    ndarray, shape (N, n)
        ``w`` of ``A T = w`` (N, N m), moments about the reference point; equal to
        ``robot.required_wrench(poses, wrench)`` at zero velocity and acceleration.
    """
    p, v, a = motion_arrays(robot, poses, velocities, accelerations, rates)
    mass, bias = _newton_euler(robot, p, v)
    return robot.required_wrench(p, wrench) + (np.einsum("nij,nj->ni", mass, a) + bias)
