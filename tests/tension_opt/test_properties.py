"""Property tests over random robots and poses: equilibrium, bounds, optimality, round trips."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import tension_opt as to

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@st.composite
def suspended_robot_and_poses(draw, m: int = 4):
    """A point-mass robot hanging from ``m`` anchors on a random frame, with poses under it."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, 2 * np.pi, m)) + rng.uniform(0, 0.3)
    angles = np.linspace(0, 2 * np.pi, m, endpoint=False) + rng.uniform(-0.4, 0.4, m) * (
        2 * np.pi / m) / 2
    radius = rng.uniform(2, 50)
    height = rng.uniform(1, 20)
    anchors = np.column_stack([radius * np.cos(angles) * rng.uniform(0.7, 1.3),
                               radius * np.sin(angles) * rng.uniform(0.7, 1.3),
                               height + rng.uniform(-0.1, 0.1, m) * height])
    mass = rng.uniform(1, 500)
    t_min = rng.uniform(0, 0.5) * mass * 9.81
    robot = to.CableRobot(anchors, np.zeros((m, 3)), mass, t_min=t_min,
                          t_max=rng.choice([np.inf, 20 * mass * 9.81]))
    poses = np.column_stack([rng.uniform(-0.4, 0.4, (8, 2)) * radius,
                             height - rng.uniform(0.2, 1.0, 8) * height])
    return robot, poses


@SETTINGS
@given(suspended_robot_and_poses())
def test_closed_form_solutions_are_feasible_and_in_equilibrium(case):
    robot, poses = case
    for objective in ("min_sum", "min_norm", "min_max"):
        sol = to.distribute(robot, poses, objective, "closed_form")
        ok = sol.success
        assert ((sol.residual[ok] / robot.weight) < 1e-9).all()
        assert (sol.bound_violation[ok] <= 1e-9 * robot.weight).all()
        assert np.isnan(sol.tensions[~ok]).all()
        assert all(str(s) == "infeasible" for s in sol.status[~ok])


@SETTINGS
@given(suspended_robot_and_poses())
def test_closed_form_is_optimal_against_an_interior_point_solver(case):
    robot, poses = case
    for objective in ("min_sum", "min_norm", "min_max"):
        exact = to.distribute(robot, poses, objective, "closed_form")
        ipm = to.distribute(robot, poses, objective, "qpsolvers:clarabel", accuracy="high")
        # Where the interior point method solves a pose, so does the closed form. It may
        # solve more: the solver can stop short on a feasible pose (max_iter), never
        # claiming a wrong answer.
        assert (exact.success | ~ipm.success).all()
        stopped = exact.success & ~ipm.success
        assert all(str(s) in ("max_iter", "solver_error", "inaccurate")
                   for s in ipm.status[stopped])
        ok = exact.success & ipm.success
        assume(ok.any())
        scale = np.abs(exact.objective[ok]).max()
        # The closed form is never worse than the solver (up to the solver's tolerance).
        assert (exact.objective[ok] <= ipm.objective[ok] + 1e-7 * scale).all()


@SETTINGS
@given(suspended_robot_and_poses(m=5))
def test_two_dimensional_null_space_matches_highs(case):
    robot, poses = case
    exact = to.distribute(robot, poses, "min_sum", "closed_form")
    lp = to.distribute(robot, poses, "min_sum", "scipy:highs", accuracy="high")
    np.testing.assert_array_equal(exact.success, lp.success)
    ok = exact.success
    assume(ok.any())
    scale = np.abs(exact.tensions[ok]).max()
    np.testing.assert_allclose(exact.tensions[ok], lp.tensions[ok], atol=1e-6 * scale)


@SETTINGS
@given(suspended_robot_and_poses())
def test_pseudo_inverse_is_the_minimum_norm_solution(case):
    robot, poses = case
    sol = to.distribute(robot, poses, "pinv", "closed_form")
    A = robot.structure_matrices(poses)
    b = robot.required_wrench(poses)
    expected = np.einsum("nij,nj->ni", np.linalg.pinv(A), b)
    np.testing.assert_allclose(sol.tensions, expected, rtol=1e-9, atol=1e-9 * robot.weight)


@SETTINGS
@given(suspended_robot_and_poses())
def test_inverse_then_forward_kinematics_returns_the_pose(case):
    robot, poses = case
    L, _ = robot.inverse_kinematics(poses)
    fk = robot.forward_kinematics(L, initial_poses=poses + 0.01)
    assert fk.success.all()
    np.testing.assert_allclose(fk.poses, poses, atol=1e-7 * np.abs(robot.anchors).max())


@SETTINGS
@given(st.integers(0, 2**32 - 1))
def test_rate_limit_holds_and_joint_smoothing_is_optimal_for_its_path_cost(seed):
    from tension_opt.dynamics.trajectory import smooth_jointly

    rng = np.random.default_rng(seed)
    robot = to.presets.algae_harvester()
    start, end = rng.uniform([-20, -12, 0.5], [20, 12, 4], (2, 3))
    path = start + np.linspace(0, 1, 30)[:, None] * (end - start)
    plain = to.distribute(robot, path, "min_sum")
    assume(plain.success.all())
    limit = 150.0
    limited = to.distribute(robot, path, to.TensionProblem("min_sum", rate_limit=limit))
    ok = limited.success
    steps = np.abs(np.diff(limited.tensions[ok], axis=0))
    assert (steps <= limit + 1e-6).all()
    # Every other schedule is feasible for the joint problem, so none has a lower path cost.
    weight = 1e-2
    greedy = to.distribute(robot, path, to.TensionProblem("min_sum", smoothing=weight))
    joint = smooth_jointly(robot, path, "min_sum", weight=weight, accuracy="high")
    assert joint.success.all()
    assert (joint.residual / robot.weight).max() < 1e-8

    def path_cost(T):
        return T.sum() + weight * (np.diff(T, axis=0) ** 2).sum()

    best = path_cost(joint.tensions)
    for other in (plain, greedy):
        assert best <= path_cost(other.tensions) * (1 + 1e-8)
