"""Platform stiffness, natural frequencies and deflection (catenary.robot_stiffness,
catenary.response, catenary.stiffness_maps).

Reference points: finite differences of the cable forces with the unstretched lengths
held (the catenary solver for sagging cables, Hooke's law for straight ones), MoorPy's
analytic system stiffness, pendulum limits, and the exact (forward-kinematics)
deflection.
"""

from __future__ import annotations

import contextlib
import io
import sys

import matplotlib
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary as cat
import tension_opt as to
from catenary.geometry import cable_data, cable_planes, cable_wrench, platform_forces
from catenary.robot_stiffness import assemble_stiffness, cross_matrix
from tension_opt.robot import CableProperties
from tension_opt.workspace.sampling import random_feasible_poses

matplotlib.use("Agg")

#: The study robot's 20 mm steel wire rope: EA on the nominal section at the rope modulus.
STEEL_EA = float(cat.cable_properties("steel", 0.020)[1])


def steel_study() -> to.CableRobot:
    """The reference study's robot (point mass, 4 cables) with elastic steel cables."""
    return to.presets.algae_harvester(EA=STEEL_EA)


def cogiro() -> to.CableRobot:
    """CoGiRo with its preset cables: 4 mm steel, 0.064 kg/m, EA = 8.2e5 N."""
    robot = to.presets.cogiro()
    assert robot.cable is not None and np.isfinite(robot.cable.EA)
    return robot


ROBOTS = {"study": steel_study, "cogiro": cogiro}


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def case(request: pytest.FixtureRequest) -> tuple[to.CableRobot, np.ndarray]:
    robot = ROBOTS[request.param]()
    return robot, random_feasible_poses(robot, 100, seed=11)


# ------------------------------------------------------------------ finite differences
def net_wrench_catenary(robot: to.CableRobot, poses: np.ndarray, L0: np.ndarray) -> np.ndarray:
    """Net wrench (N, n) of sagging cables of unstretched lengths L0 and gravity."""
    w, EA = cable_data(robot)
    planes = cable_planes(robot, poses)
    sol = cat.solve_forces(planes.x, planes.z, L0, w, EA, rtol=1e-14)
    assert sol.converged.all()
    forces = platform_forces(planes, sol.H, sol.V_A)
    return cable_wrench(robot, forces, planes.arms) - robot.required_wrench(poses)


def net_wrench_straight(robot: to.CableRobot, poses: np.ndarray, L0: np.ndarray) -> np.ndarray:
    """Net wrench (N, n) of straight elastic cables (Hooke: T = EA (L - L0) / L0)."""
    _, EA = cable_data(robot)
    geometry = robot.cable_geometry(poses)
    T = EA * (geometry.lengths - L0) / L0
    return (cable_wrench(robot, T[..., None] * geometry.unit, geometry.arms)
            - robot.required_wrench(poses))


def fd_stiffness(robot: to.CableRobot, poses: np.ndarray, L0: np.ndarray, net,
                 h: np.ndarray | float = 1e-4) -> np.ndarray:
    """-dW/dq (N, n, n) by central differences along robot.displace, Richardson-extrapolated
    from steps h and h/2 (m, rad; a number or one per pose)."""
    N, n = poses.shape
    step = np.broadcast_to(np.asarray(h, dtype=float), (N,))

    def central(size: np.ndarray) -> np.ndarray:
        K = np.empty((N, n, n))
        for j in range(n):
            s = np.zeros((N, n))
            s[:, j] = size
            plus = net(robot, robot.displace(poses, s), L0)
            minus = net(robot, robot.displace(poses, -s), L0)
            K[:, :, j] = -(plus - minus) / (2.0 * size[:, None])
        return K

    return (4.0 * central(step / 2) - central(step)) / 3.0


