"""The wrench-feasible workspace of a batch of poses, in chunks over an executor.

A pose is *wrench-feasible* when tensions within ``[t_min, t_max]`` hold the platform's
weight plus every external wrench of a given set (each on its own). Every pose gets its
capacity margin under each wrench (:mod:`tension_opt.workspace.margin`); the smallest decides.
A pose is reported feasible when ``margin >= -FEAS_TOL * scale``, ``scale`` being the
pose's typical tension (:func:`tension_opt.problem.affine.typical_tension`, as in the
closed-form backend). Feasible poses also get their minimum-sum tensions under the
critical wrench.

Large batches are cut into chunks of poses run through
:func:`tension_opt.workspace.executors.run_chunks` (in-process, a process pool or Dask); the
chunks are the same whatever the executor, so the result is too.
"""

from __future__ import annotations

from dataclasses import dataclass
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
from tension_opt.workspace.margin import pose_margins
from tension_opt.workspace.result import WorkspaceResult

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


def _chunk(task: _Task) -> dict[str, Any]:
    """Margins, feasibility and minimum-sum tensions of one chunk of poses.

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


def wrench_feasible_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
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
        give an empty result.

    Raises
    ------
    InvalidInputError
        On bad poses, wrenches, bounds or backend.
    """
    P, W, layout = prepare(robot, poses, wrenches, bounds)
    if not isinstance(backend, Backend) and backend not in ("auto", "closed_form"):
        get_backend(backend)  # fail early on an unknown name
    # No poses: one empty chunk, so that the result has the right (empty) shapes.
    tasks = [_Task(robot, P[sl], W, backend, dict(options))
             for sl in chunk_slices(len(P), chunk_size)] or [
                 _Task(robot, P, W, backend, dict(options))]
    parts = run_chunks(_chunk, tasks, executor, progress=progress, description="workspace")
    out = merge_chunks(parts, _FIELDS)
    methods = sorted({p["method"] for p in parts if p["method"]})
    return WorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["margin"], tensions=out["tensions"],
        status=out["status"], margins=out["margins"], critical_wrench=out["crit"],
        wrenches=W, robot=robot, backend="+".join(methods), **layout)
