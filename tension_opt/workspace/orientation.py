"""Orientation workspaces of robots that rotate (``planar3``, ``spatial6``).

- :func:`orientation_workspace`: one position, a set of orientations; which of them meet
  a criterion (CASPR's and WireX's *orientation workspace*).
- :func:`total_orientation_workspace`: positions at which a criterion holds at every
  orientation of a set (the *total orientation workspace*);
- :func:`inclusion_orientation_workspace`: positions at which it holds at one
  orientation of the set at least (the *inclusion orientation workspace*).

A criterion is a name of :data:`tension_opt.workspace.criteria.CRITERIA`
(``"wrench_feasible"``, ``"static"``, ``"wrench_closure"``, ``"interference_free"``) or
a function ``(robot, poses, **options) -> WorkspaceResult``. Orientations are the pose's
angle coordinates: ``theta`` (rad) for ``planar3``, a rotation vector ``(rx, ry, rz)``
(rad) for ``spatial6``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.checks import as_float_array
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.workspace.criteria import get_criterion
from tension_opt.workspace.grid import Grid
from tension_opt.workspace.result import WorkspaceResult

__all__ = [
    "inclusion_orientation_workspace",
    "orientation_workspace",
    "total_orientation_workspace",
]


def _coordinates(robot: CableRobot) -> tuple[list[int], list[int]]:
    """The pose's position and angle coordinates; raise for a robot that does not rotate."""
    pattern = robot.pattern
    if not pattern.rotates:
        raise InvalidInputError(f"robot: orientation workspaces need a robot that rotates "
                                f"(planar3, spatial6); this one is {robot.kind}")
    pos = list(pattern.positions)
    return pos, [i for i in range(robot.dof) if i not in pos]


def _rows(name: str, value: ArrayLike | Grid, size: int, what: str) -> NDArray:
    """``value`` (or a Grid's points) as finite rows of ``size`` entries, shape (K, size)."""
    arr = as_float_array(name, value.poses if isinstance(value, Grid) else value)
    if arr.ndim == 1 and size == 1 and arr.size > 0:
        arr = arr[:, None]
    elif arr.ndim == 1 and arr.shape[0] == size:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != size or arr.shape[0] < 1:
        raise InvalidInputError(f"{name} must have shape (K, {size}) ({what}), got "
                                f"{np.shape(value.poses if isinstance(value, Grid) else value)}")
    if not np.isfinite(arr).all():
        raise InvalidInputError(f"{name} must be finite")
    return arr


def _full_grid(robot: CableRobot, fixed: NDArray, fixed_at: list[int], grid: Grid,
               grid_at: list[int]) -> Grid:
    """A grid over every pose coordinate: ``grid`` along ``grid_at``, one point at
    ``fixed`` along ``fixed_at``."""
    n = robot.dof
    axes: list[NDArray] = [np.zeros(1)] * n
    lower, upper = np.zeros(n), np.zeros(n)
    g_lo, g_hi = grid.box()
    for j, i in enumerate(grid_at):
        axes[i], lower[i], upper[i] = grid.axes[j], g_lo[j], g_hi[j]
    for j, i in enumerate(fixed_at):
        axes[i] = np.array([fixed[j]])
        lower[i] = upper[i] = fixed[j]
    poses = np.empty((len(grid.poses), n))
    poses[:, grid_at] = grid.poses
    poses[:, fixed_at] = fixed
    return Grid(poses, tuple(len(a) for a in axes), tuple(axes), lower, upper)


