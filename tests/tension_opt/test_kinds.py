"""Robot kinds (motion patterns): frames, steps, structure matrices, and a new kind."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from tension_opt.kinds import KINDS, MotionPattern, get_kind

PRESETS = {
    "point3": to.presets.algae_harvester,
    "planar_point2": to.presets.point_xz_4cable,
    "planar3": to.presets.kntu_planar,
    "spatial6": to.presets.cogiro,
}


def test_every_kind_is_registered_once_with_consistent_sizes() -> None:
    assert set(KINDS) == set(PRESETS)
    for name, kind in KINDS.items():
        assert kind.name == name
        assert kind.pose_size == len(kind.wrench_rows) == len(kind.coordinates)
        assert get_kind(name) is kind


def test_unknown_kind_is_an_input_error_listing_the_known_ones() -> None:
    with pytest.raises(to.InvalidInputError, match="point3"):
        get_kind("hexapod")


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_structure_matrix_is_minus_the_length_jacobian(name: str) -> None:
    # dL_i/dq = -(A^T)_i: a finite-difference check of every kind's frames and wrench rows.
    robot = PRESETS[name]()
    rng = np.random.default_rng(3)
    home = robot.default_home()
    poses = home + rng.uniform(-0.05, 0.05, (5, robot.dof))
    A = robot.structure_matrices(poses)
    h = 1e-6
    for j in range(robot.dof):
        step = np.zeros((5, robot.dof))
        step[:, j] = h
        up, _ = robot.inverse_kinematics(robot.displace(poses, step))
        down, _ = robot.inverse_kinematics(robot.displace(poses, -step))
        slope = (up - down) / (2 * h)
        np.testing.assert_allclose(slope, -A[:, j, :], atol=1e-7)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_step_maps_match_displace(name: str) -> None:
    kind = get_kind(name)
    rng = np.random.default_rng(1)
    poses = np.zeros((4, kind.pose_size))
    step = 1e-7 * rng.standard_normal((4, kind.pose_size))
    translation, rotation = kind.step_maps()
    p0, R0 = kind.frames(poses)
    p1, R1 = kind.frames(kind.displace(poses, step))
    np.testing.assert_allclose(p1 - p0, step @ translation.T, atol=1e-15)
    # A small rotation R1 R0^T = I + [omega]x.
    dR = np.einsum("nij,nkj->nik", R1, R0) - np.eye(3)
    omega = np.stack([dR[:, 2, 1], dR[:, 0, 2], dR[:, 1, 0]], axis=1)
    np.testing.assert_allclose(omega, step @ rotation.T, atol=1e-13)


def test_cable_geometry_flags_a_pose_on_a_drawing_point() -> None:
    robot = to.presets.algae_harvester()
    geometry = robot.cable_geometry([robot.anchors[0], [0.0, 0.0, 0.0]], check=False)
    assert geometry.degenerate.tolist() == [True, False]
    np.testing.assert_allclose(geometry.lengths[1], np.hypot(np.hypot(46.55, 31.1), 7.6))
    with pytest.raises(to.InvalidInputError, match="zero-length"):
        robot.cable_geometry([robot.anchors[0]])


class _PointInYZ(MotionPattern):
    """A point mass in the vertical yz plane: the whole of a new kind."""

    name = "planar_point_yz"
    coordinates = ("y", "z")
    positions = (0, 1)
    position_axes = (1, 2)
    wrench_rows = (1, 2)


def test_a_new_kind_is_one_class() -> None:
    # Three cables in the yz plane holding a 10 kg point: the yz twin of point_xz_4cable.
    anchors = np.array([[0.0, -2.0, 3.0], [0.0, 2.0, 3.0], [0.0, 0.0, -1.0]])
    robot = to.CableRobot(anchors=anchors, attachments=np.zeros((3, 3)), mass=10.0,
                          kind=_PointInYZ(), t_min=1.0)
    assert robot.kind == "planar_point_yz" and robot.dof == 2
    sol = to.distribute(robot, [[0.0, 1.0], [0.5, 1.5]], "min_sum", backend="closed_form")
    assert (sol.status == to.Status.OPTIMAL).all()
    A = robot.structure_matrices([[0.0, 1.0], [0.5, 1.5]])
    np.testing.assert_allclose(np.einsum("nij,nj->ni", A, sol.tensions),
                               [[0.0, 98.1], [0.0, 98.1]], atol=1e-9)
    # Symmetric pose: the two upper cables share the load equally.
    assert sol.tensions[0, 0] == pytest.approx(sol.tensions[0, 1], rel=1e-12)


def test_read_only_poses_are_accepted() -> None:
    robot = to.presets.cogiro()
    poses = np.array([[0.1, -0.2, 2.0, 0.05, -0.03, 0.2]])
    expected = robot.structure_matrices(poses)
    poses.setflags(write=False)
    np.testing.assert_array_equal(robot.structure_matrices(poses), expected)
    step = np.full((1, 6), 1e-3)
    step.setflags(write=False)
    assert np.isfinite(robot.displace(poses, step)).all()
