"""Robot model: presets, structure matrices, straight-line kinematics and input validation."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from tension_opt.robot.presets import PUBLISHED


@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_published_robot_is_full_rank_and_feasible_at_home(name):
    robot = PUBLISHED[name]()
    A = robot.structure_matrices(robot.home)
    assert A.shape == (1, robot.dof, robot.m)
    assert np.linalg.matrix_rank(A[0]) == robot.dof
    sol = to.distribute(robot, robot.home, "min_norm", "cvxpy:CLARABEL", accuracy="high")
    assert sol.success.all()
    T = sol.tensions[0]
    assert (T >= robot.t_min - 1e-6).all() and (T <= robot.t_max + 1e-6).all()
    assert sol.residual[0] < 1e-6 * max(robot.weight, 1.0)


def test_algae_harvester_geometry_follows_the_study():
    robot = to.presets.algae_harvester()
    # PL = 80.9 m along x, PW = 50 m along y, 6.1 m offsets, 7.6 m towers.
    np.testing.assert_allclose(robot.anchors[0], [-46.55, -31.1, 7.6])
    np.testing.assert_allclose(robot.anchors[2], [46.55, 31.1, 7.6])
    assert robot.t_min[0] == pytest.approx(2536.866)
    assert robot.cable.linear_mass == pytest.approx(2.4693, abs=1e-4)
    other = to.presets.algae_harvester(pond_length=50.0, pond_width=80.9, mass=100.0)
    np.testing.assert_allclose(other.anchors[0], [-31.1, -46.55, 7.6])
    assert other.t_min[0] == pytest.approx(981.0)


def test_straight_lengths_and_unit_vectors_at_pond_centre():
    robot = to.presets.algae_harvester()
    L, u = robot.inverse_kinematics([0.0, 0.0, 0.0])
    expected = np.sqrt(46.55**2 + 31.1**2 + 7.6**2)
    np.testing.assert_allclose(L, expected)
    np.testing.assert_allclose(np.linalg.norm(u, axis=-1), 1.0)
    np.testing.assert_allclose(u[0, 0], np.array([-46.55, -31.1, 7.6]) / expected)


@pytest.mark.parametrize("name", ["cogiro", "ipanema3", "kntu_planar", "point_xz_4cable"])
def test_forward_kinematics_returns_the_pose(name):
    robot = PUBLISHED[name]()
    rng = np.random.default_rng(1)
    span = {"spatial6": [0.5, 0.5, 0.3, 0.1, 0.1, 0.1], "planar3": [0.3, 0.3, 0.3],
            "planar_point2": [0.2, 0.2]}[robot.kind]
    poses = robot.home + rng.uniform(-1, 1, (50, robot.dof)) * span
    L, _ = robot.inverse_kinematics(poses)
    fk = robot.forward_kinematics(L)
    assert (fk.status == "converged").all()
    np.testing.assert_allclose(fk.poses, poses, atol=1e-8)


def test_forward_kinematics_of_the_thesis_robot_round_trip():
    robot = to.presets.algae_harvester()
    rng = np.random.default_rng(2)
    poses = np.column_stack([rng.uniform(-40, 40, 500), rng.uniform(-25, 25, 500),
                             rng.uniform(0, 5, 500)])
    fk = robot.forward_kinematics(robot.inverse_kinematics(poses)[0])
    assert fk.success.all()
    np.testing.assert_allclose(fk.poses, poses, atol=1e-8)


def test_forward_kinematics_flags_inconsistent_lengths():
    robot = to.presets.algae_harvester()
    L, _ = robot.inverse_kinematics([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]])
    L[1, 0] += 2.0  # no point is at these four distances from the anchors
    fk = robot.forward_kinematics(L)
    assert list(fk.status) == ["converged", "inconsistent"]
    assert fk.residual[1] > 0.1


def test_spatial_structure_matrix_matches_finite_differences_of_lengths():
    # dL/dpose = -A^T (for the angular part: a rotation applied in the base frame).
    robot = to.presets.cogiro()
    pose = np.array([0.3, -0.2, 2.1, 0.05, -0.03, 0.02])
    A = robot.structure_matrices(pose)[0]
    L0, _ = robot.inverse_kinematics(pose)
    h = 1e-7
    for j in range(3):
        step = np.zeros(6)
        step[j] = h
        Lj, _ = robot.inverse_kinematics(pose + step)
        np.testing.assert_allclose((Lj - L0)[0] / h, -A[j], atol=1e-6)


def test_gravity_moment_uses_the_centre_of_mass():
    robot = to.presets.cogiro()
    w = robot.gravity_wrench(robot.home)[0]
    mg = robot.mass * robot.g
    np.testing.assert_allclose(w[:3], [0, 0, -mg])
    np.testing.assert_allclose(w[3:], np.cross(robot.com, [0, 0, -mg]))


# ------------------------------------------------------------------ validation
def _robot(**changes):
    base = dict(anchors=np.array([[-1.0, -1, 2], [-1, 1, 2], [1, 1, 2], [1, -1, 2]]),
                attachments=np.zeros((4, 3)), mass=1.0)
    base.update(changes)
    return to.CableRobot(**base)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"anchors": np.array([[np.nan, 0, 2], [-1, 1, 2], [1, 1, 2], [1, -1, 2]])},
         "non-finite"),
        ({"anchors": np.array([[0.0, 0, np.inf], [-1, 1, 2], [1, 1, 2], [1, -1, 2]])},
         "non-finite"),
        ({"anchors": np.zeros((4, 2))}, r"shape \(m, 3\)"),
        ({"attachments": np.zeros((3, 3))}, "attachments must have shape"),
        ({"t_min": 5.0, "t_max": 4.0}, "t_min.*exceeds t_max"),
        ({"t_min": -1.0}, "negative"),
        ({"mass": 0.0}, "mass"),
        ({"mass": -3.0}, "mass"),
        ({"kind": "hexapod"}, "kind"),
    ],
)
def test_bad_robot_raises_naming_the_value(changes, message):
    with pytest.raises(to.InvalidInputError, match=message):
        _robot(**changes)


def test_pose_on_an_anchor_is_a_zero_length_cable():
    robot = _robot()
    with pytest.raises(to.InvalidInputError, match="zero-length cable"):
        robot.structure_matrices([[0.0, 0, 1], [1.0, 1, 2]])


@pytest.mark.parametrize("poses", [np.zeros((2, 2)), np.zeros((2, 3, 1)), [[0.0, np.nan, 1]]])
def test_bad_poses_raise(poses):
    with pytest.raises(to.InvalidInputError):
        to.distribute(_robot(), poses)


def test_bad_problem_arguments_raise():
    robot = to.presets.algae_harvester()
    with pytest.raises(to.InvalidInputError, match="unknown objective"):
        to.distribute(robot, [0, 0, 0], "min_energy")
    with pytest.raises(to.InvalidInputError, match="exceeds t_max"):
        to.distribute(robot, [0, 0, 0], to.TensionProblem("min_sum", t_min=10.0, t_max=5.0))
    with pytest.raises(to.InvalidInputError, match="finite t_max"):
        to.distribute(robot, [0, 0, 0], "centered")
    with pytest.raises(to.InvalidInputError, match="wrench"):
        to.distribute(robot, [0, 0, 0], wrench=[1.0, 2.0])
    with pytest.raises(to.InvalidInputError, match="weights"):
        to.TensionProblem("min_sum", weights=[1.0, -1.0, 1.0, 1.0])
    with pytest.raises(to.InvalidInputError, match="unknown override"):
        to.presets.algae_harvester(pond_depth=3.0)
    with pytest.raises(to.BackendNotAvailableError, match="unknown backend"):
        to.distribute(robot, [0, 0, 0], backend="gurobi")
    with pytest.raises(to.BackendNotAvailableError, match="not installed"):
        to.distribute(robot, [0, 0, 0], backend="qpsolvers:mosek")


def test_unsupported_problem_names_backends_that_can():
    robot = to.presets.algae_harvester()
    with pytest.raises(to.UnsupportedProblemError, match="closed_form"):
        to.distribute(robot, [0, 0, 0], "pinv", backend="scipy:highs")
    with pytest.raises(to.UnsupportedProblemError, match="cvxpy"):
        to.distribute(to.presets.cogiro(), [0, 0, 2, 0, 0, 0], "min_max", "closed_form")