def sag_step(robot: to.CableRobot, poses: np.ndarray, tensions: np.ndarray) -> np.ndarray:
    """A difference step per pose (m, rad) well inside the span over which the catenary
    stiffness changes, at most 1e-4.

    Along the chord a cable is a spring of compliance ``c_e + c_s``: elastic
    ``c_e = c / EA`` and sag ``c_s = w^2 x^2 c / (12 T^3)`` (parabolic). A step ``h``
    changes ``T`` by ``h / (c_e + c_s)`` and so the stiffness by the fraction
    ``h / l`` with ``l = (c_e + c_s)^2 T / (3 c_s)``; taut inextensible cables have
    ``l`` of a fraction of a millimetre. The step is 3 % of the smallest ``l``.
    """
    w, EA = cable_data(robot)
    planes = cable_planes(robot, poses)
    c_e = planes.chord / EA
    c_s = w**2 * planes.x**2 * planes.chord / (12.0 * tensions**3)
    span = (c_e + c_s) ** 2 * tensions / (3.0 * c_s)
    return np.minimum(1e-4, 0.03 * span.min(axis=1))


def scaled_error(K: np.ndarray, K_ref: np.ndarray) -> np.ndarray:
    """Largest |K - K_ref|_ij / sqrt(|K_ii K_jj|) per pose (unit-free), shape (N,)."""
    d = np.sqrt(np.abs(np.einsum("kii->ki", K_ref)))
    return (np.abs(K - K_ref) / (d[:, :, None] * d[:, None, :])).max(axis=(1, 2))


def asymmetry(K: np.ndarray) -> np.ndarray:
    return scaled_error(np.swapaxes(K, 1, 2), K)


def test_coupled_stiffness_matches_finite_differences_of_the_catenaries(case) -> None:
    robot, poses = case
    result = cat.stiffness_analysis(robot, poses, model="coupled")
    assert result.success.all()
    assert result.equilibrium_residual.max() < 1e-6 * robot.weight
    K_fd = fd_stiffness(robot, poses, result.lengths, net_wrench_catenary,
                        sag_step(robot, poses, result.tensions))
    err = scaled_error(result.stiffness, K_fd)
    assert err.max() < 1e-6, (err.max(), np.median(err))
    # Conservative cables and gravity at equilibrium (no net moment): symmetric.
    assert asymmetry(result.stiffness).max() < 1e-10
    # A suspended robot at an ordinary pose is stable: K positive definite.
    sym = 0.5 * (result.stiffness + np.swapaxes(result.stiffness, 1, 2))
    assert (np.linalg.eigvalsh(sym)[:, 0] > 0).all()


def test_straight_stiffness_matches_finite_differences_of_hookes_law(case) -> None:
    robot, poses = case
    result = cat.stiffness_analysis(robot, poses, model="straight")
    assert result.success.all()
    K_fd = fd_stiffness(robot, poses, result.lengths, net_wrench_straight)
    assert scaled_error(result.stiffness, K_fd).max() < 1e-6
    assert asymmetry(result.stiffness).max() < 1e-10
    # Away from equilibrium (tensions 30 % higher, lengths to match) it is still -dW/dq.
    off = cat.stiffness_analysis(robot, poses, 1.3 * result.tensions, model="straight")
    K_fd = fd_stiffness(robot, poses, off.lengths, net_wrench_straight)
    assert scaled_error(off.stiffness, K_fd).max() < 1e-6
    # The axial term is EA / L0 = (EA + T) / L: with EA / L instead (first order in
    # T / EA) the comparison fails, so it does see the difference.
    geometry = robot.cable_geometry(poses)
    u, L, T = geometry.unit, geometry.lengths, off.tensions
    uu = (T / L)[..., None, None] * u[..., :, None] * u[..., None, :]
    approx = assemble_stiffness(
        robot, geometry.rotation, geometry.arms, off.platform_forces,
        off.cable_stiffness - uu)
    assert scaled_error(approx, K_fd).max() > 1e-5


