"""The cables' weight to first order: half at the platform, half at the winch.

A taut cable of weight ``w`` per length hanging along a chord of length ``L`` and
height ``dz`` (from its attachment up to its drawing point) is, to first order in its
sag, a parabola: its end forces are the chord's tension ``T`` plus ``w L / 2`` down at
each end, so that

- the platform carries ``w L / 2`` of each cable's weight beside its load (an external
  wrench ``f_i = -(w L_i / 2) e_z`` at the attachment, with its moment);
- the tension is ``T + w dz / 2`` at the drawing point (the highest) and ``T - w dz / 2``
  at the attachment (exactly ``w dz`` apart, as on any inextensible catenary).

:class:`HalfWeight` gives these terms for a batch of poses and the gradients of
weighted sums of them by the robot's design numbers. Against the coupled catenary
model (:func:`catenary.inverse_kinematics`, ``model="coupled"``) the drawing-point
tensions of this model agree to 1 % for the reference study's 20 mm steel cables and to
0.2 % for 10 mm ones (tests).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tension_opt import CableRobot

from ..geometry import cable_data
from .space import RobotGradient

__all__ = ["HalfWeight"]

FloatArray = NDArray[np.float64]


def _cross_z(v: FloatArray) -> FloatArray:
    """``e_z x v`` for vectors ``v`` (..., 3)."""
    out = np.zeros_like(v)
    out[..., 0] = -v[..., 1]
    out[..., 1] = v[..., 0]
    return out


class HalfWeight:
    """The half-weight model of a robot's cables over poses (module notes).

    Attributes
    ----------
    wrench : ndarray, shape (N, n)
        The external wrench of the cables' halves at the platform (N, N m), in the
        robot's wrench rows (``A T = -(w_g + wrench)``).
    half_height : ndarray, shape (N, m)
        ``w dz / 2`` (N): the drawing point's tension above the chord's.
    """

    def __init__(self, robot: CableRobot, poses: FloatArray) -> None:
        w, _ = cable_data(robot)
        geometry = robot.cable_geometry(poses, check=False)
        _, rotation = robot.frames(poses)
        self.w = w
        self.m = robot.m
        self.diameter = robot.cable.diameter if robot.cable is not None else 1.0
        self.rows = list(robot.wrench_rows)
        self.rotation = np.asarray(rotation)                        # (N, 3, 3)
        self.unit = geometry.vectors / geometry.lengths[..., None]  # (N, m, 3)
        self.arms = np.einsum("kij,aj->kai", self.rotation, robot.attachments)
        self.half = 0.5 * w * geometry.lengths                      # (N, m) newtons
        self.half_height = 0.5 * w * geometry.vectors[..., 2]
        full = np.zeros((len(poses), 6))
        full[:, 2] = -self.half.sum(axis=1)
        # Moment of -c e_z at the arm r: r x (-c e_z) = c (e_z x r).
        full[:, 3:] = np.einsum("ka,kai->ki", self.half, _cross_z(self.arms))
        self.wrench = full[:, self.rows]

    def wrench_gradient(self, g: FloatArray) -> RobotGradient:
        """Gradient of ``sum(g * wrench)`` (g (N, n))."""
        full = np.zeros((len(g), 6))
        full[:, self.rows] = g
        g_f, g_m = full[:, 2], full[:, 3:]
        # sum = sum_ki c_ki q_ki with q = -g_fz + (e_z x r) . g_m = -g_fz + r . (g_m x e_z).
        g_m_x_z = -_cross_z(g_m)                                  # g_m x e_z
        q = -g_f[:, None] + np.einsum("kai,ki->ka", self.arms, g_m_x_z)
        dc = 0.5 * self.w                                         # dc/dL
        anchors = dc * np.einsum("ka,kai->ai", q, self.unit)      # dL/dD = u
        # dL/da = -R'u; dr/da = R.
        attachments = (-dc * np.einsum("ka,kji,kaj->ai", q, self.rotation, self.unit)
                       + np.einsum("ka,kji,kj->ai", self.half, self.rotation, g_m_x_z))
        diameter = 2.0 / self.diameter * float((q * self.half).sum())
        return RobotGradient(anchors, attachments, diameter, np.zeros(self.m))

    def height_gradient(self, g: FloatArray) -> RobotGradient:
        """Gradient of ``sum(g * half_height)`` (g (N, m))."""
        anchors = np.zeros((self.m, 3))
        anchors[:, 2] = 0.5 * self.w * g.sum(axis=0)
        attachments = -0.5 * self.w * np.einsum("ka,kj->aj", g, self.rotation[:, 2, :])
        diameter = 2.0 / self.diameter * float((g * self.half_height).sum())
        return RobotGradient(anchors, attachments, diameter, np.zeros(self.m))
