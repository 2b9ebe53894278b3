"""Wrench-feasible workspace with cable sag: the coupled catenary model.

:func:`sag_workspace` is the sag-aware counterpart of
:func:`tension_opt.workspace.wrench_feasible_workspace`. Every cable hangs as an
elastic catenary and the catenary end forces at the platform balance the load (the
``"coupled"`` model of :func:`catenary.inverse_kinematics`). As there, the tension
bounds apply along the whole cable: ``t_min`` to the lowest tension of each cable
(at its lowest point when it dips below both ends, else at an end) and ``t_max`` to
the highest (at the drawing point for a cable hanging from above).

Per pose:

``feasible``
    The coupled inverse kinematics with the minimum-sum objective converged with
    every cable's lowest tension >= ``t_min`` and highest <= ``t_max`` (for every
    wrench of the set). It starts from the straight-line distribution; where that is
    infeasible but the margin iteration below found balanced catenaries within the
    bounds, from those tensions (``initial_tensions``): sag makes some poses feasible
    that straight cables cannot hold (long cables dipping below the platform pull it
    down, so the others may pull harder), and the default start would miss them.
``margin``
    The **coupled capacity margin** (N): the largest ``s`` for which platform-end
    tensions exist whose catenaries balance the load with every cable's lowest tension
    ``>= t_min + s`` and highest ``<= t_max - s`` (the smallest over the wrenches),
    found by sequential linear programming on the equilibrium manifold
    (:func:`catenary.margin.coupled_margin`, where the method is described). NaN where
    no balanced start was found.
``tensions``, ``lengths``, ``sag_correction``
    The coupled minimum-sum tensions at the drawing points (N), the unstretched
    lengths (m) and ``max_i |L_sag,i - L_straight,i|`` (m), the largest length
    correction the sag (and stretch) asks of any cable; NaN where infeasible.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.backends import Backend
from tension_opt.distribution.chunks import chunk_slices
from tension_opt.status import Status, status_array
from tension_opt.workspace import (
    FEAS_TOL,
    Grid,
    WorkspaceResult,
    on_drawing_point,
    prepare,
)
from tension_opt.workspace.executors import Executor, merge_chunks, run_chunks
from tension_opt.workspace.margin import pose_margins

from .geometry import cable_data
from .inverse import inverse_kinematics
from .margin import coupled_margin, min_end_tension

__all__ = ["SagWorkspaceResult", "coupled_margin", "min_end_tension", "sag_workspace"]

#: Default poses per chunk (the coupled model costs more per pose than the straight one).
CHUNK_SIZE = 4096


@dataclass(eq=False, repr=False)  # the parent's one-line repr, not every array
class SagWorkspaceResult(WorkspaceResult):
    """:class:`~tension_opt.workspace.WorkspaceResult` of the coupled sag model.

    Attributes (besides those of the parent)
    ----------------------------------------
    sag_correction : ndarray, shape (N,)
        ``max_i |L_sag,i - L_straight,i|`` (m) of the minimum-sum coupled solution under
        the critical wrench; NaN where infeasible.
    lengths : ndarray, shape (N, m)
        Unstretched cable lengths (m) of that solution.
    straight_lengths : ndarray, shape (N, m)
        Straight-line lengths (m); NaN for a pose on a drawing point.
    equilibrium_residual : ndarray, shape (N,)
        Wrench left on the platform by the catenary end forces of the minimum-sum
        solution (N, N m).
    straight_margin : ndarray, shape (N,)
        Capacity margin of the straight-line model (N), for comparison.
    margin_status : ndarray of str, shape (N,)
        How the coupled margin iteration ended (see :func:`coupled_margin`):
        ``"converged"``, ``"stalled"``, ``"max_iter"``, ``"catenary_failed"``,
        ``"singular"`` or ``"unbounded"``.
    margin_iterations : ndarray of int, shape (N,)
        Linearised LPs solved for the margin (summed over the wrenches).
    margin_residual : ndarray, shape (N,)
        Equilibrium residual of the catenaries at the margin's tensions (N, N m).
    """

    sag_correction: NDArray = None  # type: ignore[assignment]
    lengths: NDArray = None  # type: ignore[assignment]
    straight_lengths: NDArray = None  # type: ignore[assignment]
    equilibrium_residual: NDArray = None  # type: ignore[assignment]
    straight_margin: NDArray = None  # type: ignore[assignment]
    margin_status: NDArray = None  # type: ignore[assignment]
    margin_iterations: NDArray = None  # type: ignore[assignment]
    margin_residual: NDArray = None  # type: ignore[assignment]

    QUANTITIES: ClassVar[dict[str, str]] = {
        **WorkspaceResult.QUANTITIES,
        "margin": "coupled capacity margin (N)",
        "sag_correction": "largest sag length correction (m)",
        "straight_margin": "straight-line capacity margin (N)",
        "equilibrium_residual": "equilibrium residual (N)",
    }

    def _extra_columns(self, frame: pd.DataFrame) -> None:
        frame["sag_correction"] = self.sag_correction
        frame["straight_margin"] = self.straight_margin
        frame["equilibrium_residual"] = self.equilibrium_residual
        frame["margin_status"] = self.margin_status
        for i in range(self.lengths.shape[1]):
            frame[f"L{i + 1}"] = self.lengths[:, i]


# ------------------------------------------------------------------------ workspace
@dataclass(frozen=True)
class _SagTask:
    robot: CableRobot
    poses: NDArray
    wrenches: NDArray
    backend: str | Backend
    tol: float
    max_iter: int
    options: dict[str, Any]


def _sag_chunk(task: _SagTask) -> dict[str, Any]:
    """Coupled margins, feasibility, tensions and sag of one chunk of poses.

    Poses on a drawing point (:func:`~tension_opt.workspace.on_drawing_point`) are not
    computed: infeasible, margins ``-inf`` (margin status ``"singular"``), NaN tensions,
    lengths and sag, status ``INFEASIBLE``; so are no poses at all.
    """
    robot, P, W = task.robot, task.poses, task.wrenches
    N, K, m = P.shape[0], W.shape[0], robot.m
    out: dict[str, Any] = {
        "margins": np.full((N, K), -np.inf), "margin": np.full(N, -np.inf),
        "crit": np.zeros(N, dtype=np.intp), "feasible": np.zeros(N, dtype=bool),
        "tensions": np.full((N, m), np.nan), "status": status_array(N, Status.INFEASIBLE),
        "lengths": np.full((N, m), np.nan), "chords": np.full((N, m), np.nan),
        "sag": np.full(N, np.nan), "residual": np.full(N, np.nan),
        "straight": np.full(N, -np.inf), "mstat": status_array(N, Status.SINGULAR),
        "miters": np.zeros(N, np.int64), "mresid": np.full(N, np.nan)}
    ok = ~on_drawing_point(robot, P) if N else np.zeros(0, dtype=bool)
    if ok.any():
        for key, value in _sag_chunk_poses(task, P[ok]).items():
            out[key][ok] = value
    return out


def _sag_chunk_poses(task: _SagTask, P: NDArray) -> dict[str, Any]:
    """:func:`_sag_chunk` of poses ``P`` (N, n) that keep every cable off its drawing
    point."""
    # A handful of wrenches; every pose at once inside.
    cases = [_one_wrench(task, P, w if w.any() else None) for w in task.wrenches]

    def stacked(key: str) -> NDArray:  # (N, K, ...) over the wrenches
        return np.stack([case[key] for case in cases], axis=1)

    N = P.shape[0]
    margins = stacked("margin")
    # Straight lengths do not depend on the wrench: those of any solved case.
    chords = np.full((N, task.robot.m), np.nan)
    for case in cases:
        chords = np.where(np.isfinite(case["chords"]), case["chords"], chords)
    missing = ~np.isfinite(chords).all(axis=1)
    if missing.any():
        chords[missing] = task.robot.inverse_kinematics(P[missing])[0]
    with np.errstate(invalid="ignore"):
        crit = np.argmin(np.where(np.isnan(margins), -np.inf, margins), axis=1)
    rows = np.arange(N)
    feasible = stacked("feasible").all(axis=1)
    tensions = stacked("tensions")[rows, crit]
    lengths = stacked("lengths")[rows, crit]
    tensions[~feasible] = np.nan
    lengths[~feasible] = np.nan
    status = status_array(N, Status.INFEASIBLE)
    status[feasible] = Status.OPTIMAL
    status[stacked("limit").any(axis=1) & ~feasible] = Status.MAX_ITER
    return {
        "margins": margins, "margin": margins[rows, crit], "crit": crit,
        "feasible": feasible, "tensions": tensions, "status": status, "lengths": lengths,
        "chords": chords, "sag": np.abs(lengths - chords).max(axis=1),
        "residual": stacked("residual")[rows, crit],
        "straight": stacked("straight")[rows, crit],
        # The margin status of the critical wrench (worst first among failures).
        "mstat": stacked("mstat")[rows, crit], "miters": stacked("miters").sum(axis=1),
        "mresid": stacked("mresid")[rows, crit],
    }


def _one_wrench(task: _SagTask, P: NDArray, wrench: NDArray | None) -> dict[str, NDArray]:
    """Straight and coupled margins of poses ``P`` (N, n) under one external wrench
    (n,) (or none), and the coupled minimum-sum solution where they say feasible."""
    robot = task.robot
    N, m = P.shape[0], robot.m
    s0, st0, typical, _ = pose_margins(robot, P, wrench, task.backend, task.options)
    margin, T_m, m_status, its, m_resid = coupled_margin(
        robot, P, wrench, task.backend, tol=task.tol, max_iter=task.max_iter, **task.options)
    out = {"straight": s0, "margin": margin, "mstat": m_status, "miters": its,
           "mresid": m_resid, "feasible": np.zeros(N, bool), "limit": np.zeros(N, bool),
           "tensions": np.full((N, m), np.nan), "lengths": np.full((N, m), np.nan),
           "residual": np.full(N, np.nan), "chords": np.full((N, m), np.nan)}
    tol = FEAS_TOL * typical
    # The coupled inverse kinematics starts from the straight-line distribution where
    # it exists; where only the margin iteration found catenaries in equilibrium
    # within the bounds (sag can widen the workspace), it starts from those.
    certified = (m_status == Status.CONVERGED) & (margin >= -tol)
    plain = (st0 == Status.OPTIMAL) & (s0 >= -tol)
    start = np.where((certified & ~plain)[:, None], T_m, np.nan)
    idx = np.flatnonzero(plain | certified)
    for attempt in range(2):
        if not len(idx):
            break
        ik = inverse_kinematics(robot, P[idx], model="coupled", objective="min_sum",
                                backend=task.backend, wrench=wrench, tol=task.tol,
                                max_iter=task.max_iter, initial_tensions=start[idx],
                                **task.options)
        out["limit"][idx] = ik.status == Status.MAX_ITER
        out["feasible"][idx] = ik.success
        out["tensions"][idx] = ik.tensions
        out["lengths"][idx] = ik.lengths
        out["residual"][idx] = ik.equilibrium_residual
        out["chords"][idx] = ik.straight_lengths
        if attempt == 0:  # certified poses the first start missed: from the margin's
            idx = idx[~ik.success & certified[idx]]
            start[idx] = T_m[idx]
    return out


def sag_workspace(
    robot: CableRobot,
    poses: ArrayLike | Grid,
    wrenches: ArrayLike | None = None,
    *,
    backend: str | Backend = "auto",
    executor: str | Executor | Any | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool = False,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    tol: float = 1e-9,
    max_iter: int = 60,
    **options: Any,
) -> SagWorkspaceResult:
    """Wrench-feasible workspace of the coupled catenary model (cables with sag).

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (linear mass, ``EA``); bounds ``t_min`` / ``t_max`` (N).
    poses : array_like, shape (N, n), or Grid
        Poses to check (m, rad); see :func:`tension_opt.workspace.workspace_grid`.
    wrenches : array_like, shape (n,) or (K, n), optional
        External wrenches besides gravity (N, N m), each to be held on its own.
    backend : str or Backend
        For the straight-line start, the linearised LPs of the margin and the coupled
        inverse kinematics (as :func:`catenary.inverse_kinematics`).
    executor, chunk_size, progress
        As :func:`tension_opt.workspace.wrench_feasible_workspace`.
    bounds : (array_like, array_like), optional
        The sampled box, shape (n,) each, finite, ``lower <= upper`` (m, rad), for
        :meth:`~tension_opt.workspace.WorkspaceResult.volume`; default for a
        :class:`~tension_opt.workspace.Grid`: its box.
    tol, max_iter
        Convergence of the coupled iterations (relative change of the tensions) and
        their iteration limit.
    **options
        Passed to the backend.

    Returns
    -------
    SagWorkspaceResult
        ``feasible``, coupled ``margin`` (N), min-sum coupled ``tensions`` (N, m),
        ``sag_correction`` (m) per pose, and the straight-line margin for comparison.
        A pose that puts a cable on its drawing point (zero length) does not stop the
        batch: it is reported infeasible with margins ``-inf`` (margin status
        ``"singular"``), NaN tensions, lengths and sag, status ``INFEASIBLE``. No poses
        (N = 0) give an empty result.
    """
    cable_data(robot)  # fail early without cable properties
    P, W, layout = prepare(robot, poses, wrenches, bounds)
    # No poses: one empty chunk, so that the result has the right (empty) shapes.
    tasks = [_SagTask(robot, P[sl], W, backend, tol, max_iter, dict(options))
             for sl in chunk_slices(len(P), chunk_size)] or [
                 _SagTask(robot, P, W, backend, tol, max_iter, dict(options))]
    parts = run_chunks(_sag_chunk, tasks, executor, progress=progress,
                       description="sag workspace")
    out = merge_chunks(parts, ("margins", "margin", "crit", "feasible", "tensions",
                               "status", "lengths", "chords", "sag", "residual", "straight",
                               "mstat", "miters", "mresid"))
    return SagWorkspaceResult(
        poses=P, feasible=out["feasible"], margin=out["margin"], tensions=out["tensions"],
        status=out["status"], margins=out["margins"], critical_wrench=out["crit"],
        wrenches=W, robot=robot, backend="coupled catenary", **layout,
        sag_correction=out["sag"], lengths=out["lengths"],
        straight_lengths=out["chords"], equilibrium_residual=out["residual"],
        straight_margin=out["straight"], margin_status=out["mstat"],
        margin_iterations=out["miters"], margin_residual=out["mresid"])

