"""Drawing a :class:`~catenary.viz.scene.RobotScene` on matplotlib axes (3-D or a plane).

The pieces :func:`catenary.viz.plot_robot` and :func:`catenary.viz.animate` share: the
projection of a view, the tension colour scale, the artists of one scene (which an
animation moves frame by frame) and the legend of the cable states. matplotlib is
imported by the functions, never at module import.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot

from ..errors import InvalidCableError
from .scene import RobotScene

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.colors import Colormap, Normalize

__all__ = [
    "PLANES",
    "STATE_STYLES",
    "VIEWS",
    "SceneArtists",
    "check_view",
    "colour_map",
    "default_view",
    "draw_scene",
    "hull_polygon",
    "new_axes",
    "set_limits",
    "state_legend",
    "tension_norm",
]

FloatArray = NDArray[np.float64]

#: The base axes each plane view shows (horizontal, vertical).
PLANES: dict[str, tuple[int, int]] = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
#: Every view: the 3-D one and the planes.
VIEWS: tuple[str, ...] = ("3d", *PLANES)
#: How each cable state is drawn: line style, fixed colour (None: its tension's), label.
STATE_STYLES: dict[str, tuple[str, str | None, str]] = {
    "taut": ("-", None, "taut"),
    "out_of_bounds": ("-", None, "outside [t_min, t_max]"),
    "slack": ("--", "0.55", "slack"),
    "infeasible": ("--", "red", "infeasible (no tensions)"),
}
#: Colour of the halo behind a cable outside its bounds.
BOUND_COLOUR = "red"
#: Colour and style of the reference model's cables.
REFERENCE_STYLE: dict[str, Any] = {"color": "0.35", "ls": ":", "lw": 1.2}


def default_view(robot: CableRobot) -> str:
    """The 3-D view for a robot that moves in space, the plane of a planar robot."""
    axes = tuple(robot.pattern.position_axes)
    if len(axes) == 2:
        return {(0, 1): "xy", (0, 2): "xz", (1, 2): "yz"}[(axes[0], axes[1])]
    return "3d"


def check_view(view: object, robot: CableRobot) -> str:
    """``view`` (or the robot's default for None) if it is one of :data:`VIEWS`."""
    if view is None:
        return default_view(robot)
    if view not in VIEWS:
        raise InvalidCableError(
            f'view must be "3d", "xy", "xz" or "yz" (or None for the '
            f"robot's own); got view={view!r}"
        )
    return str(view)


def colour_map(cmap: object) -> Colormap:
    """The matplotlib colour map named ``cmap`` (or ``cmap`` itself if it is one)."""
    import matplotlib as mpl
    from matplotlib.colors import Colormap

    if isinstance(cmap, Colormap):
        return cmap
    if isinstance(cmap, str) and cmap in mpl.colormaps:
        return mpl.colormaps[cmap]
    raise InvalidCableError(
        f"cmap must be a matplotlib colour map or its name (e.g. 'viridis'); got cmap={cmap!r}"
    )


def tension_norm(scenes: list[RobotScene], tension_range: ArrayLike | None) -> Normalize:
    """Colour scale of the tensions (N): ``tension_range`` or from the lowest bound (or
    tension) to the largest tension of the scenes."""
    from matplotlib.colors import Normalize

    if tension_range is not None:
        try:
            lo, hi = (float(v) for v in np.asarray(tension_range, dtype=float).ravel())
        except (TypeError, ValueError) as exc:
            raise InvalidCableError(
                f"tension_range must be two numbers (low, high) in N; got {tension_range!r}"
            ) from exc
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise InvalidCableError(
                f"tension_range must be finite with low < high (N); got ({lo}, {hi})"
            )
        return Normalize(lo, hi)
    values = np.concatenate([s.tensions[np.isfinite(s.tensions)] for s in scenes])
    t_min = float(np.min(scenes[0].robot.t_min))
    lo = min(t_min, float(values.min())) if values.size else t_min
    hi = float(values.max()) if values.size else lo + 1.0
    if hi <= lo:
        hi = lo + max(abs(lo), 1.0) * 0.1
    return Normalize(lo, hi)


def new_axes(view: str, figsize: tuple[float, float]) -> Axes:
    """A new figure with one axes for ``view`` (3-D or a plane)."""
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=figsize)
    if view == "3d":
        return fig.add_subplot(projection="3d")
    return fig.add_subplot()


