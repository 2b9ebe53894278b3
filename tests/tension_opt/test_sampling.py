"""The shared random-feasible-pose sampler (tension_opt.workspace.sampling) behind the random
scenarios."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import tension_opt as to
from benchmarks.scenarios import POND_HIGH, POND_LOW, SCENARIOS
from tension_opt.errors import InvalidInputError
from tension_opt.workspace.sampling import default_box, feasible_mask, random_feasible_poses


def test_poses_are_feasible_in_the_box_and_reproducible() -> None:
    robot = to.presets.algae_harvester()
    poses = random_feasible_poses(robot, 300, seed=4, low=POND_LOW, high=POND_HIGH)
    assert poses.shape == (300, 3)
    assert (poses >= POND_LOW).all() and (poses <= POND_HIGH).all()
    assert to.distribute(robot, poses, "min_sum", "closed_form").success.all()
    again = random_feasible_poses(robot, 300, seed=4, low=POND_LOW, high=POND_HIGH)
    np.testing.assert_array_equal(poses, again)
    # The first round's draws, in order: x, y and z each one column.
    rng = np.random.default_rng(4)
    drawn = np.column_stack([rng.uniform(lo, hi, 600) for lo, hi in zip(POND_LOW, POND_HIGH,
                                                                         strict=True)])
    np.testing.assert_array_equal(poses, drawn[feasible_mask(robot, drawn)][:300])


def test_the_random_scenarios_use_it() -> None:
    scenario = SCENARIOS["thesis_random"]
    expected = random_feasible_poses(scenario.robot, 100, seed=1, low=POND_LOW, high=POND_HIGH)
    np.testing.assert_array_equal(scenario.poses, expected)


@pytest.mark.parametrize("make", [to.presets.algae_harvester, to.presets.cogiro,
                                  to.presets.ipanema3, to.presets.kntu_planar,
                                  to.presets.point_xz_4cable])
def test_default_box_holds_feasible_poses_of_every_kind(make: Callable[[], to.CableRobot]
                                                         ) -> None:
    robot = make()
    low, high = default_box(robot)
    assert low.shape == high.shape == (robot.dof,) and (low < high).all()
    poses = random_feasible_poses(robot, 50, seed=0)
    assert poses.shape == (50, robot.dof)
    assert ((poses >= low) & (poses <= high)).all()


def test_margin_keeps_tensions_inside_the_bounds() -> None:
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 40, seed=1, margin=300.0)
    tight = to.TensionProblem("min_sum", t_min=robot.t_min + 300.0, t_max=robot.t_max - 300.0)
    assert to.distribute(robot, poses, tight, "closed_form").success.all()


def test_errors_name_the_argument() -> None:
    robot = to.presets.cogiro()
    with pytest.raises(InvalidInputError, match="max_draws=20"):
        random_feasible_poses(robot, 100, seed=0, max_draws=20, batch=10)
    with pytest.raises(InvalidInputError, match="margin"):
        random_feasible_poses(robot, 5, margin=-1.0)
    with pytest.raises(InvalidInputError, match="low and high"):
        random_feasible_poses(robot, 5, low=np.zeros(6))
    with pytest.raises(InvalidInputError, match="n must be"):
        random_feasible_poses(robot, -1)
    assert random_feasible_poses(robot, 0).shape == (0, 6)
