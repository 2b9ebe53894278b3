"""One pose of a robot as a picture: :func:`plot_robot` (matplotlib or plotly)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal, Unpack

import numpy as np
from numpy.typing import ArrayLike

from tension_opt import CableRobot
from tension_opt.checks import is_number

from ..errors import InvalidCableError
from ..geometry import check_robot
from .drawing import (
    check_view,
    colour_map,
    draw_scene,
    new_axes,
    set_limits,
    state_legend,
    tension_norm,
)
from .options import ViewOptions, resolve, solve_options
from .scene import RobotScene, ViewModel, check_model, robot_scene

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["ENGINES", "check_axes", "check_positive_number", "plot_robot", "pose_label"]

#: The drawing engines of :func:`plot_robot`.
ENGINES: tuple[str, ...] = ("matplotlib", "plotly")


def check_positive_number(name: str, value: object) -> float:
    """``value`` as a float if it is a finite number > 0, else :class:`InvalidCableError`."""
    number = float(value) if is_number(value) else np.nan  # type: ignore[arg-type]
    if not np.isfinite(number) or number <= 0:
        raise InvalidCableError(f"{name} must be a finite number > 0; got {name}={value!r}")
    return number


def check_axes(ax: Any, view: str) -> None:
    """Raise unless ``ax`` is a matplotlib axes of the kind ``view`` needs."""
    from matplotlib.axes import Axes

    if not isinstance(ax, Axes):
        raise InvalidCableError(
            f"ax must be a matplotlib Axes (or None for a new figure); got {type(ax).__name__}"
        )
    three_d = getattr(ax, "name", "") == "3d"
    if three_d != (view == "3d"):
        need = (
            "3-D axes: fig.add_subplot(projection='3d')"
            if view == "3d"
            else "2-D axes: fig.add_subplot()"
        )
        raise InvalidCableError(
            f"view {view!r} needs {need}; got {ax.name!r} axes (or pass "
            f"view={'3d' if three_d else 'xz'!r})"
        )


def pose_label(robot: CableRobot, pose: np.ndarray) -> str:
    """The pose in words, ``x = 0 m, y = 0 m, z = 2 m`` (angles in degrees)."""
    parts = []
    for i, name in enumerate(robot.pattern.coordinates):
        if i in robot.pattern.positions:
            parts.append(f"{name} = {pose[i]:.3g} m")
        else:
            parts.append(f"{name} = {np.degrees(pose[i]):.3g}\u00b0")
    return ", ".join(parts)


def plot_robot(
    robot: CableRobot,
    pose: ArrayLike,
    tensions: ArrayLike | None = None,
    model: ViewModel = "coupled",
    ax: Any = None,
    *,
    engine: Literal["matplotlib", "plotly"] = "matplotlib",
    reference: ViewModel | None = None,
    view: str | None = None,
    z_scale: float = 1.0,
    **options: Unpack[ViewOptions],
) -> Figure | Any:
    """Draw the robot at one pose: drawing points, platform and cables coloured by tension.

    Parameters
    ----------
    robot : CableRobot
    pose : array_like, shape (n,)
        The platform pose (m, rad).
    tensions : array_like, shape (m,), optional
        Tension of each cable at its drawing point (N). Default: the sag model's own
        (:func:`catenary.inverse_kinematics`; :func:`tension_opt.distribute` for
        ``"straight"``).
    model : {"coupled", "thesis", "straight"}
        How the cables hang: the coupled sag model, the study's convention, or straight.
    ax : matplotlib Axes, optional
        Axes to draw on (3-D for the 3-D view); default a new figure.
    engine : {"matplotlib", "plotly"}
        ``"plotly"``: an interactive ``plotly.graph_objects.Figure`` (hover for tension,
        length and sag; the ``viz`` extra, ``pip install "tension-opt[viz]"``).
    reference : {"coupled", "thesis", "straight"}, optional
        Another model's cables drawn thin and dotted (e.g. straight against coupled).
    view : {"3d", "xy", "xz", "yz"}, optional
        3-D, or a projection on a base plane; default 3-D, a planar robot's plane.
    z_scale : float
        The vertical axis drawn ``z_scale`` times its true scale (ticks in metres), to
        show the sag of long flat robots.
    **options
        :class:`~catenary.viz.ViewOptions`: ``samples``, ``cmap``, ``tension_range``,
        ``platform_size``, ``colorbar``, ``legend``, ``title``, ``figsize``, and
        ``wrench``, ``objective``, ``backend``, ``solver_options`` of the solve.

    Returns
    -------
    matplotlib.figure.Figure or plotly.graph_objects.Figure
        One line per cable: matplotlib ``gid`` ``"cable <i>"``, plotly trace
        ``"cable <i+1>"``.

    Raises
    ------
    InvalidCableError
        For an unknown model, engine, view or option, axes of the wrong kind, or
        tensions of the wrong shape or sign.
    OptionalDependencyError
        For ``engine="plotly"`` without plotly.

    Examples
    --------
    >>> import tension_opt as to
    >>> fig = plot_robot(to.presets.algae_harvester(), [0.0, 0.0, 2.0], reference="straight")
    >>> len([a for a in fig.axes[0].lines if str(a.get_gid()).startswith("cable")])
    4
    """
    if engine not in ENGINES:
        raise InvalidCableError(f'engine must be "matplotlib" or "plotly"; got engine={engine!r}')
    if engine == "plotly" and ax is not None:
        raise InvalidCableError('engine="plotly" draws its own figure: pass ax=None')
    scene, other, view, z_scale, opts = _scenes(
        robot, pose, tensions, model, reference, view, z_scale, dict(options)
    )
    if engine == "matplotlib":
        return _matplotlib_figure(scene, other, ax, view, z_scale, opts)
    from .plotly_view import plotly_figure

    return plotly_figure([scene], other, view, z_scale, opts)


def _scenes(
    robot: CableRobot,
    pose: ArrayLike,
    tensions: ArrayLike | None,
    model: ViewModel,
    reference: ViewModel | None,
    view: str | None,
    z_scale: float,
    options: dict[str, Any],
) -> tuple[RobotScene, RobotScene | None, str, float, dict[str, Any]]:
    """The checked arguments of :func:`plot_robot`: its scene, the reference model's, the
    view, ``z_scale`` and the resolved options (the default title set)."""
    check_robot(robot, pulleys=True)
    check_model(model)
    if reference is not None:
        check_model(reference)
    view = check_view(view, robot)
    z_scale = check_positive_number("z_scale", z_scale)
    opts = resolve(options)
    solve = solve_options(opts)
    scene = robot_scene(robot, pose, tensions, model, samples=opts["samples"], **solve)
    other = (
        None
        if reference is None
        else robot_scene(robot, pose, None, reference, samples=opts["samples"], **solve)
    )
    if opts["title"] is None:
        shown = model if robot.cable is not None else "straight (no cable properties)"
        opts["title"] = f"{robot.name}: {shown} cables\n{pose_label(robot, scene.pose)}"
    return scene, other, view, z_scale, opts


def _matplotlib_figure(
    scene: RobotScene,
    other: RobotScene | None,
    ax: Any,
    view: str,
    z_scale: float,
    opts: dict[str, Any],
) -> Figure:
    """:func:`plot_robot` on matplotlib axes (``opts`` the resolved options)."""
    from matplotlib.cm import ScalarMappable

    if ax is None:
        ax = new_axes(view, opts["figsize"])
    else:
        check_axes(ax, view)
    colours = colour_map(opts["cmap"])
    norm = tension_norm([scene], opts["tension_range"])
    draw_scene(ax, scene, view, norm, colours, platform_size=opts["platform_size"], reference=other)
    set_limits(ax, [scene] if other is None else [scene, other], view, z_scale)
    fig = ax.figure
    if opts["colorbar"]:
        fig.colorbar(
            ScalarMappable(norm=norm, cmap=colours),
            ax=ax,
            shrink=0.7,
            pad=0.12 if view == "3d" else 0.04,
            label="tension at the drawing point (N)",
        )
    if opts["legend"]:
        state_legend(ax, [scene], other.model if other is not None else None)
    if opts["title"]:
        ax.set_title(opts["title"], fontsize="medium")
    return fig