def test_stiffness_away_from_equilibrium_has_the_net_moment_as_its_antisymmetric_part() -> None:
    """K - K^T = [M]x in the rotation block, M the moment of cables and gravity."""
    robot = cogiro()
    poses = random_feasible_poses(robot, 20, seed=4)
    for model in ("straight", "coupled"):
        eq = cat.stiffness_analysis(robot, poses, model=model)
        off = cat.stiffness_analysis(robot, poses, 1.5 * eq.tensions, model=model)
        planes = cable_planes(robot, poses)
        moment = cable_wrench(robot, off.platform_forces, planes.arms)[:, 3:]
        moment -= robot.required_wrench(poses)[:, 3:]  # + gravity's moment
        assert np.linalg.norm(moment, axis=1).min() > 1.0  # really off equilibrium
        K = off.stiffness
        skew = K - np.swapaxes(K, 1, 2)
        np.testing.assert_allclose(skew[:, 3:, 3:], cross_matrix(moment),
                                   atol=1e-9 * np.abs(K).max())
        np.testing.assert_allclose(skew[:, :3, :], 0.0, atol=1e-9 * np.abs(K).max())
    # A point mass has no moment arms: symmetric whatever the tensions.
    robot = steel_study()
    poses = random_feasible_poses(robot, 20, seed=4)
    T = np.random.default_rng(0).uniform(3e3, 3e4, (20, 4))
    assert asymmetry(cat.platform_stiffness(robot, poses, T)).max() < 1e-14


@settings(max_examples=25, deadline=None)
@given(x=st.floats(-35.0, 35.0), y=st.floats(-20.0, 20.0), z=st.floats(0.0, 6.0),
       tensions=st.lists(st.floats(5e3, 6e4), min_size=4, max_size=4),
       EA=st.sampled_from([STEEL_EA, 1e6, np.inf]))
def test_catenary_cable_stiffness_is_the_derivative_of_any_catenary(x, y, z, tensions, EA):
    """Any drawing-point tensions (not in equilibrium), elastic or inextensible cables."""
    robot = to.presets.algae_harvester(EA=EA)
    pose = np.array([[x, y, z]])
    result = cat.stiffness_analysis(robot, pose, np.array(tensions), model="coupled")
    assert result.success.all()
    K_fd = fd_stiffness(robot, pose, result.lengths, net_wrench_catenary,
                        sag_step(robot, pose, result.tensions))
    assert scaled_error(result.stiffness, K_fd).max() < 1e-6
    np.testing.assert_allclose(result.tensions, [tensions], rtol=1e-9)


def test_a_vertical_cable_has_the_limit_stiffness_across() -> None:
    """Platform right under a drawing point: the cable has no plane; sideways it resists
    with H / x -> 1 / (dx/dH), the same all round."""
    robot = steel_study()
    anchor = robot.anchors[0]
    pose = np.array([[anchor[0], anchor[1], 0.0]])
    result = cat.stiffness_analysis(robot, pose, [5e3, 2e4, 2e4, 2e4])
    assert result.success.all()
    Kc = result.cable_stiffness[0, 0]
    assert Kc[0, 0] == Kc[1, 1] > 0 and Kc[0, 1] == 0
    K_fd = fd_stiffness(robot, pose, result.lengths, net_wrench_catenary, 1e-5)
    assert scaled_error(result.stiffness, K_fd).max() < 1e-7


#: Horizontal offsets (m) of the platform from under a drawing point: 0, every decade
#: from 1e-16 to 1e-6 (where a span divided into a rounded H was off) and uniform ones.
NEAR_VERTICAL = st.one_of(st.just(0.0), st.floats(-16.0, -6.0).map(lambda e: 10.0**e),
                          st.floats(0.0, 1e-6))


def under_anchor(robot: to.CableRobot, cable: int, offset: float, angle: float,
                 z: float) -> np.ndarray:
    """A pose ``offset`` (m) from right under the drawing point of ``cable``."""
    a = robot.anchors[cable]
    return np.array([[a[0] + offset * np.cos(angle), a[1] + offset * np.sin(angle), z]])


@settings(max_examples=60, deadline=None)
@given(offset=NEAR_VERTICAL, angle=st.floats(0.0, 2 * np.pi), z=st.floats(0.0, 6.0),
       cable=st.integers(0, 3),
       tensions=st.lists(st.floats(3e3, 6e4), min_size=4, max_size=4),
       EA=st.sampled_from([STEEL_EA, 1e6]))
