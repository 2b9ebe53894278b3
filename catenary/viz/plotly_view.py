"""Interactive views in plotly: one pose (:func:`plotly_figure`) and an animation with
its tension trace (:func:`plotly_animation`).

plotly is an optional extra (``pip install "tension-opt[viz]"``); :func:`require_plotly`
imports it when a view is drawn and says which extra to install when it is missing.
The traces mirror the matplotlib view: one trace per cable named ``"cable <i>"`` (from
1) whose hover shows its tensions, lengths and sag, the drawing points, the platform as
a mesh, and an invisible trace that carries the tension colour bar.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OptionalDependencyError
from .drawing import PLANES, STATE_STYLES, colour_map, tension_norm
from .scene import RobotScene

__all__ = ["cable_traces", "plotly_animation", "plotly_figure", "require_plotly"]

FloatArray = NDArray[np.float64]
#: plotly's dash of each matplotlib line style.
_DASH = {"-": "solid", "--": "dash", ":": "dot"}


def require_plotly() -> Any:
    """``plotly.graph_objects``, or :class:`OptionalDependencyError` naming the extra."""
    try:
        import plotly.graph_objects as go
    except ImportError as exc:
        raise OptionalDependencyError(
            'engine="plotly" and HTML animations need plotly: pip install "tension-opt[viz]" '
            '(or pip install "plotly>=5"); engine="matplotlib" needs nothing more'
        ) from exc
    return go


def _rgb(colour: Any) -> str:
    """A matplotlib colour as plotly's ``rgb(r, g, b)``."""
    from matplotlib.colors import to_rgb

    r, g, b = (round(255 * c) for c in to_rgb(colour))
    return f"rgb({r},{g},{b})"


def _colourscale(cmap: Any) -> list[list[Any]]:
    """A matplotlib colour map as a plotly colour scale (11 stops)."""
    colours = colour_map(cmap)
    return [[float(t), _rgb(colours(float(t)))] for t in np.linspace(0.0, 1.0, 11)]


def _coords(points: FloatArray, view: str) -> dict[str, FloatArray]:
    """Trace coordinates of points (k, 3): x, y, z in 3-D, x, y on a plane."""
    if view == "3d":
        return {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2]}
    h, v = PLANES[view]
    return {"x": points[:, h], "y": points[:, v]}


def _hover(scene: RobotScene, i: int) -> str:
    """What the hover shows for cable ``i``."""
    return (
        f"cable {i + 1} ({scene.state[i]})<br>"
        f"tension at drawing point {scene.tensions[i]:.1f} N<br>"
        f"tension at platform {scene.tensions_platform[i]:.1f} N<br>"
        f"unstretched length {scene.lengths[i]:.4f} m<br>"
        f"chord {scene.straight_lengths[i]:.4f} m<br>"
        f"sag below chord {scene.sag[i]:.4f} m"
    )


def cable_traces(
    go: Any, scene: RobotScene, view: str, norm: Any, cmap: Any, reference: bool = False
) -> list[Any]:
    """One line trace per cable of ``scene``, coloured by tension (or its state's colour).

    ``reference``: thin grey dotted lines named after the model (``"straight model"``),
    without hover. Then, over guide pulleys, one thin dark line per wheel.
    """
    traces = []
    colours = colour_map(cmap)
    scatter = go.Scatter3d if view == "3d" else go.Scatter
    for i in range(scene.m):
        if reference:
            line = {"color": "rgb(90,90,90)", "width": 2, "dash": "dot"}
            traces.append(
                scatter(
                    **_coords(scene.curves[i], view),
                    mode="lines",
                    line=line,
                    name=f"{scene.model} model",
                    hoverinfo="skip",
                    showlegend=i == 0,
                    legendgroup="reference",
                )
            )
            continue
        style, fixed, _ = STATE_STYLES[str(scene.state[i])]
        colour = fixed if fixed is not None else colours(norm(scene.tensions[i]))
        width = 9 if scene.state[i] == "out_of_bounds" else 6
        line = {
            "color": _rgb(colour),
            "width": width if view == "3d" else width / 2,
            "dash": _DASH[style],
        }
        traces.append(
            scatter(
                **_coords(scene.curves[i], view),
                mode="lines",
                line=line,
                name=f"cable {i + 1}",
                text=[_hover(scene, i)] * len(scene.curves[i]),
                hovertemplate="%{text}<extra></extra>",
            )
        )
    if scene.wheels is not None and not reference:
        shown = np.flatnonzero(np.isfinite(scene.wheels[:, 0, 0])).tolist()
        for j, wheel in enumerate(shown):
            traces.append(
                scatter(
                    **_coords(scene.wheels[wheel], view),
                    mode="lines",
                    line={"color": "rgb(60,60,60)", "width": 2 if view == "3d" else 1},
                    name="guide pulleys",
                    hoverinfo="skip",
                    showlegend=j == 0,
                    legendgroup="pulleys",
                )
            )
    return traces


