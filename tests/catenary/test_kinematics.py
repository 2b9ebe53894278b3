"""Sag-aware inverse and forward kinematics (catenary.inverse, catenary.forward)."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from catenary.forward import forward_kinematics
from catenary.inverse import inverse_kinematics


def _thesis_poses(robot: to.CableRobot, N: int, seed: int) -> np.ndarray:
    """Random poses over the pond kept where the straight-line distribution is feasible."""
    rng = np.random.default_rng(seed)
    M = 2 * N
    poses = np.column_stack([rng.uniform(-40.45, 40.45, M), rng.uniform(-25, 25, M),
                             rng.uniform(0, 5, M)])
    ok = to.distribute(robot, poses).success
    assert ok.sum() >= N
    return poses[ok][:N]


def _cogiro_poses(robot: to.CableRobot, N: int, seed: int) -> np.ndarray:
    """CoGiRo poses around home (0, 0, 2 m) with small offsets and rotations."""
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-2, 2, N), rng.uniform(-1.5, 1.5, N),
                             rng.uniform(1.0, 3.0, N), rng.uniform(-0.08, 0.08, (N, 3))])
    assert to.distribute(robot, poses).success.all()
    return poses


# ----------------------------------------------------------------- thesis model
def test_thesis_model_reproduces_snapshot_lengths(thesis, snapshots):
    poses = np.array([s["pose"] for s in snapshots], dtype=float)
    ik = inverse_kinematics(thesis, poses, model="thesis")
    assert (ik.status == "converged").all()
    assert (ik.iterations == 0).all()
    L_ref = np.array([s["L"] for s in snapshots])
    D_ref = np.array([s["D"] for s in snapshots])  # mm
    np.testing.assert_allclose(ik.lengths, L_ref, atol=0.01, rtol=0)
    np.testing.assert_allclose(ik.sag * 1e3, D_ref, atol=0.2, rtol=0)
    # The imposed tension is the drawing-point one: the straight-line LP tensions.
    T_ref = np.array([s["T_lp"] for s in snapshots])
    np.testing.assert_allclose(ik.tensions, T_ref, atol=0.15, rtol=0)
    # The tension falls from the drawing point to the attachment by w * height.
    w = thesis.cable.weight_per_length(thesis.g)
    dz = thesis.anchors[None, :, 2] - poses[:, None, 2]
    np.testing.assert_allclose(ik.tensions - ik.tensions_platform, w * dz, rtol=1e-9)


def test_thesis_convention_is_not_in_equilibrium(thesis, snapshots, capsys):
    """The decoupled convention leaves a large force on the platform (printed with -s)."""
    poses = np.array([s["pose"] for s in snapshots], dtype=float)
    ik = inverse_kinematics(thesis, poses, model="thesis")
    with capsys.disabled():
        print("\nthesis-convention equilibrium residual per snapshot (N):",
              np.array2string(ik.equilibrium_residual, precision=1),
              f"(platform weight {thesis.weight:.1f} N)")
    assert (ik.equilibrium_residual > 1000.0).all()
    # Mostly a missing upward force: the cables leave the platform below their chords.
    net = ik.platform_forces.sum(axis=1)
    assert (net[:, 2] < thesis.weight - 1000.0).all()


# ---------------------------------------------------------------- coupled model
def test_coupled_balances_the_load_on_the_thesis_robot(thesis, snapshots):
    poses = np.vstack([[s["pose"] for s in snapshots], _thesis_poses(thesis, 300, 1)])
    ik = inverse_kinematics(thesis, poses, model="coupled")
    assert (ik.status == "converged").all()
    assert ik.equilibrium_residual.max() < 1e-6 * thesis.weight
    assert 1 <= np.median(ik.iterations) and ik.iterations.max() <= 20
    # t_min bounds the lowest tension along each cable; at least one cable sits on it.
    H, Ta, Tb = ik.horizontal_tensions, ik.tensions_platform, ik.tensions
    Vp = ik.platform_forces[..., 2]
    low = np.where(Vp < 0, H, np.minimum(Ta, Tb))
    assert (low >= thesis.t_min - 1e-6).all()
    # Snapshot 1 is symmetric: four equal tensions, well above the straight-line 4714.6 N.
    np.testing.assert_allclose(ik.tensions[0], ik.tensions[0, 0], rtol=1e-9)
    assert ik.tensions[0, 0] > 9000.0
    # Sag makes every cable longer than its chord.
    assert (ik.sag > 0).all()


def test_coupled_converged_means_its_certificate_holds(thesis):
    """A loose step tolerance stops the iteration early: those poses are inaccurate,
    not converged, and they are exactly the ones whose forces miss the certificate."""
    from catenary.inverse import CERT_TOL

    poses = _thesis_poses(thesis, 40, 3)
    loose = inverse_kinematics(thesis, poses, model="coupled", tol=0.5)
    tight = inverse_kinematics(thesis, poses, model="coupled")
    assert (tight.status == "converged").all()
    load = np.linalg.norm(thesis.required_wrench(poses), axis=1)
    met = loose.equilibrium_residual <= CERT_TOL * np.maximum(load, thesis.t_min.max())
    assert (loose.status == "inaccurate").any()
    np.testing.assert_array_equal(loose.status == "converged", met)
    assert set(loose.status) <= {"converged", "inaccurate"}


@pytest.mark.parametrize("objective", ["min_sum", "min_norm"])
def test_coupled_balances_the_load_on_cogiro(objective):
    robot = to.presets.cogiro()
    poses = _cogiro_poses(robot, 100, 2)
    ik = inverse_kinematics(robot, poses, model="coupled", objective=objective)
    assert (ik.status == "converged").all()
    assert ik.equilibrium_residual.max() < 1e-6 * robot.weight
    tol = 1e-6 * robot.t_max.max()
    assert (ik.tensions <= robot.t_max + tol).all()
    assert (ik.tensions_platform >= robot.t_min - tol).all()


def test_coupled_reaches_poses_only_sag_makes_feasible(thesis):
    # Near the pond's edges and low down no straight-line tensions reach t_min = m g on
    # every cable, but sagging cables (which pull the platform down) can. The coupled
    # model must find these poses, as the coupled workspace does, not call them infeasible.
    from catenary.workspace import sag_workspace

    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-44, 44, 60), rng.uniform(-29, 29, 60),
                             rng.uniform(0.0, 1.5, 60)])
    straight = to.distribute(thesis, poses, "min_sum")
    ik = inverse_kinematics(thesis, poses, model="coupled")
    ws = sag_workspace(thesis, poses)
    gained = ik.success & ~straight.success
    assert gained.sum() >= 5  # the sample does contain such poses
    np.testing.assert_array_equal(ik.success, ws.feasible)
    np.testing.assert_allclose(ik.tensions[ik.success], ws.tensions[ws.feasible], rtol=1e-6)
    assert ik.equilibrium_residual[ik.success].max() < 1e-6 * thesis.weight
    # t_min bounds the lowest tension along each cable, so it holds at the platform end.
    assert ik.tensions_platform[gained].min() >= thesis.t_min[0] * (1 - 1e-9)


def test_coupled_objective_matters(thesis):
    poses = _thesis_poses(thesis, 50, 3)
    a = inverse_kinematics(thesis, poses, model="coupled", objective="min_sum")
    b = inverse_kinematics(thesis, poses, model="coupled", objective="min_norm")
    assert (a.success & b.success).all()
    assert (a.tensions_platform.sum(axis=1) <= b.tensions_platform.sum(axis=1) + 1e-6).all()
    assert ((b.tensions_platform**2).sum(axis=1)
            <= (a.tensions_platform**2).sum(axis=1) * (1 + 1e-9)).all()


def test_coupled_tends_to_straight_line_as_weight_vanishes():
    robot = to.presets.algae_harvester(cable_density=1e-6)
    poses = _thesis_poses(robot, 100, 4)
    for objective in ("min_sum", "min_norm"):
        ik = inverse_kinematics(robot, poses, model="coupled", objective=objective)
        sol = to.distribute(robot, poses, objective)
        assert (ik.status == "converged").all()
        np.testing.assert_allclose(ik.tensions, sol.tensions, rtol=1e-6)
        np.testing.assert_allclose(ik.lengths, ik.straight_lengths, rtol=1e-9)


# ----------------------------------------------------------- forward kinematics
def test_circular_thesis_robot(thesis):
    poses = _thesis_poses(thesis, 200, 5)
    ik = inverse_kinematics(thesis, poses, model="coupled")
    assert ik.success.all()
    fk = forward_kinematics(thesis, ik.lengths)
    assert (fk.status == "converged").all()
    np.testing.assert_allclose(fk.poses, poses, atol=1e-6, rtol=0)
    np.testing.assert_allclose(fk.tensions, ik.tensions, rtol=1e-6)
    np.testing.assert_allclose(fk.tensions_platform, ik.tensions_platform, rtol=1e-6)
    assert fk.residual.max() < 1e-6 * thesis.weight


def test_circular_cogiro():
    robot = to.presets.cogiro()
    poses = _cogiro_poses(robot, 50, 6)
    ik = inverse_kinematics(robot, poses, model="coupled")
    fk = forward_kinematics(robot, ik.lengths)
    assert (fk.status == "converged").all()
    np.testing.assert_allclose(fk.poses, poses, atol=1e-6, rtol=0)
    np.testing.assert_allclose(fk.tensions, ik.tensions, rtol=1e-6)


def test_forward_straight_model_matches_robot(thesis):
    poses = _thesis_poses(thesis, 20, 7)
    lengths, _ = thesis.inverse_kinematics(poses)
    fk = forward_kinematics(thesis, lengths, model="straight")
    np.testing.assert_allclose(fk.poses, poses, atol=1e-8)
    np.testing.assert_allclose(fk.tensions, to.distribute(thesis, poses).tensions, rtol=1e-8)
    assert fk.residual.max() < 1e-6 * thesis.weight


def test_invalid_arguments(thesis):
    with pytest.raises(ValueError, match="model"):
        inverse_kinematics(thesis, [0, 0, 0], model="rigid")
    with pytest.raises(ValueError, match="lengths"):
        forward_kinematics(thesis, [[50.0, 50.0, -1.0, 50.0]])
    with pytest.raises(ValueError, match="cable properties"):
        inverse_kinematics(to.presets.kntu_planar(), [0, 0, 0])


@pytest.mark.parametrize("poses", [[[1.0, 2.0], [3.0]], [[1.0, 2.0, 3.0], [1.0, 2.0]], "abc"])
def test_thesis_ik_names_poses_numpy_cannot_read(poses: object) -> None:
    """Ragged or non-numeric poses meet the package's error naming them on the compiled
    thesis path too (its one-pose test once let numpy's ValueError through)."""
    robot = to.presets.algae_harvester()
    with pytest.raises(to.InvalidInputError, match="poses"):
        inverse_kinematics(robot, poses, model="thesis")


@pytest.mark.parametrize("lengths", [[[1.0, 2.0], [3.0]], "abc", [1.0, "x", 2.0, 3.0]])
def test_forward_kinematics_names_lengths_numpy_cannot_read(lengths: object) -> None:
    robot = to.presets.algae_harvester()
    with pytest.raises(to.InvalidInputError, match="lengths"):
        forward_kinematics(robot, lengths)