def test_a_nearly_vertical_cable_has_the_stiffness_of_the_vertical_limit(
        offset, angle, z, cable, tensions, EA) -> None:
    """0 <= x <= 1e-6 m from under a drawing point, the stiffness is continuous at x = 0:
    within (1e-9 + x / 1 m) of the limit's largest entry (measured: up to 0.55 x / 1 m
    over 80 random cases, 1e-10 of a rounded H), so within 1e-6 over the range. The
    frequencies follow to 1e-7. Before, H / x of a rounded H gave up to 16 times the
    limit's largest entry at x = 1e-14 and 1e-3 at 1e-10 (converged, no warning)."""
    robot = to.presets.algae_harvester(EA=EA)
    limit = cat.stiffness_analysis(robot, under_anchor(robot, cable, 0.0, angle, z), tensions)
    near = cat.stiffness_analysis(robot, under_anchor(robot, cable, offset, angle, z),
                                  tensions)
    assert limit.success.all() and near.success.all()
    K0, K = limit.stiffness[0], near.stiffness[0]
    assert np.abs(K - K0).max() <= (1e-9 + offset) * np.abs(K0).max()
    f0 = cat.natural_frequencies(robot, under_anchor(robot, cable, 0.0, angle, z), tensions)
    f = cat.natural_frequencies(robot, under_anchor(robot, cable, offset, angle, z), tensions)
    np.testing.assert_allclose(f, f0, rtol=1e-7)


def test_a_pose_typed_from_the_printed_anchor_has_the_limit_frequencies() -> None:
    """x = -46.55 under a drawing point at -46.550000000000004: one rounding (7e-15 m)
    from vertical. The limit's frequencies are 0.686, 1.045 and 23.44 Hz; before, H / x
    of a rounded H gave a top frequency of 83.0 Hz."""
    robot = steel_study()
    tensions = np.full(4, 5e3)
    typed = np.array([[-46.55, -31.1, 2.0]])
    under = np.array([[*robot.anchors[0][:2], 2.0]])
    assert 0.0 < abs(typed[0, 0] - under[0, 0]) < 1e-14
    result = cat.stiffness_analysis(robot, typed, tensions)
    assert (result.status == "converged").all()
    limit = cat.platform_stiffness(robot, under, tensions)
    np.testing.assert_allclose(result.stiffness, limit, rtol=0, atol=1e-9 * np.abs(limit).max())
    f0 = cat.natural_frequencies(robot, under, tensions)
    np.testing.assert_allclose(f0, [[0.686, 1.045, 23.44]], rtol=1e-3)
    np.testing.assert_allclose(cat.natural_frequencies(robot, typed, tensions), f0, rtol=1e-9)


@pytest.mark.parametrize("offset", [1e-10, 1e-3, 1e-2, 0.1])
def test_a_nearly_vertical_cable_agrees_with_moorpy(offset: float) -> None:
    """MoorPy's analytic stiffness (its vertical-line profile below about 1e-6 m, its
    catenary above): within 1e-5 at 1e-10 m from vertical (was 4.7e-4) and within 1e-7
    at a moderate offset (measured 1e-8 at 1 mm and 1 cm, 6e-11 at 10 cm)."""
    pytest.importorskip("moorpy")
    robot = steel_study()
    tensions = [5e3, 2e4, 2e4, 2e4]
    pose = under_anchor(robot, 0, offset, 0.9, 0.5)
    result = cat.stiffness_analysis(robot, pose, tensions)
    assert result.success.all()
    K, lines = moorpy_stiffness(robot, pose[0], result.lengths[0], body=False)
    np.testing.assert_allclose([line.TB for line in lines], tensions, rtol=1e-9)
    Kk = result.stiffness[0]
    assert np.abs(K - Kk).max() < (1e-5 if offset < 1e-6 else 1e-7) * np.abs(Kk).max()


def test_given_tensions_at_either_end_reproduce_the_equilibrium_stiffness() -> None:
    robot = cogiro()
    poses = random_feasible_poses(robot, 10, seed=2)
    ik = cat.inverse_kinematics(robot, poses, model="coupled")
    K = cat.platform_stiffness(robot, poses)
    K_B = cat.platform_stiffness(robot, poses, ik.tensions, end="B")
    K_A = cat.platform_stiffness(robot, poses, ik.tensions_platform, end="A")
    np.testing.assert_allclose(K_B, K, rtol=1e-7, atol=1e-9 * np.abs(K).max())
    np.testing.assert_allclose(K_A, K, rtol=1e-7, atol=1e-9 * np.abs(K).max())
    # A row without tensions (NaN, as a failed pose of a result gives) is skipped.
    T = ik.tensions.copy()
    T[3, 1] = np.nan
    for model in ("coupled", "straight"):
        result = cat.stiffness_analysis(robot, poses, T, model=model)
        assert result.status[3] == "not_run" and np.isnan(result.stiffness[3]).all()
        assert result.success[np.arange(10) != 3].all()


