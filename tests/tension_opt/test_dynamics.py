"""Dynamics: the Newton-Euler wrench against momentum derivatives, timed trajectories,
dynamic tension distribution and open-loop simulation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import tension_opt as to
from tension_opt import dynamics as dyn
from tension_opt.dynamics import rotation

# 8th-order central difference of a first derivative: weights of f(t + k h), k = 1..4.
_FD8 = np.array([4 / 5, -1 / 5, 4 / 105, -1 / 280])


def _d_dt(f, t: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Derivative of ``f`` (times (N,) -> (N, ...)) by the 8th-order central stencil."""
    return sum(w * (f(t + (k + 1) * h) - f(t - (k + 1) * h)) for k, w in enumerate(_FD8)) / h


def _rodrigues(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors; complex-step safe (phi != 0)."""
    t2 = np.einsum("ni,ni->n", phi, phi)
    t = np.sqrt(t2)
    K = np.zeros((len(phi), 3, 3), dtype=phi.dtype)
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    K = K - np.swapaxes(K, 1, 2)
    return (np.eye(3) + (np.sin(t) / t)[:, None, None] * K
            + ((1 - np.cos(t)) / t2)[:, None, None] * (K @ K))


class _Motion:
    """A smooth random pose trajectory: position and rotation vector as sums of sines."""

    def __init__(self, seed: int, angle: float) -> None:
        rng = np.random.default_rng(seed)
        self.p0 = rng.uniform(-1, 1, 3) + np.array([0, 0, 2.0])
        self.pa, self.pw, self.pf = rng.uniform(0.2, 1, 3), rng.uniform(0.5, 2, 3), rng.uniform(
            0, 6, 3)
        self.r0 = rng.normal(size=3)
        self.r0 *= angle / np.linalg.norm(self.r0)
        self.ra, self.rw, self.rf = rng.uniform(0.05, 0.5, 3) * max(angle, 0.2), rng.uniform(
            0.5, 2, 3), rng.uniform(0, 6, 3)

    def pose(self, t: np.ndarray, k: int = 0) -> np.ndarray:
        """k-th derivative of (position, rotation vector), shape (N, 6); complex t ok."""
        t = np.asarray(t)[:, None]
        out = []
        for c0, a, w, f in ((self.p0, self.pa, self.pw, self.pf),
                            (self.r0, self.ra, self.rw, self.rf)):
            wave = a * w**k * np.sin(w * t + f + k * np.pi / 2)
            out.append(wave + (c0 if k == 0 else 0.0))
        return np.concatenate(out, axis=1)


def _spatial_robot(seed: int, g: float = 9.81) -> to.CableRobot:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    return to.CableRobot(
        anchors=rng.uniform(-5, 5, (8, 3)) + np.array([0, 0, 5.0]),
        attachments=rng.uniform(-0.5, 0.5, (8, 3)),
        mass=rng.uniform(20, 100), kind="spatial6", com=rng.uniform(-0.3, 0.3, 3), g=g,
        inertia=A @ A.T + np.eye(3))


def _momentum_wrench(robot: to.CableRobot, motion: _Motion, t: np.ndarray) -> np.ndarray:
    """The cables' wrench from the time derivatives of linear and angular momentum.

    ``omega`` comes from a complex-step derivative of the rotation matrix; linear
    momentum ``m v_c`` and angular momentum about the reference point ``I_w omega +
    r x m v_c`` are differentiated numerically; moments about the moving reference
    point add ``v_p x m v_c``.
    """
    m, c, gvec = robot.mass, robot.com, np.array([0.0, 0.0, -robot.g])

    def state(tt: np.ndarray) -> tuple[np.ndarray, ...]:
        h = 1e-30
        q = motion.pose(tt + 1j * h)
        R = _rodrigues(q[:, 3:]).real
        R_dot = _rodrigues(q[:, 3:]).imag / h
        W = R_dot @ np.swapaxes(R, 1, 2)
        omega = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        v_p = q[:, :3].imag / h
        r = R @ c
        v_c = v_p + np.cross(omega, r)
        I_w = R @ robot.inertia @ np.swapaxes(R, 1, 2)
        return v_p, v_c, r, np.einsum("nij,nj->ni", I_w, omega) + np.cross(r, m * v_c)

    v_p, v_c, r, _ = state(t)
    force = m * _d_dt(lambda tt: state(tt)[1], t) - m * gvec
    moment = (_d_dt(lambda tt: state(tt)[3], t) + np.cross(v_p, m * v_c)
              - np.cross(r, m * gvec))
    return np.concatenate([force, moment], axis=1)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("angle", [1e-3, 0.2, 2.5])
def test_newton_euler_against_momentum_derivatives(seed: int, angle: float) -> None:
    robot = _spatial_robot(seed)
    motion = _Motion(seed, angle)
    t = np.linspace(0.0, 3.0, 7)
    expected = _momentum_wrench(robot, motion, t)
    got = dyn.required_wrench(robot, motion.pose(t), motion.pose(t, 1), motion.pose(t, 2),
                              rates="pose")
    # The same through a timed trajectory (angular velocity from the rotation vector).
    traj = dyn.TimedTrajectory.from_functions(robot, t, lambda tt, k: motion.pose(tt, k))
    again = traj.required_wrench(robot)
    inertial = expected - robot.required_wrench(motion.pose(t))
    scale = np.linalg.norm(inertial, axis=1)
    assert scale.min() > 1.0  # a real motion, not a trajectory at rest
    for w in (got, again):
        assert np.all(np.linalg.norm(w - expected, axis=1) <= 1e-9 * scale)


def test_newton_euler_planar_body_about_the_reference_point() -> None:
    """planar3: m (a_c - g) in the plane and I_zz theta'' + (r x m a_c)_z, worked by hand."""
    robot = to.presets.kntu_planar().with_(com=np.array([0.1, -0.05, 0.0]), mass=3.0,
                                           inertia=np.diag([0.5, 0.7, 0.2]))
    q, v, a = np.array([0.1, 0.2, 0.7]), np.array([0.3, -0.2, 1.5]), np.array([1.0, 2.0, -3.0])
    c, s = np.cos(q[2]), np.sin(q[2])
    r = np.array([c * 0.1 + s * 0.05, s * 0.1 - c * 0.05])
    a_c = a[:2] + a[2] * np.array([-r[1], r[0]]) - v[2] ** 2 * r
    force = 3.0 * a_c
    moment = 0.2 * a[2] + r[0] * force[1] - r[1] * force[0]
    got = dyn.required_wrench(robot, q, v, a)[0]
    assert got == pytest.approx([force[0], force[1], moment], rel=1e-13, abs=1e-13)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=9, max_size=9))
def test_angular_rates_match_rotation_matrix_derivatives(values: list[float]) -> None:
    """omega = J(phi) phi' and alpha = J phi'' + J' phi' against finite differences of R."""
    phi0, phid, phidd = (np.array(values[i:i + 3]) for i in (0, 3, 6))
    if np.linalg.norm(phi0) > 3.0:  # stay away from the rotation vector's 2 pi wrap
        phi0 *= 3.0 / np.linalg.norm(phi0)

    def phi(t: np.ndarray) -> np.ndarray:
        return phi0 + np.asarray(t)[:, None] * phid + 0.5 * np.asarray(t)[:, None] ** 2 * phidd

    def omega(t: np.ndarray) -> np.ndarray:
        R = Rotation.from_rotvec(phi(t)).as_matrix()
        W = _d_dt(lambda tt: Rotation.from_rotvec(phi(tt)).as_matrix(), t, 1e-3) @ np.swapaxes(
            R, 1, 2)
        return np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)

    t0 = np.zeros(1)
    got_w = rotation.angular_velocity(phi0[None], phid[None])
    got_a = rotation.angular_acceleration(phi0[None], phid[None], phidd[None])
    scale = 1.0 + np.abs(phid).sum() ** 2 + np.abs(phidd).sum()
    assert np.abs(got_w - omega(t0)).max() <= 1e-8 * scale
    assert np.abs(got_a - _d_dt(omega, t0, 1e-2)).max() <= 1e-6 * scale
    back = rotation.pose_rates(to.presets.cogiro().pattern, np.r_[0, 0, 2, phi0][None],
                               np.r_[0, 0, 0, got_w[0]][None])[0, 3:]
    assert back == pytest.approx(phid, abs=1e-10 * scale)