def _project(points: FloatArray, view: str) -> list[FloatArray]:
    """Coordinates of points (..., 3) in a view: three for 3-D, two for a plane."""
    if view == "3d":
        return [points[..., 0], points[..., 1], points[..., 2]]
    h, v = PLANES[view]
    return [points[..., h], points[..., v]]


def hull_polygon(points: FloatArray) -> FloatArray:
    """The convex hull of 2-D points (k, 2) as a closed polygon's corners."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points, qhull_options="QJ")
    return np.asarray(points[hull.vertices], dtype=float)


@dataclass
class SceneArtists:
    """The artists of one scene on one axes, to be moved to another scene."""

    ax: Any
    view: str
    norm: Any
    cmap: Any
    platform_size: float | None
    cables: list[Any] = field(default_factory=list)
    halos: list[Any] = field(default_factory=list)
    references: list[Any] = field(default_factory=list)
    platform: Any = None
    anchors: Any = None
    wheels: list[tuple[int, Any]] = field(default_factory=list)

    def colour(self, scene: RobotScene, i: int) -> Any:
        """The colour of cable ``i``: its tension's, or its state's fixed colour."""
        fixed = STATE_STYLES[str(scene.state[i])][1]
        return fixed if fixed is not None else self.cmap(self.norm(scene.tensions[i]))

    def update(self, scene: RobotScene, reference: RobotScene | None = None) -> None:
        """Move the artists to ``scene`` (same robot, same view)."""
        for i, line in enumerate(self.cables):
            style = STATE_STYLES[str(scene.state[i])]
            _set_line(line, _project(scene.curves[i], self.view))
            line.set_color(self.colour(scene, i))
            line.set_linestyle(style[0])
            halo = self.halos[i]
            _set_line(halo, _project(scene.curves[i], self.view))
            halo.set_visible(bool(scene.state[i] == "out_of_bounds"))
        if reference is not None:
            for i, line in enumerate(self.references):
                _set_line(line, _project(reference.curves[i], self.view))
        for i, line in self.wheels:  # the pulleys swivel with the pose
            assert scene.wheels is not None
            _set_line(line, _project(scene.wheels[i], self.view))
        vertices, triangles = scene.platform(self.platform_size)
        if self.view == "3d":
            self.platform.set_verts(list(vertices[triangles]))
        else:
            self.platform.set_xy(hull_polygon(np.column_stack(_project(vertices, self.view))))


def _set_line(line: Any, coords: list[FloatArray]) -> None:
    """New data of a 2-D or 3-D line."""
    if len(coords) == 3:
        line.set_data_3d(*coords)
    else:
        line.set_data(*coords)


def draw_scene(
    ax: Any,
    scene: RobotScene,
    view: str,
    norm: Normalize,
    cmap: Colormap,
    *,
    platform_size: float | None = None,
    reference: RobotScene | None = None,
    linewidth: float = 2.0,
) -> SceneArtists:
    """Draw the drawing points, the platform and the cables of ``scene`` on ``ax``.

    Each cable is one line whose ``gid`` is ``"cable <i>"`` (i from 0), coloured by its
    tension at the drawing point, with a hidden red halo (``"halo <i>"``) shown while
    it is outside its bounds; the reference model's cables are ``"reference <i>"``, and
    the wheel of a cable's guide pulley ``"pulley <i>"``.
    """
    from matplotlib.patches import Polygon

    art = SceneArtists(ax, view, norm, cmap, platform_size)
    for i in range(scene.m):
        coords = _project(scene.curves[i], view)
        (halo,) = ax.plot(
            *coords,
            color=BOUND_COLOUR,
            lw=linewidth + 4,
            alpha=0.35,
            solid_capstyle="round",
            zorder=2,
        )
        halo.set_gid(f"halo {i}")
        (line,) = ax.plot(*coords, lw=linewidth, zorder=3)
        line.set_gid(f"cable {i}")
        art.halos.append(halo)
        art.cables.append(line)
    if reference is not None:
        for i in range(reference.m):
            (line,) = ax.plot(*_project(reference.curves[i], view), zorder=2, **REFERENCE_STYLE)
            line.set_gid(f"reference {i}")
            art.references.append(line)
    if scene.wheels is not None:
        for wheel in np.flatnonzero(np.isfinite(scene.wheels[:, 0, 0])).tolist():
            (line,) = ax.plot(*_project(scene.wheels[wheel], view), color="0.25", lw=1.0,
                              zorder=4)
            line.set_gid(f"pulley {wheel}")
            art.wheels.append((wheel, line))
    vertices, triangles = scene.platform(platform_size)
    if view == "3d":
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        art.platform = Poly3DCollection(
            list(vertices[triangles]), facecolor="0.6", edgecolor="0.3", linewidth=0.3, alpha=0.85
        )
        ax.add_collection3d(art.platform)
    else:
        art.platform = Polygon(
            hull_polygon(np.column_stack(_project(vertices, view))),
            closed=True,
            facecolor="0.6",
            edgecolor="0.2",
            zorder=4,
        )
        ax.add_patch(art.platform)
    art.platform.set_gid("platform")
    marks: dict[str, Any] = {"marker": "^", "s": 50, "c": "crimson", "edgecolors": "k", "zorder": 5}
    if view == "3d":
        marks["depthshade"] = False
    art.anchors = ax.scatter(*_project(scene.anchors, view), **marks)
    art.anchors.set_gid("drawing points")
    art.update(scene, reference)
    return art


def set_limits(ax: Any, scenes: list[RobotScene], view: str, z_scale: float) -> None:
    """Axis limits holding every scene, equal scales (the vertical ``z_scale`` times)."""
    points = np.concatenate([np.concatenate([s.curves.reshape(-1, 3), s.anchors]) for s in scenes])
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.04 * float((hi - lo).max())
    lo, hi = lo - pad, hi + pad
    if view == "3d":
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        span = hi - lo
        ax.set_box_aspect((span[0], span[1], span[2] * z_scale))
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)" if z_scale == 1 else f"z (m, drawn \u00d7{z_scale:g})")
        return
    h, v = PLANES[view]
    ax.set_xlim(lo[h], hi[h])
    ax.set_ylim(lo[v], hi[v])
    ax.set_aspect(z_scale if v == 2 else 1.0)
    names = "xyz"
    ax.set_xlabel(f"{names[h]} (m)")
    ax.set_ylabel(
        f"{names[v]} (m)" if v != 2 or z_scale == 1 else f"{names[v]} (m, drawn \u00d7{z_scale:g})"
    )


def state_legend(
    ax: Any, scenes: list[RobotScene], reference: str | None, loc: str = "upper left"
) -> Any:
    """Legend of the drawing points, the cable states that occur and the reference."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="^", ls="", color="crimson", mec="k", label="drawing points")]
    present = set().union(*(set(map(str, s.state)) for s in scenes))
    for state in ("out_of_bounds", "slack", "infeasible"):
        if state in present:
            ls, colour, label = STATE_STYLES[state]
            if state == "out_of_bounds":
                handles.append(Line2D([], [], color=BOUND_COLOUR, lw=6, alpha=0.35, label=label))
            else:
                handles.append(Line2D([], [], color=colour, ls=ls, lw=2, label=label))
    if reference is not None:
        handles.append(Line2D([], [], label=f"{reference} model", **REFERENCE_STYLE))
    return ax.legend(handles=handles, loc=loc, fontsize="small", framealpha=0.8)