@pytest.mark.parametrize("linear_mass", [0.0, 1e-9])
def test_weightless_catenaries_have_the_straight_stiffness(linear_mass: float) -> None:
    for robot in (steel_study(), cogiro()):
        c = robot.cable
        light = robot.with_(cable=CableProperties(c.diameter, linear_mass, c.EA))
        poses = random_feasible_poses(light, 20, seed=3)
        T = to.distribute(light, poses).tensions
        K_straight = cat.platform_stiffness(light, poses, T, model="straight")
        K_sag = cat.platform_stiffness(light, poses, T, model="coupled")
        np.testing.assert_allclose(K_sag, K_straight, rtol=1e-7,
                                   atol=1e-9 * np.abs(K_straight).max())


# ----------------------------------------------------------------------------- MoorPy
def moorpy_stiffness(robot: to.CableRobot, position: np.ndarray, L0: np.ndarray,
                     body: bool) -> tuple[np.ndarray, list]:
    """MoorPy's analytic stiffness of a point (3x3) or a body (6x6, lines at its reference
    point) held by the robot's cables of unstretched lengths L0 from its anchors.

    No water (rho = 0: the lines weigh m g all along, as ours) and a seabed 1 km down, so
    every line hangs free; the lines are re-solved to 1e-10 (MoorPy's default line
    tolerance, 1e-4 m, limits the stiffness to about 1e-3).
    """
    mp = pytest.importorskip("moorpy")
    c = robot.cable
    system = mp.System(depth=1000.0, rho=0.0, g=robot.g)
    system.setLineType(dnommm=1e3 * c.diameter, name="cable", d_vol=c.diameter,
                       mass=c.linear_mass, EA=c.EA)
    if body:
        system.addBody(0, np.r_[position, 0.0, 0.0, 0.0])
        platform = system.addPoint(1, np.zeros(3), body=1)
    else:
        platform = system.addPoint(0, position)
    for i, anchor in enumerate(robot.anchors):
        fixed = system.addPoint(1, anchor)
        # End A on the platform (the lower end), as in catenary.geometry.
        system.addLine(L0[i], "cable", pointA=platform.number, pointB=fixed.number)
    hook = sys.breakpointhook
    sys.breakpointhook = lambda *a, **k: None  # MoorPy calls breakpoint() on failures
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            system.initialize()
            for line in system.lineList:
                line.staticSolve(tol=1e-10)
            K = system.getSystemStiffnessA(DOFtype="free", lines_only=True)
    finally:
        sys.breakpointhook = hook
    return K, system.lineList


def test_point_mass_stiffness_agrees_with_moorpy() -> None:
    pytest.importorskip("moorpy")
    robot = steel_study()
    poses = random_feasible_poses(robot, 30, seed=8)
    result = cat.stiffness_analysis(robot, poses)
    rel, compared = [], 0
    for k, pose in enumerate(poses):
        for body in (False, True):
            try:
                K, lines = moorpy_stiffness(robot, pose, result.lengths[k], body)
            except Exception:  # MoorPy raises its own errors where it does not converge
                continue
            if any(line.info.get("ProfileType", -1) != 1 for line in lines):
                continue  # not a freely hanging catenary (seabed contact or a fallback)
            compared += 1
            # Same catenaries: MoorPy's end tensions at the anchors are ours.
            np.testing.assert_allclose([line.TB for line in lines], result.tensions[k],
                                       rtol=1e-8)
            Kk = result.stiffness[k]
            rel.append(np.abs(K[:3, :3] - Kk).max() / np.abs(Kk).max())
            if body:  # lines at the reference point: no moment arms, no rotation stiffness
                assert np.abs(K[3:, :]).max() <= 1e-9 * np.abs(Kk).max()
    assert compared >= 50
    rel = np.array(rel)
    assert rel.max() < 1e-4
    assert np.median(rel) < 1e-8


