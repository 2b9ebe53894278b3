"""The platform moving along a path: :func:`animate` (GIF, MP4 or HTML) and
:func:`animation_figure` (one frame as a matplotlib figure).

The cables of every frame are solved in one batch (:func:`catenary.viz.robot_scenes`);
the left panel shows the robot with the path travelled so far, the right panel each
cable's tension at its drawing point along the path with a cursor at the frame.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot

from ..errors import InvalidCableError, OptionalDependencyError
from ..geometry import check_robot
from .drawing import (
    SceneArtists,
    check_view,
    colour_map,
    draw_scene,
    set_limits,
    state_legend,
    tension_norm,
)
from .scene import RobotScene, ViewModel, check_model, robot_scenes
from .views import check_positive_number

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["FORMATS", "animate", "animation_figure", "path_frames"]

FloatArray = NDArray[np.float64]
#: The file formats :func:`animate` writes, by suffix.
FORMATS: tuple[str, ...] = (".gif", ".mp4", ".html")


def path_frames(
    robot: CableRobot, poses_or_trajectory: Any, times: ArrayLike | None, frames: int | None
) -> tuple[FloatArray, FloatArray, bool, NDArray[np.intp]]:
    """The poses (F, n) and times (F,) of the frames, whether the times are real, and
    the index of each frame's pose in the path (F,).

    ``poses_or_trajectory`` is an array of poses (N, n) or anything with ``poses``
    (N, n) and ``times`` (N,) (a :class:`tension_opt.dynamics.TimedTrajectory`, a
    timing result). At most ``frames`` poses are kept, evenly spaced, both ends
    included.
    """
    source = getattr(poses_or_trajectory, "poses", poses_or_trajectory)
    poses = robot.as_poses(source)
    if times is None:
        times = getattr(poses_or_trajectory, "times", None)
    timed = times is not None
    t = np.arange(len(poses), dtype=float) if times is None else np.asarray(times, float)
    if t.shape != (len(poses),) or not np.isfinite(t).all():
        raise InvalidCableError(
            f"times must be finite, one per pose (shape ({len(poses)},), s); got shape {t.shape}"
        )
    keep = np.arange(len(poses))
    if frames is not None:
        if isinstance(frames, bool) or not isinstance(frames, int | np.integer) or frames < 1:
            raise InvalidCableError(
                f"frames must be an integer >= 1 (or None for every pose); got frames={frames!r}"
            )
        if len(poses) > frames:
            keep = np.unique(np.round(np.linspace(0, len(poses) - 1, frames)).astype(np.intp))
    return poses[keep], t[keep], timed, keep


class _Animator:
    """The figure of an animation and how it moves from frame to frame (matplotlib)."""

    def __init__(
        self,
        scenes: list[RobotScene],
        times: FloatArray,
        timed: bool,
        view: str,
        z_scale: float,
        style: dict[str, Any],
    ) -> None:
        import matplotlib.pyplot as plt

        self.scenes, self.times = scenes, times
        fig = plt.figure(figsize=style["figsize"])
        grid = fig.add_gridspec(1, 2, width_ratios=(1.5, 1.0))
        ax = fig.add_subplot(grid[0, 0], projection="3d" if view == "3d" else None)
        trace = fig.add_subplot(grid[0, 1])
        cmap = colour_map(style["cmap"])
        norm = tension_norm(scenes, style["tension_range"])
        self.art: SceneArtists = draw_scene(
            ax, scenes[0], view, norm, cmap, platform_size=style["platform_size"], linewidth=1.5
        )
        centres = np.array([s.attachments.mean(axis=0) for s in scenes])
        self.centres, self.view = centres, view
        coords = [centres[:1, k] for k in ((0, 1, 2) if view == "3d" else _plane(view))]
        self.trail: Any = ax.plot(*coords, color="k", lw=1.0, ls="--", zorder=1)[0]
        set_limits(ax, scenes, view, z_scale)
        state_legend(ax, scenes, None)
        fig.colorbar(
            _mappable(norm, cmap),
            ax=ax,
            shrink=0.6,
            pad=0.12 if view == "3d" else 0.04,
            label="tension (N)",
        )
        tensions = np.array([s.tensions for s in scenes])
        palette = colour_map("tab10")
        for i in range(tensions.shape[1]):
            trace.plot(times, tensions[:, i], color=palette(i % 10), lw=1.2, label=f"cable {i + 1}")
        self.cursor = trace.axvline(times[0], color="k", ls=":", lw=1.0)
        self.dots = trace.scatter(
            np.full(tensions.shape[1], times[0]),
            tensions[0],
            c=[palette(i % 10) for i in range(tensions.shape[1])],
            s=18,
            zorder=3,
        )
        trace.set_xlabel("time (s)" if timed else "pose")
        trace.set_ylabel("tension at the drawing point (N)")
        trace.legend(fontsize="small", ncol=2)
        if style["title"]:
            fig.suptitle(style["title"], fontsize="medium")
        fig.subplots_adjust(left=0.02, right=0.97, wspace=0.3)
        self.fig = fig

    def show(self, k: int) -> list[Any]:
        """Move every moving artist to frame ``k``; returns them."""
        self.art.update(self.scenes[k])
        seen = self.centres[: k + 1]
        axes = (0, 1, 2) if self.view == "3d" else _plane(self.view)
        if self.view == "3d":
            self.trail.set_data_3d(*(seen[:, a] for a in axes))
        else:
            self.trail.set_data(*(seen[:, a] for a in axes))
        self.cursor.set_xdata([self.times[k], self.times[k]])
        self.dots.set_offsets(
            np.column_stack([np.full(self.scenes[k].m, self.times[k]), self.scenes[k].tensions])
        )
        return [
            *self.art.halos,
            *self.art.cables,
            self.art.platform,
            self.trail,
            self.cursor,
            self.dots,
        ]

    def images(self, dpi: float) -> Iterator[NDArray[np.uint8]]:
        """Each frame as an RGBA image (h, w, 4): the still parts (axes, ticks, colour
        bar, the tension trace) drawn once, the moving artists blitted over them."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        self.fig.set_dpi(dpi)
        canvas = FigureCanvasAgg(self.fig)
        moving = self.show(0)
        for artist in moving:
            artist.set_animated(True)
        canvas.draw()
        background = canvas.copy_from_bbox(self.fig.bbox)
        for k in range(len(self.scenes)):
            self.show(k)
            canvas.restore_region(background)
            for artist in moving:
                if hasattr(artist, "do_3d_projection"):
                    artist.do_3d_projection()
                artist.axes.draw_artist(artist)
            yield np.array(canvas.buffer_rgba(), dtype=np.uint8)