def orientation_workspace(
    robot: CableRobot,
    position: ArrayLike,
    orientations: ArrayLike | Grid,
    criterion: str | Callable[..., WorkspaceResult] = "wrench_feasible",
    **options: Any,
) -> WorkspaceResult:
    """Which orientations at one position meet a criterion (the orientation workspace).

    Parameters
    ----------
    robot : CableRobot
        A robot that rotates (``planar3``, ``spatial6``).
    position : array_like, shape (p,)
        The platform's position (m): ``(x, y)`` for ``planar3``, ``(x, y, z)`` for
        ``spatial6``.
    orientations : array_like, shape (K, r) or (K,) for r = 1, or Grid
        Orientations (rad): ``theta`` for ``planar3`` (r = 1), rotation vectors for
        ``spatial6`` (r = 3); a :func:`~tension_opt.workspace.workspace_grid` over the
        ``r`` angles keeps its shape (for ``reshape`` and :meth:`WorkspaceResult.fraction`).
    criterion : str or callable
        A name of :data:`~tension_opt.workspace.criteria.CRITERIA` or a function
        ``(robot, poses, **options) -> WorkspaceResult``.
    **options
        Passed to the criterion (``wrenches``, ``wrench_set``, ``clearance``,
        ``backend``, ``executor`` ...).

    Returns
    -------
    WorkspaceResult
        The criterion's result over the K poses ``position + orientation``;
        ``extras["orientations"]`` (K, r).

    Raises
    ------
    InvalidInputError
        For a robot that does not rotate, bad position or orientations, an unknown
        criterion, or what the criterion refuses.
    """
    pos, ang = _coordinates(robot)
    _, run = get_criterion(criterion)
    where = _rows("position", position, len(pos), "the platform's position")
    if len(where) != 1:
        raise InvalidInputError(f"position must be one position of shape ({len(pos)},), got "
                                f"{np.shape(position)}")
    turns = _rows("orientations", orientations, len(ang), "angles of the orientations, rad")
    if isinstance(orientations, Grid):
        poses: ArrayLike | Grid = _full_grid(robot, where[0], pos, orientations, ang)
    else:
        full = np.empty((len(turns), robot.dof))
        full[:, pos], full[:, ang] = where[0], turns
        poses = full
    result = run(robot, poses, **options)
    result.extras["orientations"] = turns
    return result


def _positions_layout(robot: CableRobot, positions: ArrayLike | Grid, pos: list[int],
                      ang: list[int]) -> tuple[NDArray, dict[str, Any]]:
    """Positions (N, p) and the layout of the result's poses (at zero angles)."""
    where = _rows("positions", positions, len(pos), "the platform's positions, m")
    if not isinstance(positions, Grid):
        return where, {"grid_shape": None, "axes": None, "bounds": None}
    grid = _full_grid(robot, np.zeros(len(ang)), ang, positions, pos)
    return where, {"grid_shape": grid.shape, "axes": grid.axes,
                   "bounds": (grid.lower, grid.upper)}


def _per_position(inner: WorkspaceResult, N: int, K: int, every: bool
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray, dict[str, Any]]:
    """The inner result (N K poses, position-major) per position: feasible (N,) at
    every orientation (``every``) or at some, margins (N, K), the orientation that sets
    the margin (N,): the smallest margin, or with ``every=False`` the largest, the
    fraction of feasible orientations (N,), and per-pose extras over the orientations:
    ``*_margin`` the smallest (largest), ``*_feasible`` all (any) of them."""
    ok = np.asarray(inner.feasible, dtype=bool).reshape(N, K)
    margins = np.asarray(inner.margin, dtype=float).reshape(N, K)
    ranked = np.where(np.isnan(margins), -np.inf, margins)
    crit = np.argmin(ranked, axis=1) if every else np.argmax(ranked, axis=1)
    extras: dict[str, Any] = {}
    for key, value in inner.per_pose_extras().items():
        if key.endswith("_margin"):
            per = np.asarray(value, dtype=float).reshape(N, K)
            extras[key] = per.min(axis=1) if every else per.max(axis=1)
        elif key.endswith("_feasible") and value.dtype == bool:
            extras[key] = value.reshape(N, K).all(axis=1) if every else value.reshape(
                N, K).any(axis=1)
    feasible = ok.all(axis=1) if every else ok.any(axis=1)
    return np.asarray(feasible), margins, crit, np.asarray(ok.mean(axis=1)), extras


