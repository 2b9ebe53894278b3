"""Sag-aware inverse kinematics of one pose in the thesis convention, compiled, for
control loops: :class:`ThesisIK`.

The numpy reference is :func:`catenary.inverse_kinematics` with ``model="thesis"``:
the straight-line distribution (here a :class:`tension_opt.Distributor`) gives each
cable's tension, imposed at its drawing point on the taut catenary through both ends;
the platform forces and the equilibrium residual follow. One compiled call does the
cable planes, the four-to-eight taut catenaries (:func:`catenary.kernels.solve_length_one`),
the platform forces and the residual. A pose whose straight-line distribution is not
optimal, or one of whose cables the kernel leaves to the numpy path (vertical cable,
degenerate limit, Newton not converging), is answered by
:func:`catenary.inverse_kinematics` itself, so the statuses are the numpy path's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt.kernels.geometry import GEOMETRY_OK, geometry_into, kind_code, rotation
from tension_opt.problems import TensionProblem
from tension_opt.solution import STATUS_DTYPE, Status

from .geometry import cable_data
from .inverse import InverseKinematicsResult, inverse_kinematics
from .kernels import CONVERGED, solve_length_one

__all__ = ["ThesisIK", "thesis_pose"]


@njit(cache=True, error_model="numpy")
def thesis_pose(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                weight: float, pose: NDArray, wrench: NDArray, tensions: NDArray,
                w: float, inv_EA: float, out: NDArray, forces: NDArray, work: NDArray
                ) -> tuple[bool, float]:
    """Taut catenaries of one pose with the drawing-point ``tensions`` (m,) (N).

    ``out`` (m, 7) gets per cable ``(L0, T_B, T_A, H, chord, iterations, V_A)``;
    ``forces`` (m, 3) the force of each cable on the platform (N). ``work`` holds at
    least ``n m + 2 n`` floats. Returns ``(solved, equilibrium residual)``; not solved
    where a cable's catenary is left to the numpy path.
    """
    m = anchors.shape[0]
    n = wrench.size
    R00, R01, R02, R10, R11, R12, R20, R21, R22 = rotation(kind, pose)
    A = work[:n * m].reshape((n, m))
    b = work[n * m:n * m + n]
    total = work[n * m + n:n * m + 2 * n]
    if geometry_into(kind, anchors, attachments, com, weight, 0.0, pose, wrench, A,
                     b) != GEOMETRY_OK:
        return False, np.nan
    px, py, pz = pose[0], pose[1], pose[2]
    if kind == 1:
        py, pz = 0.0, pose[1]
    elif kind == 2:
        pz = 0.0
    sol = work[n * m + 2 * n:n * m + 2 * n + 5]
    for k in range(n):
        total[k] = 0.0
    for i in range(m):
        a0, a1, a2 = attachments[i, 0], attachments[i, 1], attachments[i, 2]
        r0 = R00 * a0 + R01 * a1 + R02 * a2
        r1 = R10 * a0 + R11 * a1 + R12 * a2
        r2 = R20 * a0 + R21 * a1 + R22 * a2
        d0 = anchors[i, 0] - (px + r0)
        d1 = anchors[i, 1] - (py + r1)
        d2 = anchors[i, 2] - (pz + r2)
        x = math.hypot(d0, d1)
        if solve_length_one(True, x, d2, tensions[i], w, inv_EA, 1e-9, 30, sol) != CONVERGED:
            return False, np.nan
        H, V_B, V_A, L0 = sol[0], sol[1], sol[2], sol[3]
        out[i, 0], out[i, 1], out[i, 2] = L0, math.hypot(H, V_B), math.hypot(H, V_A)
        out[i, 3], out[i, 4], out[i, 5], out[i, 6] = H, math.sqrt(x * x + d2 ** 2), sol[4], V_A
        f0, f1, f2 = H * (d0 / x), H * (d1 / x), V_A
        forces[i, 0], forces[i, 1], forces[i, 2] = f0, f1, f2
        _add_wrench(kind, total, f0, f1, f2, r1 * f2 - r2 * f1, r2 * f0 - r0 * f2,
                    r0 * f1 - r1 * f0)
    residual = 0.0
    for k in range(n):
        residual += (total[k] - b[k]) ** 2
    return True, math.sqrt(residual)


@njit(cache=True, error_model="numpy")
def _add_wrench(kind: int, total: NDArray, f0: float, f1: float, f2: float, m0: float,
                m1: float, m2: float) -> None:
    """Add the rows of a cable's wrench that the kind keeps (as ``pattern.select``)."""
    if kind == 0:
        total[0] += f0
        total[1] += f1
        total[2] += f2
    elif kind == 1:
        total[0] += f0
        total[1] += f2
    elif kind == 2:
        total[0] += f0
        total[1] += f1
        total[2] += m2
    else:
        total[0] += f0
        total[1] += f1
        total[2] += f2
        total[3] += m0
        total[4] += m1
        total[5] += m2


