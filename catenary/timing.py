"""Sag-aware time-optimal timing: the coupled sag model around the straight-cable timing.

A sagging cable pulls the platform along the tangent of its catenary at the
attachment, not along the chord, and its tension varies along it (by ``w`` times the
height difference), so the bounds ``t_min`` (on the lowest tension along the cable)
and ``t_max`` (on the highest) of the coupled model of
:func:`catenary.inverse_kinematics` leave the platform-end tension a different range.
Linearised at given catenaries, both effects are affine in the platform-end tensions
``t`` (:func:`sag_constraints`), so :func:`tension_opt.dynamics.time_optimal` takes
them as per-point structure matrices, an offset wrench and bounds.
:func:`time_optimal_sag` iterates to a fixed point (sequential convex programming, as
the coupled inverse kinematics of :mod:`catenary.coupled`):

1. time the path with straight cables;
2. solve the taut catenary of every cable at every grid point with the timing's
   platform-end tensions (:func:`catenary.geometry.taut_catenaries`, end ``"A"``);
3. time the path again with those directions and bounds;

until the duration settles and the catenaries that carry the timing's tensions supply
its dynamic wrench within the bounds (both to ``tol``): at the fixed point the
linearisation is exact at the timing's tensions.
The cables are quasi-static: their own inertia is neglected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tension_opt import CableRobot
from tension_opt.dynamics import PathSpline, TimingResult, required_wrench, time_optimal
from tension_opt.problem.form import as_problem
from tension_opt.status import Status

from .geometry import (
    CablePlanes,
    Catenaries,
    cable_data,
    cable_planes,
    cable_wrench,
    extreme_tensions,
    force_slope,
    platform_forces,
    taut_catenaries,
)

__all__ = ["SagTimingResult", "sag_constraints", "time_optimal_sag"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SagTimingResult:
    """A sag-aware timing and how it was reached.

    Attributes
    ----------
    timing : TimingResult
        The timing with the sag model (its ``tensions`` are platform-end tensions).
    straight : TimingResult
        The timing with straight cables it started from.
    durations : ndarray, shape (iterations + 1,)
        Duration (s) of the straight timing and of every sag-aware one.
    status : str
        ``Status.CONVERGED``; ``Status.MAX_ITER``; ``Status.CATENARY_FAILED`` (no taut
        catenary carries a tension); or the failing timing's status (``infeasible``).
    lengths : ndarray, shape (K, m)
        Unstretched cable lengths along the timed path (m).
    tensions_top : ndarray, shape (K, m)
        Tension at the drawing points (N).
    lowest, highest : ndarray, shape (K, m)
        Lowest and highest tension along each cable (N), within ``[t_min, t_max]``.
    equilibrium_residual : ndarray, shape (K,)
        Norm of the dynamic wrench minus the catenary end forces' wrench (N, N m).
    extras : dict
        ``defect``: per iteration, how far the catenaries carrying the timing's
        tensions are from supplying its wrench within the bounds (relative to the
        largest tension).
    """

    timing: TimingResult
    straight: TimingResult
    durations: FloatArray
    status: str
    lengths: FloatArray
    tensions_top: FloatArray
    lowest: FloatArray
    highest: FloatArray
    equilibrium_residual: FloatArray
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Duration of the sag-aware timing (s)."""
        return self.timing.duration

    @property
    def slowdown(self) -> float:
        """How much longer the sag-aware timing takes: ``duration / straight - 1``."""
        return self.timing.duration / self.straight.duration - 1.0

    @property
    def iterations(self) -> int:
        """Sag-aware timings computed."""
        return len(self.durations) - 1

    @property
    def success(self) -> bool:
        """Whether the iteration converged to a timing with tensions at every point."""
        return self.status == Status.CONVERGED and self.timing.success


