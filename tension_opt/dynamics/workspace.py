"""The dynamic workspace: poses that can hold the platform under a box of accelerations.

A pose belongs to the dynamic workspace when tensions within the bounds supply the
wrench of every acceleration of a box ``|acc_j| <= a_max_j`` (linear accelerations
along the position axes) at a given velocity. The wrench is affine in the
acceleration and the wrench-feasible set is convex, so checking the box's ``2^d``
vertices (``d`` position coordinates) is exact: every vertex's d'Alembert wrench
(:func:`~tension_opt.dynamics.wrench.inertia_wrench`) becomes one external wrench of
the set that :func:`tension_opt.wrench_feasible_workspace` checks, each on its own.

Only the angular part of the velocity changes the rigid-body wrench (centripetal and
gyroscopic terms); a linear speed alone does not. When neither the velocity nor a
centre-of-mass offset makes the wrenches depend on the orientation, the vertex
wrenches are the same at every pose and the workspace machinery (chunks, executors)
runs as is; otherwise each vertex's per-pose wrench goes to
:func:`tension_opt.capacity_margin`.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_finite
from tension_opt.distribution.entry import distribute
from tension_opt.dynamics.wrench import inertia_wrench
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace import (
    FEAS_TOL,
    Grid,
    WorkspaceResult,
    on_drawing_point,
    prepare,
    wrench_feasible_workspace,
)
from tension_opt.workspace.margin import pose_margins

__all__ = ["acceleration_vertices", "dynamic_workspace"]


def acceleration_vertices(robot: CableRobot, a_max: float | ArrayLike) -> NDArray:
    """Vertices of the box of linear accelerations, shape (2^d, n) (m/s^2).

    Parameters
    ----------
    robot : CableRobot
    a_max : float or array_like, shape (d,)
        Largest acceleration along each position coordinate (m/s^2), >= 0.
    """
    positions = list(robot.pattern.positions)
    limits = as_finite("a_max", a_max)
    try:
        limits = np.broadcast_to(limits, (len(positions),))
    except ValueError:
        raise InvalidInputError(f"a_max must be a number or have shape ({len(positions)},) "
                                f"(one per position coordinate), got {limits.shape}") from None
    if (limits < 0).any():
        raise InvalidInputError(f"a_max must be >= 0, got {limits}")
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=len(positions))))
    vertices = np.zeros((len(signs), robot.dof))
    vertices[:, positions] = signs * limits
    return np.unique(vertices, axis=0)  # a zero limit gives each vertex twice


def dynamic_workspace(robot: CableRobot, poses: ArrayLike | Grid, a_max: float | ArrayLike,
                      *, velocity: ArrayLike | None = None,
                      accelerations: ArrayLike | None = None, backend: str = "auto",
                      bounds: tuple[ArrayLike, ArrayLike] | None = None,
                      **options: Any) -> WorkspaceResult:
    """Poses whose tensions can produce every acceleration of a box.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad).
    a_max : float or array_like, shape (d,)
        Half-widths of the box of linear accelerations (m/s^2); see
        :func:`acceleration_vertices`.
    velocity : array_like, shape (n,), optional
        Velocity coordinates (m/s, rad/s) the accelerations happen at; only the
        angular part matters.
    accelerations : array_like, shape (K, n), optional
        Acceleration vectors (velocity coordinates' derivatives) to check instead of the
        box's vertices (any convex set is checked exactly by its vertices).
    backend : str
        As in :func:`tension_opt.wrench_feasible_workspace`.
    bounds : (array_like, array_like), optional
        The box the poses were sampled from, for :meth:`WorkspaceResult.volume`.
    **options
        Passed to :func:`tension_opt.wrench_feasible_workspace` (``executor``,
        ``chunk_size`` ...) or to the LP backend.

    Returns
    -------
    WorkspaceResult
        ``margins`` (N, K) under each acceleration (``extras["accelerations"]``), the
        smallest as ``margin``, ``feasible`` where every one can be held.
    """
    acc = acceleration_vertices(robot, a_max) if accelerations is None else as_finite(
        "accelerations", accelerations)
    if acc.ndim != 2 or acc.shape[1] != robot.dof or not len(acc):
        raise InvalidInputError(f"accelerations must have shape (K, {robot.dof}), got "
                                f"{acc.shape}")
    vel = np.zeros(robot.dof) if velocity is None else as_finite("velocity", velocity)
    if vel.shape != (robot.dof,):
        raise InvalidInputError(f"velocity must have shape ({robot.dof},), got {vel.shape}")
    P, _, layout = prepare(robot, poses, None, bounds)
    turning = robot.pattern.rotates and (robot.com.any() or vel.any())
    if not turning:  # the same wrenches at every pose
        home = robot.default_home()[None]
        wrenches = np.concatenate([inertia_wrench(robot, home, vel, a[None]) for a in acc])
        result = wrench_feasible_workspace(robot, poses, wrenches, backend=backend,
                                           bounds=bounds, **options)
        result.extras["accelerations"] = acc
        return result
    return _per_pose(robot, P, acc, vel, backend, layout, options)


def _per_pose(robot: CableRobot, P: NDArray, acc: NDArray, vel: NDArray, backend: str,
              layout: dict[str, Any], options: dict[str, Any]) -> WorkspaceResult:
    """The dynamic workspace when the vertex wrenches depend on the orientation; poses
    on a drawing point are infeasible (margin ``-inf``), as in the static workspace."""
    N, K = len(P), len(acc)
    margins, typical = np.full((N, K), -np.inf), np.zeros((N, K))
    status = status_array(N, Status.INFEASIBLE)
    ok = np.flatnonzero(~on_drawing_point(robot, P)) if N else np.zeros(0, dtype=int)
    status[ok] = Status.OPTIMAL
    wrenches = np.zeros((N, K, robot.dof))
    for k, a in enumerate(acc):
        if not len(ok):
            break
        wrenches[ok, k] = inertia_wrench(robot, P[ok], vel, a)
        margins[ok, k], status_k, typical[ok, k], _ = pose_margins(
            robot, P[ok], wrenches[ok, k], backend, options)
        failed = ok[status_k != Status.OPTIMAL]
        status[failed] = status_k[status_k != Status.OPTIMAL]
    crit = np.argmin(np.where(np.isnan(margins), -np.inf, margins), axis=1)
    margin = margins[np.arange(N), crit]
    feasible = (status == Status.OPTIMAL) & (margin >= -FEAS_TOL * typical.max(axis=1,
                                                                            initial=0.0))
    status[~feasible & (status == Status.OPTIMAL)] = Status.INFEASIBLE
    tensions = np.full((N, robot.m), np.nan)
    idx = np.flatnonzero(feasible)
    if len(idx):
        sol = distribute(robot, P[idx], "min_sum", backend,
                         wrench=wrenches[idx, crit[idx]], **options)
        tensions[idx], status[idx] = sol.tensions, sol.status
    # The wrenches vary with the orientation: the result lists those of the home pose.
    home = robot.default_home()[None]
    listed = np.concatenate([inertia_wrench(robot, home, vel, a[None]) for a in acc])
    return WorkspaceResult(P, feasible, margin, tensions, status, margins, crit, listed,
                           robot=robot, backend=str(backend),
                           extras={"accelerations": acc, "pose_dependent": True}, **layout)
