"""Test sets of the benchmark: scenarios (a robot and its poses) and the problems posed on them.

A :class:`Scenario` is a named, described set of poses of one robot, either an ordered
trajectory (smoothness and sequential problems apply) or an unordered set. A
:class:`ProblemSpec` is a named tension-distribution problem, built for a robot (the
centred problem needs finite bounds, which the study's robot does not have) and solved
over poses by :func:`tension_opt.distribute` or, for joint smoothing,
``tension_opt.dynamics.trajectory.smooth_jointly``.

Random sets are seeded draws of :func:`tension_opt.workspace.sampling.random_feasible_poses`
(kept where the exact ``closed_form`` backend finds feasible tensions), so every
scenario is the same on every machine. Besides the study's robot and CoGiRo, seeded
random suspended robots (:mod:`benchmarks.random_robots`: 3 DOF with 6 and 7 cables, one
of them symmetric, and 6 DOF with 7 cables) widen the test set, with poses at the edge
of their workspaces where the optimum is nearly degenerate.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import tension_opt
from benchmarks.random_robots import random_robot, random_robot_poses
from tension_opt import CableRobot, TensionProblem, TensionSolution, presets
from tension_opt.backends import Backend
from tension_opt.workspace.sampling import feasible_mask, random_feasible_poses

_SNAPSHOT_FILE = Path(__file__).resolve().parents[1] / "tests" / "data" / "thesis_snapshots.json"
# The study's Table 4 poses (m); used when the data file is not beside the package.
_SNAPSHOT_POSES = ((0.0, 0.0, 0.0), (-29.4, 10.2, 1.5), (-33.0, -18.8, 2.0),
                   (28.5, -18.0, 3.1), (35.0, 22.0, 5.0))


class NotAvailableError(RuntimeError):
    """A problem needs a function that this version of ``tension_opt`` does not have."""


# ------------------------------------------------------------------ scenarios
@dataclass(eq=False)
class Scenario:
    """A robot and a fixed set of poses.

    Parameters
    ----------
    name : str
        Identifier used on the command line and in tables.
    description : str
        One line saying what the poses are.
    make_robot : callable () -> CableRobot
    make_poses : callable (CableRobot) -> ndarray, shape (N, n)
        Poses (m, rad); called once, the result is cached.
    trajectory : bool
        True if the poses are an ordered path (smoothness metrics, sequential problems).
    sag : bool
        True to compute the catenary (sag) columns (point-mass robots with cables).
    large : bool
        True for throughput scenarios, run only with fast backends in the default suite.
    """

    name: str
    description: str
    make_robot: Callable[[], CableRobot]
    make_poses: Callable[[CableRobot], NDArray]
    trajectory: bool = False
    sag: bool = False
    large: bool = False

    @cached_property
    def robot(self) -> CableRobot:
        """The scenario's robot."""
        return self.make_robot()

    @cached_property
    def poses(self) -> NDArray:
        """Poses, shape (N, n) (m, rad); treat as read-only."""
        p = np.asarray(self.make_poses(self.robot), dtype=float)
        return p

    @property
    def N(self) -> int:
        """Number of poses."""
        return int(self.poses.shape[0])


def snapshot_poses() -> NDArray:
    """The study's five snapshot poses, shape (5, 3) (m), from ``tests/data``."""
    if _SNAPSHOT_FILE.exists():
        data = json.loads(_SNAPSHOT_FILE.read_text())
        return np.array([s["pose"] for s in data["snapshots"]], dtype=float)
    return np.array(_SNAPSHOT_POSES)


def pick_and_place(step: float = 0.5, z_low: float = 1.0, z_high: float = 2.0,
                   start: tuple[float, float] = (-3.0, -4.0), end: tuple[float, float] = (3.0, 4.0),
                   dip_both_ways: bool = False) -> NDArray:
    """The study's pick-and-place harvesting path, shape (N, 3) (m).

    Raise from ``z_low`` to ``z_high`` at ``start``, go straight to ``end`` at ``z_high``,
    lower to ``z_low`` there, all at steps of ``step``. With the defaults this gives the
    study's 25 poses, the 13th at x = y = 0. With ``dip_both_ways`` the path instead
    starts at ``z_high`` and goes down to ``z_low`` and back up at each end (29 poses).

    Parameters
    ----------
    step : float
        Step length (m).
    z_low, z_high : float
        Heights of the pick/place point and of the transfer line (m).
    start, end : tuple of float
        (x, y) of the two ends (m).
    dip_both_ways : bool
        Lower and raise again at both ends.
    """
    k = round((z_high - z_low) / step)
    up = np.linspace(z_low, z_high, k + 1)
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    n = round(float(np.linalg.norm(b - a)) / step)
    s = np.linspace(0.0, 1.0, n + 1)[1:-1, None]
    line = np.column_stack([a + s * (b - a), np.full(len(s), z_high)])
    if dip_both_ways:
        dip = np.concatenate([up[::-1], up[1:]])
    else:
        dip = None
    first = dip if dip is not None else up
    last = dip if dip is not None else up[::-1]
    at_a = np.column_stack([np.tile(a, (len(first), 1)), first])
    at_b = np.column_stack([np.tile(b, (len(last), 1)), last])
    return np.concatenate([at_a, line, at_b])