def _fixed_traces(
    go: Any,
    scene: RobotScene,
    view: str,
    norm: Any,
    cmap: Any,
    platform_size: float | None,
    bar_x: float = 1.02,
) -> list[Any]:
    """The platform, the drawing points and the colour-bar carrier of ``scene`` (its
    colour bar at ``bar_x``, paper coordinates)."""
    vertices, triangles = scene.platform(platform_size)
    anchors = {
        "marker": {
            "symbol": "diamond" if view == "3d" else "triangle-up",
            "size": 6,
            "color": "crimson",
            "line": {"color": "black", "width": 1},
        },
        "mode": "markers",
        "name": "drawing points",
        "hoverinfo": "skip",
    }
    centre = scene.attachments.mean(axis=0, keepdims=True)
    bar = {
        "mode": "markers",
        "name": "tension scale",
        "showlegend": False,
        "hoverinfo": "skip",
        "marker": {
            "size": 0.1,
            "opacity": 0,
            "color": [norm.vmin],
            "cmin": norm.vmin,
            "cmax": norm.vmax,
            "colorscale": _colourscale(cmap),
            "showscale": True,
            "colorbar": {"title": {"text": "tension (N)"}, "x": bar_x, "len": 0.8},
        },
    }
    if view == "3d":
        platform = go.Mesh3d(
            **_coords(vertices, view),
            i=triangles[:, 0],
            j=triangles[:, 1],
            k=triangles[:, 2],
            color="rgb(150,150,150)",
            opacity=0.9,
            name="platform",
            hoverinfo="skip",
            showlegend=True,
        )
        return [
            platform,
            go.Scatter3d(**_coords(scene.anchors, view), **anchors),
            go.Scatter3d(**_coords(centre, view), **bar),
        ]
    from .drawing import hull_polygon

    corners = hull_polygon(np.column_stack(list(_coords(vertices, view).values())))
    corners = np.vstack([corners, corners[:1]])
    platform = go.Scatter(
        x=corners[:, 0],
        y=corners[:, 1],
        fill="toself",
        mode="lines",
        line={"color": "rgb(60,60,60)"},
        fillcolor="rgb(150,150,150)",
        name="platform",
        hoverinfo="skip",
    )
    return [
        platform,
        go.Scatter(**_coords(scene.anchors, view), **anchors),
        go.Scatter(**_coords(centre, view), **bar),
    ]


def _layout(scenes: list[RobotScene], view: str, z_scale: float) -> dict[str, Any]:
    """Equal scales (the vertical ``z_scale`` times) holding every scene."""
    points = np.concatenate([np.concatenate([s.curves.reshape(-1, 3), s.anchors]) for s in scenes])
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.04 * float((hi - lo).max())
    lo, hi = lo - pad, hi + pad
    if view == "3d":
        span = (hi - lo) * np.array([1.0, 1.0, z_scale])
        ratio = span / span.max()
        axes = {
            f"{n}axis": {"range": [lo[k], hi[k]], "title": {"text": f"{n} (m)"}}
            for k, n in enumerate("xyz")
        }
        return {
            "scene": {
                **axes,
                "aspectmode": "manual",
                "aspectratio": dict(zip("xyz", map(float, ratio), strict=True)),
            }
        }
    h, v = PLANES[view]
    return {
        "xaxis": {"range": [lo[h], hi[h]], "title": {"text": f"{'xyz'[h]} (m)"}},
        "yaxis": {
            "range": [lo[v], hi[v]],
            "title": {"text": f"{'xyz'[v]} (m)"},
            "scaleanchor": "x",
            "scaleratio": z_scale if v == 2 else 1.0,
        },
    }


def plotly_figure(
    scenes: list[RobotScene],
    reference: RobotScene | None,
    view: str,
    z_scale: float,
    opts: dict[str, Any],
) -> Any:
    """The interactive figure of ``scenes[0]`` (see :func:`catenary.viz.plot_robot`;
    ``opts`` its resolved :class:`~catenary.viz.ViewOptions`)."""
    cmap, tension_range = opts["cmap"], opts["tension_range"]
    platform_size, title = opts["platform_size"], opts["title"]
    go = require_plotly()
    scene = scenes[0]
    norm = tension_norm(scenes, tension_range)
    data = cable_traces(go, scene, view, norm, cmap)
    if reference is not None:
        data += cable_traces(go, reference, view, norm, cmap, reference=True)
    data += _fixed_traces(go, scene, view, norm, cmap, platform_size)
    fig = go.Figure(data=data)
    fig.update_layout(
        title={"text": title.replace("\n", "<br>")},
        template="plotly_white",
        legend={"x": 0.0, "y": 1.0},
        margin={"l": 10, "r": 10, "t": 60, "b": 10},
        **_layout(scenes if reference is None else [*scenes, reference], view, z_scale),
    )
    return fig


