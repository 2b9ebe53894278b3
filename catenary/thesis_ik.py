"""Sag-aware inverse kinematics of one pose in the thesis convention, built once and
called per pose, for control loops: :class:`ThesisIK`.

The numpy reference is :func:`catenary.inverse_kinematics` with ``model="thesis"``,
which itself runs the compiled kernels of :mod:`catenary.thesis_ik_kernels` for one pose
(through a small cache). :class:`ThesisIK` holds its own
:class:`~catenary.thesis_ik_kernels.CompiledThesis` (so any backend may be used, also one
that keeps a warm start between poses); a pose the kernels do not settle is answered by
:func:`catenary.inverse_kinematics` itself, so the statuses are the numpy path's.
"""

from __future__ import annotations

import time
from typing import Any

from numpy.typing import ArrayLike

import tension_opt
from tension_opt.problem.form import TensionProblem

from .inverse import InverseKinematicsResult, inverse_kinematics, thesis_result
from .thesis_ik_kernels import CompiledThesis
from .thesis_ik_kernels import thesis_pose as thesis_pose

__all__ = ["ThesisIK", "thesis_pose"]


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
        self.robot = robot
        self.args = (objective, backend)
        self.options = options
        self.solver = CompiledThesis(robot, objective, backend, **options)

    def __call__(self, pose: ArrayLike, wrench: ArrayLike | None = None
                 ) -> InverseKinematicsResult:
        """Lengths and forces of one pose (see the class docstring)."""
        result = thesis_result(self.solver, pose, wrench, time.perf_counter())
        if result is not None:
            return result
        objective, backend = self.args
        return inverse_kinematics(self.robot, pose, "thesis", objective, backend, wrench,
                                  **self.options)