#: The study's pond (80.9 m along x, 50 m along y) at heights 0..5 m: corners (m).
POND_LOW = (-40.45, -25.0, 0.0)
POND_HIGH = (40.45, 25.0, 5.0)
#: Around CoGiRo's home (0, 0, 2 m): +-4 m x, +-3 m y, z in [1, 3] m, rotations up to
#: 0.2 rad: corners (m, rad).
COGIRO_LOW = (-4.0, -3.0, 1.0, -0.2, -0.2, -0.2)
COGIRO_HIGH = (4.0, 3.0, 3.0, 0.2, 0.2, 0.2)


def random_poses(low: tuple[float, ...], high: tuple[float, ...], count: int,
                 seed: int) -> Callable[[CableRobot], NDArray]:
    """Pose maker of a random scenario: ``count`` wrench-feasible poses in a box.

    The poses are :func:`tension_opt.workspace.sampling.random_feasible_poses` of the robot
    (exact ``closed_form`` check, rounds of ``2 * count`` draws), shape (count, n).
    """
    def poses(robot: CableRobot) -> NDArray:
        return random_feasible_poses(robot, count, seed=seed, low=low, high=high)
    return poses


def long_pond_path(robot: CableRobot, count: int = 10_000) -> NDArray:
    """A smooth closed Lissajous path over the pond at z in [1, 3] m, shape (count, 3) (m).

    Amplitudes 30 m (x) and 18 m (y) keep it inside the feasible part of the pond;
    steps are about 2 cm for 10^4 poses.
    """
    t = np.linspace(0.0, 2.0 * np.pi, count)
    return np.column_stack([30.0 * np.sin(t), 18.0 * np.sin(2.0 * t), 2.0 + np.sin(3.0 * t)])


def cogiro_path(robot: CableRobot, count: int = 60) -> NDArray:
    """A loop around CoGiRo's home (0, 0, 2 m) with small rotations, shape (count, 6).

    Circle of radius 1.5 m, height 2 +- 0.3 m, tilt up to 0.1 rad and yaw up to 0.2 rad.
    """
    t = np.linspace(0.0, 2.0 * np.pi, count)
    return np.column_stack([1.5 * np.cos(t), 1.5 * np.sin(t), 2.0 + 0.3 * np.sin(2 * t),
                            0.1 * np.sin(t), 0.1 * np.cos(t), 0.2 * np.sin(t)])


def feasible_only(make: Callable[[CableRobot], NDArray]) -> Callable[[CableRobot], NDArray]:
    """Pose maker that keeps the wrench-feasible poses of ``make`` (exact closed form)."""
    def poses(robot: CableRobot) -> NDArray:
        p = make(robot)
        return p[feasible_mask(robot, p)]
    return poses


#: Poses of each random-robot scenario (two fifths of them at the workspace's edge).
RANDOM_ROBOT_POSES = 40


def _random(name: str, seed: int, m: int, kind: str, symmetric: bool = False) -> Scenario:
    """A scenario of one seeded random suspended robot (:mod:`benchmarks.random_robots`)."""
    dof = 3 if kind == "point3" else 6
    shape = f"{'symmetric ' if symmetric else ''}{dof}-DOF, {m} cables"
    return Scenario(
        name, f"a seeded random suspended robot ({shape}, seed {seed}): "
        f"{RANDOM_ROBOT_POSES} feasible poses, two fifths at the workspace's edge"
        f"{' and its centre' if symmetric else ''}",
        lambda: random_robot(seed, m, kind, symmetric),
        lambda robot: random_robot_poses(robot, RANDOM_ROBOT_POSES, seed,
                                         symmetric=symmetric))


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("thesis_snapshots", "the study's five snapshot poses (Table 4)",
                 presets.algae_harvester, lambda r: snapshot_poses(), sag=True),
        Scenario("thesis_trajectory",
                 "the study's pick-and-place path: raise at (-3,-4), line at z=2, lower at "
                 "(3,4), 0.5 m steps (25 poses)",
                 presets.algae_harvester, lambda r: pick_and_place(), trajectory=True, sag=True),
        Scenario("thesis_random",
                 "100 random wrench-feasible poses in the pond, z in [0, 5] m (seed 1; about "
                 "a fifth of the pond is not wrench-feasible with t_min = m g)",
                 presets.algae_harvester,
                 random_poses(POND_LOW, POND_HIGH, 100, seed=1), sag=True),
        Scenario("cogiro_trajectory",
                 "CoGiRo (8 cables, 6 DOF): 60-pose loop around home with small rotations",
                 presets.cogiro, feasible_only(cogiro_path), trajectory=True),
        Scenario("cogiro_random",
                 "CoGiRo: 100 random wrench-feasible poses around home, rotations <= 0.2 rad "
                 "(seed 2)",
                 presets.cogiro, random_poses(COGIRO_LOW, COGIRO_HIGH, 100, seed=2)),
        Scenario("thesis_long",
                 "throughput: 10^4-pose Lissajous path over the pond (about 2 cm steps)",
                 presets.algae_harvester, long_pond_path, trajectory=True, sag=True, large=True),
        _random("random_point3_m6", 2000, 6, "point3"),
        _random("random_point3_m7_symmetric", 3000, 7, "point3", symmetric=True),
        _random("random_spatial6_m7", 5000, 7, "spatial6"),
    )
}