def _plane(view: str) -> tuple[int, int]:
    """The base axes of a plane view."""
    from .drawing import PLANES

    return PLANES[view]


def _mappable(norm: Any, cmap: Any) -> Any:
    """A colour-bar source of the tension scale."""
    from matplotlib.cm import ScalarMappable

    return ScalarMappable(norm=norm, cmap=cmap)


def _prepare(
    robot: CableRobot, poses_or_trajectory: Any, options: dict[str, Any], solve: dict[str, Any]
) -> tuple[list[RobotScene], FloatArray, bool, str, float]:
    """Checked arguments and the solved scenes of an animation's frames."""
    check_robot(robot)
    check_model(options["model"])
    view = check_view(options["view"], robot)
    z_scale = check_positive_number("z_scale", options["z_scale"])
    poses, times, timed, keep = path_frames(
        robot, poses_or_trajectory, options["times"], options["frames"]
    )
    tensions = options["tensions"]
    if tensions is not None and np.ndim(tensions) == 2 and len(tensions) > len(keep):
        tensions = np.asarray(tensions, dtype=float)[keep]  # one row per pose of the path
    scenes = robot_scenes(
        robot, poses, tensions, options["model"], samples=options["samples"], **solve
    )
    return scenes, times, timed, view, z_scale


def animation_figure(
    robot: CableRobot,
    poses_or_trajectory: Any,
    frame: int = 0,
    *,
    tensions: ArrayLike | None = None,
    model: ViewModel = "coupled",
    times: ArrayLike | None = None,
    frames: int | None = 30,
    view: str | None = None,
    z_scale: float = 1.0,
    samples: int = 41,
    cmap: Any = "viridis",
    tension_range: ArrayLike | None = None,
    platform_size: float | None = None,
    title: str | None = None,
    figsize: tuple[float, float] = (11.0, 4.6),
    **solve: Any,
) -> Figure:
    """One frame of :func:`animate` as a matplotlib figure (same arguments, and the
    index ``frame`` among the kept frames, negative from the end)."""
    options = dict(
        model=model,
        view=view,
        z_scale=z_scale,
        times=times,
        frames=frames,
        tensions=tensions,
        samples=samples,
    )
    scenes, t, timed, view, z_scale = _prepare(robot, poses_or_trajectory, options, solve)
    if (
        isinstance(frame, bool)
        or not isinstance(frame, int | np.integer)
        or not (-len(scenes) <= frame < len(scenes))
    ):
        raise InvalidCableError(
            f"frame must be an integer index into the {len(scenes)} frames; got frame={frame!r}"
        )
    style = dict(
        cmap=cmap,
        tension_range=tension_range,
        platform_size=platform_size,
        figsize=figsize,
        title=_title(robot, model, title),
    )
    animator = _Animator(scenes, t, timed, view, z_scale, style)
    animator.show(int(frame) % len(scenes))
    return animator.fig


def _title(robot: CableRobot, model: str, title: str | None) -> str:
    """The default title of an animation."""
    return f"{robot.name}: {model} cables along the path" if title is None else title


