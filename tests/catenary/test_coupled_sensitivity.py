"""Jacobians of the coupled sag model against central differences of the coupled
inverse kinematics itself: interior optima (the study robot), vertices (winch limits),
a turning 6-DOF platform (CoGiRo), by the pose, the wrench, the cable's weight and EA."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary.coupled_sensitivity import coupled_jacobian
from catenary.errors import InvalidCableError
from tension_opt.robot.model import CableProperties

STUDY_POSES = np.array([[-29.4, 10.2, 1.5], [-3.0, -4.0, 2.0], [10.0, -5.0, 1.5],
                        [0.0, 5.0, 1.0], [-33.0, -18.8, 2.0]])


def solve(robot: to.CableRobot, poses: np.ndarray, **kw: object
          ) -> catenary.InverseKinematicsResult:
    return catenary.inverse_kinematics(robot, poses, "coupled", "min_sum", tol=1e-13, **kw)


def assert_matches(jac: np.ndarray, plus: catenary.InverseKinematicsResult,
                   minus: catenary.InverseKinematicsResult, step: float, rtol: float) -> None:
    for got, a, b in ((jac[0], plus.tensions, minus.tensions),
                      (jac[1], plus.tensions_platform, minus.tensions_platform),
                      (jac[2], plus.lengths, minus.lengths)):
        fd = (a - b) / (2 * step)
        np.testing.assert_allclose(got, fd, rtol=rtol, atol=rtol * np.abs(fd).max())


def pose_check(robot: to.CableRobot, poses: np.ndarray, step: float, rtol: float) -> None:
    J = coupled_jacobian(robot, poses, "pose", result=solve(robot, poses))
    assert J.ok.all(), J.status
    for j in range(poses.shape[1]):
        e = np.zeros(poses.shape[1])
        e[j] = step
        assert_matches([J.tensions[..., j], J.tensions_platform[..., j], J.lengths[..., j]],
                       solve(robot, poses + e), solve(robot, poses - e), step, rtol)


def test_study_robot_interior_optima_by_the_pose() -> None:
    """The study's t_min = m g leaves every cable of the first four poses above its
    bound: the minimum sum lies inside, where only the Lagrangian's curvature fixes it.
    The last pose is a vertex (a cable on t_min)."""
    robot = to.presets.algae_harvester()
    got = solve(robot, STUDY_POSES)
    w = robot.cable.weight_per_length(robot.g)
    low, _ = catenary.geometry.extreme_tensions(
        got.horizontal_tensions, got.platform_forces[..., 2],
        got.platform_forces[..., 2] + w * got.lengths)
    assert (low[:4] > 1.05 * robot.t_min).all()
    assert low[4].min() == pytest.approx(robot.t_min[0], rel=1e-9)
    pose_check(robot, STUDY_POSES, 1e-4, 1e-6)


def test_vertices_at_the_winch_limit() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    poses = STUDY_POSES[:3]
    got = solve(robot, poses)
    assert (np.abs(got.tensions - 15000.0) < 1e-6).any()
    pose_check(robot, poses, 1e-4, 1e-6)


def test_turning_platform() -> None:
    robot = to.presets.cogiro()
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-2, 2, (4, 2)), rng.uniform(1.5, 2.5, 4),
                             rng.uniform(-0.1, 0.1, (4, 3))])
    pose_check(robot, poses, 1e-5, 1e-6)


@pytest.mark.parametrize("robot", [to.presets.algae_harvester(),
                                   to.presets.algae_harvester(t_max=15000.0)])
def test_by_the_wrench(robot: to.CableRobot) -> None:
    poses = STUDY_POSES[:3]
    J = coupled_jacobian(robot, poses, "wrench")
    assert J.ok.all()
    for j in range(3):
        e = np.zeros(3)
        e[j] = 0.1
        assert_matches([J.tensions[..., j], J.tensions_platform[..., j], J.lengths[..., j]],
                       solve(robot, poses, wrench=e), solve(robot, poses, wrench=-e), 0.1,
                       1e-6)


@pytest.mark.parametrize("wrt", ["weight_per_length", "EA"])
def test_by_the_cable(wrt: str) -> None:
    base = to.presets.algae_harvester(EA=3.14e7)
    cable = base.cable
    w = cable.weight_per_length(base.g)
    poses = STUDY_POSES[:3]
    J = coupled_jacobian(base, poses, wrt)
    assert J.ok.all()

    def robot(dv: float) -> to.CableRobot:
        if wrt == "EA":
            return base.with_(cable=CableProperties(cable.diameter, cable.linear_mass,
                                                    cable.EA + dv))
        return base.with_(cable=CableProperties(cable.diameter, (w + dv) / base.g, cable.EA))

    step = 1e-4 * (cable.EA if wrt == "EA" else w)
    assert_matches([J.tensions[..., 0], J.tensions_platform[..., 0], J.lengths[..., 0]],
                   solve(robot(step), poses), solve(robot(-step), poses), step, 1e-5)


@settings(max_examples=5, deadline=None)
@given(st.floats(-35.0, 35.0), st.floats(-20.0, 20.0), st.floats(0.5, 3.0))
def test_random_pond_poses(x: float, y: float, z: float) -> None:
    robot = to.presets.algae_harvester()
    pose = np.array([[x, y, z]])
    got = solve(robot, pose)
    J = coupled_jacobian(robot, pose, "pose", result=got)
    if not J.ok[0]:
        assert np.isnan(J.tensions[0]).all()
        return
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-4
        assert_matches([J.tensions[..., j], J.tensions_platform[..., j], J.lengths[..., j]],
                       solve(robot, pose + e), solve(robot, pose - e), 1e-4, 1e-5)


def test_statuses_and_errors() -> None:
    robot = to.presets.algae_harvester(t_max=15000.0)
    J = coupled_jacobian(robot, [[20.0, 12.0, 2.5]], "pose")
    assert J.status[0] == "not_converged" and np.isnan(J.lengths).all()
    with pytest.raises(InvalidCableError, match="wrt"):
        coupled_jacobian(robot, STUDY_POSES, "mass")
    thesis = catenary.inverse_kinematics(robot, STUDY_POSES)
    with pytest.raises(InvalidCableError, match="coupled"):
        coupled_jacobian(robot, STUDY_POSES, "pose", result=thesis)
    with pytest.raises(InvalidCableError, match="pulleys"):
        coupled_jacobian(robot.with_(pulleys=[to.Pulley(0.3)] * 4), STUDY_POSES, "pose")


def test_chunks_give_the_same_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = to.presets.algae_harvester()
    got = solve(robot, STUDY_POSES)
    whole = coupled_jacobian(robot, STUDY_POSES, "pose", result=got)
    monkeypatch.setattr("catenary.coupled_sensitivity.CHUNK", 2)
    parts = coupled_jacobian(robot, STUDY_POSES, "pose", result=got)
    np.testing.assert_array_equal(parts.status, whole.status)
    np.testing.assert_allclose(parts.tensions, whole.tensions, rtol=1e-12)


def test_a_result_of_another_problem_is_refused() -> None:
    """A min-norm or weighted result differentiated as a minimum sum gave finite wrong
    numbers labelled ok; the result now carries its problem and is refused."""
    robot = to.presets.algae_harvester()
    norm = catenary.inverse_kinematics(robot, STUDY_POSES, "coupled", "min_norm", tol=1e-13)
    assert norm.success.all()
    with pytest.raises(InvalidCableError, match="'min_norm' objective"):
        coupled_jacobian(robot, STUDY_POSES, "pose", result=norm)
    weighted = to.TensionProblem("min_sum", weights=[1.0, 2.0, 1.0, 1.0])
    with pytest.raises(InvalidCableError, match="weighted"):
        coupled_jacobian(robot, STUDY_POSES, "pose", result=catenary.inverse_kinematics(
            robot, STUDY_POSES, "coupled", weighted, tol=1e-13))
    unknown = dataclasses.replace(solve(robot, STUDY_POSES), problem=None)
    with pytest.raises(InvalidCableError, match="unknown"):
        coupled_jacobian(robot, STUDY_POSES, "pose", result=unknown)
    equal = to.TensionProblem("min_sum", weights=[3.0] * 4)  # the same minimiser
    same = catenary.inverse_kinematics(robot, STUDY_POSES, "coupled", equal, tol=1e-13)
    np.testing.assert_allclose(
        coupled_jacobian(robot, STUDY_POSES, "pose", result=same).tensions,
        coupled_jacobian(robot, STUDY_POSES, "pose", result=solve(robot, STUDY_POSES)).tensions,
        rtol=1e-6, atol=1e-6)


def test_the_problems_own_bounds() -> None:
    """A problem's t_max (not the robot's) decides which cables are on a bound: the
    Jacobian matches central differences of the solve with that problem."""
    robot = to.presets.algae_harvester()
    problem = to.TensionProblem("min_sum", t_max=15000.0)
    poses = STUDY_POSES[:3]
    got = catenary.inverse_kinematics(robot, poses, "coupled", problem, tol=1e-13)
    assert (np.abs(got.tensions - 15000.0) < 1e-6).any()
    J = coupled_jacobian(robot, poses, "pose", result=got)
    assert J.ok.all(), J.status
    step = 1e-4
    for j in range(3):
        e = np.zeros(3)
        e[j] = step
        plus, minus = (catenary.inverse_kinematics(robot, poses + s * e, "coupled", problem,
                                                   tol=1e-13) for s in (1, -1))
        assert_matches([J.tensions[..., j], J.tensions_platform[..., j], J.lengths[..., j]],
                       plus, minus, step, 1e-6)