# ------------------------------------------------------------------------ frequencies
def test_point_mass_on_nearly_parallel_cables_swings_as_a_pendulum() -> None:
    L, eps, m = 10.0, 1e-5, 5.0
    anchors = np.array([[eps, eps, L], [-eps, eps, L], [-eps, -eps, L], [eps, -eps, L]])
    # Axial springs soft enough that their sideways share EA eps^2 / L^3 is negligible.
    robot = to.CableRobot(anchors, np.zeros((4, 3)), m, "point3",
                          cable=CableProperties(0.001, 0.0, 1e6))
    T = np.full(4, m * robot.g / 4)
    f = cat.natural_frequencies(robot, [0.0, 0.0, 0.0], T, model="straight")[0]
    pendulum = np.sqrt(robot.g / L) / (2 * np.pi)
    np.testing.assert_allclose(f[:2], pendulum, rtol=1e-6)
    # Bounce: four springs EA/L0 + T/L in parallel.
    bounce = np.sqrt(4 * (1e6 + T[0]) / L / m) / (2 * np.pi)
    np.testing.assert_allclose(f[2], bounce, rtol=1e-6)


def test_rigid_body_hung_from_its_reference_point_is_a_compound_pendulum() -> None:
    """Cables from four far anchors all meet at the reference point: it stays put (stiff
    cables), and the body swings about it under gravity: omega^2 = m g d / (I + m d^2)."""
    D, h, m, d = 5.0, 0.5, 20.0, 0.3
    anchors = np.array([[D, 0, h], [-D, 0, h], [0, D, h], [0, -D, h]])
    inertia = np.diag([0.4, 0.6, 0.5])
    robot = to.CableRobot(anchors, np.zeros((4, 3)), m, "spatial6", com=[0.0, 0.0, -d],
                          inertia=inertia, cable=CableProperties(0.001, 0.0, 1e13))
    T = np.full(4, m * robot.g / 4 * np.hypot(D, h) / h)
    modes = cat.vibration_modes(robot, np.zeros(6), T, model="straight")
    f = modes.frequencies[0]
    swing = np.sqrt(m * robot.g * d / (np.diag(inertia)[:2] + m * d * d)) / (2 * np.pi)
    assert abs(f[0]) < 1e-6  # yaw: nothing resists it
    np.testing.assert_allclose(f[1:3], np.sort(swing), rtol=1e-6)
    # The slower swing (about y, the larger inertia) turns about the fixed pivot only;
    # mass-normalised: theta^2 (I_yy + m d^2) = 1.
    shape = modes.shapes[0][:, 1]
    np.testing.assert_allclose(shape, [0, 0, 0, 0, 1 / np.sqrt(inertia[1, 1] + m * d * d), 0],
                               atol=1e-6)


def test_modes_solve_the_generalised_eigenproblem_against_scipy() -> None:
    linalg = pytest.importorskip("scipy.linalg")
    robot = cogiro()
    poses = random_feasible_poses(robot, 10, seed=6)
    for model in ("straight", "coupled"):
        modes = cat.vibration_modes(robot, poses, model=model)
        K, M, phi = modes.stiffness, modes.mass, modes.shapes
        for k in range(len(poses)):
            ref = linalg.eigh(0.5 * (K[k] + K[k].T), M[k], eigvals_only=True)
            np.testing.assert_allclose(modes.eigenvalues[k], ref, rtol=1e-9)
        np.testing.assert_allclose(np.swapaxes(phi, 1, 2) @ M @ phi,
                                   np.broadcast_to(np.eye(6), M.shape), atol=1e-10)
        np.testing.assert_allclose(K @ phi, M @ phi * modes.eigenvalues[:, None, :],
                                   rtol=1e-8, atol=1e-8 * np.abs(K).max())
        np.testing.assert_allclose(modes.frequencies,
                                   np.sqrt(modes.eigenvalues) / (2 * np.pi), rtol=1e-12)
        assert (np.diff(modes.frequencies, axis=1) >= 0).all()


@settings(max_examples=30, deadline=None)
@given(rotvec=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),
       velocity=st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
       seed=st.integers(0, 2**16))
