"""The keyword options every view takes (:class:`ViewOptions`), checked in one place."""

from __future__ import annotations

from typing import Any, TypedDict

from ..errors import InvalidCableError

__all__ = ["DEFAULTS", "ViewOptions", "resolve", "solve_options"]


class ViewOptions(TypedDict, total=False):
    """Keyword options of :func:`~catenary.viz.plot_robot`, :func:`~catenary.viz.animate`
    and :func:`~catenary.viz.animation_figure`.

    Attributes
    ----------
    samples : int
        Points along each catenary, >= 2 (101; 41 in animations).
    cmap : str or matplotlib Colormap
        Colour map of the tensions (``"viridis"``).
    tension_range : (float, float)
        Tensions (N) at the two ends of the colour scale; default from the lowest
        bound or tension to the largest tension drawn.
    platform_size : float
        Smallest extent of the platform solid (m); default 2 % of the frame.
    colorbar, legend : bool
        Draw the tension colour bar and the legend (drawing points, and the slack,
        infeasible and out-of-bounds cables where there are some). True.
    title : str
        Default: the robot, the model and the pose; ``""`` for none.
    figsize : (float, float)
        Size of a new figure (inches): (7, 5.5); (11, 4.6) in animations.
    wrench : array_like, shape (n,) or (N, n)
        External wrench on the platform besides gravity (N, N m) for the default
        tensions.
    objective, backend
        How the default tensions are chosen, as in :func:`tension_opt.distribute`
        (``"min_sum"``, ``"auto"``).
    solver_options : dict
        Further options of the solve of the default tensions.
    """

    samples: int
    cmap: Any
    tension_range: Any
    platform_size: float | None
    colorbar: bool
    legend: bool
    title: str | None
    figsize: tuple[float, float]
    wrench: Any
    objective: Any
    backend: Any
    solver_options: dict[str, Any]


#: The default of every option.
DEFAULTS: dict[str, Any] = {
    "samples": 101,
    "cmap": "viridis",
    "tension_range": None,
    "platform_size": None,
    "colorbar": True,
    "legend": True,
    "title": None,
    "figsize": (7.0, 5.5),
    "wrench": None,
    "objective": "min_sum",
    "backend": "auto",
    "solver_options": None,
}


def resolve(options: dict[str, Any], **defaults: Any) -> dict[str, Any]:
    """Every option: those given over ``defaults`` over :data:`DEFAULTS`.

    Raises
    ------
    InvalidCableError
        For an option no view takes, naming those that exist.
    """
    unknown = sorted(set(options) - set(DEFAULTS))
    if unknown:
        raise InvalidCableError(
            f"unknown option(s) {unknown}; the views take "
            f"{sorted(DEFAULTS)} (catenary.viz.ViewOptions)"
        )
    return {**DEFAULTS, **defaults, **options}


def solve_options(options: dict[str, Any]) -> dict[str, Any]:
    """The keywords of :func:`catenary.viz.robot_scenes`' solve among resolved options."""
    extra = options["solver_options"] or {}
    if not isinstance(extra, dict):
        raise InvalidCableError(
            f"solver_options must be a dict of solver options; got {type(extra).__name__}"
        )
    return {
        "wrench": options["wrench"],
        "objective": options["objective"],
        "backend": options["backend"],
        **extra,
    }
