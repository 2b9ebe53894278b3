"""Plots of a workspace result: a heat-map slice of a grid and a 3-D scatter.

Coordinate names and which coordinates are positions come from the robot's motion
pattern (:attr:`tension_opt.robot.CableRobot.pattern`). matplotlib is imported when a
plot is drawn.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tension_opt.errors import InvalidInputError
from tension_opt.kinds import MotionPattern
from tension_opt.workspace.result import WorkspaceResult

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["plot_slice", "plot_workspace_3d"]


def _slice_of(pattern: MotionPattern, grid_shape: tuple[int, ...], axes: tuple[NDArray, ...],
              z: float | None) -> tuple[int, int, tuple[int | slice, ...], list[str]]:
    """The plotted plane of a grid: the horizontal and vertical pose coordinates, the
    grid index of the slice and the fixed position coordinates (for the title)."""
    names, pos = pattern.coordinates, pattern.positions
    vertical = pattern.vertical_coordinate
    varying = [i for i in pos if grid_shape[i] > 1]
    if len(varying) < 2:
        raise InvalidInputError(
            f"plot_slice needs a grid with several points along two position coordinates; "
            f"it has {dict(zip(names, grid_shape, strict=True))}")
    h, v = varying[0], varying[1]
    index: list[int | slice] = [slice(None)] * len(grid_shape)
    at: list[str] = []
    for i, axis in enumerate(axes):
        if i in (h, v):
            continue
        if i == vertical and z is not None:
            j = int(np.argmin(np.abs(axis - z)))
        elif len(axis) == 1:
            j = 0
        elif i == vertical:
            j = len(axis) // 2
        else:
            raise InvalidInputError(f"plot_slice needs {names[i]} fixed on the grid; it has "
                                    f"{len(axis)} values")
        index[i] = j
        if i in pos:
            at.append(f"{names[i]} = {float(axis[j]):.3g} m")
    return h, v, tuple(index), at


def _draw_values(ax: Axes, xs: NDArray, ys: NDArray, values: NDArray, quantity: str,
                 label: str, cmap: str | None) -> None:
    """Heat map of ``values`` (len(xs), len(ys)) with its colour bar."""
    data = np.ma.masked_invalid(np.asarray(values, dtype=float).T)
    if quantity == "feasible":
        from matplotlib.colors import ListedColormap

        mesh = ax.pcolormesh(xs, ys, data, shading="nearest",
                             cmap=ListedColormap(["#d9d9d9", "#2b8cbe"]), vmin=0, vmax=1)
        bar = ax.figure.colorbar(mesh, ax=ax, ticks=[0.25, 0.75])
        bar.ax.set_yticklabels(["infeasible", "feasible"])
    else:
        mesh = ax.pcolormesh(xs, ys, data, shading="nearest", cmap=cmap or "viridis")
        bar = ax.figure.colorbar(mesh, ax=ax)
        bar.set_label(label)


def _draw_boundary(ax: Axes, xs: NDArray, ys: NDArray, margin: NDArray) -> None:
    """The zero-margin contour; infinite margins are drawn as large finite ones."""
    level = np.asarray(margin, dtype=float)
    top = float(np.nanmax(np.abs(np.where(np.isfinite(level), level, np.nan)), initial=1.0))
    level = np.nan_to_num(level, nan=-2 * top, posinf=2 * top, neginf=-2 * top)
    ax.contour(xs, ys, level.T, levels=[0.0], colors="k", linewidths=1.0)


def _draw_anchors(ax: Axes, pattern: MotionPattern, anchors: NDArray, h: int, v: int,
                  xs: NDArray, ys: NDArray) -> None:
    """The drawing points (m, 3) projected on the plane of pose coordinates ``h``, ``v``."""
    base_axis = dict(zip(pattern.positions, pattern.position_axes, strict=True))
    ch, cv = base_axis[h], base_axis[v]
    ax.scatter(anchors[:, ch], anchors[:, cv], marker="^", s=60, c="crimson",
               edgecolors="k", zorder=3, label="drawing points", clip_on=False)
    # Room for the drawing points, which often sit on the edge of the grid's box.
    span = [np.concatenate([xs, anchors[:, ch]]), np.concatenate([ys, anchors[:, cv]])]
    for lim, vals, cur in ((ax.set_xlim, span[0], ax.get_xlim()),
                           (ax.set_ylim, span[1], ax.get_ylim())):
        lo, hi = min(cur[0], vals.min()), max(cur[1], vals.max())
        pad = 0.03 * (hi - lo)
        lim(lo - pad, hi + pad)


def plot_slice(result: WorkspaceResult, z: float | None = None, quantity: str = "margin",
               *, ax: Axes | None = None, cmap: str | None = None,
               show_anchors: bool = True, boundary: bool = True) -> Axes:
    """Heat map of a quantity over a slice of a grid workspace, with a colour bar.

    Parameters
    ----------
    result : WorkspaceResult
        From a :class:`~tension_opt.workspace.Grid`.
    z : float, optional
        Height of the x-y slice (m); the nearest grid layer is drawn (default: the
        middle one). The plotted plane is spanned by the first two position coordinates
        with more than one grid point: x-y, or y-z / x-z for a vertical slice (a grid
        with one point in x or y), where ``z`` is ignored, as it is by planar robots
        (x-y, or x-z for ``planar_point2``). Other coordinates must be fixed on the
        grid (except z, whose layer is picked).
    quantity : str
        ``"margin"`` (N), ``"feasible"``, ``"tension_sum"``, ``"max_tension"``,
        ``"T1"``.., or a subclass's own (``"sag_correction"``, m). Infinite values are
        left blank.
    ax : matplotlib Axes, optional
    cmap : str, optional
    show_anchors : bool
        Mark the drawing points (tower tops) projected on the plane.
    boundary : bool
        Draw the workspace boundary (zero-margin contour, or that of ``feasible`` where
        the margin's sign does not tell it: :meth:`WorkspaceResult.boundary_values`).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if result.grid_shape is None or result.axes is None:
        raise InvalidInputError("plot_slice needs a result computed on a Grid")
    pattern = result.pattern
    h, v, index, at = _slice_of(pattern, result.grid_shape, result.axes, z)
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5))
    xs, ys = result.axes[h], result.axes[v]
    values = result.reshape(result.quantity(quantity))[index]
    _draw_values(ax, xs, ys, values, quantity, result.label(quantity), cmap)
    feasible = result.reshape(result.feasible)[index]
    if boundary and np.any(feasible) and not np.all(feasible):
        _draw_boundary(ax, xs, ys, result.reshape(result.boundary_values())[index])
    anchors = result.robot.anchors if show_anchors and result.robot is not None else None
    if anchors is not None:
        _draw_anchors(ax, pattern, anchors, h, v, xs, ys)
    names = pattern.coordinates
    ax.set_xlabel(f"{names[h]} (m)")
    ax.set_ylabel(f"{names[v]} (m)")
    ax.set_aspect("equal")
    title = result.label(quantity)
    if at:
        title += " at " + ", ".join(at)
    if anchors is not None:
        title += "  (\u25b2 drawing points)"
    ax.set_title(title, fontsize="medium")
    return ax