def test_mass_matrix_gives_the_kinetic_energy_of_a_rigid_body_of_point_masses(
        rotvec, velocity, seed) -> None:
    """Eight lumped masses: m, centre of mass and inertia from them; the kinetic energy
    sum m_k |v + omega x R rho_k|^2 / 2 equals dq^T M dq / 2."""
    rng = np.random.default_rng(seed)
    rho = rng.uniform(-1.0, 1.0, (8, 3))
    masses = rng.uniform(0.5, 2.0, 8)
    m = masses.sum()
    com = masses @ rho / m
    r = rho - com
    inertia = (masses[:, None, None] * ((r * r).sum(1)[:, None, None] * np.eye(3)
                                        - r[:, :, None] * r[:, None, :])).sum(0)
    anchors = np.array([[5, 5, 5], [-5, 5, 5], [-5, -5, 5], [5, -5, 5],
                        [5, 5, -5], [-5, 5, -5], [-5, -5, -5], [5, -5, -5]], float)
    robot = to.CableRobot(anchors, np.zeros((8, 3)), m, "spatial6", com=com, inertia=inertia)
    pose = np.r_[0.3, -0.2, 0.1, rotvec]
    M = cat.mass_matrix(robot, pose)[0]
    _, R = robot.frames(pose[None])
    v, omega = np.array(velocity[:3]), np.array(velocity[3:])
    points = np.cross(omega, rho @ R[0].T) + v
    energy = 0.5 * (masses * (points * points).sum(1)).sum()
    dq = np.array(velocity)
    assert 0.5 * dq @ M @ dq == pytest.approx(energy, rel=1e-10, abs=1e-12)


def test_mass_matrix_of_the_kinds() -> None:
    robot = steel_study()
    np.testing.assert_array_equal(cat.mass_matrix(robot, np.zeros((2, 3))),
                                  np.broadcast_to(robot.mass * np.eye(3), (2, 3, 3)))
    planar = to.presets.kntu_planar()
    M = cat.mass_matrix(planar, [0.1, 0.2, 0.3])[0]
    c = planar.com
    assert M[2, 2] == pytest.approx(planar.inertia[2, 2] + planar.mass * (c[0]**2 + c[1]**2))


# -------------------------------------------------------------------------- deflection
def test_linear_deflection_is_the_limit_of_the_exact_one() -> None:
    """Exact deflection (forward kinematics, lengths held) minus linear is second order.

    CoGiRo's light cables at ~100 N stiffen fast with tension (a 10 N push is already
    off by a few per cent), so its loads are smaller.
    """
    cases = [(steel_study(), np.array([1.0, 0.6, -0.3]), (100.0, 10.0)),
             (cogiro(), np.array([1.0, 0.6, -0.3, 0.2, -0.1, 0.3]), (1.0, 0.1))]
    for robot, direction, sizes in cases:
        poses = random_feasible_poses(robot, 8, seed=9)
        for model in ("straight", "coupled"):
            K = cat.platform_stiffness(robot, poses, model=model)
            rel = []
            for size in sizes:
                load = size * direction
                linear = cat.deflection(robot, poses, load, model=model)
                exact = cat.deflection(robot, poses, load, model=model, method="exact")
                np.testing.assert_allclose(np.einsum("kij,kj->ki", K, linear),
                                           np.broadcast_to(load, linear.shape), rtol=1e-8,
                                           atol=1e-8 * size)
                rel.append(np.linalg.norm(exact - linear, axis=1)
                           / np.linalg.norm(linear, axis=1))
            assert rel[1].max() < 2e-3, (robot.name, model, rel[1].max())
            # Ten times less load, ten times smaller relative error.
            ratio = np.median(rel[0] / rel[1])
            assert 7.0 < ratio < 13.0, (robot.name, model, ratio)


def test_study_robot_is_softer_with_sag_at_the_pond_centre() -> None:
    """The numbers of the notebook: a 100 N push at the pond centre, straight vs sag."""
    robot = steel_study()
    centre = np.zeros((1, 3))
    f_straight = cat.natural_frequencies(robot, centre, model="straight")[0]
    f_sag = cat.natural_frequencies(robot, centre, model="coupled")[0]
    d_straight = cat.deflection(robot, centre, [100.0, 0.0, 0.0], model="straight")[0]
    d_sag = cat.deflection(robot, centre, [100.0, 0.0, 0.0], model="coupled")[0]
    # Lowest mode: the bounce (z) in both models, 2.4 times slower with sag.
    np.testing.assert_allclose([f_straight[0], f_sag[0]], [1.99381, 0.841941], rtol=1e-5)
    np.testing.assert_allclose(1e3 * np.array([d_straight[0], d_sag[0]]),
                               [0.0662099, 0.404941], rtol=1e-5)
    # By symmetry the push moves the platform along the push only.
    assert np.abs(d_sag[1:]).max() < 1e-9 * d_sag[0]
    assert np.abs(d_straight[1:]).max() < 1e-9 * d_straight[0]