def test_series_and_closed_forms_agree_at_the_switch() -> None:
    """The Jacobian coefficients are continuous where the Taylor series takes over."""
    below = rotation.jacobian_coefficients(np.array([[0.25 * (1 - 1e-12), 0, 0]]))
    above = rotation.jacobian_coefficients(np.array([[0.25 * (1 + 1e-12), 0, 0]]))
    for lo, hi in zip(below, above, strict=True):
        assert lo == pytest.approx(hi, rel=1e-12)


# ------------------------------------------------------------- rest and static tensions
@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "pinv", "min_max"])
def test_trajectory_at_rest_gives_exactly_the_static_tensions(objective: str) -> None:
    for robot, poses in ((to.presets.algae_harvester(), [[-3, -4, 1.0], [0, 0, 2], [3, 4, 1]]),
                         (to.presets.cogiro(), [[0, 0, 2, 0, 0, 0], [0.5, -0.2, 2.2, 0.05, 0,
                                                                      0.1]])):
        p = np.array(poses, dtype=float)
        zeros = np.zeros_like(p)
        assert np.array_equal(dyn.required_wrench(robot, p, zeros, zeros),
                              robot.required_wrench(p))
        traj = dyn.TimedTrajectory(np.arange(len(p), dtype=float), p, zeros, zeros, robot.kind)
        got = dyn.distribute_trajectory(robot, traj, objective)
        static = to.distribute(robot, p, objective)
        assert np.array_equal(got.tensions, static.tensions)
        assert np.array_equal(got.status, static.status)


