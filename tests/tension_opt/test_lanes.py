"""The certified closed form of four-cable point robots with poses side by side
(:mod:`tension_opt.kernels.certified_lanes`) against the pose-by-pose kernel it stands for.

:func:`tension_opt.kernels.certified.certified_poses` runs a point robot on four
cables in blocks of poses; with ``side_by_side=False`` it runs every pose by the
pose-by-pose loop. Both must write the same bits into every output: the blocks do the
same operations in the same order, with choices in place of branches. The blocks must
also settle nearly every pose themselves (a kernel that handed every pose back would
pass the first test trivially).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import tension_opt as to
from benchmarks.random_robots import random_robot, random_robot_poses
from tension_opt import presets
from tension_opt.distribution.certified import CertifiedBatch, certified_plan
from tension_opt.errors import InvalidInputError
from tension_opt.kernels.certified import certified_poses, problem_views
from tension_opt.kernels.certified_lanes import LANES, REDO, lane_poses
from tension_opt.kernels.closed_form import HEADER
from tension_opt.problem.form import TensionProblem
from tension_opt.tolerances import RIDGE, ROW_FLOOR, UB_SHARE
from tension_opt.workspace.sampling import default_box

OBJECTIVES = ["min_sum", "min_norm", "pinv", "centered"]
#: The outputs of certified_poses, in its order after the poses and wrenches.
NAMES = ("tensions", "codes", "unique", "objective", "residual", "bound_violation",
         "infeasibility", "primal_residual", "dual_residual", "duality_gap", "y", "mu", "z")


def outputs(batch: CertifiedBatch) -> tuple[np.ndarray, ...]:
    """The batch's output arrays, in :data:`NAMES`' order."""
    mult = batch.multipliers
    return (batch.tensions, batch.codes, batch.unique,
            *(batch.measures[name] for name in NAMES[3:10]), mult.y, mult.mu, mult.z)


def both(robot: to.CableRobot, poses: np.ndarray, problem: TensionProblem,
         wrench: np.ndarray | None) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...],
                                             int, int]:
    """Every output of the blocks and of the pose-by-pose loop, and the poses each
    left to the caller."""
    plan = certified_plan(robot, problem, "closed_form")
    assert plan is not None
    runs, left = [], []
    for side_by_side in (True, False):
        batch = CertifiedBatch(plan, poses, wrench)
        for out in outputs(batch):  # garbage in every slot the kernels must write
            out[...] = 7 if out.dtype != bool else True
        left.append(certified_poses(plan.data, batch.poses, batch.wrench, *outputs(batch),
                                    side_by_side))
        runs.append(outputs(batch))
    return runs[0], runs[1], left[0], left[1]


def assert_bits(fast: tuple[np.ndarray, ...], slow: tuple[np.ndarray, ...],
                done: np.ndarray) -> None:
    """The outputs agree bit for bit on the poses ``done`` (the kernel's codes 0-3;
    other poses' results are the caller's to write)."""
    for name, a, b in zip(NAMES, fast, slow, strict=True):
        if name == "codes":
            np.testing.assert_array_equal(a, b)
            continue
        a, b = a[done], b[done]
        if a.dtype.kind == "f":  # NaN as NaN; 0.0 and -0.0 told apart
            a, b = a.view(np.int64), b.view(np.int64)
        np.testing.assert_array_equal(a, b, err_msg=name)


def redone(robot: to.CableRobot, poses: np.ndarray, problem: TensionProblem,
           wrench: np.ndarray | None) -> int:
    """Poses the blocks hand back (:data:`REDO`)."""
    plan = certified_plan(robot, problem, "closed_form")
    assert plan is not None
    batch = CertifiedBatch(plan, poses, wrench)
    data = plan.data
    o = HEADER + 12 * robot.m
    T, codes, unique, *rest = outputs(batch)
    count = lane_poses(data, problem_views(data), data[o], int(data[o + 1]), batch.poses,
                       batch.wrench, (T, rest[7], rest[8], rest[9]), (codes, unique),
                       tuple(rest[:7]), RIDGE, UB_SHARE, ROW_FLOOR)
    assert count == (codes == REDO).sum()
    return int(count)


def spread_poses(robot: to.CableRobot, count: int, seed: int, spread: float = 1.6
                 ) -> np.ndarray:
    """Poses in and around the robot's default box: feasible and infeasible ones."""
    low, high = default_box(robot)
    mid, half = (low + high) / 2, (high - low) / 2 * spread
    return np.random.default_rng(seed).uniform(mid - half, mid + half, (count, robot.dof))


