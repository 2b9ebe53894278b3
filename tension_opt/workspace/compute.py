"""The wrench-feasible workspace of a batch of poses, in chunks over an executor.

A pose is *wrench-feasible* when tensions within ``[t_min, t_max]`` hold the platform's
weight plus every external wrench of a given set: a list of wrenches (each on its own)
or a polytope (:class:`tension_opt.workspace.wrench_set.WrenchPolytope`, held through its
vertices). Every pose gets its capacity margin under each wrench
(:mod:`tension_opt.workspace.margin`); the smallest decides.
A pose is reported feasible when ``margin >= -FEAS_TOL * scale``, ``scale`` being the
pose's typical tension (:func:`tension_opt.problem.affine.typical_tension`, as in the
closed-form backend). Feasible poses also get their minimum-sum tensions under the
critical wrench.

Large batches are cut into chunks of poses run through
:func:`tension_opt.workspace.executors.run_chunks` (in-process, a process pool or Dask); the
chunks are the same whatever the executor, so the result is too.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend
from tension_opt.backends.registry import get_backend
from tension_opt.checks import as_float_array
from tension_opt.distribution.chunks import chunk_slices
from tension_opt.distribution.entry import distribute
from tension_opt.errors import InvalidInputError
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace.executors import Executor, merge_chunks, run_chunks
from tension_opt.workspace.grid import Grid, check_bounds
from tension_opt.workspace.hyperplane import has_finite_bounds, pose_facet_margins
from tension_opt.workspace.margin import pose_margins
from tension_opt.workspace.result import WorkspaceResult
from tension_opt.workspace.wrench_set import WrenchPolytope, as_wrench_polytope

__all__ = [
    "CHUNK_SIZE",
    "FEAS_TOL",
    "on_drawing_point",
    "prepare",
    "wrench_feasible_workspace",
]

#: Relative tolerance (of the pose's typical tension) below zero still counted feasible.
FEAS_TOL = 1e-9
#: Default number of poses per chunk.
CHUNK_SIZE = 16384
# Fields of a chunk's result that are per-pose arrays, concatenated over the chunks.
_FIELDS = ("margins", "margin", "crit", "feasible", "tensions", "status")


def _as_wrenches(robot: CableRobot, wrenches: ArrayLike | None) -> NDArray:
    """External wrenches as (K, n), finite; a zero row (the weight alone) for None."""
    if wrenches is None:
        return np.zeros((1, robot.dof))
    W = as_float_array("wrenches", wrenches)
    if W.ndim == 1:
        W = W[None]
    if W.ndim != 2 or W.shape[1] != robot.dof or W.shape[0] < 1:
        raise InvalidInputError(f"wrenches must have shape ({robot.dof},) or (K, {robot.dof}); "
                                f"got {np.shape(wrenches)}")
    if not np.isfinite(W).all():
        raise InvalidInputError("wrenches must be finite")
    return W


def prepare(robot: CableRobot, poses: ArrayLike | Grid, wrenches: ArrayLike | None,
            bounds: tuple[ArrayLike, ArrayLike] | None
            ) -> tuple[NDArray, NDArray, dict[str, Any]]:
    """Checked poses (N, n), wrenches (K, n) and the layout fields of a result.

    The layout is ``grid_shape``, ``axes`` (from a :class:`Grid`) and ``bounds``: as
    given (checked: shape (n,) each, finite, ``lower <= upper``, around the grid's
    points), else the grid's box (:meth:`Grid.box`); as keyword arguments of
    :class:`WorkspaceResult`.
    """
    grid = poses if isinstance(poses, Grid) else None
    P = robot.as_poses(poses.poses if isinstance(poses, Grid) else poses)
    W = _as_wrenches(robot, wrenches)
    box = None
    if bounds is not None:
        box = check_bounds(bounds, robot.dof)
        if grid is not None and any(a[0] < box[0][i] or a[-1] > box[1][i]
                                    for i, a in enumerate(grid.axes)):
            raise InvalidInputError("bounds must contain the grid's points")
    elif grid is not None:
        box = grid.box()
    layout = {"grid_shape": grid.shape if grid is not None else None,
              "axes": grid.axes if grid is not None else None, "bounds": box}
    return P, W, layout


def on_drawing_point(robot: CableRobot, poses: NDArray) -> NDArray:
    """Poses that put some cable on its drawing point (zero length), shape (N,) of bool.

    The robot's own test (:attr:`tension_opt.robot.CableGeometry.degenerate`;
    :meth:`CableRobot.structure_matrices` raises there). Such a pose has no cable
    direction, so the workspace functions report it infeasible instead of computing it.

    Parameters
    ----------
    robot : CableRobot
    poses : ndarray, shape (N, n)
        Validated poses (m, rad).
    """
    return robot.cable_geometry(poses, check=False).degenerate


@dataclass(frozen=True)
class _Task:
    """One chunk of a workspace check (picklable for process pools and Dask)."""

    robot: CableRobot
    poses: NDArray
    wrenches: NDArray
    backend: str | Backend
    options: dict[str, Any]
    wrench_space: bool = False


def _chunk(task: _Task) -> dict[str, Any]:
    """Margins, feasibility and minimum-sum tensions of one chunk of poses (and, with
    ``task.wrench_space``, the hyperplane-shifting margin of
    :mod:`tension_opt.workspace.hyperplane`).

    Poses on a drawing point (:func:`on_drawing_point`) are not computed: infeasible,
    margin ``-inf``, NaN tensions, status ``INFEASIBLE``; so are no poses at all.
    """
    robot, P, W = task.robot, task.poses, task.wrenches
    N, K = P.shape[0], W.shape[0]
    out: dict[str, Any] = {
        "margins": np.full((N, K), -np.inf), "margin": np.full(N, -np.inf),
        "crit": np.zeros(N, dtype=np.intp), "feasible": np.zeros(N, dtype=bool),
        "tensions": np.full((N, robot.m), np.nan), "status": status_array(N, Status.INFEASIBLE),
        "method": ""}
    ok = ~on_drawing_point(robot, P) if N else np.zeros(0, dtype=bool)
    if ok.any():
        part = _chunk_poses(task, P[ok])
        for key, value in part.items():
            if key == "method":
                out[key] = value
            else:
                out[key][ok] = value
    if task.wrench_space:
        out["wrench_space_margin"] = pose_facet_margins(robot, P, W)
    return out


def _chunk_poses(task: _Task, P: NDArray) -> dict[str, Any]:
    """:func:`_chunk` of poses ``P`` (N, n) that keep every cable off its drawing point."""
    robot, W = task.robot, task.wrenches
    N, K = P.shape[0], W.shape[0]
    margins = np.empty((N, K))
    typical = np.empty((N, K))
    statuses = []
    method = ""
    for k in range(K):  # a handful of wrenches; every pose at once inside
        wk = W[k] if W[k].any() else None
        margins[:, k], status_k, typical[:, k], method = pose_margins(
            robot, P, wk, task.backend, task.options)
        statuses.append(status_k)
    with np.errstate(invalid="ignore"):
        crit = np.argmin(np.where(np.isnan(margins), -np.inf, margins), axis=1)
    solved = np.all([s == Status.OPTIMAL for s in statuses], axis=0)
    margin = np.where(solved, margins[np.arange(N), crit], np.nan)
    feasible = solved & (margin >= -FEAS_TOL * typical.max(axis=1))
    status = status_array(N, Status.INFEASIBLE)
    for status_k in statuses:  # a failed solve under any wrench is reported (the last)
        bad = status_k != Status.OPTIMAL
        status[bad] = status_k[bad]
    tensions = np.full((N, robot.m), np.nan)
    idx = np.flatnonzero(feasible)
    if len(idx):
        Wc = W[crit[idx]]
        sol = distribute(robot, P[idx], "min_sum",
                         "auto" if task.backend == "closed_form" else task.backend,
                         wrench=Wc if Wc.any() else None, **task.options)
        tensions[idx] = sol.tensions
        status[idx] = sol.status
    return {"margins": margins, "margin": margin, "crit": crit, "feasible": feasible,
            "tensions": tensions, "status": status, "method": method}


def wrench_set_of(robot: CableRobot, wrenches: ArrayLike | None, wrench_set: Any
                  ) -> tuple[ArrayLike | None, WrenchPolytope | None]:
    """The wrenches to hold and the polytope they come from (None for a list).

    Raises
    ------
    InvalidInputError
        If both are given, or on a bad ``wrench_set``.
    """
    if wrench_set is None:
        return wrenches, None
    if wrenches is not None:
        raise InvalidInputError("give wrenches (a list, each held on its own) or wrench_set "
                                "(a polytope), not both; a list's convex hull is "
                                "wrench_set=WrenchPolytope.from_vertices(wrenches)")
    poly = as_wrench_polytope(wrench_set, robot.dof)
    return poly.vertices, poly


def _wants_wrench_space(robot: CableRobot, wrench_space: bool | None,
                        poly: WrenchPolytope | None) -> bool:
    """Whether to compute the wrench-space margin (default: for a polytope and finite
    ``t_max``); raises if asked for it with an infinite ``t_max``."""
    if wrench_space is None:
        return poly is not None and has_finite_bounds(robot)
    if wrench_space and not has_finite_bounds(robot):
        raise InvalidInputError("wrench_space=True needs a finite t_max for every cable; "
                                "set one with robot.with_(t_max=...) or pass "
                                "wrench_space=False")
    return bool(wrench_space)


def wrench_feasible_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
    wrench_set: WrenchPolytope | tuple[ArrayLike, ArrayLike] | ArrayLike | None = None,
    wrench_space: bool | None = None,
    backend: str | Backend = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    **options: Any,
) -> WorkspaceResult:
    """Which poses hold the weight and every external wrench with tensions in bounds.

    Parameters
    ----------
    robot : CableRobot
        Bounds ``robot.t_min`` / ``robot.t_max`` (N); change them with ``robot.with_``.
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad); a :class:`Grid` from :func:`workspace_grid` keeps its
        shape for :meth:`WorkspaceResult.volume` and the plots.
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches besides gravity (N, N m), each of which must be held on its
        own; include a zero row to also require the weight alone. Default: the weight
        alone.
    wrench_set : WrenchPolytope, (H, h) tuple or array_like of shape (K, n), optional
        Instead of ``wrenches``: a polytope of external wrenches (N, N m) to hold, every
        one: a :class:`~tension_opt.workspace.wrench_set.WrenchPolytope`, ``(H, h)`` for
        ``H w <= h``, or vertices. The capacity margin is concave in the wrench, so its
        minimum over the polytope is at a vertex: feasibility and margin are those of
        the vertices (``margins`` (N, K) per vertex, ``wrenches`` the vertices).
    wrench_space : bool, optional
        Also the wrench-space margin by hyperplane shifting
        (:func:`~tension_opt.workspace.hyperplane.wrench_space_margin`) into
        ``extras["wrench_space_margin"]`` (N, N m). Default: for a ``wrench_set`` when
        every ``t_max`` is finite; True with an infinite ``t_max`` raises.
    backend : str or Backend
        ``"auto"`` (exact enumeration where the null space has dimension <= 2, the
        first installed LP solver elsewhere), ``"closed_form"`` (exact only; error
        where it does not apply) or an LP backend (``"qpsolvers:daqp"``,
        ``"scipy:highs"``, ``"cvxpy:CLARABEL"`` ...) for every pose. The minimum-sum
        tensions come from :func:`tension_opt.distribute` with the same backend.
    executor : str, Executor or dask.distributed.Client, optional
        Where the chunks run: None (this process), ``"processes:N"``,
        ``"dask:tcp://host:port"`` or a Dask client; see :mod:`tension_opt.workspace.executors`.
    chunk_size : int
        Poses per chunk. The chunks do not depend on the executor, so neither does
        the result.
    progress : bool
        Show a progress bar over the chunks.
    bounds : (array_like, array_like), optional
        The box the poses were sampled from, shape (n,) each, finite, ``lower <=
        upper`` (m, rad), for :meth:`WorkspaceResult.volume` of samples. Default for a
        :class:`Grid`: its box.
    **options
        Passed to the LP backend and to :func:`tension_opt.distribute`.

    Returns
    -------
    WorkspaceResult
        ``feasible`` (N,), ``margin`` (N,) in N, min-sum ``tensions`` (N, m), ``status``.
        A pose that puts a cable on its drawing point (zero length,
        :func:`on_drawing_point`) does not stop the batch: it is reported infeasible
        with margin ``-inf``, NaN tensions and status ``INFEASIBLE``. No poses (N = 0)
        give an empty result. ``extras``: ``"criterion"`` (``"wrench_feasible"``),
        ``"wrench_set"`` (a polytope given), ``"wrench_space_margin"`` (N,).

    Raises
    ------
    InvalidInputError
        On bad poses, wrenches, wrench set, bounds or backend, or both ``wrenches`` and
        ``wrench_set``.
    """
    wrenches, poly = wrench_set_of(robot, wrenches, wrench_set)
    P, W, layout = prepare(robot, poses, wrenches, bounds)
    task = _Task(robot, P, W, backend, dict(options),
                 _wants_wrench_space(robot, wrench_space, poly))
    return _run(layout, poly, task, executor, chunk_size, progress)


def _run(layout: dict[str, Any], poly: WrenchPolytope | None, whole: _Task,
         executor: str | Executor | Any | None, chunk_size: int, progress: bool
         ) -> WorkspaceResult:
    """:func:`wrench_feasible_workspace` of a checked task: its poses cut into chunks,
    run through the executor, joined."""
    robot, P, W, backend = whole.robot, whole.poses, whole.wrenches, whole.backend
    if not isinstance(backend, Backend) and backend not in ("auto", "closed_form"):
        get_backend(backend)  # fail early on an unknown name
    # No poses: one empty chunk, so that the result has the right (empty) shapes.
    tasks = [replace(whole, poses=P[sl]) for sl in chunk_slices(len(P), chunk_size)] or [whole]
    parts = run_chunks(_chunk, tasks, executor, progress=progress, description="workspace")
    facets = whole.wrench_space
    out = merge_chunks(parts, _FIELDS + (("wrench_space_margin",) if facets else ()))
    methods = sorted({p["method"] for p in parts if p["method"]})
    extras: dict[str, Any] = {"criterion": "wrench_feasible"}
    if poly is not None:
        extras["wrench_set"] = poly
    if facets:
        extras["wrench_space_margin"] = out["wrench_space_margin"]
    return WorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["margin"], tensions=out["tensions"],
        status=out["status"], margins=out["margins"], critical_wrench=out["crit"],
        wrenches=W, robot=robot, backend="+".join(methods), extras=extras, **layout)