def test_distribute_trajectory_takes_every_smoothing_mode() -> None:
    robot = to.presets.algae_harvester()
    traj = dyn.TimedTrajectory.from_waypoints(robot, [[-3, -4, 1.0], [-3, -4, 2], [3, 4, 2]],
                                              [1.0, 3.0], dt=0.1)
    W = traj.required_wrench(robot)
    step = np.abs(np.diff(dyn.distribute_trajectory(robot, traj, "min_norm").tensions,
                          axis=0)).max()
    for mode, kwargs in (("pointwise", {}), ("penalty", {"smoothing": 1e-3}),
                         ("rate_limit", {"rate_limit": 1.2 * step}),
                         ("joint", {"smoothing": 1e-3})):
        sol = dyn.distribute_trajectory(robot, traj, "min_norm", mode=mode, **kwargs)
        assert sol.success.all(), mode
        A = robot.structure_matrices(traj.poses)
        assert np.abs(np.einsum("nij,nj->ni", A, sol.tensions) - W).max() < 1e-6 * np.abs(W).max()
        assert (sol.tensions >= robot.t_min - 1e-6).all()
        if mode == "rate_limit":
            assert np.abs(np.diff(sol.tensions, axis=0)).max() <= 1.2 * step * (1 + 1e-6)
    problem = to.TensionProblem("min_sum", smoothing=1e-3)
    smoothed = dyn.distribute_trajectory(robot, traj, problem)
    assert smoothed.success.all()


def test_waypoint_trajectories_start_and_end_at_rest() -> None:
    robot = to.presets.cogiro()
    wp = [[0, 0, 2, 0, 0, 0], [1, 0.5, 2.3, 0.1, -0.1, 0.2], [0.5, -0.5, 1.8, 0, 0.1, -0.1]]
    for method in ("quintic", "rest"):
        traj = dyn.TimedTrajectory.from_waypoints(robot, wp, [1.5, 2.0], method=method, dt=0.05)
        assert traj.duration == pytest.approx(3.5)
        assert np.abs(traj.velocities[[0, -1]]).max() < 1e-12
        assert np.abs(traj.accelerations[[0, -1]]).max() < 1e-9
        assert traj.poses[0] == pytest.approx(wp[0]) and traj.poses[-1] == pytest.approx(wp[-1])
    cubic = dyn.TimedTrajectory.from_waypoints(robot, wp, [1.5, 2.0], method="cubic")
    assert np.abs(cubic.velocities[[0, -1]]).max() < 1e-12
    again = dyn.TimedTrajectory.from_path(robot, wp, [0.0, 1.5, 3.5])
    assert again.times == pytest.approx([0.0, 1.5, 3.5])
    assert again.poses == pytest.approx(np.array(wp, dtype=float))


# ------------------------------------------------------------------------- simulation
@pytest.fixture(scope="module")
def study_motion() -> tuple[to.CableRobot, dyn.TimedTrajectory]:
    """The study's pick-and-place in 10 s: raise 1 m at (-3, -4) in 2 s, cross to (3, 4)
    at z = 2 m in 6 s, lower 1 m in 2 s, at rest at every corner."""
    robot = to.presets.algae_harvester()
    corners = [[-3, -4, 1.0], [-3, -4, 2.0], [3, 4, 2.0], [3, 4, 1.0]]
    return robot, dyn.TimedTrajectory.from_waypoints(robot, corners, [2.0, 6.0, 2.0],
                                                     method="rest", dt=0.01)


