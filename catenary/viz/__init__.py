"""Views of a cable robot: its frame, platform and sagging cables, drawn or animated.

- :func:`plot_robot`: one pose as a matplotlib figure (3-D, planar robots in 2-D) or
  an interactive plotly figure (``engine="plotly"``, the ``viz`` extra);
- :func:`animate`: the platform moving along a path with a tension trace beside it,
  written as GIF or MP4 (matplotlib) or self-contained HTML (plotly);
  :func:`animation_figure` draws one of its frames;
- :func:`plot_workspace` and :func:`plot_compliance`: overlays of a workspace result
  (feasible points coloured by their margin) and of the platform's compliance
  ellipsoid at a pose;
- :func:`robot_scene`, :func:`robot_scenes`: what the views draw, as arrays
  (:class:`RobotScene`).

matplotlib and plotly are imported when a view is drawn, not on import.
"""

from .animation import animate, animation_figure
from .options import ViewOptions
from .overlays import compliance_ellipsoid, plot_compliance, plot_workspace
from .scene import MODELS, STATES, RobotScene, robot_scene, robot_scenes, sag_below_chord
from .views import plot_robot

__all__ = [
    "MODELS",
    "STATES",
    "RobotScene",
    "ViewOptions",
    "animate",
    "animation_figure",
    "compliance_ellipsoid",
    "plot_compliance",
    "plot_robot",
    "plot_workspace",
    "robot_scene",
    "robot_scenes",
    "sag_below_chord",
]