def sag_constraints(robot: CableRobot, planes: CablePlanes, cats: Catenaries,
                    tensions: FloatArray, w: float, EA: float
                    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The coupled model linearised at the catenaries ``cats`` that carry the
    platform-end tensions ``tensions`` (K, m).

    Each cable's platform force is ``f_i(t) ~ f_i(t0) + f_i'(t0) (t - t0)``
    (:func:`~catenary.geometry.force_slope`), so the wrench balance reads
    ``A t + w0 = required`` with the columns of ``A`` the slopes' wrenches and ``w0``
    the constant part. The lowest tension along a cable is its platform end (slope 1)
    or, where the cable dips below it, the horizontal tension (slope ``dH/dt``); the
    highest is taken to move with the platform-end tension (slope 1).

    Returns
    -------
    A : ndarray, shape (K, n, m)
    offset : ndarray, shape (K, n)
        ``w0`` (N, N m): the external-wrench argument of the timing.
    lb, ub : ndarray, shape (K, m)
        Bounds on the platform-end tensions (N).
    """
    forces = platform_forces(planes, cats.H, cats.V_A)
    slope = force_slope(planes, cats.H, cats.V_A, cats.V_B, cats.L0, w, EA)
    A = np.swapaxes(robot.cable_wrenches(slope, planes.arms), 1, 2)
    offset = cable_wrench(robot, forces - slope * tensions[..., None], planes.arms)
    low, high = extreme_tensions(cats.H, cats.V_A, cats.V_B)
    dip = (cats.V_A < 0) & (cats.V_B > 0)
    rate = np.where(dip, np.einsum("kmi,kmi->km", slope, planes.e_h), 1.0)
    rate = np.where(rate > 0, rate, 1.0)
    lb = tensions + (robot.t_min - low) / rate
    ub = tensions + (robot.t_max - high)  # inf stays inf
    return np.ascontiguousarray(A), offset, lb, ub


def time_optimal_sag(
    robot: CableRobot,
    path: ArrayLike | PathSpline,
    v_max: float | ArrayLike | None = None,
    a_max: float | ArrayLike | None = None,
    *,
    tol: float = 1e-5,
    max_iter: int = 30,
    proximal: float = 1e-4,
    **options: Any,
) -> SagTimingResult:
    """Time-optimal timing of a path with sagging cables (coupled model).

    Parameters
    ----------
    robot : CableRobot
        Needs ``robot.cable`` (weight per length and ``EA``).
    path : array_like, shape (N, n), or PathSpline
        Poses in order (m, rad), as in :func:`tension_opt.dynamics.time_optimal`.
    v_max, a_max : float or array_like, optional
        Velocity and acceleration limits, as there.
    tol : float
        Converged when the duration changed less than ``tol`` (relative) in the last
        iteration and the catenaries carrying the timing's tensions supply the dynamic
        wrench within the bounds, to ``tol`` times the largest tension.
    max_iter : int
        Largest number of sag-aware timings.
    proximal : float
        Weight of ``||t - t_prev||^2`` added to the objective of the reported tensions
        in every sag-aware timing (as ``TensionProblem.smoothing``), against the
        previous iterate's tensions: it keeps the linearisation's steps short. At the
        fixed point the term and its gradient vanish, so the tensions are optimal for
        the objective itself.
    **options
        Passed to :func:`tension_opt.dynamics.time_optimal` (``gridpoints``,
        ``method``, ``objective``, ``backend`` ...).

    Returns
    -------
    SagTimingResult
        The sag-aware timing, the straight one, the durations per iteration and the
        catenaries along the timed path.
    """
    w, EA = cable_data(robot)
    problem = as_problem(options.pop("objective", "min_sum"))
    straight = time_optimal(robot, path, v_max, a_max, objective=problem, **options)
    if not straight.success:
        first = straight.status[straight.status != Status.OPTIMAL][0]
        return _result(robot, cable_planes(robot, straight.poses), straight, straight,
                       [straight.duration], str(first), [], w, EA)
    options = {**options, "gridpoints": straight.s,
               "objective": problem.with_(smoothing=proximal) if proximal else problem}
    spline = straight.extras["path"]
    planes = cable_planes(robot, straight.poses)
    timing, t = straight, straight.tensions
    durations, defects = [straight.duration], []
    status = Status.MAX_ITER
    for it in range(max_iter + 1):
        cats = taut_catenaries(planes.x, planes.z, t, w, EA, "A")
        if not cats.converged.all():
            status = Status.CATENARY_FAILED
            break
        defects.append(_defect(robot, planes, timing, cats))
        if it and defects[-1] <= tol and abs(durations[-1] - durations[-2]) <= (
                tol * durations[-1]):
            status = Status.CONVERGED
            break
        if it == max_iter:
            break
        A, offset, lb, ub = sag_constraints(robot, planes, cats, t, w, EA)
        nxt = time_optimal(robot, spline, v_max, a_max, structure=A, bounds=(lb, ub),
                           wrench=offset, previous=t if proximal else None, **options)
        durations.append(nxt.duration)
        timing, t = nxt, nxt.tensions
        if not nxt.success:
            status = Status.INFEASIBLE
            break
    return _result(robot, planes, timing, straight, durations, str(status), defects, w, EA)


def _defect(robot: CableRobot, planes: CablePlanes, timing: TimingResult,
            cats: Catenaries) -> float:
    """How far the catenaries ``cats`` (carrying the timing's tensions) are from
    supplying its dynamic wrench within the bounds, relative to the largest tension."""
    forces = platform_forces(planes, cats.H, cats.V_A)
    needed = required_wrench(robot, timing.poses, timing.velocities, timing.accelerations)
    residual = np.linalg.norm(cable_wrench(robot, forces, planes.arms) - needed, axis=1)
    low, high = extreme_tensions(cats.H, cats.V_A, cats.V_B)
    violation = np.maximum(robot.t_min - low, high - robot.t_max).max(axis=1)
    scale = float(np.abs(timing.tensions).max())
    return float(np.maximum(residual, violation).max() / scale)


def _result(robot: CableRobot, planes: CablePlanes, timing: TimingResult,
            straight: TimingResult, durations: list[float], status: str,
            defects: list[float], w: float, EA: float) -> SagTimingResult:
    """The catenaries carrying the final timing's tensions and what they supply."""
    t = timing.tensions
    cats = taut_catenaries(planes.x, planes.z, np.nan_to_num(t, nan=0.0), w, EA, "A")
    ok = cats.converged & np.isfinite(t)
    H, V_A, V_B, L0 = (np.where(ok, a, np.nan) for a in (cats.H, cats.V_A, cats.V_B,
                                                         cats.L0))
    forces = platform_forces(planes, H, V_A)
    supplied = cable_wrench(robot, forces, planes.arms)
    needed = np.full_like(supplied, np.nan)
    if np.isfinite(timing.accelerations).all():
        needed = required_wrench(robot, timing.poses, timing.velocities, timing.accelerations)
    residual = np.linalg.norm(supplied - needed, axis=1)
    low, high = extreme_tensions(H, V_A, V_B)
    return SagTimingResult(timing, straight, np.array(durations), status, L0,
                           np.hypot(H, V_B), low, high, residual,
                           {"defect": np.array(defects)})
