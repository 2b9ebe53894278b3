"""The tensions of a timing: the wrench it needs at every grid point, distributed.

A timing's grid points are a batch of independent poses, each with the wrench its
motion needs. Where :func:`tension_opt.distribution.certified.certified_plan` takes the
call (the robot's own structure matrices and bounds, one of the package's objectives
without smoothing, the compiled closed form as the backend), the batch runs the
compiled certified pass of :mod:`tension_opt.distribution.certified` (the wrench
besides gravity given as the external wrench: the same tensions, diagnostics and
certificate as the plain path, to rounding), and the poses it leaves take the plain
path; else the plain path: the problem's standard form on the path's structure
matrices, the backend, and :func:`~tension_opt.distribution.solution.solution_of`
(its certificate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.backends.registry import choose_backend
from tension_opt.checks import as_float_array
from tension_opt.distribution.certified import CertifiedBatch, certified_plan
from tension_opt.distribution.chunks import certified_chunks
from tension_opt.distribution.solution import TensionSolution, solution_of
from tension_opt.dynamics.path import PathStages
from tension_opt.problem.form import TensionProblem
from tension_opt.robot import CableRobot

__all__ = ["CERTIFIED_OPTIONS", "timing_tensions"]

#: Options of a call that the certified pass takes (the closed form has no time limit).
CERTIFIED_OPTIONS = frozenset({"accuracy", "time_limit"})


def _plain(
    robot: CableRobot,
    stages: PathStages,
    W: NDArray,
    problem: TensionProblem,
    backend: Any,
    options: dict[str, Any],
) -> TensionSolution:
    """The plain path (module docstring); ``options["previous"]`` (K, m), if any, are the
    previous tensions of a smoothed objective, each point against its own."""
    options = dict(options)
    previous = options.pop("previous", None)
    if previous is not None:
        previous = np.broadcast_to(as_float_array("previous", previous), stages.lb.shape)
    form = problem.standard_form_from(robot, stages.A, W, previous)
    chosen = choose_backend(backend, form)
    return solution_of(form, chosen.solve(form, **options), chosen)


def timing_tensions(
    robot: CableRobot,
    stages: PathStages,
    W: NDArray,
    problem: TensionProblem,
    custom_bounds: bool,
    own_structure: bool,
    backend: Any,
    options: dict[str, Any],
    certified: bool = True,
) -> tuple[NDArray, NDArray]:
    """Tensions (K, m) holding the wrenches ``W`` (K, n) at ``stages`` by the objective of
    ``problem``, and their status (K,).

    Parameters
    ----------
    robot : CableRobot
    stages : PathStages
        The path at the grid points.
    W : ndarray, shape (K, n)
        The wrench the cables supply at each (N, N m).
    problem : TensionProblem
    custom_bounds : bool
        The bounds of ``stages`` were given (they replace the problem's).
    own_structure : bool
        The structure matrices of ``stages`` are the robot's own at its poses.
    backend, options
        As in :func:`tension_opt.distribute`.
    certified : bool
        Take the certified pass where it applies (module docstring); False: the plain
        path always (the reference).
    """
    if custom_bounds:
        problem = problem.with_(t_min=stages.lb, t_max=stages.ub)
    plan = None
    rows = problem.has_pose_rows
    if (
        certified
        and own_structure
        and not (custom_bounds or rows)
        and set(options) <= CERTIFIED_OPTIONS
    ):
        plan = certified_plan(robot, problem, backend, options.get("accuracy"))
    if plan is None:
        sol = _plain(robot, stages, W, problem, backend, options)
        return sol.tensions, sol.status
    # A T = b(q, w_ext) = -(w_g + w_ext): the wrench besides gravity is b(q) - W.
    external = robot.required_wrench(stages.poses) - W
    batch = CertifiedBatch(plan, stages.poses, external)
    K = stages.K

    def rest(poses: NDArray | slice) -> TensionSolution:
        index = np.arange(K)[poses]  # a slice or indices: the points
        return _plain(robot, stages.take(index), W[index], problem, backend, options)

    sol = certified_chunks(batch, K, K, 1, rest, problem)
    return sol.tensions, np.array(sol.status)