def _orientation_set(robot: CableRobot, positions: ArrayLike | Grid,
                     orientations: ArrayLike | Grid,
                     criterion: str | Callable[..., WorkspaceResult], every: bool,
                     options: dict[str, Any]) -> WorkspaceResult:
    """:func:`total_orientation_workspace` (``every``) or
    :func:`inclusion_orientation_workspace`."""
    pos, ang = _coordinates(robot)
    name, run = get_criterion(criterion)
    where, layout = _positions_layout(robot, positions, pos, ang)
    turns = _rows("orientations", orientations, len(ang), "angles of the orientations, rad")
    N, K = len(where), len(turns)
    full = np.empty((N, K, robot.dof))
    full[..., pos] = where[:, None, :]
    full[..., ang] = turns[None]
    inner = run(robot, full.reshape(N * K, robot.dof), **options)
    feasible, margins, crit, share, extras = _per_position(inner, N, K, every)
    pick = np.arange(N) * K + crit
    poses = np.zeros((N, robot.dof))
    poses[:, pos] = where
    kind, best = ("total", "smallest") if every else ("inclusion", "largest")
    extras.update({"criterion": f"{kind}_orientation_{name}", "orientations": turns,
                   "margin_label": f"{inner.label('margin')}, {best} over orientations",
                   "orientation_margins": margins, "critical_orientation": crit,
                   "orientation_fraction": share})
    return WorkspaceResult(
        poses=poses, feasible=feasible, margin=margins[np.arange(N), crit],
        tensions=inner.tensions[pick], status=inner.status[pick], margins=inner.margins[pick],
        critical_wrench=inner.critical_wrench[pick], wrenches=inner.wrenches, robot=robot,
        backend=inner.backend, extras=extras, **layout)


def total_orientation_workspace(
    robot: CableRobot,
    positions: ArrayLike | Grid,
    orientations: ArrayLike | Grid,
    criterion: str | Callable[..., WorkspaceResult] = "wrench_feasible",
    **options: Any,
) -> WorkspaceResult:
    """Positions where a criterion holds at every orientation of a set.

    Parameters
    ----------
    robot : CableRobot
        A robot that rotates (``planar3``, ``spatial6``).
    positions : array_like, shape (N, p), or Grid
        Positions (m): ``(x, y)`` for ``planar3``, ``(x, y, z)`` for ``spatial6``; a
        :func:`~tension_opt.workspace.workspace_grid` over the ``p`` position
        coordinates keeps its shape for :meth:`WorkspaceResult.volume` and the plots.
    orientations : array_like, shape (K, r) or (K,) for r = 1, or Grid
        The orientations (rad) each position must allow, as in
        :func:`orientation_workspace`.
    criterion : str or callable
        A name of :data:`~tension_opt.workspace.criteria.CRITERIA` or a function
        ``(robot, poses, **options) -> WorkspaceResult``.
    **options
        Passed to the criterion, which runs once over all ``N K`` poses (chunked over
        its ``executor``).

    Returns
    -------
    WorkspaceResult
        One row per position; ``poses`` (N, n) the positions at zero angles (the result
        stands for positions). ``feasible``: the criterion holds at every orientation;
        ``margin``: the smallest over the orientations (the criterion's units);
        ``tensions``, ``status``, ``margins``, ``critical_wrench``: those of the
        critical orientation (the smallest margin). ``extras``: ``"criterion"``
        (``"total_orientation_<name>"``), ``"orientations"`` (K, r),
        ``"orientation_margins"`` (N, K), ``"critical_orientation"`` (N,) index,
        ``"orientation_fraction"`` (N,) share of the orientations that meet the
        criterion, and the criterion's per-pose extras over the orientations (a
        ``*_margin`` the smallest).

    Raises
    ------
    InvalidInputError
        As :func:`orientation_workspace`, for bad positions too.
    """
    return _orientation_set(robot, positions, orientations, criterion, True, options)


def inclusion_orientation_workspace(
    robot: CableRobot,
    positions: ArrayLike | Grid,
    orientations: ArrayLike | Grid,
    criterion: str | Callable[..., WorkspaceResult] = "wrench_feasible",
    **options: Any,
) -> WorkspaceResult:
    """Positions where a criterion holds at some orientation of a set.

    The arguments are those of :func:`total_orientation_workspace`.

    Returns
    -------
    WorkspaceResult
        As :func:`total_orientation_workspace`, with ``feasible``: the criterion holds
        at one orientation at least; ``margin``: the largest over the orientations, and
        the tensions, status and ``extras["critical_orientation"]`` of that orientation
        (per-pose extras: a ``*_margin`` the largest, a ``*_feasible`` any);
        ``extras["criterion"]``: ``"inclusion_orientation_<name>"``.

    Raises
    ------
    InvalidInputError
        As :func:`total_orientation_workspace`.
    """
    return _orientation_set(robot, positions, orientations, criterion, False, options)
