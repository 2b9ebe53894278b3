"""The interference-free workspace: poses whose cables keep a minimum clearance.

A pose is *interference-free* when every two cables stay at least ``clearance`` (m)
apart (:func:`tension_opt.workspace.interference.cable_clearance`; compare a cable
diameter). Alone, or combined with wrench feasibility (both must hold). Sagging cables
are :func:`catenary.interference_free_workspace`, which builds the same result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace.compute import prepare, wrench_feasible_workspace
from tension_opt.workspace.grid import Grid
from tension_opt.workspace.interference import (
    SHARED_TRIM,
    CableClearance,
    cable_clearance,
    check_clearance,
)
from tension_opt.workspace.platform import PlatformClearance, platform_clearance
from tension_opt.workspace.result import WorkspaceResult

__all__ = ["InterferenceResult", "interference_free_workspace", "interference_result"]


@dataclass(eq=False)
class InterferenceResult(WorkspaceResult):
    """An interference-free workspace (:func:`interference_free_workspace`).

    The fields of :class:`WorkspaceResult`, with ``feasible`` true where the smallest
    distance between two cables exceeds the required ``clearance`` (and, with
    ``with_wrenches``, the pose is also wrench-feasible). ``margin`` is the capacity
    margin (N) of the wrench check where it was made, else the clearance excess
    ``cable_clearance - required`` (m).

    Attributes
    ----------
    cable_clearance : ndarray, shape (N,)
        Smallest distance between two cables (m); NaN where a sag model failed.
    pair : ndarray of int, shape (N, 2)
        The closest two cables.
    required : float
        The required clearance (m).
    interference_free : ndarray of bool, shape (N,)
        ``cable_clearance > required``.
    wrench_feasible : ndarray of bool, shape (N,)
        Wrench feasibility; all true when it was not checked.
    clearances : CableClearance
        Every pair's distance, closest points and certified lower bound.
    platform : PlatformClearance, optional
        The cables' distances to the platform where it was checked (``with_platform``);
        then ``interference_free`` also needs ``platform.clearance > required``.
    """

    cable_clearance: NDArray = field(default_factory=lambda: np.zeros(0))
    pair: NDArray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.intp))
    required: float = 0.0
    interference_free: NDArray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    wrench_feasible: NDArray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    clearances: CableClearance | None = field(default=None, repr=False)
    platform: PlatformClearance | None = field(default=None, repr=False)

    QUANTITIES: ClassVar[dict[str, str]] = {
        **WorkspaceResult.QUANTITIES,
        "cable_clearance": "smallest distance between cables (m)",
        "interference_free": "interference-free",
    }

    def quantity(self, name: str) -> NDArray:
        """A per-pose quantity by name; adds ``"cable_clearance"`` (m) and
        ``"interference_free"`` (0/1) to :meth:`WorkspaceResult.quantity`."""
        if name == "cable_clearance":
            return np.asarray(self.cable_clearance, dtype=float)
        if name == "interference_free":
            return np.asarray(self.interference_free, dtype=float)
        return super().quantity(name)

    def _extra_columns(self, frame: Any) -> None:
        frame["cable_clearance"] = self.cable_clearance
        frame["interference_free"] = self.interference_free
        frame["wrench_feasible"] = self.wrench_feasible


def interference_result(
    robot: CableRobot,
    poses: NDArray,
    layout: dict[str, Any],
    clear: CableClearance,
    required: float,
    wrench: WorkspaceResult | None,
    platform: PlatformClearance | None = None,
) -> InterferenceResult:
    """Assemble an :class:`InterferenceResult` from clearances and an optional wrench check.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Checked poses (m, rad).
    layout : dict
        ``grid_shape``, ``axes``, ``bounds`` (:func:`tension_opt.workspace.prepare`).
    clear : CableClearance
        Clearances of the poses.
    required : float
        Required clearance (m), checked.
    wrench : WorkspaceResult or None
        The wrench-feasible workspace of the same poses, or None for clearance alone.
    platform : PlatformClearance, optional
        The cables' distances to the platform, also required to exceed ``required``.
    """
    N = poses.shape[0]
    with np.errstate(invalid="ignore"):
        free = np.asarray(clear.clearance > required, dtype=bool)
        if platform is not None:
            free &= platform.clearance > required
    excess = clear.clearance - required
    if wrench is None:
        status = status_array(N, Status.INFEASIBLE)
        status[free] = Status.OPTIMAL
        return InterferenceResult(
            poses,
            free,
            excess,
            np.full((N, robot.m), np.nan),
            status,
            excess[:, None],
            np.zeros(N, dtype=np.intp),
            np.zeros((1, robot.dof)),
            robot=robot,
            backend="interference",
            extras={"criterion": "interference_free",
                    "margin_label": "clearance excess (m)"},
            cable_clearance=clear.clearance,
            pair=clear.pair,
            required=required,
            interference_free=free,
            wrench_feasible=np.ones(N, dtype=bool),
            clearances=clear,
            platform=platform,
            **layout,
        )
    return InterferenceResult(
        poses,
        free & wrench.feasible,
        wrench.margin,
        wrench.tensions,
        wrench.status,
        wrench.margins,
        wrench.critical_wrench,
        wrench.wrenches,
        robot=robot,
        backend=wrench.backend,
        extras={**wrench.extras, "criterion": "interference_free"},
        cable_clearance=clear.clearance,
        pair=clear.pair,
        required=required,
        interference_free=free,
        wrench_feasible=np.asarray(wrench.feasible, dtype=bool),
        clearances=clear,
        platform=platform,
        **layout,
    )


def interference_free_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    clearance: float = 0.0,
    *,
    with_wrenches: bool = False,
    wrenches: ArrayLike | None = None,
    shared_trim: float = SHARED_TRIM,
    with_platform: bool = False,
    platform_hull: ArrayLike | None = None,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    **options: Any,
) -> InterferenceResult:
    """Which poses keep every two straight cables more than ``clearance`` apart.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad); a :class:`Grid` keeps its shape for ``volume()`` and
        the plots.
    clearance : float
        Required smallest distance between two cables (m), >= 0; e.g. the cable
        diameter ``robot.cable.diameter``.
    with_wrenches : bool
        Also require wrench feasibility (:func:`wrench_feasible_workspace` with
        ``wrenches`` and ``**options``): ``feasible`` is the AND of both.
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches of the wrench check (N, N m).
    shared_trim : float
        Share of a cable's length left out at an end it shares with another cable
        (:func:`tension_opt.workspace.interference.cable_clearance`).
    with_platform : bool
        Also require every cable to clear the platform by ``clearance``
        (:func:`tension_opt.workspace.platform.platform_clearance`).
    platform_hull : array_like, shape (k, 3), optional
        Vertices of the platform polyhedron in the platform frame (m); default the
        robot's ``platform_hull``, else the attachment points.
    bounds : (array_like, array_like), optional
        The sampled box, as in :func:`wrench_feasible_workspace`.
    **options
        Passed to :func:`wrench_feasible_workspace` (``backend``, ``executor`` ...).

    Returns
    -------
    InterferenceResult
        ``cable_clearance`` (N,) in m, ``interference_free`` (N,), ``feasible`` (N,).

    Raises
    ------
    InvalidInputError
        On bad poses, clearance, shared_trim, platform_hull, wrenches or bounds.
    """
    required = check_clearance(clearance)
    P, _, layout = prepare(robot, poses, wrenches, bounds)
    clear = cable_clearance(robot, P, shared_trim=shared_trim)
    platform = platform_clearance(robot, P, platform_hull) if with_platform else None
    wrench = None
    if with_wrenches:
        wrench = wrench_feasible_workspace(robot, P, wrenches, **options)
    return interference_result(robot, P, layout, clear, required, wrench, platform)
