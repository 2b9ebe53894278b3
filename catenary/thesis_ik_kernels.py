"""The compiled part of the sag-aware inverse kinematics of one pose in the thesis
convention (:func:`catenary.inverse_kinematics` with ``model="thesis"``):
:func:`thesis_pose` and :class:`CompiledThesis`, with a small cache of them
(:func:`thesis_solver`).

The straight-line distribution of the pose (a :class:`tension_opt.Distributor`) gives
each cable's tension, imposed at its drawing point on the taut catenary through both
ends; one compiled call then does the cable planes, the four-to-eight taut catenaries
(:func:`catenary.solve.kernels.solve_length_one`), the platform forces and the
equilibrium residual. Where the distributor answers by the compiled closed form,
both steps are one compiled call (:func:`thesis_closed_form`): the distributor's
Python wrapper costs as much as the arithmetic of a pose. A pose whose straight-line
distribution is not optimal, or one of whose cables the kernel leaves to the numpy
path (vertical cable, degenerate limit, Newton not converging), is not answered here:
the caller runs the numpy path, so the statuses are the numpy path's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

import tension_opt
from tension_opt.errors import TensionOptError
from tension_opt.kernels.arrays import writable
from tension_opt.kernels.closed_form import solve_one
from tension_opt.kernels.first_use import announce
from tension_opt.kernels.geometry import (
    GEOMETRY_OK,
    arm_and_vector,
    geometry_into,
    kind_code,
    platform_position,
    rotation,
)
from tension_opt.kernels.launch import entry_point
from tension_opt.problem.form import TensionProblem, as_problem
from tension_opt.status import Status

from .errors import CatenaryError
from .geometry import cable_data
from .solve.kernels import CONVERGED, solve_length_one

__all__ = ["CACHE_SIZE", "CompiledThesis", "thesis_closed_form", "thesis_pose",
           "thesis_solver"]

#: Distinct (robot, objective, backend, options) whose :class:`CompiledThesis` is kept.
CACHE_SIZE = 8
#: Backends whose :class:`tension_opt.Distributor` answers a pose as
#: :func:`tension_opt.distribute` does, keeping no state between calls.
STATELESS_BACKENDS = ("auto", "closed_form")
_CACHE: dict[tuple[Any, ...], tuple[tension_opt.CableRobot, CompiledThesis]] = {}


@njit(cache=True, error_model="numpy")
def thesis_pose(kind: int, anchors: NDArray, attachments: NDArray, com: NDArray,
                weight: float, pose: NDArray, wrench: NDArray, tensions: NDArray,
                w: float, inv_EA: float, out: NDArray, forces: NDArray, work: NDArray
                ) -> tuple[bool, float]:
    """Taut catenaries of one pose with the drawing-point ``tensions`` (m,) (N).

    ``out`` (7, m) gets rows ``(L0, T_B, T_A, H, chord, iterations, V_A)`` (m, N);
    ``forces`` (m, 3) the force of each cable on the platform (N). ``work`` holds at
    least ``n m + 2 n`` floats. Returns ``(solved, equilibrium residual)``; not solved
    where a cable's catenary is left to the numpy path.
    """
    m = anchors.shape[0]
    n = wrench.size
    R = rotation(kind, pose)
    A = work[:n * m].reshape((n, m))
    b = work[n * m:n * m + n]
    total = work[n * m + n:n * m + 2 * n]
    if geometry_into(kind, anchors, attachments, com, weight, 0.0, pose, wrench, A,
                     b) != GEOMETRY_OK:
        return False, np.nan
    position = platform_position(kind, pose)
    sol = work[n * m + 2 * n:n * m + 2 * n + 5]
    for k in range(n):
        total[k] = 0.0
    for i in range(m):
        r0, r1, r2, d0, d1, d2 = arm_and_vector(R, position, anchors, attachments, i)
        x = math.hypot(d0, d1)
        if solve_length_one(True, x, d2, tensions[i], w, inv_EA, 1e-9, 30, sol) != CONVERGED:
            return False, np.nan
        H, V_B, V_A, L0 = sol[0], sol[1], sol[2], sol[3]
        out[0, i], out[1, i], out[2, i] = L0, math.hypot(H, V_B), math.hypot(H, V_A)
        out[3, i], out[4, i], out[5, i], out[6, i] = H, math.sqrt(x * x + d2 ** 2), sol[4], V_A
        f0, f1, f2 = H * (d0 / x), H * (d1 / x), V_A
        forces[i, 0], forces[i, 1], forces[i, 2] = f0, f1, f2
        _add_wrench(kind, total, f0, f1, f2, r1 * f2 - r2 * f1, r2 * f0 - r0 * f2,
                    r0 * f1 - r1 * f0)
    residual = 0.0
    for k in range(n):
        residual += (total[k] - b[k]) ** 2
    return True, math.sqrt(residual)


@njit(cache=True, error_model="numpy")
def thesis_closed_form(data: NDArray, anchors: NDArray, attachments: NDArray,
                       pose: NDArray, wrench: NDArray, no_prev: NDArray, w: float,
                       inv_EA: float, out: NDArray, forces: NDArray, work: NDArray,
                       tensions: NDArray) -> tuple[bool, float]:
    """:func:`thesis_pose` of the tensions the compiled closed form
    (:func:`tension_opt.kernels.closed_form.solve_one`) gives the pose, in one call.

    ``data`` is the distributor's packed problem (:func:`~tension_opt.kernels.
    closed_form.pack`), ``anchors`` and ``attachments`` (m, 3) its robot's,
    ``no_prev`` (m,) any vector (the problem is not sequential). Written, with a
    leading axis of one pose: ``out`` (7, 1, m) and ``forces`` (1, m, 3) as
    :func:`thesis_pose`'s, ``tensions`` (1, m) the straight-line tensions (N).
    ``work`` holds at least the closed form's work size and ``n m + 2 n + 5`` floats.
    Returns ``(solved, equilibrium residual)``; not solved where the closed form's
    status is not optimal (or it leaves the pose to the numpy path) or a catenary is
    left to the numpy path.
    """
    T = tensions[0]
    code = solve_one(data, pose, wrench, no_prev, False, work, T)[0]
    if code != 0:
        return False, np.nan
    return thesis_pose(int(data[0]), anchors, attachments, data[8:11], data[3], pose,
                       wrench, T, w, inv_EA, out[:, 0, :], forces[0], work)


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


class CompiledThesis:
    """The thesis-convention inverse kinematics of one pose, built once per robot and
    straight-line problem.

    Parameters
    ----------
    robot : CableRobot
        With cable properties (``robot.cable``) of positive weight.
    objective, backend, **options
        Of the straight-line distribution, as in :func:`catenary.inverse_kinematics`.
    """

    def __init__(self, robot: tension_opt.CableRobot,
                 objective: str | TensionProblem = "min_sum", backend: str = "auto",
                 **options: Any) -> None:
        w, self.EA = cable_data(robot)
        self.w = float(w)
        self.robot = robot
        self.distributor = tension_opt.Distributor(robot, objective, backend, **options)
        self.kind = kind_code(robot.kind)
        self.anchors = np.ascontiguousarray(robot.anchors, dtype=float)
        self.attachments = np.ascontiguousarray(robot.attachments, dtype=float)
        self.com = writable(robot.com)
        self.weight = float(robot.mass * robot.g)
        self.inv_EA = 0.0 if math.isinf(self.EA) else float(1.0 / self.EA)
        self.work = robot.dof * robot.m + 2 * robot.dof + 5
        self.no_wrench = np.zeros(robot.dof)
        m = robot.m
        announce("thesis sag IK", thesis_pose, thesis_closed_form)
        # Called with exactly these types, those thesis_closed_form passes (a writable
        # centre of mass, a strided 2-D view of the output, which numba types "A"
        # inside a kernel; numpy calls a view of a (7, 1, m) array contiguous, so the
        # example is a view of a (7, 2, m) one): one compiled copy of the pose.
        self._thesis_pose = entry_point(
            thesis_pose, self.kind, self.anchors, self.attachments, self.com, self.weight,
            self.no_wrench, self.no_wrench, np.zeros(m), self.w, self.inv_EA,
            np.empty((7, 2, m))[:, 0, :], np.empty((m, 3)), np.empty(self.work))
        # The closed form and the catenaries in one compiled call, where they apply.
        self._data = self.distributor.closed_form_data
        self._fused = None
        if self._data is not None:
            from tension_opt.kernels.closed_form import work_size

            self.work = max(self.work, int(work_size(m, robot.dof)))
            self._no_prev = np.zeros(m)
            self._fused = entry_point(
                thesis_closed_form, self._data, self.anchors, self.attachments,
                self.no_wrench, self.no_wrench, self._no_prev, self.w, self.inv_EA,
                np.empty((7, 1, m)), np.empty((1, m, 3)), np.empty(self.work),
                np.empty((1, m)))

    def solve(self, pose: NDArray, wrench: NDArray | None
              ) -> tuple[NDArray, NDArray, float] | None:
        """``(out, forces, residual)`` of one pose (n,) as :func:`thesis_pose` fills
        them, with a leading axis of one pose (``out`` (7, 1, m), ``forces`` (1, m, 3)),
        with an external wrench (n,) or None; None where the numpy path decides
        (straight-line distribution not optimal, a cable the kernel leaves, weightless
        cables, data the distributor rejects)."""
        if self.w <= 0.0:
            return None
        if self._fused is not None:
            m = self.robot.m
            out, forces, tensions = np.empty((7, 1, m)), np.empty((1, m, 3)), np.empty((1, m))
            w = self.no_wrench if wrench is None else wrench
            solved, residual = self._fused(
                self._data, self.anchors, self.attachments, pose, w, self._no_prev, self.w,
                self.inv_EA, out, forces, np.empty(self.work), tensions)
            return (out, forces, residual) if solved else None
        try:
            straight = self.distributor(pose, wrench)
        except TensionOptError:
            return None  # the numpy path raises its own error, or answers
        if straight.status != Status.OPTIMAL:
            return None
        m = self.robot.m
        out, forces = np.empty((7, 1, m)), np.empty((m, 3))
        w = self.no_wrench if wrench is None else wrench
        tensions = np.ascontiguousarray(straight.tensions, dtype=np.float64)
        solved, residual = self._thesis_pose(
            self.kind, self.anchors, self.attachments, self.com, self.weight, pose, w,
            tensions, self.w, self.inv_EA, out[:, 0, :], forces, np.empty(self.work))
        return (out, forces[None], residual) if solved else None


def thesis_solver(robot: tension_opt.CableRobot, objective: Any, backend: Any,
                  options: dict[str, Any]) -> CompiledThesis | None:
    """The cached :class:`CompiledThesis` of these arguments (built on first use), or
    None where they are not for it: a backend other than :data:`STATELESS_BACKENDS`, a
    sequential (smoothed, rate-limited) objective, options that cannot be a cache key,
    a robot without cable properties or arguments the distributor rejects (the numpy
    path then raises its own error)."""
    if not (isinstance(backend, str) and backend in STATELESS_BACKENDS):
        return None
    try:
        key = (id(robot), objective, backend, tuple(sorted(options.items())))
        hash(key)
    except TypeError:
        return None
    cached = _CACHE.get(key)
    if cached is not None and cached[0] is robot:
        return cached[1]
    try:
        if as_problem(objective).is_sequential:
            return None
        solver = CompiledThesis(robot, objective, backend, **options)
    except (TensionOptError, CatenaryError):
        return None
    while len(_CACHE) >= CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = (robot, solver)
    return solver