# ------------------------------------------------------------------- problems
@dataclass(eq=False)
class ProblemSpec:
    """A named tension-distribution problem of the matrix.

    Parameters
    ----------
    name : str
        Identifier used on the command line and in tables.
    description : str
    build : callable (CableRobot) -> TensionProblem
        The problem for a robot (may set bounds the robot lacks).
    sequential : bool
        True if pose k depends on the solution at pose k - 1 (run on trajectories only).
    joint : bool
        True for joint smoothing over the whole path (one optimisation, not chunked).
    """

    name: str
    description: str
    build: Callable[[CableRobot], TensionProblem]
    sequential: bool = False
    joint: bool = False
    options: dict[str, Any] = field(default_factory=dict)

    def solve(self, robot: CableRobot, poses: NDArray, backend: str | Backend,
              previous: NDArray | None = None, **options: Any) -> TensionSolution:
        """Solve the problem over ``poses`` (N, n) with ``backend`` (a name or an instance).

        Raises
        ------
        NotAvailableError
            If joint smoothing is not in this version of ``tension_opt``.
        """
        if self.joint:
            try:
                from tension_opt.dynamics.trajectory import smooth_jointly  # type: ignore[import-not-found]
            except ImportError as exc:
                raise NotAvailableError(
                    "tension_opt.dynamics.trajectory.smooth_jointly is missing") from exc
            name = backend if isinstance(backend, str) else backend.name
            return smooth_jointly(robot, poses, objective="min_sum", backend=name,
                                  **self.options, **options)
        return tension_opt.distribute(robot, poses, self.build(robot), backend=backend,
                                      previous=previous, **options)


def _centered(robot: CableRobot) -> TensionProblem:
    if np.isfinite(robot.t_max).all():
        return TensionProblem("centered")
    return TensionProblem("centered", t_max=4.0 * robot.weight)


#: Smoothing weight of the penalised problem (1/N): a 100 N step costs 10 N of sum.
SMOOTHING = 1e-3
#: Rate limit as a fraction of the platform weight per step.
RATE_FRACTION = 0.5

PROBLEMS: dict[str, ProblemSpec] = {
    p.name: p
    for p in (
        ProblemSpec("min_sum", "minimum sum of tensions (LP), ties to minimum 2-norm",
                    lambda r: TensionProblem("min_sum")),
        ProblemSpec("min_norm", "minimum 2-norm within the bounds (QP)",
                    lambda r: TensionProblem("min_norm")),
        ProblemSpec("pinv", "Moore-Penrose pseudo-inverse (no bounds)",
                    lambda r: TensionProblem("pinv")),
        ProblemSpec("min_max", "minimise the largest tension (LP in epigraph form)",
                    lambda r: TensionProblem("min_max")),
        ProblemSpec("centered", "closest to the middle of [t_min, t_max]; t_max = 4 m g "
                    "where the robot has none", _centered),
        ProblemSpec("smoothed", f"min-sum + {SMOOTHING:g} ||T - T_prev||^2, pose by pose",
                    lambda r: TensionProblem("min_sum", smoothing=SMOOTHING), sequential=True),
        ProblemSpec("rate_limited", f"min-sum with |T - T_prev| <= {RATE_FRACTION:g} m g",
                    lambda r: TensionProblem("min_sum", rate_limit=RATE_FRACTION * r.weight),
                    sequential=True),
        ProblemSpec("joint_smoothing", f"min-sum + {SMOOTHING:g} sum_k ||T_k - T_(k-1)||^2, "
                    "one problem over the whole path",
                    lambda r: TensionProblem("min_sum", smoothing=SMOOTHING),
                    sequential=True, joint=True, options={"weight": SMOOTHING}),
    )
}


def applicable(scenario: Scenario, problem: ProblemSpec) -> bool:
    """Whether ``problem`` is posed on ``scenario`` (sequential problems need a trajectory)."""
    return scenario.trajectory or not problem.sequential