def study_poses() -> np.ndarray:
    """The study robot's poses: spread ones, poses on its planes of symmetry (exact
    zeros in the fit's matrix), a pose on a drawing point, a singular one (every cable
    horizontal) and one just below it; 701 poses, not a whole number of blocks."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 701, 5)
    centre, top = robot.anchors[:, :2].mean(axis=0), robot.anchors[0, 2]
    poses[10:40, 0] = centre[0]
    poses[40:70, 1] = centre[1]
    poses[70:80, :2] = centre
    poses[80] = robot.anchors[2]
    poses[81] = [*centre, top]
    poses[82] = [*centre, top - 1e-9]
    return poses


@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("wrench", ["none", "one", "per_pose"])
def test_blocks_give_the_pose_by_pose_bits(objective: str, wrench: str) -> None:
    robot = presets.algae_harvester()
    poses = study_poses()
    rng = np.random.default_rng(2)
    w = {"none": None, "one": rng.normal(0.0, 0.05 * robot.weight, 3),
         "per_pose": rng.normal(0.0, 0.05 * robot.weight, (len(poses), 3))}[wrench]
    if wrench == "per_pose":
        w[[100, 200]] = [0.0, 0.0, -1e160]  # beyond the kernels' range
    changes: dict[str, object] = {} if objective == "pinv" else {
        "weights": rng.uniform(0.5, 2.0, 4)}
    if objective == "centered":  # finite upper bounds
        changes["t_max"] = np.asarray(robot.t_min) + 5 * robot.weight
    problem = TensionProblem(objective, **changes)
    fast, slow, left_fast, left_slow = both(robot, poses, problem, w)
    assert left_fast == left_slow
    codes = slow[1]
    expected = {0} if objective == "pinv" else {0, 1}  # pinv: no bounds
    assert set(np.unique(codes).tolist()) >= expected
    assert_bits(fast, slow, codes <= 3)
    # The blocks settle all but the poses off the common path.
    count = redone(robot, poses, problem, w)
    assert count <= 8, count


def test_a_few_poses_and_one_pose() -> None:
    """Fewer poses than a block, and one pose: the block repeats the last pose."""
    robot = presets.algae_harvester()
    problem = TensionProblem("min_sum")
    for count in (1, 3, LANES - 1, LANES, LANES + 1):
        poses = spread_poses(robot, count, count, spread=1.0)
        fast, slow, _, _ = both(robot, poses, problem, None)
        assert_bits(fast, slow, slow[1] <= 3)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), objective=st.sampled_from(OBJECTIVES),
       bounds=st.booleans(), wrench=st.booleans(), symmetric=st.booleans())
@example(seed=0, objective="min_norm", bounds=True, wrench=True, symmetric=True)
def test_random_robots_give_the_pose_by_pose_bits(seed: int, objective: str, bounds: bool,
                                                  wrench: bool, symmetric: bool) -> None:
    """Random four-cable point robots (ties of symmetric ones included), poses inside,
    outside and on the edge of the workspace, bounds finite or not."""
    robot = random_robot(seed, 4, "point3", symmetric)
    try:
        edge = random_robot_poses(robot, 40, seed, boundary=0.5, symmetric=symmetric)
    except InvalidInputError:  # a robot without a workspace: spread poses only
        edge = np.empty((0, 3))
    poses = np.concatenate([edge, spread_poses(robot, 200, seed, spread=1.3)])
    rng = np.random.default_rng(seed + 1)
    changes: dict[str, object] = {}
    if objective != "pinv":
        changes["weights"] = rng.uniform(0.5, 2.0, 4)
    if (bounds and objective != "pinv") or objective == "centered":
        changes["t_min"] = np.asarray(robot.t_min) * rng.uniform(0.5, 1.5, 4)
        changes["t_max"] = changes["t_min"] + robot.weight * rng.uniform(1.0, 8.0, 4)
    if objective == "min_norm":
        changes["reference"] = rng.uniform(0.0, 2.0, 4) * robot.weight / 4
    problem = TensionProblem(objective, **changes)
    w = rng.normal(0.0, 0.05 * robot.weight, (len(poses), 3)) if wrench else None
    fast, slow, left_fast, left_slow = both(robot, poses, problem, w)
    assert left_fast == left_slow
    assert_bits(fast, slow, slow[1] <= 3)
    assert redone(robot, poses, problem, w) <= len(poses) // 10
