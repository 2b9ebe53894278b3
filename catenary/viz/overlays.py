"""Overlays on a view of the robot: a workspace result's feasible points coloured by a
quantity (:func:`plot_workspace`), and the platform's compliance ellipsoid at a pose
(:func:`plot_compliance`, from :func:`catenary.stiffness_analysis`).

Each draws on the axes of :func:`catenary.viz.plot_robot` (``ax=fig.axes[0]``) or on
new axes, 3-D or a plane view alike.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.workspace.result import WorkspaceResult

from ..errors import InvalidCableError
from ..geometry import check_robot
from ..robot_stiffness import stiffness_analysis
from .drawing import PLANES, check_view, colour_map, default_view, hull_polygon, new_axes
from .views import check_axes, check_positive_number

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["compliance_ellipsoid", "plot_compliance", "plot_workspace"]

FloatArray = NDArray[np.float64]


def _axes_for(ax: Any, view: str, figsize: tuple[float, float]) -> Any:
    """``ax`` checked for ``view``, or new axes."""
    if ax is None:
        return new_axes(view, figsize)
    check_axes(ax, view)
    return ax


def _view_of(ax: Any, view: str | None, robot: CableRobot | None) -> str:
    """The view: given, that of the axes (3-D or the robot's plane), or the robot's."""
    if view is not None:
        return check_view(view, robot) if robot is not None else str(view)
    if ax is not None and getattr(ax, "name", "") == "3d":
        return "3d"
    if robot is None:
        return "3d" if ax is None else "xy"
    own = default_view(robot)
    return "xz" if ax is not None and own == "3d" else own


def plot_workspace(
    result: WorkspaceResult,
    ax: Any = None,
    *,
    quantity: str = "margin",
    view: str | None = None,
    max_points: int = 5000,
    cmap: Any = "viridis",
    size: float = 6.0,
    alpha: float = 0.6,
    colorbar: bool = True,
    seed: int = 0,
    figsize: tuple[float, float] = (7.0, 5.5),
) -> Figure:
    """Overlay the feasible points of a workspace result, coloured by a quantity.

    Parameters
    ----------
    result : tension_opt.workspace.WorkspaceResult
        E.g. :func:`tension_opt.workspace.wrench_feasible_workspace` or
        :func:`catenary.sag_workspace`'s (the coupled model's margin); poses (N, n).
    ax : matplotlib Axes, optional
        E.g. ``plot_robot(...).axes[0]``; default new axes.
    quantity : str
        The colour: ``"margin"`` (capacity margin, N) or any name
        :meth:`~tension_opt.workspace.WorkspaceResult.quantity` knows.
    view : {"3d", "xy", "xz", "yz"}, optional
        Default: that of ``ax``, else the robot's.
    max_points : int
        At most this many feasible points are drawn (a random subset, ``seed``).
    cmap, size, alpha, colorbar, figsize
        Colour map, marker size (points^2), opacity, a colour bar labelled with the
        quantity, and the size of a new figure (inches).

    Returns
    -------
    matplotlib.figure.Figure
        The points are one collection with ``gid`` ``"workspace"``.

    Raises
    ------
    InvalidCableError
        If ``result`` is not a workspace result, or for arguments out of their domain.
    """
    if not isinstance(result, WorkspaceResult):
        raise InvalidCableError(
            "result must be a tension_opt.workspace.WorkspaceResult (e.g. from "
            f"tension_opt.workspace.wrench_feasible_workspace); got {type(result).__name__}"
        )
    if isinstance(max_points, bool) or not isinstance(max_points, int) or max_points < 1:
        raise InvalidCableError(f"max_points must be an integer >= 1; got {max_points!r}")
    view = _view_of(ax, view, result.robot)
    ax = _axes_for(ax, view, figsize)
    values = np.asarray(result.quantity(quantity), dtype=float)
    idx = np.flatnonzero(np.asarray(result.feasible, dtype=bool) & np.isfinite(values))
    if len(idx) > max_points:
        idx = np.sort(np.random.default_rng(seed).choice(idx, max_points, replace=False))
    position = result.pattern.frames(np.asarray(result.poses, dtype=float)[idx])[0]
    coords = _coords(position, view)
    extra: dict[str, Any] = {"depthshade": False} if view == "3d" else {}
    points = ax.scatter(
        *coords,
        c=values[idx],
        s=size,
        alpha=alpha,
        cmap=colour_map(cmap),
        linewidths=0,
        zorder=1,
        **extra,
    )
    points.set_gid("workspace")
    if colorbar:
        ax.figure.colorbar(
            points,
            ax=ax,
            shrink=0.6,
            pad=0.12 if view == "3d" else 0.04,
            label=result.label(quantity),
        )
    return ax.figure


def _coords(points: FloatArray, view: str) -> list[FloatArray]:
    """Coordinates of points (k, 3) in a view."""
    if view == "3d":
        return [points[:, 0], points[:, 1], points[:, 2]]
    h, v = PLANES[view]
    return [points[:, h], points[:, v]]


def compliance_ellipsoid(
    robot: CableRobot,
    pose: ArrayLike,
    tensions: ArrayLike | None = None,
    model: str = "coupled",
    *,
    load: float | None = None,
    **kwargs: Any,
) -> tuple[FloatArray, FloatArray]:
    """Deflections of the platform's reference point under a force of size ``load``.

    The stiffness ``K`` (:func:`catenary.stiffness_analysis`, the unstretched lengths
    held) gives the compliance ``C = K^-1``; its block of the position coordinates maps
    a force ``f`` on the platform to the deflection ``C f``. Over every direction of a
    force of size ``load`` the deflections fill an ellipsoid.

    Parameters
    ----------
    robot : CableRobot
    pose : array_like, shape (n,)
        The platform pose (m, rad).
    tensions, model, **kwargs
        As in :func:`catenary.stiffness_analysis` (``"coupled"`` or ``"straight"``).
    load : float, optional
        Size of the force (N), > 0; default the platform's weight (1 N without gravity).

    Returns
    -------
    centre : ndarray, shape (3,)
        The platform's reference point (m), base frame.
    semi_axes : ndarray, shape (3, 3)
        The ellipsoid's semi-axes as columns (m), base frame, longest first; a planar
        robot's third is zero.

    Raises
    ------
    InvalidCableError
        If the pose has no stiffness (no tensions, or a singular stiffness).
    """
    check_robot(robot)
    p = robot.as_poses(pose)
    if len(p) != 1:
        raise InvalidCableError(f"pose must be one pose, shape ({robot.dof},); got {len(p)}")
    load = robot.weight if load is None and robot.weight > 0 else load
    load = check_positive_number("load", 1.0 if load is None else load)
    res = stiffness_analysis(robot, p, tensions, model, **kwargs)  # type: ignore[arg-type]
    K = res.stiffness[0]
    if not np.isfinite(K).all() or np.linalg.cond(K) > 1e14:
        raise InvalidCableError(
            f"no compliance at this pose: the stiffness is {res.status[0]!r} or singular; "
            "pick a pose inside the workspace (or pass tensions)"
        )
    pos = list(robot.pattern.positions)
    block = np.linalg.inv(K)[np.ix_(pos, pos)]
    embed = np.zeros((3, len(pos)))
    embed[list(robot.pattern.position_axes), np.arange(len(pos))] = 1.0
    U, S, _ = np.linalg.svd(block)
    semi = np.zeros((3, 3))
    semi[:, : len(pos)] = embed @ U * (load * S)
    centre = robot.frames(p)[0][0]
    return centre, semi


def plot_compliance(
    robot: CableRobot,
    pose: ArrayLike,
    ax: Any = None,
    *,
    tensions: ArrayLike | None = None,
    model: str = "coupled",
    load: float | None = None,
    scale: float | None = None,
    view: str | None = None,
    color: Any = "tab:red",
    alpha: float = 0.35,
    figsize: tuple[float, float] = (7.0, 5.5),
    **kwargs: Any,
) -> Figure:
    """Overlay the platform's compliance ellipsoid (:func:`compliance_ellipsoid`) at a pose.

    Parameters
    ----------
    robot : CableRobot
    pose : array_like, shape (n,)
    ax : matplotlib Axes, optional
        E.g. ``plot_robot(robot, pose).axes[0]``; default new axes.
    tensions, model, load, **kwargs
        As in :func:`compliance_ellipsoid`.
    scale : float, optional
        The deflections are drawn ``scale`` times their size; default so that the
        longest semi-axis is 5 % of the frame. The legend states the load and scale.
    view : {"3d", "xy", "xz", "yz"}, optional
        Default: that of ``ax``, else the robot's.
    color, alpha : colour and opacity of the ellipsoid.
    figsize : (float, float)
        Size of a new figure (inches).

    Returns
    -------
    matplotlib.figure.Figure
        The ellipsoid has ``gid`` ``"compliance"``.
    """
    centre, semi = compliance_ellipsoid(robot, pose, tensions, model, load=load, **kwargs)
    longest = float(np.linalg.norm(semi, axis=0).max())
    if scale is None:
        scale = 0.05 * float(np.ptp(robot.anchors, axis=0).max()) / max(longest, 1e-300)
    scale = check_positive_number("scale", scale)
    view = _view_of(ax, view, robot)
    ax = _axes_for(ax, view, figsize)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 33), np.linspace(0, np.pi, 17))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    surface = centre + scale * sphere @ semi.T
    force = robot.weight if load is None and robot.weight > 0 else (load or 1.0)
    label = f"deflection under {force:.3g} N, drawn \u00d7{scale:.3g}"
    if view == "3d":
        art = ax.plot_surface(
            *(surface[..., k] for k in range(3)),
            color=color,
            alpha=alpha,
            linewidth=0,
            shade=True,
            label=label,
        )
    else:
        from matplotlib.patches import Polygon

        flat = np.column_stack(_coords(surface.reshape(-1, 3), view))
        art = Polygon(
            hull_polygon(flat),
            closed=True,
            facecolor=color,
            alpha=alpha,
            edgecolor=color,
            label=label,
            zorder=6,
        )
        ax.add_patch(art)
    art.set_gid("compliance")
    old = ax.get_legend()
    handles = [] if old is None else list(old.legend_handles)
    labels = [] if old is None else [text.get_text() for text in old.get_texts()]
    ax.legend([*handles, art], [*labels, label], fontsize="small", loc="upper left", framealpha=0.8)
    return ax.figure