def test_open_loop_simulation_follows_the_study_path(study_motion) -> None:
    robot, traj = study_motion
    tensions = dyn.distribute_trajectory(robot, traj).tensions
    sim = dyn.simulate(robot, traj.times, tensions, traj.poses[0], traj.velocities[0])
    assert sim.success and sim.rtol == 1e-10 and sim.atol == 1e-12
    error = np.linalg.norm(sim.poses - traj.poses, axis=1)
    assert error[-1] < 1e-3  # m
    assert error.max() < 1e-3
    static = to.distribute(robot, traj.poses).tensions
    drift = dyn.simulate(robot, traj.times, static, traj.poses[0], traj.velocities[0])
    assert np.linalg.norm(drift.poses[-1] - traj.poses[-1]) > 1.0  # metres off


@pytest.fixture(scope="module")
def slack_min_sum(study_motion) -> tuple[to.CableRobot, dyn.TimedTrajectory, np.ndarray,
                                         dyn.SimulationResult]:
    """The study's motion with t_min = 0 and min_sum: two cables go slack while the
    platform crosses, their optimal tensions rounded to about -1e-13 N at the bound;
    and its simulation with the default interpolation."""
    _, traj = study_motion
    robot = to.presets.algae_harvester(t_min=0.0)
    sol = dyn.distribute_trajectory(robot, traj, "min_sum")
    assert (sol.status == "optimal").all()
    sim = dyn.simulate(robot, traj.times, sol.tensions, traj.poses[0], traj.velocities[0])
    return robot, traj, sol.tensions, sim


def test_simulation_takes_optimal_tensions_rounded_below_a_zero_bound(slack_min_sum) -> None:
    robot, traj, T, sim = slack_min_sum
    assert (T < 0).any() and T.min() > -1e-9  # rounding within the certificate
    assert sim.success
    assert np.linalg.norm(sim.poses - traj.poses, axis=1).max() < 1e-3  # m
    # The rounding is clipped to 0, a real push (1 N on a tension scale of 1e4 N) refused.
    assert np.array_equal(sim.tension_at(traj.times), np.maximum(T, 0.0))
    pushed = T.copy()
    pushed[300, 1] = -1.0
    with pytest.raises(to.InvalidInputError, match=r"tensions\[300, 1\] = -1.0 .*can only pull"):
        dyn.simulate(robot, traj.times, pushed, traj.poses[0], traj.velocities[0])


def test_interpolated_tensions_stay_within_their_bounds(slack_min_sum) -> None:
    """Between the samples the simulated cables neither push nor leave the samples'
    range: the default interpolation is shape-preserving (PCHIP)."""
    robot, traj, T, sim = slack_min_sum
    fine = np.linspace(traj.times[0], traj.times[-1], 50 * traj.N + 1)
    applied = sim.tension_at(fine)
    assert applied.shape == (fine.size, robot.m)
    assert applied.min() >= robot.t_min.min()  # 0: no cable pushes
    assert (applied <= robot.t_max).all()
    assert (applied <= T.max(axis=0)).all()
    # Each interpolated tension within the range of its two neighbouring samples.
    k = np.clip(np.searchsorted(traj.times, fine, side="right") - 1, 0, traj.N - 2)
    clipped = np.maximum(T, 0.0)
    low, high = np.minimum(clipped[k], clipped[k + 1]), np.maximum(clipped[k], clipped[k + 1])
    assert ((applied >= low) & (applied <= high)).all()


def test_simulation_of_a_spatial_robot_at_rest_stays_put() -> None:
    robot = to.presets.cogiro()
    pose = np.array([0.3, -0.2, 2.1, 0.05, -0.03, 0.1])
    times = np.linspace(0.0, 2.0, 21)
    T = np.tile(to.distribute(robot, pose, "min_norm").tensions, (21, 1))
    sim = dyn.simulate(robot, times, T, pose, np.zeros(6))
    assert np.abs(sim.poses - pose).max() < 1e-8
    assert np.abs(sim.velocities).max() < 1e-8