class ThesisIK:
    """``catenary.inverse_kinematics(robot, pose, model="thesis", ...)`` for one pose at a
    time, built once and called per pose.

    Parameters
    ----------
    robot : CableRobot
        With cable properties (``robot.cable``).
    objective, backend, **options
        Of the straight-line distribution, as in :func:`catenary.inverse_kinematics`.

    Calling
    -------
    ``ik(pose, wrench=None)`` with a pose (n,) returns the
    :class:`~catenary.inverse.InverseKinematicsResult` of that one pose (arrays with a
    first axis of length 1, as the numpy function returns them).
    """

    def __init__(self, robot: tension_opt.CableRobot,
                 objective: str | TensionProblem = "min_sum", backend: str = "auto",
                 **options: Any) -> None:
        self.w, self.EA = cable_data(robot)
        self.robot = robot
        self.args = (objective, backend)
        self.options = options
        self.distributor = tension_opt.Distributor(robot, objective, backend, **options)
        self.kind = kind_code(robot.kind)
        self.anchors = np.ascontiguousarray(robot.anchors, dtype=float)
        self.attachments = np.ascontiguousarray(robot.attachments, dtype=float)
        self.com = np.ascontiguousarray(robot.com, dtype=float)
        self.weight = robot.mass * robot.g
        self.inv_EA = 0.0 if math.isinf(self.EA) else 1.0 / self.EA
        self.work = robot.dof * robot.m + 2 * robot.dof + 5
        self.no_wrench = np.zeros(robot.dof)
        self.converged = np.array([Status.CONVERGED], dtype=STATUS_DTYPE)

    def __call__(self, pose: ArrayLike, wrench: ArrayLike | None = None
                 ) -> InverseKinematicsResult:
        """Lengths and forces of one pose (see the class docstring)."""
        p = np.ascontiguousarray(pose, dtype=float)
        straight = self.distributor(p, wrench)
        if np.ndim(p) != 1 or straight.status != Status.OPTIMAL or self.w <= 0.0:
            return self._numpy(p, wrench)
        m = self.robot.m
        out, forces = np.empty((m, 7)), np.empty((m, 3))
        w = self.no_wrench if wrench is None else np.ascontiguousarray(wrench, dtype=float)
        solved, residual = thesis_pose(self.kind, self.anchors, self.attachments, self.com,
                                       self.weight, p, w, straight.tensions, self.w,
                                       self.inv_EA, out, forces, np.empty(self.work))
        if not solved:
            return self._numpy(p, wrench)
        return InverseKinematicsResult(
            lengths=out[None, :, 0], straight_lengths=out[None, :, 4],
            tensions=out[None, :, 1], tensions_platform=out[None, :, 2],
            horizontal_tensions=out[None, :, 3], platform_forces=forces[None],
            equilibrium_residual=np.array([residual]), iterations=np.zeros(1, np.int64),
            catenary_iterations=out[None, :, 5].astype(np.int64),
            status=self.converged.copy(), model="thesis", solve_time=0.0)

    def _numpy(self, p: NDArray, wrench: ArrayLike | None) -> InverseKinematicsResult:
        objective, backend = self.args
        return inverse_kinematics(self.robot, p, "thesis", objective, backend, wrench,
                                  **self.options)
