"""The platform moving along a path: :func:`animate` (GIF, MP4 or HTML) and
:func:`animation_figure` (one frame as a matplotlib figure).

The cables of every frame are solved in one batch (:func:`catenary.viz.robot_scenes`);
the left panel shows the robot with the path travelled so far, the right panel each
cable's tension at its drawing point along the path with a cursor at the frame.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Unpack

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
from .options import ViewOptions, resolve, solve_options
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
            pad=0.16 if view == "3d" else 0.04,
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
    robot: CableRobot,
    poses_or_trajectory: Any,
    frame_args: dict[str, Any],
    options: dict[str, Any],
) -> tuple[list[RobotScene], FloatArray, bool, str, float, dict[str, Any]]:
    """Checked arguments, the solved scenes of an animation's frames, their times,
    whether those are times, the view, its ``z_scale`` and the resolved options."""
    check_robot(robot, pulleys=True)
    model = frame_args["model"]
    check_model(model)
    view = check_view(frame_args["view"], robot)
    z_scale = check_positive_number("z_scale", frame_args["z_scale"])
    opts = resolve(options, samples=41, figsize=(11.0, 4.6))
    if opts["title"] is None:
        opts["title"] = f"{robot.name}: {model} cables along the path"
    poses, times, timed, keep = path_frames(
        robot, poses_or_trajectory, frame_args["times"], frame_args["frames"]
    )
    tensions = frame_args["tensions"]
    if tensions is not None and np.ndim(tensions) == 2 and len(tensions) > len(keep):
        tensions = np.asarray(tensions, dtype=float)[keep]  # one row per pose of the path
    scenes = robot_scenes(
        robot,
        poses,
        tensions,
        model,  # type: ignore[arg-type]
        samples=opts["samples"],
        **solve_options(opts),
    )
    return scenes, times, timed, view, z_scale, opts


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
    **options: Unpack[ViewOptions],
) -> Figure:
    """One frame of :func:`animate` as a matplotlib figure: the same arguments, and
    ``frame`` the index among the kept frames (negative from the end)."""
    frame_args = dict(
        tensions=tensions, model=model, times=times, frames=frames, view=view, z_scale=z_scale
    )
    scenes, t, timed, view, z_scale, opts = _prepare(
        robot, poses_or_trajectory, frame_args, dict(options)
    )
    if (
        isinstance(frame, bool)
        or not isinstance(frame, int | np.integer)
        or not (-len(scenes) <= frame < len(scenes))
    ):
        raise InvalidCableError(
            f"frame must be an integer index into the {len(scenes)} frames; got frame={frame!r}"
        )
    animator = _Animator(scenes, t, timed, view, z_scale, opts)
    animator.show(int(frame) % len(scenes))
    return animator.fig


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
    dpi: int = 80,
    **options: Unpack[ViewOptions],
) -> Path:
    """Write the platform moving along a path, with its cables and a tension trace.

    Parameters
    ----------
    robot : CableRobot
    poses_or_trajectory : array_like, shape (N, n), or a trajectory
        Poses along the path (m, rad), or an object with ``poses`` (N, n) and ``times``
        (N,) (s): a :class:`tension_opt.dynamics.TimedTrajectory`, a timing result.
    path : str or Path
        The file; its suffix is the format: ``.gif`` (matplotlib and pillow), ``.mp4``
        (needs the ``ffmpeg`` program) or ``.html`` (one self-contained plotly page
        with a play button and a slider; the ``viz`` extra).
    tensions : array_like, shape (N, m), optional
        Tension of each cable at its drawing point (N) at each pose (e.g. dynamic ones,
        :func:`tension_opt.dynamics.distribute_trajectory`). Default: the model's own.
    model : {"coupled", "thesis", "straight"}
    times : array_like, shape (N,), optional
        Time of each pose (s); default the trajectory's, else the pose index.
    frames : int or None
        At most this many frames, evenly spaced (ends kept); None: one per pose.
    fps : float
        Frames per second (the HTML's playing speed too).
    view, z_scale
        As in :func:`catenary.viz.plot_robot`.
    dpi : int
        Resolution of a GIF or MP4 (dots per inch).
    **options
        :class:`~catenary.viz.ViewOptions` (``samples`` 41, ``figsize`` (11, 4.6)).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    InvalidCableError
        For an unknown suffix, model, view or option, or arguments out of their domain.
    OptionalDependencyError
        For ``.mp4`` without ffmpeg, ``.html`` without plotly.
    """
    target = Path(path)
    if target.suffix.lower() not in FORMATS:
        raise InvalidCableError(
            f"path must end in .gif, .mp4 or .html (the format); got {str(path)!r}"
        )
    fps = check_positive_number("fps", fps)
    frame_args = dict(
        tensions=tensions, model=model, times=times, frames=frames, view=view, z_scale=z_scale
    )
    prepared = _prepare(robot, poses_or_trajectory, frame_args, dict(options))
    if target.suffix.lower() == ".html":
        return _write_html(prepared, target, fps)
    return _write_movie(*prepared[:5], target, fps, dpi, prepared[5])


def _write_html(
    prepared: tuple[list[RobotScene], FloatArray, bool, str, float, dict[str, Any]],
    target: Path,
    fps: float,
) -> Path:
    """Write the frames as one self-contained plotly page."""
    from .plotly_view import plotly_animation

    scenes, t, timed, view, z_scale, opts = prepared
    fig = plotly_animation(
        scenes,
        t,
        view=view,
        z_scale=z_scale,
        cmap=opts["cmap"],
        tension_range=opts["tension_range"],
        platform_size=opts["platform_size"],
        title=opts["title"],
        frame_ms=round(1000 / fps),
        time_label="time (s)" if timed else "pose",
    )
    fig.write_html(target, include_plotlyjs=True, full_html=True, auto_play=False)
    return target


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