def plotly_animation(
    scenes: list[RobotScene],
    times: FloatArray,
    *,
    view: str,
    z_scale: float,
    cmap: Any,
    tension_range: ArrayLike | None,
    platform_size: float | None,
    title: str,
    frame_ms: int,
    time_label: str = "time (s)",
) -> Any:
    """The platform moving through ``scenes`` at ``times`` (s), with the tension trace
    beside it and a frame cursor on the trace; a play button and a slider."""
    go = require_plotly()
    from plotly.subplots import make_subplots

    norm = tension_norm(scenes, tension_range)
    first = scenes[0]
    left = {"type": "scene"} if view == "3d" else {"type": "xy"}
    fig = make_subplots(
        rows=1,
        cols=2,
        specs=[[left, {"type": "xy"}]],
        column_widths=[0.58, 0.42],
        horizontal_spacing=0.16,
    )
    moving = cable_traces(go, first, view, norm, cmap)
    moving += _fixed_traces(go, first, view, norm, cmap, platform_size)[:1]
    still = _fixed_traces(go, first, view, norm, cmap, platform_size, bar_x=0.5)[1:]
    for trace in moving + still:
        fig.add_trace(trace, row=1, col=1)
    tensions = np.array([s.tensions for s in scenes])
    colours = colour_map("tab10")
    for i in range(first.m):
        fig.add_trace(
            go.Scatter(
                x=times,
                y=tensions[:, i],
                mode="lines",
                name=f"T{i + 1}",
                line={"color": _rgb(colours(i % 10))},
                hovertemplate="t = %{x:.2f} s<br>%{y:.1f} N",
            ),
            row=1,
            col=2,
        )
    finite = tensions[np.isfinite(tensions)]
    span = [float(finite.min()), float(finite.max())] if finite.size else [0.0, 1.0]
    cursor = go.Scatter(
        x=[times[0]] * 2,
        y=span,
        mode="lines",
        name="now",
        line={"color": "black", "dash": "dot"},
        hoverinfo="skip",
    )
    fig.add_trace(cursor, row=1, col=2)
    index = [*range(len(moving)), len(fig.data) - 1]
    frames = []
    for k, scene in enumerate(scenes):
        data = cable_traces(go, scene, view, norm, cmap)
        data += _fixed_traces(go, scene, view, norm, cmap, platform_size)[:1]
        data.append(go.Scatter(x=[times[k]] * 2, y=span))
        frames.append(go.Frame(data=data, traces=index, name=str(k)))
    fig.frames = frames
    _animation_controls(fig, len(scenes), times, frame_ms)
    layout = _layout(scenes, view, z_scale)
    if view != "3d":
        layout["yaxis"]["scaleanchor"] = "x"
    fig.update_layout(
        title={"text": title},
        template="plotly_white",
        xaxis2={"title": {"text": time_label}},
        yaxis2={"title": {"text": "tension at the drawing point (N)"}},
        **layout,
    )
    return fig


def _animation_controls(fig: Any, count: int, times: FloatArray, frame_ms: int) -> None:
    """A play/pause button and a time slider over the frames."""
    play = {
        "label": "play",
        "method": "animate",
        "args": [
            None,
            {
                "frame": {"duration": frame_ms, "redraw": True},
                "fromcurrent": True,
                "transition": {"duration": 0},
            },
        ],
    }
    pause = {
        "label": "pause",
        "method": "animate",
        "args": [[None], {"frame": {"duration": 0, "redraw": False}, "mode": "immediate"}],
    }
    steps = [
        {
            "label": f"{times[k]:.2f}",
            "method": "animate",
            "args": [[str(k)], {"frame": {"duration": 0, "redraw": True}, "mode": "immediate"}],
        }
        for k in range(count)
    ]
    fig.update_layout(
        updatemenus=[
            {
                "type": "buttons",
                "buttons": [play, pause],
                "x": 0.0,
                "y": -0.05,
                "xanchor": "left",
                "yanchor": "top",
                "direction": "left",
            }
        ],
        sliders=[
            {
                "steps": steps,
                "x": 0.12,
                "y": -0.05,
                "len": 0.85,
                "currentvalue": {"prefix": "t (s) = "},
            }
        ],
    )