def animate(
    robot: CableRobot,
    poses_or_trajectory: Any,
    path: str | Path,
    *,
    tensions: ArrayLike | None = None,
    model: ViewModel = "coupled",
    times: ArrayLike | None = None,
    frames: int | None = 30,
    fps: float = 10.0,
    view: str | None = None,
    z_scale: float = 1.0,
    samples: int = 41,
    cmap: Any = "viridis",
    tension_range: ArrayLike | None = None,
    platform_size: float | None = None,
    title: str | None = None,
    figsize: tuple[float, float] = (11.0, 4.6),
    dpi: int = 80,
    **solve: Any,
) -> Path:
    """Write the platform moving along a path, with its cables and a tension trace.

    Parameters
    ----------
    robot : CableRobot
    poses_or_trajectory : array_like, shape (N, n), or a trajectory
        Poses along the path (m, rad), or an object with ``poses`` (N, n) and ``times``
        (N,) (s): a :class:`tension_opt.dynamics.TimedTrajectory` or a timing result.
    path : str or Path
        The file to write; its suffix picks the format: ``.gif`` (matplotlib and
        pillow), ``.mp4`` (matplotlib, needs the ``ffmpeg`` program) or ``.html``
        (self-contained plotly page with a play button and a slider; the ``viz``
        extra).
    tensions : array_like, shape (N, m), optional
        Tension of each cable at its drawing point (N) at each pose (e.g. dynamic ones
        from :func:`tension_opt.dynamics.distribute_trajectory`); thinned with the
        poses. Default: the sag model's own static tensions.
    model : {"coupled", "thesis", "straight"}
    times : array_like, shape (N,), optional
        Time of each pose (s); default the trajectory's, else the pose index.
    frames : int or None
        At most this many frames, evenly spaced along the path (ends kept); None: one
        per pose.
    fps : float
        Frames per second of the GIF or MP4, and the HTML's playing speed.
    view, z_scale, samples, cmap, tension_range, platform_size
        As in :func:`catenary.viz.plot_robot` (``samples`` points per catenary).
    title : str, optional
        Default: the robot and the model; ``""`` for none.
    figsize : (float, float)
        Figure size (inches) of the GIF or MP4.
    dpi : int
        Resolution of the GIF or MP4 (dots per inch).
    **solve
        ``wrench``, ``objective``, ``backend``, solver options for the default tensions.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    InvalidCableError
        For an unknown suffix, model or view, or arguments out of their domain.
    OptionalDependencyError
        For ``.mp4`` without ffmpeg, ``.html`` without plotly.
    """
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in FORMATS:
        raise InvalidCableError(
            f"path must end in .gif, .mp4 or .html (the format); got {str(path)!r}"
        )
    fps = check_positive_number("fps", fps)
    options = dict(
        model=model,
        view=view,
        z_scale=z_scale,
        times=times,
        frames=frames,
        tensions=tensions,
        samples=samples,
    )
    scenes, t, timed, view, z_scale = _prepare(robot, poses_or_trajectory, options, solve)
    title = _title(robot, model, title)
    if suffix == ".html":
        from .plotly_view import plotly_animation

        fig = plotly_animation(
            scenes,
            t,
            view=view,
            z_scale=z_scale,
            cmap=cmap,
            tension_range=tension_range,
            platform_size=platform_size,
            title=title,
            frame_ms=round(1000 / fps),
        )
        fig.write_html(target, include_plotlyjs=True, full_html=True, auto_play=False)
        return target
    return _write_movie(
        scenes,
        t,
        timed,
        view,
        z_scale,
        target,
        fps,
        dpi,
        dict(
            cmap=cmap,
            tension_range=tension_range,
            platform_size=platform_size,
            figsize=figsize,
            title=title,
        ),
    )


def _write_movie(
    scenes: list[RobotScene],
    times: FloatArray,
    timed: bool,
    view: str,
    z_scale: float,
    target: Path,
    fps: float,
    dpi: int,
    style: dict[str, Any],
) -> Path:
    """Write a GIF (pillow, the frames blitted) or MP4 (matplotlib's ffmpeg writer)."""
    import matplotlib.pyplot as plt
    from matplotlib import animation

    animator = _Animator(scenes, times, timed, view, z_scale, style)
    try:
        if target.suffix.lower() == ".gif":
            from PIL import Image  # pillow comes with matplotlib

            frames = [Image.fromarray(image[..., :3]) for image in animator.images(dpi)]
            # One palette for every frame (no flicker), from the first.
            palette = frames[0].quantize(256, method=Image.Quantize.FASTOCTREE)
            frames = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
            frames[0].save(
                target, save_all=True, append_images=frames[1:], loop=0, duration=round(1000 / fps)
            )
            return target
        if not animation.writers.is_available("ffmpeg"):
            raise OptionalDependencyError(
                "an .mp4 needs the ffmpeg program (e.g. apt-get install ffmpeg); write a "
                ".gif or .html instead"
            )
        writer = animation.FFMpegWriter(fps=max(1, round(fps)))
        with writer.saving(animator.fig, str(target), dpi):
            for k in range(len(scenes)):
                animator.show(k)
                writer.grab_frame()
    finally:
        plt.close(animator.fig)
    return target