def test_simulation_follows_a_spatial_trajectory() -> None:
    robot = to.presets.cogiro()
    wp = [[0, 0, 2, 0, 0, 0], [0.8, 0.4, 2.3, 0.1, -0.1, 0.2]]
    traj = dyn.TimedTrajectory.from_waypoints(robot, wp, [2.0], dt=0.01)
    T = dyn.distribute_trajectory(robot, traj, "min_norm").tensions
    sim = dyn.simulate(robot, traj.times, T, traj.poses[0], traj.velocities[0])
    assert np.abs(sim.poses - traj.poses).max() < 1e-5


# ------------------------------------------------------------------------- bad input
def test_bad_input_raises_the_packages_error(study_motion) -> None:
    robot, traj = study_motion
    T = np.full((traj.N, 4), 3000.0)
    with pytest.raises(to.InvalidInputError, match="times"):
        dyn.simulate(robot, traj.times[::-1], T, traj.poses[0], np.zeros(3))
    with pytest.raises(to.InvalidInputError, match="tensions"):
        dyn.simulate(robot, traj.times, T[:, :3], traj.poses[0], np.zeros(3))
    with pytest.raises(to.InvalidInputError, match="tensions"):
        dyn.simulate(robot, traj.times, np.where(np.eye(traj.N, 4) > 0, np.nan, T),
                     traj.poses[0], np.zeros(3))
    with pytest.raises(to.InvalidInputError, match="initial_velocity"):
        dyn.simulate(robot, traj.times, T, traj.poses[0], np.zeros(4))
    with pytest.raises(to.InvalidInputError, match="interpolation must be one of"):
        dyn.simulate(robot, traj.times, T, traj.poses[0], np.zeros(3), interpolation="spline")
    with pytest.raises(to.InvalidInputError, match="velocities"):
        dyn.required_wrench(robot, traj.poses, traj.velocities[:5], traj.accelerations)
    with pytest.raises(to.InvalidInputError, match="accelerations"):
        dyn.required_wrench(robot, traj.poses, traj.velocities, np.full_like(traj.poses, np.nan))
    with pytest.raises(to.InvalidInputError, match="poses"):
        dyn.required_wrench(robot, [[0, 0, np.nan]], [0, 0, 0], [0, 0, 0])
    with pytest.raises(to.InvalidInputError, match="rates"):
        dyn.required_wrench(robot, traj.poses, traj.velocities, traj.accelerations, rates="x")
    with pytest.raises(to.InvalidInputError, match="times"):
        dyn.TimedTrajectory(np.array([0.0, 1.0, 1.0]), traj.poses[:3], traj.poses[:3],
                            traj.poses[:3], "point3")
    with pytest.raises(to.InvalidInputError, match="durations"):
        dyn.TimedTrajectory.from_waypoints(robot, traj.poses[:3], [1.0, -1.0])
    # 4e9 samples (30 GB), and a duration whose samples overflow: a larger dt, not a
    # MemoryError or numpy's error.
    for durations, dt in (([2.0, 2.0], 1e-9), ([1e300, 1e300], 0.01)):
        with pytest.raises(to.InvalidInputError, match="give a larger dt"):
            dyn.TimedTrajectory.from_waypoints(robot, traj.poses[:3], durations, dt=dt)
    with pytest.raises(to.InvalidInputError, match="spatial6"):
        dyn.distribute_trajectory(to.presets.cogiro(), traj)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**16), st.floats(0.1, 3.0))
def test_slowing_down_in_time_scales_the_inertial_wrench_quadratically(seed: int,
                                                                       lam: float) -> None:
    """``q(lam t)``: velocities scale by ``lam``, accelerations by ``lam^2``, and so does
    the whole inertial wrench (what makes the timing's constraints linear in s'^2, s'')."""
    robot = _spatial_robot(seed % 7)
    rng = np.random.default_rng(seed)
    q = np.r_[rng.uniform(-1, 1, 3), rng.uniform(-1.5, 1.5, 3)][None]
    v, a = rng.normal(size=(1, 6)), rng.normal(size=(1, 6))
    static = robot.required_wrench(q)
    base = dyn.required_wrench(robot, q, v, a, rates="pose") - static
    scaled = dyn.required_wrench(robot, q, lam * v, lam**2 * a, rates="pose") - static
    assert scaled == pytest.approx(lam**2 * base, rel=1e-9, abs=1e-9 * np.abs(base).max())
    mass, bias = dyn.inertia_terms(robot, q, v)
    assert np.abs(dyn.required_wrench(robot, q, v, a) - static
                  - (mass[0] @ a[0] + bias)).max() <= 1e-12 * (1 + np.abs(base).max())
