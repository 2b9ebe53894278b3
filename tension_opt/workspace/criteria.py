"""Workspace criteria besides wrench feasibility, and the table of every criterion.

Names follow CASPR's workspace conditions:

``"wrench_feasible"`` (:func:`~tension_opt.workspace.compute.wrench_feasible_workspace`)
    Tensions in ``[t_min, t_max]`` hold gravity plus every external wrench of a list or
    polytope; margin: the capacity margin (N).
``"static"`` (:func:`static_feasible_workspace`)
    Tensions ``>= t_min``, without upper bound, hold gravity (plus the wrenches given);
    margin: the capacity margin without upper bound (N), ``+inf`` where tensions can
    grow without bound.
``"wrench_closure"`` (:func:`wrench_closure_workspace`)
    Strictly positive tensions balance zero wrench and the structure matrix has full
    rank, so that, with tensions large enough, any wrench can be held; margin: the
    closure ratio below.
``"interference_free"`` (:func:`~tension_opt.workspace.interference_free_workspace`)
    Every two cables stay ``clearance`` apart; margin: the clearance excess (m).

The *closure ratio* of a pose is the largest ``min_i T_i / max_i T_i`` over tensions
``T >= 0``, not all zero, with ``A T = 0``: 1 when equal tensions balance, 0 when no
strictly positive tensions do. It is the linear program ``max s : A T = 0,
s <= T_i <= 1``, computed as a capacity margin with the tension box ``[s, 2 - s]``
(:func:`tension_opt.workspace.margin.margin_solve`: exact where the null space has
dimension <= 2, an LP elsewhere), whose optimum is ``2 r / (1 + r)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt.backends.base import Backend
from tension_opt.backends.registry import get_backend
from tension_opt.distribution.chunks import chunk_slices
from tension_opt.errors import InvalidInputError
from tension_opt.problem.affine import RANK_TOL
from tension_opt.robot import CableRobot
from tension_opt.status import Status, status_array
from tension_opt.workspace.compute import (
    CHUNK_SIZE,
    on_drawing_point,
    prepare,
    wrench_feasible_workspace,
)
from tension_opt.workspace.executors import Executor, merge_chunks, run_chunks
from tension_opt.workspace.grid import Grid
from tension_opt.workspace.interference_free import interference_free_workspace
from tension_opt.workspace.margin import margin_solve
from tension_opt.workspace.result import WorkspaceResult
from tension_opt.workspace.wrench_set import WrenchPolytope

__all__ = [
    "CLOSURE_TOL",
    "CRITERIA",
    "closure_ratio",
    "get_criterion",
    "static_feasible_workspace",
    "wrench_closure_workspace",
]

#: A closure ratio at or below this counts as no closure (the LP path's accuracy).
CLOSURE_TOL = 1e-7


def closure_ratio(A: NDArray, backend: str | Backend = "auto",
                  **options: Any) -> tuple[NDArray, NDArray, NDArray, str]:
    """Closure ratio and rank of structure matrices (module docstring).

    Parameters
    ----------
    A : ndarray, shape (N, n, m)
        Structure matrices.
    backend : str or Backend
        As in :func:`tension_opt.workspace.margin.margin_solve`.
    **options
        Passed to the LP backend.

    Returns
    -------
    ratio : ndarray, shape (N,)
        In ``[0, 1]``; NaN where a solver failed.
    rank : ndarray of int, shape (N,)
        Numerical rank of ``A`` (singular values above ``RANK_TOL`` of the largest).
    status : ndarray of Status values, shape (N,)
        ``OPTIMAL`` where the ratio was found, else the solver's status.
    method : str
        How the ratios were computed.
    """
    N, n, m = A.shape
    S = np.linalg.svd(A, compute_uv=False) if N else np.zeros((0, n))
    rank = (S > RANK_TOL * np.maximum(S[:, :1], 1e-300)).sum(axis=1)
    if not N:
        return np.zeros(0), rank, status_array(0), ""
    ones = np.ones((N, m))
    s, _, status, method = margin_solve(A, np.zeros((N, n)), 0.0 * ones, ones, 2.0 * ones,
                                        ones, backend, **options)
    s = np.clip(s, 0.0, 1.0)  # T = 0 gives s = 0; the box caps it at 1
    return s / (2.0 - s), rank, status, method


@dataclass(frozen=True)
class _ClosureTask:
    """One chunk of a closure check (picklable for process pools and Dask)."""

    robot: CableRobot
    poses: NDArray
    backend: str | Backend
    options: dict[str, Any]


def _closure_chunk(task: _ClosureTask) -> dict[str, Any]:
    """Closure ratio, rank, feasibility and status of one chunk of poses; a pose on a
    drawing point is not computed (ratio ``-inf``, rank 0, infeasible)."""
    robot, P = task.robot, task.poses
    N = len(P)
    out: dict[str, Any] = {"ratio": np.full(N, -np.inf), "rank": np.zeros(N, dtype=np.intp),
                           "status": status_array(N, Status.INFEASIBLE), "method": ""}
    ok = ~on_drawing_point(robot, P) if N else np.zeros(0, dtype=bool)
    if ok.any():
        ratio, rank, status, out["method"] = closure_ratio(
            robot.structure_matrices(P[ok]), task.backend, **task.options)
        out["ratio"][ok], out["rank"][ok] = ratio, rank
        failed = status != Status.OPTIMAL
        status = np.where(failed, status, Status.INFEASIBLE).astype(out["status"].dtype)
        status[~failed & (ratio > CLOSURE_TOL) & (rank == robot.dof)] = Status.OPTIMAL
        out["status"][ok] = status
    out["feasible"] = out["status"] == Status.OPTIMAL
    return out


def wrench_closure_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    *,
    backend: str | Backend = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    **options: Any,
) -> WorkspaceResult:
    """Which poses are in wrench closure (CASPR's ``WrenchClosure`` condition).

    A pose is in wrench closure when strictly positive tensions balance zero wrench
    (``A T = 0`` with every ``T_i > 0``) and the structure matrix ``A`` has full rank
    ``n``: the cables' wrenches positively span the wrench space, so any wrench can be
    held with tensions large enough (gravity, ``t_min`` and ``t_max`` play no part).
    Equivalently, the origin lies strictly inside the convex hull of ``A``'s columns.

    Parameters
    ----------
    robot : CableRobot
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad).
    backend : str or Backend
        ``"auto"`` (exact where the null space has dimension <= 2, LP elsewhere),
        ``"closed_form"`` or an LP backend name, as in
        :func:`~tension_opt.workspace.compute.wrench_feasible_workspace`.
    executor, chunk_size, progress, bounds
        As in :func:`~tension_opt.workspace.compute.wrench_feasible_workspace`.
    **options
        Passed to the LP backend.

    Returns
    -------
    WorkspaceResult
        ``feasible`` (N,): closure with ratio above :data:`CLOSURE_TOL`; ``margin``
        (N,): the closure ratio (dimensionless, in ``[0, 1]``, module docstring;
        ``-inf`` at a pose on a drawing point, NaN where a solver failed); ``status``
        ``OPTIMAL`` where in closure, ``INFEASIBLE`` elsewhere, or a failed solve's;
        ``tensions`` NaN; ``extras["rank"]`` (N,) the rank of ``A``.

    Raises
    ------
    InvalidInputError
        On bad poses, bounds or backend.
    """
    P, _, layout = prepare(robot, poses, None, bounds)
    if not isinstance(backend, Backend) and backend not in ("auto", "closed_form"):
        get_backend(backend)  # fail early on an unknown name
    whole = _ClosureTask(robot, P, backend, dict(options))
    tasks = [replace(whole, poses=P[sl]) for sl in chunk_slices(len(P), chunk_size)] or [whole]
    parts = run_chunks(_closure_chunk, tasks, executor, progress=progress,
                       description="wrench closure")
    out = merge_chunks(parts, ("ratio", "rank", "status", "feasible"))
    N = len(P)
    return WorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["ratio"],
        tensions=np.full((N, robot.m), np.nan), status=out["status"],
        margins=out["ratio"][:, None], critical_wrench=np.zeros(N, dtype=np.intp),
        wrenches=np.zeros((1, robot.dof)), robot=robot,
        backend="+".join(sorted({p["method"] for p in parts if p["method"]})),
        extras={"criterion": "wrench_closure", "rank": out["rank"],
                "margin_label": "closure ratio (min T / max T)"}, **layout)


def static_feasible_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
    wrench_set: WrenchPolytope | tuple[ArrayLike, ArrayLike] | ArrayLike | None = None,
    **options: Any,
) -> WorkspaceResult:
    """Which poses hold gravity with tensions ``>= t_min`` (CASPR's ``Static`` condition).

    :func:`~tension_opt.workspace.compute.wrench_feasible_workspace` of the robot
    without upper tension bounds (``t_max = inf``): positive tensions, at least
    ``t_min``, hold the platform's weight and every external wrench given.

    Parameters
    ----------
    robot : CableRobot
        Its ``t_max`` is not used.
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad).
    wrenches, wrench_set
        External wrenches besides gravity (N, N m), a list or a polytope, as in
        :func:`~tension_opt.workspace.compute.wrench_feasible_workspace`. Default: the
        weight alone.
    **options
        Passed to :func:`~tension_opt.workspace.compute.wrench_feasible_workspace`
        (``backend``, ``executor``, ``chunk_size`` ...).

    Returns
    -------
    WorkspaceResult
        ``margin`` (N,): the largest ``s`` with tensions ``>= t_min + s`` in
        equilibrium (N), ``+inf`` where they can grow without bound; ``robot`` the
        robot given; ``extras["criterion"] = "static"``.

    Raises
    ------
    InvalidInputError
        As :func:`~tension_opt.workspace.compute.wrench_feasible_workspace`.
    """
    options.pop("wrench_space", None)  # no upper bound: no bounded wrench set
    result = wrench_feasible_workspace(robot.with_(t_max=np.inf), poses, wrenches,
                                       wrench_set=wrench_set, wrench_space=False, **options)
    result.robot = robot
    result.extras["criterion"] = "static"
    result.extras["margin_label"] = "capacity margin without t_max (N)"
    return result


#: Every workspace criterion by name: a function ``(robot, poses, **options) ->
#: WorkspaceResult``.
CRITERIA: dict[str, Callable[..., WorkspaceResult]] = {
    "wrench_feasible": wrench_feasible_workspace,
    "static": static_feasible_workspace,
    "wrench_closure": wrench_closure_workspace,
    "interference_free": interference_free_workspace,
}


def get_criterion(criterion: str | Callable[..., WorkspaceResult]
                  ) -> tuple[str, Callable[..., WorkspaceResult]]:
    """The name and function of a criterion of :data:`CRITERIA`, or a function of one's
    own (``(robot, poses, **options) -> WorkspaceResult``, named after itself).

    Raises
    ------
    InvalidInputError
        For an unknown name, listing the known ones.
    """
    if callable(criterion):
        return getattr(criterion, "__name__", "criterion"), criterion
    if isinstance(criterion, str) and criterion in CRITERIA:
        return criterion, CRITERIA[criterion]
    raise InvalidInputError(f"criterion must be one of {sorted(CRITERIA)} or a function "
                            f"(robot, poses, **options) -> WorkspaceResult, got {criterion!r}")