# -------------------------------------------------------------------------------- maps
def test_stiffness_map_equals_the_pointwise_functions() -> None:
    robot = steel_study()
    grid = to.workspace.workspace_grid([-40, -24, 2.0], [40, 24, 2.0], counts=[4, 3, 1])
    load = np.array([100.0, 0.0, 0.0])
    for model in ("straight", "coupled"):
        result = cat.stiffness_map(robot, grid, load, model=model, chunk_size=5)
        f = cat.natural_frequencies(robot, grid.poses, model=model)
        d = cat.deflection(robot, grid.poses, load, model=model)
        np.testing.assert_allclose(result.lowest_frequency, f[:, 0], rtol=1e-9)
        np.testing.assert_allclose(result.deflection, d, rtol=1e-9, atol=1e-15)
        np.testing.assert_array_equal(np.isnan(result.lowest_frequency), np.isnan(f[:, 0]))
        assert result.reshape(result.lowest_frequency).shape == (4, 3, 1)
        frame = result.to_frame()
        assert len(frame) == 12 and "lowest_frequency" in frame
        for quantity in ("lowest_frequency", "deflection"):
            ax = cat.plot_stiffness_map(result, quantity)
            assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
        import matplotlib.pyplot as plt

        plt.close("all")
    # The corners are outside the straight model's workspace: no stiffness there.
    straight = cat.stiffness_map(robot, grid, load, model="straight")
    assert (straight.status == "infeasible").any()
    assert np.isnan(straight.lowest_frequency[straight.status == "infeasible"]).all()


# ------------------------------------------------------------------------------ errors
def test_bad_arguments_raise_the_packages_error() -> None:
    robot = steel_study()
    pose = [0.0, 0.0, 2.0]
    with pytest.raises(cat.InvalidCableError, match="finite EA"):
        cat.platform_stiffness(to.presets.algae_harvester(), pose, model="straight")
    with pytest.raises(cat.InvalidCableError, match="no cable properties"):
        cat.platform_stiffness(to.presets.kntu_planar(), [0.0, 0.0, 0.0])
    with pytest.raises(cat.InvalidCableError, match="model must be"):
        cat.platform_stiffness(robot, pose, model="thesis")
    with pytest.raises(cat.InvalidCableError, match="shape"):
        cat.platform_stiffness(robot, pose, tensions=[1.0, 2.0])
    with pytest.raises(cat.InvalidCableError, match=">= 0"):
        cat.platform_stiffness(robot, pose, tensions=[-1.0, 2e3, 2e3, 2e3])
    with pytest.raises(cat.InvalidCableError, match="finite"):
        cat.platform_stiffness(robot, pose, tensions=[np.inf, 2e3, 2e3, 2e3])
    with pytest.raises(cat.InvalidCableError, match="end must be"):
        cat.platform_stiffness(robot, pose, tensions=[5e3] * 4, end="C")
    with pytest.raises(cat.InvalidCableError, match="load must"):
        cat.deflection(robot, pose, [1.0, 2.0])
    with pytest.raises(cat.InvalidCableError, match="method must"):
        cat.deflection(robot, pose, [1.0, 0.0, 0.0], method="newton")
    with pytest.raises(cat.InvalidCableError, match="load must"):
        cat.stiffness_map(robot, np.array([pose]), [np.nan, 0.0, 0.0])
    # A rotating platform without inertia has no finite frequencies.
    c = cogiro()
    massless = c.with_(inertia=np.zeros((3, 3)), com=np.zeros(3))
    with pytest.raises(cat.InvalidCableError, match="inertia"):
        cat.natural_frequencies(massless, c.home)
    with pytest.raises(to.TensionOptError):
        cat.platform_stiffness(robot, [0.0, 0.0])
