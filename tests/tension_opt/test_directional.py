"""One-sided directional derivatives at poses where a bound is just touched: against
forward differences of the solver on each side, against the Jacobian where it exists,
and NaN with a status where they are not available."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.errors import InvalidInputError


def _crossing(robot: to.CableRobot, objective: str, start: np.ndarray, axis: int,
              lo: float, hi: float, cable: int) -> np.ndarray:
    """A pose on the segment where ``cable`` leaves its lower bound (bisection to
    rounding on whether its optimal tension is above ``t_min``)."""
    t_min = float(np.broadcast_to(robot.t_min, (robot.m,))[cable])

    def above(x: float) -> bool:
        pose = start.copy()
        pose[axis] = x
        t = float(to.distribute(robot, pose[None], objective).tensions[0, cable])
        return t > t_min * (1 + 1e-12)

    side = above(lo)
    assert side != above(hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if above(mid) == side:
            lo = mid
        else:
            hi = mid
    pose = start.copy()
    pose[axis] = 0.5 * (lo + hi)
    return pose[None]


@cache
def study_touching() -> tuple[to.CableRobot, np.ndarray]:
    """The study robot, min-norm, where cable P1 just touches t_min = m g."""
    robot = to.presets.algae_harvester()
    return robot, _crossing(robot, "min_norm", np.array([0.0, -15.0, 2.0]), 0, 33.0, 34.0, 0)


def forward_difference(robot: to.CableRobot, pose: np.ndarray, wrt: str,
                       direction: np.ndarray, h: float) -> np.ndarray:
    base = to.distribute(robot, pose, "min_norm").tensions[0]
    if wrt == "wrench":
        moved = to.distribute(robot, pose, "min_norm", wrench=h * direction)
    elif wrt == "pose":
        moved = to.distribute(robot, pose + h * direction, "min_norm")
    elif wrt == "t_min":
        moved = to.distribute(robot.with_(t_min=robot.t_min + h * direction), pose,
                              "min_norm")
    else:
        moved = to.distribute(robot.with_(anchors=robot.anchors + h * direction), pose,
                              "min_norm")
    return (moved.tensions[0] - base) / h


@pytest.mark.parametrize(("wrt", "direction"), [
    ("wrench", [0.0, 0.0, 50.0]), ("wrench", [0.0, 0.0, -50.0]),
    ("wrench", [30.0, 0.0, 0.0]), ("wrench", [-30.0, 0.0, 0.0]),
    ("pose", [1.0, 0.0, 0.0]), ("pose", [-1.0, 0.0, 0.0]),
    ("t_min", [1.0, 0.0, 0.0, 0.0]), ("t_min", [-1.0, 0.0, 0.0, 0.0]),
    ("drawing_points", [[0, 0, 1.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]),
    ("drawing_points", [[0, 0, -1.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]),
])
def test_one_sided_derivatives_match_forward_differences(wrt: str, direction: list) -> None:
    robot, pose = study_touching()
    sol = to.distribute(robot, pose, "min_norm")
    assert sol.jacobian("wrench").status[0] == "degenerate"
    d = np.asarray(direction)
    got = sol.directional_derivative(wrt, d, robot=robot, poses=pose)
    assert got.status[0] == "one_sided"
    fd = forward_difference(robot, pose, wrt, d, 1e-4)
    np.testing.assert_allclose(got.derivative[0], fd, rtol=1e-4,
                               atol=1e-4 * np.abs(fd).max())


def test_the_two_sides_differ() -> None:
    robot, pose = study_touching()
    sol = to.distribute(robot, pose, "min_norm")
    up = sol.directional_derivative("wrench", [0.0, 0.0, 50.0]).derivative[0]
    down = sol.directional_derivative("wrench", [0.0, 0.0, -50.0]).derivative[0]
    # Pushing the cable below t_min keeps it on the bound; the other way it leaves it.
    assert up[0] == pytest.approx(0.0, abs=1e-9) and down[0] > 1.0
    assert not np.allclose(up, -down)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
    lambda v: np.linalg.norm(v) > 0.1))
def test_random_directions_of_the_wrench(direction: list) -> None:
    robot, pose = study_touching()
    sol = to.distribute(robot, pose, "min_norm")
    d = 100.0 * np.asarray(direction)
    got = sol.directional_derivative("wrench", d)
    fd = forward_difference(robot, pose, "wrench", d, 1e-4)
    np.testing.assert_allclose(got.derivative[0], fd, rtol=1e-4, atol=1e-4 * np.abs(fd).max())


def test_six_dof_touching_pose() -> None:
    robot = to.presets.cogiro()
    start = np.array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
    base = to.distribute(robot, start[None], "min_norm").tensions[0]
    cable = int(np.argmin(np.where(base > 100.0 * (1 + 1e-12), base, np.inf)))
    pose = None
    for axis in range(3):
        for hi in (-4.0, 4.0):
            end = start.copy()
            end[axis] = hi
            t_end = to.distribute(robot, end[None], "min_norm").tensions[0]
            if t_end[cable] <= 100.0 * (1 + 1e-12):
                pose = _crossing(robot, "min_norm", start, axis, 0.0, hi, cable)
                break
        if pose is not None:
            break
    assert pose is not None
    sol = to.distribute(robot, pose, "min_norm")
    assert sol.jacobian("wrench").status[0] == "degenerate"
    for sign in (1.0, -1.0):
        d = sign * np.array([0.0, 0.0, 200.0, 5.0, -5.0, 0.0])
        got = sol.directional_derivative("wrench", d)
        assert got.status[0] == "one_sided"
        fd = forward_difference(robot, pose, "wrench", d, 1e-4)
        np.testing.assert_allclose(got.derivative[0], fd, rtol=1e-4,
                                   atol=1e-4 * np.abs(fd).max())


def test_where_the_jacobian_exists_it_is_used() -> None:
    robot = to.presets.algae_harvester()
    poses = np.array([[5.0, -3.0, 2.0], [-20.0, 10.0, 1.0]])
    sol = to.distribute(robot, poses, "min_norm")
    d = np.array([10.0, -5.0, 20.0])
    got = sol.directional_derivative("wrench", d)
    assert list(got.status) == ["ok", "ok"]
    np.testing.assert_allclose(got.derivative, sol.jacobian("wrench").jacobian @ d,
                               rtol=1e-12)


def test_linear_objectives_and_faces_get_nan() -> None:
    robot = to.presets.algae_harvester()
    centre = to.distribute(robot, [[0.0, 0.0, 1.0]], "min_sum")
    got = centre.directional_derivative("wrench", [0.0, 0.0, 1.0])
    assert got.status[0] == "non_unique" and np.isnan(got.derivative).all()
    _, pose = study_touching()
    lp = to.distribute(robot, pose, "min_sum")
    status = lp.jacobian("wrench").status[0]
    got = lp.directional_derivative("wrench", [0.0, 0.0, 1.0])
    if status == "degenerate":
        assert got.status[0] == "unavailable" and np.isnan(got.derivative).all()
    else:
        assert got.status[0] in ("ok", "non_unique")


@pytest.mark.parametrize("direction", [[1.0, 2.0], np.ones((3, 3)), [np.nan, 0.0, 0.0]])
def test_bad_directions_are_refused(direction: object) -> None:
    robot = to.presets.algae_harvester()
    sol = to.distribute(robot, [[5.0, -3.0, 2.0]], "min_norm")
    with pytest.raises(InvalidInputError, match="direction"):
        sol.directional_derivative("wrench", direction)