def plot_workspace_3d(result: WorkspaceResult, quantity: str = "margin", *,
                      ax: Any = None, max_points: int = 20000,
                      cmap: str | None = None, seed: int = 0) -> Any:
    """3-D scatter of the feasible positions, coloured by a quantity, anchors marked.

    Parameters
    ----------
    result : WorkspaceResult
        Of a robot that moves in x, y and z (``point3``, ``spatial6``).
    quantity : str
        Colour (see :meth:`WorkspaceResult.quantity`).
    ax : matplotlib 3-D Axes, optional
    max_points : int
        At most this many feasible poses are drawn (a random subset).
    cmap : str, optional
    seed : int
        Seed of the random subset.

    Returns
    -------
    mpl_toolkits.mplot3d.Axes3D
    """
    import matplotlib.pyplot as plt

    pattern = result.pattern
    if tuple(pattern.position_axes) != (0, 1, 2):
        raise InvalidInputError("plot_workspace_3d draws robots that move in x, y, z")
    idx = np.flatnonzero(result.feasible)
    if len(idx) > max_points:
        idx = np.sort(np.random.default_rng(seed).choice(idx, max_points, replace=False))
    if ax is None:
        fig = plt.figure(figsize=(7, 6))
        ax = fig.add_subplot(projection="3d")
    values = np.asarray(result.quantity(quantity), dtype=float)[idx]
    values = np.where(np.isfinite(values), values, np.nan)
    pts = result.poses[idx][:, list(pattern.positions)]
    sc = ax.scatter(pts[:, 0], pts[:, 1], pts[:, 2], c=values, s=4, cmap=cmap or "viridis",
                    depthshade=False)
    ax.figure.colorbar(sc, ax=ax, shrink=0.7, label=result.label(quantity))
    if result.robot is not None:
        anchors = result.robot.anchors
        ax.scatter(anchors[:, 0], anchors[:, 1], anchors[:, 2], marker="^", s=60,
                   c="crimson", edgecolors="k", label="drawing points")
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    name = str(result.extras.get("criterion", "wrench_feasible")).replace("_", "-")
    ax.set_title(f"{name} workspace ({len(idx)} poses shown)")
    return ax
