"""Sag-aware inverse kinematics of a cable robot: unstretched lengths and cable forces.

Every cable hangs as an elastic catenary in its vertical plane
(:mod:`catenary.geometry`). :func:`inverse_kinematics` has two models:

``"thesis"``
    The reference study's decoupled convention: tensions from the straight-line
    distribution, each imposed as the tension magnitude at the drawing point of the
    taut catenary. Reproduces the study's lengths; the catenary end forces then do not
    balance the load (see ``equilibrium_residual``), by construction: a pose's
    ``converged`` status says that every catenary was solved, not that the platform is
    in equilibrium.
``"coupled"``
    Physically consistent: the catenary end forces at the platform balance the load
    (forces and moments), with the tensions chosen by the same objectives as
    :func:`tension_opt.distribute`; solved by sequential convex programming
    (:class:`catenary.coupled.CoupledSolver`).

Compiled path
-------------
The thesis model solves one pose (n,) by compiled kernels
(:mod:`catenary.thesis_ik_kernels`, built once per robot and problem and cached) where
they apply: backend ``"auto"`` or ``"closed_form"``, a non-sequential objective, an
optimal straight-line distribution, every catenary settled by the kernel. Other poses
take the numpy path, whose catenaries :func:`catenary.solve_length` solves with its own
kernels; ``compiled=False`` runs the numpy reference throughout. By default a call of
fewer than :data:`tension_opt.kernels.launch.COMPILED_MIN` cables (16; the study
robot's four cables on up to three poses) runs the numpy reference too, as a small
plain ``distribute`` does: a first call compiles nothing (the kernels take seconds to
compile), with the statuses of the kernels and their values to rounding.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any, Literal, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

import tension_opt
from tension_opt import CableRobot, TensionProblem
from tension_opt.backends import Backend, get_backend
from tension_opt.distribution.solution import TensionSolution
from tension_opt.kernels import launch
from tension_opt.problem.form import Objective, as_problem
from tension_opt.status import Status, status_array

from .coupled import CatenarySolution, CoupledSolver
from .errors import InvalidCableError
from .geometry import (
    CablePlanes,
    cable_data,
    cable_planes,
    check_robot,
    equilibrium_residual,
    platform_forces,
)
from .margin import coupled_margin
from .pulleys import MAX_WRAP_STEPS, WRAP_TOL, WheelFrames, settle_wraps
from .solve import solve_length
from .solve.common import check_settings, float_argument
from .solve.compiled import new_result
from .thesis_ik_kernels import CompiledThesis, thesis_solver

__all__ = ["CERT_TOL", "InverseKinematicsResult", "coupled_certificate", "inverse_kinematics",
           "thesis_result"]

#: Equilibrium residual and bound violation allowed in a converged answer of the
#: coupled model, relative to the pose's load scale ``max(||b||, largest t_min)`` (N).
CERT_TOL = 1e-6

FloatArray = NDArray[np.float64]
# Arrays of a pose solved by the compiled path, copied (cheaper than building them).
_ONE_CONVERGED = status_array(1, Status.CONVERGED)
_NO_ITERATIONS = np.zeros(1, np.int64)


@dataclass(frozen=True, eq=False)
class InverseKinematicsResult:
    """Sag-aware cable lengths and forces of a batch of poses.

    Attributes
    ----------
    lengths : ndarray, shape (N, m)
        Unstretched cable lengths (m); NaN where a pose failed.
    straight_lengths : ndarray, shape (N, m)
        Distance from attachment point to drawing point (m); over a guide pulley, the
        straight cable's arc plus free span (:meth:`tension_opt.CableRobot.inverse_kinematics`).
    tensions : ndarray, shape (N, m)
        Tension magnitude at the drawing point, end B (N).
    tensions_platform : ndarray, shape (N, m)
        Tension magnitude at the platform attachment point, end A (N).
    horizontal_tensions : ndarray, shape (N, m)
        Horizontal tension ``H`` of each catenary (N).
    platform_forces : ndarray, shape (N, m, 3)
        Force each cable applies on the platform, base frame (N).
    equilibrium_residual : ndarray, shape (N,)
        The force imbalance of the platform: norm of the wrench (catenary end forces,
        their moments for rotating platforms, gravity and the external wrench) left on
        the platform, restricted to the robot's degrees of freedom (N, N m); NaN where
        the pose failed. Below ``1e-6`` of the load where the coupled model converged;
        large in the thesis model, which imposes straight-cable tensions on sagging
        cables (the study's convention: its numbers are reproduced, not corrected).
    iterations : ndarray of int, shape (N,)
        Sequential-convex-programming iterations per pose (linearised subproblems
        solved after the straight-line start); 0 for the thesis model.
    catenary_iterations : ndarray of int, shape (N, m)
        Newton (and fallback) iterations of the single-cable solver, summed over the
        SCP iterations.
    status : ndarray of str, shape (N,)
        ``Status.CONVERGED``: every cable's catenary solve converged (finite forces
        whose catenary spans the cable's chord and carries its tension), and for the
        coupled model the sequential convex programming settled, so the platform is
        in equilibrium. For the thesis model it means exactly that the catenary
        solves converged: the force imbalance is in ``equilibrium_residual``.
        Otherwise ``Status.INFEASIBLE`` (no tensions within the bounds balance the
        load), another status of the straight-line distribution where it failed
        (thesis model, e.g. ``Status.SOLVER_ERROR``), ``"catenary_failed"`` (no taut
        catenary carries the tension, or its solve did not converge) or
        ``Status.MAX_ITER`` (the SCP did not settle within its iteration limit).
    model : str
        ``"thesis"`` or ``"coupled"``.
    solve_time : float
        Wall-clock time of the whole call (s).
    problem : TensionProblem or None
        The tension problem the tensions answer (objective, weights, bounds), or None
        where it is not known.
    exit_points : ndarray, shape (N, m, 3), or None
        Over guide pulleys: where each cable leaves its wheel (m, base frame; its
        drawing point without a pulley), tangent to its catenary; None for a robot
        without pulleys.
    wrap_angles : ndarray, shape (N, m), or None
        Over guide pulleys: the angle each cable wraps its wheel (rad; 0 without a
        pulley, NaN where unsettled); None for a robot without pulleys.
    """

    lengths: FloatArray
    straight_lengths: FloatArray
    tensions: FloatArray
    tensions_platform: FloatArray
    horizontal_tensions: FloatArray
    platform_forces: FloatArray
    equilibrium_residual: FloatArray
    iterations: NDArray[np.int64]
    catenary_iterations: NDArray[np.int64]
    status: NDArray[np.str_]
    model: str
    solve_time: float
    problem: TensionProblem | None = None
    exit_points: FloatArray | None = None
    wrap_angles: FloatArray | None = None

    @property
    def sag(self) -> FloatArray:
        """Length difference ``D = lengths - straight_lengths`` (m), shape (N, m)."""
        return self.lengths - self.straight_lengths

    @property
    def success(self) -> NDArray[np.bool_]:
        """Boolean mask of the poses solved, shape (N,)."""
        return np.asarray(self.status == Status.CONVERGED, dtype=bool)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per pose and cable: status, lengths, tensions, iterations."""
        N, m = self.lengths.shape
        return pd.DataFrame({
            "pose": np.repeat(np.arange(N), m), "cable": np.tile(np.arange(m), N),
            "status": np.repeat(self.status, m), "length": self.lengths.ravel(),
            "straight_length": self.straight_lengths.ravel(), "sag": self.sag.ravel(),
            "tension": self.tensions.ravel(),
            "tension_platform": self.tensions_platform.ravel(),
            "horizontal_tension": self.horizontal_tensions.ravel(),
            "equilibrium_residual": np.repeat(self.equilibrium_residual, m),
            "iterations": np.repeat(self.iterations, m),
            "catenary_iterations": self.catenary_iterations.ravel(),
        })


def inverse_kinematics(
    robot: CableRobot,
    poses: ArrayLike,
    model: Literal["thesis", "coupled"] = "thesis",
    objective: str | Objective | TensionProblem = "min_sum",
    backend: str | Backend = "auto",
    wrench: ArrayLike | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = 50,
    initial_tensions: ArrayLike | None = None,
    compiled: bool | None = None,
    **options: Any,
) -> InverseKinematicsResult:
    """Unstretched cable lengths and cable forces of a batch of poses, with sag.

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (``linear_mass * g`` and ``EA``); over guide pulleys a
        cable leaves its wheel tangentially (:mod:`catenary.pulleys`).
    poses : array_like, shape (N, n) or (n,)
        Platform poses (m, rad); see :mod:`tension_opt.robot`.
    model : {"thesis", "coupled"}
        ``"thesis"``: the reference study's decoupled convention: the straight-line
        distribution (``objective``) gives each tension, imposed at the drawing point of
        the taut catenary through both ends. ``"coupled"``: the catenary end forces at
        the platform balance the load (Notes).
    objective : str or TensionProblem
        As in :func:`tension_opt.distribute` (``"min_sum"``, ``"min_norm"``, ...).
        In the coupled model it is applied to the platform-end tensions; smoothing
        and rate limits are not supported there.
    backend : str or Backend
        As in :func:`tension_opt.distribute`; ``"auto"`` picks the fastest exact one.
    wrench : array_like, shape (n,) or (N, n), optional
        External wrench on the platform besides gravity (N, N m).
    tol : float
        Coupled model: stop when the tensions change less than ``tol`` of the largest.
    max_iter : int
        Coupled model: iteration limit of the sequential convex programming.
    initial_tensions : array_like, shape (N, m), optional
        Coupled model: platform-end tensions (N) to start from where a row is finite,
        even where the straight-line distribution is infeasible (without it, those poses
        start from the coupled capacity-margin search: sag can make them feasible).
    compiled : bool, optional
        Thesis model: compiled kernels where they apply (module notes); False: numpy
        throughout; None (default): from ``COMPILED_MIN`` cables on.
    **options
        Passed to the backend.

    Returns
    -------
    InverseKinematicsResult
        Lengths, end tensions, platform forces, equilibrium residual, iterations and
        per-pose status (thesis model: converged catenaries, equilibrium not imposed;
        coupled model: converged only where :func:`coupled_certificate` holds, else
        inaccurate).

    Notes
    -----
    The coupled model iterates on the platform-end tensions ``t`` from the straight-line
    distribution by sequential convex programming (:mod:`catenary.coupled`) until ``t``
    changes less than ``tol``. At that fixed point the catenary end forces balance the
    load exactly, within the bounds, and ``t`` is optimal for the objective among the
    tensions with the same end-force directions. The thesis model's compiled path:
    see the module notes.
    """
    t0 = time.perf_counter()
    if model not in ("thesis", "coupled"):
        raise InvalidCableError(f'model must be "thesis" or "coupled"; got model={model!r}')
    check_robot(robot, pulleys=True)
    check_settings(tol, max_iter, "tol")
    compiled = _cables(poses, robot.m) >= launch.COMPILED_MIN if compiled is None else compiled
    if compiled and model == "thesis" and _one_pose(poses) and not robot.has_pulleys:
        result = thesis_result(thesis_solver(robot, objective, backend, options), poses,
                               wrench, t0)
        if result is not None:
            return result
    return _batch(robot, poses, model, objective, backend, wrench, initial_tensions,
                  dict(tol=tol, max_iter=max_iter, compiled=compiled), options, t0)


def _cables(poses: ArrayLike, m: int) -> int:
    """Cables of a call: ``m`` per pose (as many as can be told before the checks)."""
    try:
        shape = np.shape(poses)
    except (ValueError, TypeError):  # ragged: the numpy path raises the package's error
        return m
    return m * (shape[0] if len(shape) > 1 else 1)


def _one_pose(poses: ArrayLike) -> bool:
    """Whether ``poses`` is one pose (a vector); False for anything numpy cannot read
    as an array (ragged lists: the numpy path raises the package's error for them)."""
    if isinstance(poses, np.ndarray):
        return poses.ndim == 1
    try:
        return np.ndim(poses) == 1
    except (ValueError, TypeError):
        return False


def _batch(robot: CableRobot, poses: ArrayLike, model: str, objective: Any,
           backend: str | Backend, wrench: ArrayLike | None,
           initial_tensions: ArrayLike | None, settings: dict[str, Any],
           options: dict[str, Any], start: float) -> InverseKinematicsResult:
    """:func:`inverse_kinematics` by the numpy path (``settings``: its ``tol``,
    ``max_iter`` and ``compiled``; ``start``: the :func:`time.perf_counter` reading the
    solve time counts from)."""
    w, EA = cable_data(robot, pulleys=True)
    p = robot.as_poses(poses)
    straight = tension_opt.distribute(robot, p, objective, backend, wrench=wrench, **options)
    if robot.has_pulleys:
        return _over_pulleys(robot, p, model, straight, (objective, backend, wrench),
                             initial_tensions, settings, options, start)
    planes = cable_planes(robot, p)
    # Weightless cables are straight: the straight-line distribution is then also the
    # coupled solution, and the thesis convention computes its catenaries.
    if model == "coupled" and w > 0.0:
        solution = _coupled(robot, p, planes, straight, objective, backend, wrench,
                            initial_tensions, (w, EA), settings["tol"],
                            settings["max_iter"], options)
    else:
        solution = _thesis(planes, straight.tensions, straight.status, w, EA,
                           settings["compiled"])
    result = _result(robot, p, wrench, planes, solution, model, time.perf_counter() - start,
                     as_problem(objective))
    if model == "coupled":
        _certify(result, robot, p, objective, wrench, w)
    return result


def _certify(result: InverseKinematicsResult, robot: CableRobot, p: FloatArray,
             objective: Any, wrench: ArrayLike | None, w: float) -> None:
    """Mark ``INACCURATE`` the converged poses of a coupled result whose
    :func:`coupled_certificate` fails (in place)."""
    lb, ub = as_problem(objective).bounds(robot, len(p))
    b = robot.required_wrench(p, wrench)
    missed = (result.status == Status.CONVERGED) & ~coupled_certificate(result, b, lb, ub, w)
    result.status[missed] = Status.INACCURATE


def _over_pulleys(robot: CableRobot, p: FloatArray, model: str, straight: TensionSolution,
                  call: tuple[Any, str | Backend, ArrayLike | None],
                  initial_tensions: ArrayLike | None, settings: dict[str, Any],
                  options: dict[str, Any], start: float) -> InverseKinematicsResult:
    """:func:`inverse_kinematics` of a robot with guide pulleys (:mod:`catenary.pulleys`):
    each sagging cable leaves its wheel tangentially. Thesis model: the wrap angles
    settled under the straight-line tensions. Coupled model: the coupled solve and the
    wrap angles in turn, until the wraps move less than ``WRAP_TOL`` (``call``: the
    objective, backend and wrench). The coupled model starts the poses whose
    straight-line distribution failed from the coupled answer of the robot with fixed
    drawing points (:func:`_fixed_point_start`), unless ``initial_tensions`` are given;
    where that start leads nowhere the pose reads ``NOT_CONVERGED``, not infeasible."""
    objective, backend, wrench = call
    w, EA = cable_data(robot, pulleys=True)
    attempt = np.asarray(straight.status == Status.OPTIMAL, dtype=bool)
    if model == "thesis" or w == 0.0:
        sag = settle_wraps(robot, p, straight.tensions, attempt, w, EA, settings["compiled"])
        solution = _thesis(sag.planes, straight.tensions, straight.status, w, EA,
                           settings["compiled"])
        solution.status[attempt & ~sag.settled.all(axis=1)] = Status.CATENARY_FAILED
    else:
        frames = WheelFrames(robot, p)
        h, wrap = frames.straight_h, frames.straight_wrap
        start_tensions = initial_tensions
        if initial_tensions is None and not attempt.all():
            start_tensions = _fixed_point_start(robot, p, straight, call, settings, options)
        for _ in range(MAX_WRAP_STEPS):
            planes = frames.planes(h, wrap)
            solution = _coupled(robot, p, planes, straight, objective, backend, wrench,
                                start_tensions, (w, EA), settings["tol"],
                                settings["max_iter"], options)
            new_h, new = frames.tangent(planes, solution.H[:, frames.idx],
                                        solution.V_B[:, frames.idx], h)
            moved = np.abs(new - wrap) + np.linalg.norm(new_h - h, axis=-1)
            keep = np.isfinite(new)
            wrap, h = np.where(keep, new, wrap), np.where(keep[..., None], new_h, h)
            start_tensions = solution.tensions
            if not (moved > WRAP_TOL).any():
                break
        settled = ~(moved > WRAP_TOL)
        solution.status[(solution.status == Status.CONVERGED) & ~settled.all(axis=1)] = (
            Status.MAX_ITER)
        if initial_tensions is None and start_tensions is not None:
            # Sag held these poses with fixed drawing points; over the wheels the
            # iteration from there did not: that is no proof that nothing can.
            tried = ~attempt & np.isfinite(start_tensions).all(axis=1)
            solution.status[tried & (solution.status == Status.INFEASIBLE)] = (
                Status.NOT_CONVERGED)
        sag = frames.sag(h, wrap, np.zeros(wrap.shape, np.int64), settled)
    result = _result(robot, p, wrench, sag.planes, solution, model,
                     time.perf_counter() - start, as_problem(objective))
    if model == "coupled":
        _certify(result, robot, p, objective, wrench, w)
    failed = ~np.isfinite(result.lengths) | ~sag.settled  # no wheel state to report
    return replace(result, lengths=result.lengths + sag.arcs(result.tensions, EA),
                   straight_lengths=robot.inverse_kinematics(p)[0],
                   exit_points=np.where(failed[..., None], np.nan, sag.planes.upper_ends),
                   wrap_angles=np.where(failed, np.nan, sag.wrap))


def _fixed_point_start(robot: CableRobot, p: FloatArray, straight: TensionSolution,
                       call: tuple[Any, str | Backend, ArrayLike | None],
                       settings: dict[str, Any], options: dict[str, Any]) -> FloatArray:
    """Platform-end tensions (N, m) to start the coupled model over pulleys from: the
    straight-line ones where they fit the bounds, elsewhere those of the coupled model
    of the robot with fixed drawing points (its margin search: sag can widen the
    workspace), NaN where that fails too. The wheels move the exit points by at most
    their diameters, so that start is close."""
    objective, backend, wrench = call
    start = np.where(straight.success[:, None], straight.tensions, np.nan)
    idx = np.flatnonzero(~straight.success)
    w = None if wrench is None else np.asarray(wrench, dtype=float)
    fixed = _batch(robot.with_(pulleys=None), p[idx], "coupled", objective, backend,
                   None if w is None else (w[idx] if w.ndim == 2 else w), None, settings,
                   options, time.perf_counter())
    found = fixed.status == Status.CONVERGED
    start[idx[found]] = fixed.tensions_platform[found]
    return start


def coupled_certificate(result: InverseKinematicsResult, b: FloatArray, lb: FloatArray,
                        ub: FloatArray, w: float) -> NDArray[np.bool_]:
    """Where a coupled answer holds its certificate, shape (N,): the catenary end forces
    balance the load to :data:`CERT_TOL` of the pose's load scale (``max(||b||, largest
    finite t_min)``, N) and the lowest and highest tension along every cable lie within
    the bounds to the same tolerance. ``b`` the required wrenches (N, n), ``lb``, ``ub``
    the bounds (N, m), ``w`` the weight per length (N/m)."""
    finite_lb = np.where(np.isfinite(lb), np.abs(lb), 0.0)
    scale = np.maximum(np.maximum(np.linalg.norm(b, axis=1), finite_lb.max(axis=1)), 1e-12)
    V_A, T_A, T_B = (result.platform_forces[:, :, 2], result.tensions_platform,
                     result.tensions)
    # The lowest tension: at the low point where the cable dips between its ends.
    dips = (V_A < 0) & (V_A + w * result.lengths > 0)
    low = np.where(dips, result.horizontal_tensions, np.minimum(T_A, T_B))
    with np.errstate(invalid="ignore"):
        violation = np.maximum((lb - low).max(axis=1), (np.maximum(T_A, T_B) - ub).max(axis=1))
    return (result.equilibrium_residual <= CERT_TOL * scale) & (violation <= CERT_TOL * scale)


def _coupled(robot: CableRobot, poses: FloatArray, planes: CablePlanes,
             straight: TensionSolution, objective: Any, backend: str | Backend,
             wrench: ArrayLike | None, initial_tensions: ArrayLike | None,
             cable: tuple[float, float], tol: float, max_iter: int,
             options: dict[str, Any]) -> CatenarySolution:
    """The coupled model from the straight-line distribution ``straight`` (see
    :func:`inverse_kinematics`); ``cable`` is ``(w, EA)``."""
    tensions, attempt, unsettled = _coupled_start(
        robot, poses, straight, initial_tensions, wrench, backend,
        dict(options, tol=tol, max_iter=max_iter))
    chosen = backend if isinstance(backend, Backend) else get_backend(straight.backend)
    problem = as_problem(objective)
    if unsettled.any():
        # The margin search settled nothing for these poses, which says nothing about
        # their feasibility: they start from the home pose's answer (as CoupledIK does),
        # so that "infeasible" is the iteration's verdict, never "not attempted".
        home = _home_tensions(robot, problem, chosen, cable, tol, max_iter, options)
        if home is not None:
            tensions = np.where(unsettled[:, None], home, tensions)
            attempt = attempt | unsettled
    return CoupledSolver(robot, poses, planes, problem, chosen,
                         robot.required_wrench(poses, wrench), cable, tol=tol,
                         max_iter=max_iter, options=options).solve(tensions, attempt)


def _home_tensions(robot: CableRobot, problem: Any, backend: Backend,
                   cable: tuple[float, float], tol: float, max_iter: int,
                   options: dict[str, Any]) -> FloatArray | None:
    """Platform-end tensions (m,) of the coupled model at the robot's home pose, from
    its straight-line distribution; None where that does not converge."""
    home = robot.default_home()[None, :]
    straight = tension_opt.distribute(robot, home, problem, backend, **options)
    if not straight.success[0]:
        return None
    solution = CoupledSolver(robot, home, cable_planes(robot, home), problem, backend,
                             robot.required_wrench(home, None), cable, tol=tol,
                             max_iter=max_iter, options=options).solve(
        straight.tensions, straight.success.copy())
    return solution.tensions[0] if solution.status[0] == Status.CONVERGED else None


def _given_start(value: ArrayLike, N: int, m: int) -> FloatArray:
    """``initial_tensions`` as an (N, m) array, checked: platform-end tensions (N),
    ``>= 0``, NaN where a pose has none."""
    start = float_argument("initial_tensions", value)
    if start.shape not in ((m,), (N, m)):
        raise InvalidCableError(
            f"initial_tensions must have shape ({m},) or ({N}, {m}) (platform-end tensions "
            f"in N, one row per pose); got shape {start.shape}")
    bad = np.isinf(start) | (start < 0)
    if bad.any():
        raise InvalidCableError(
            "initial_tensions must be >= 0 and finite (NaN marks a pose without one); got "
            f"initial_tensions={float(start[bad].flat[0])!r}")
    return np.broadcast_to(start, (N, m))


def _coupled_start(robot: CableRobot, poses: FloatArray, straight: TensionSolution,
                   initial_tensions: ArrayLike | None, wrench: ArrayLike | None,
                   backend: str | Backend, options: dict[str, Any]
                   ) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Platform-end tensions (N, m) to start the coupled model from, the poses to
    attempt (N,), and the poses whose margin search settled nothing (N,).

    The straight-line distribution, replaced by the finite rows of ``initial_tensions``
    when given; else, where no straight-line tensions fit the bounds, by the tensions
    the coupled capacity-margin search finds, since sag can widen the workspace.
    ``options`` holds the backend's options and the margin's ``tol`` and ``max_iter``.
    """
    N, m = poses.shape[0], robot.m
    tensions, attempt = straight.tensions, straight.success.copy()
    unsettled = np.zeros(N, dtype=bool)
    if initial_tensions is not None:
        start = _given_start(initial_tensions, N, m)
    elif attempt.all():
        return tensions, attempt, unsettled
    else:
        idx = np.flatnonzero(~attempt)
        start = np.full((N, m), np.nan)
        wk = None
        if wrench is not None:
            wr = np.asarray(wrench, dtype=float)
            wk = wr[idx] if wr.ndim == 2 else wr
        margin, T_m, m_status, _, _ = coupled_margin(robot, poses[idx], wk, backend,
                                                     **options)
        slack = 1e-9 * np.nanmax(np.abs(T_m), axis=1, initial=0.0)
        found = (m_status == Status.CONVERGED) & (margin >= -slack)
        start[idx[found]] = T_m[found]
        unsettled[idx[m_status != Status.CONVERGED]] = True
    # A row reduction of a 2-D mask: an array (the stubs also allow a scalar).
    given = cast(NDArray[np.bool_], np.isfinite(start).all(axis=1))
    return np.where(given[:, None], start, tensions), attempt | given, unsettled


def _thesis(planes: CablePlanes, tensions: FloatArray, straight_status: NDArray[np.str_],
            w: float, EA: float, compiled: bool) -> CatenarySolution:
    """The thesis convention: taut catenaries with the drawing-point tensions (N, m) of
    the poses whose straight-line distribution is optimal (``compiled``: as
    :func:`catenary.solve_length`'s keyword).

    The status of a pose is ``CONVERGED`` exactly where every catenary solve converged
    (``CATENARY_FAILED`` elsewhere), or that of its straight-line distribution where
    this one failed; equilibrium is not part of it.
    """
    N, m = planes.x.shape
    H, V_A, V_B, L0 = (np.full((N, m), np.nan) for _ in range(4))
    attempt = np.asarray(straight_status == Status.OPTIMAL, dtype=bool)
    status = status_array(N, Status.CONVERGED)
    status[~attempt] = np.asarray(straight_status)[~attempt]
    cat_its = np.zeros((N, m), np.int64)
    idx = np.flatnonzero(attempt)
    if idx.size:
        c = solve_length(planes.x[idx], planes.z[idx], tensions[idx], w, EA, "B",
                         compiled=compiled)
        cat_its[idx] += c.iterations
        status[idx[~c.converged.all(axis=1)]] = Status.CATENARY_FAILED
        H[idx], V_A[idx], V_B[idx], L0[idx] = c.H, c.V_A, c.V_B, c.L0
    return CatenarySolution(H, V_A, V_B, L0, tensions, status, np.zeros(N, np.int64),
                            cat_its)


def thesis_result(solver: CompiledThesis | None, pose: ArrayLike, wrench: ArrayLike | None,
                  start: float) -> InverseKinematicsResult | None:
    """The thesis-convention result of one pose (n,) by ``solver``, with an external
    wrench (n,) or None (N, N m), or None where the numpy path decides (no solver, see
    :meth:`CompiledThesis.solve`; also poses or wrenches of another shape or type).
    ``start`` is the :func:`time.perf_counter` reading the solve time counts from."""
    if solver is None:
        return None
    dof = solver.robot.dof
    try:
        p = np.ascontiguousarray(pose, dtype=np.float64)
        wr = None if wrench is None else np.ascontiguousarray(wrench, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    if p.shape != (dof,) or (wr is not None and wr.shape != (dof,)):
        return None
    got = solver.solve(p, wr)
    if got is None:
        return None
    out, forces, residual = got
    return new_result(
        InverseKinematicsResult, lengths=out[0], straight_lengths=out[4],
        tensions=out[1], tensions_platform=out[2], horizontal_tensions=out[3],
        platform_forces=forces, equilibrium_residual=np.array([residual]),
        iterations=_NO_ITERATIONS.copy(), catenary_iterations=out[5].astype(np.int64),
        status=_ONE_CONVERGED.copy(), model="thesis",
        solve_time=time.perf_counter() - start, problem=solver.distributor.problem)


def _result(robot: CableRobot, poses: FloatArray, wrench: ArrayLike | None,
            planes: CablePlanes, solution: CatenarySolution, model: str,
            solve_time: float, problem: TensionProblem | None = None
            ) -> InverseKinematicsResult:
    """The result of a solution: NaN catenaries where it failed, forces, residuals."""
    failed = ~np.isin(solution.status, (Status.CONVERGED, Status.MAX_ITER))[:, None]
    H, V_A, V_B, L0 = (np.where(failed, np.nan, a)
                       for a in (solution.H, solution.V_A, solution.V_B, solution.L0))
    forces = platform_forces(planes, H, V_A)
    residual = equilibrium_residual(robot, forces, planes.arms,
                                    robot.required_wrench(poses, wrench))
    return InverseKinematicsResult(
        lengths=L0,
        straight_lengths=planes.chord,
        tensions=np.hypot(H, V_B),
        tensions_platform=np.hypot(H, V_A),
        horizontal_tensions=H,
        platform_forces=forces,
        equilibrium_residual=residual,
        iterations=solution.iterations,
        catenary_iterations=solution.catenary_iterations,
        status=solution.status,
        model=model,
        solve_time=solve_time,
        problem=problem,
    )
