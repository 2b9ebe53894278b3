"""Swivel guide pulleys: exit points, wrap angles, lengths and the structure matrix.

Checked against a planar case in closed form, an independent root-finding of the
tangent point, finite differences of the lengths, and round trips.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

import catenary
import tension_opt as to
from tension_opt.errors import InvalidInputError
from tension_opt.robot.pulleys import pulley_exits


def planar_case(r: float, D: float, H: float) -> tuple[float, float]:
    """Wrap angle and length of a cable coming up a vertical axis, over a wheel of
    radius r whose leftmost point is the origin, down to B = (D, 0, -H).

    The centre is C = (r, 0, 0); the cable travels clockwise (seen from -y) from the
    wheel's leftmost point (polar angle pi about C) over the top to the tangent point,
    at polar angle atan2(-H, D - r) + acos(r / |B - C|)."""
    d = np.hypot(D - r, H)
    tangent_angle = np.arctan2(-H, D - r) + np.arccos(r / d)
    wrap = np.pi - tangent_angle
    return wrap, r * wrap + np.sqrt(d * d - r * r)


@pytest.mark.parametrize(("r", "D", "H"), [(0.3, 5.0, 7.6), (0.3, 40.0, 0.5), (0.05, 0.2, 3.0),
                                           (1.0, 3.0, -2.0), (0.3, 0.45, 6.0)])
def test_planar_pulley_matches_the_closed_form(r, D, H):
    wrap, length = planar_case(r, D, H)
    rot = Rotation.random(random_state=3).as_matrix()
    A, axis, B = np.zeros(3), np.array([0.0, 0.0, -1.0]), np.array([D, 0.0, -H])
    for R in (np.eye(3), rot):  # and the same configuration turned anywhere
        exits = pulley_exits((R @ A)[None], (R @ axis)[None], [r], (R @ B)[None, None])
        assert exits.wrap[0, 0] == pytest.approx(wrap, abs=1e-12)
        free = np.linalg.norm(R @ B - exits.exit_points[0, 0])
        assert r * exits.wrap[0, 0] + free == pytest.approx(length, abs=1e-9)


def tangent_by_root(A, axis, r, B):
    """Independent: the wheel's plane from B, then the point where the line to B is
    tangent to the wheel in the travel direction, by bracketing and brentq."""
    d = B - A
    h = d - (d @ axis) * axis
    h /= np.linalg.norm(h)
    C = A + r * h

    def point(t):
        return C + r * (-np.sin(t) * axis - np.cos(t) * h)

    def travel(t):
        return -np.cos(t) * axis + np.sin(t) * h

    normal = np.cross(axis, h)

    def g(t):  # signed sine of the angle from the travel direction to B - P(t)
        return np.cross(travel(t), B - point(t)) @ normal

    ts = np.linspace(0, 2 * np.pi, 2001)
    vals = np.array([g(t) for t in ts])
    roots = [brentq(g, ts[k], ts[k + 1], xtol=1e-15) for k in np.flatnonzero(
        np.sign(vals[:-1]) != np.sign(vals[1:]))]
    (t,) = [t for t in roots if travel(t) @ (B - point(t)) > 0]
    return t, point(t)


def test_exit_point_agrees_with_root_finding_on_random_pulleys():
    rng = np.random.default_rng(7)
    for _ in range(40):
        A, axis = rng.normal(size=3) * 5, rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        r = rng.uniform(0.05, 1.0)
        B = A + rng.normal(size=3) * 4
        exits = pulley_exits(A[None], axis[None], [r], B[None, None])
        if exits.degenerate[0, 0]:
            continue
        t, T = tangent_by_root(A, axis, r, B)
        assert exits.wrap[0, 0] == pytest.approx(t, abs=1e-9)
        np.testing.assert_allclose(exits.exit_points[0, 0], T, atol=1e-9)


def pulley_robot(seed: int, kind: str = "spatial6", m: int = 8) -> to.CableRobot:
    robot = to.presets.cogiro() if kind == "spatial6" else to.presets.algae_harvester()
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(robot.m, 3)) * 0.3 + [0, 0, -1]
    pulleys = [to.Pulley(rng.uniform(0.05, 0.4), axes[i]) for i in range(robot.m)]
    pulleys[1] = None  # one cable drawn from a fixed point
    return robot.with_(pulleys=pulleys)


@pytest.mark.parametrize("kind", ["spatial6", "point3"])
def test_structure_matrix_is_minus_the_length_jacobian(kind):
    robot = pulley_robot(2, kind)
    rng = np.random.default_rng(4)
    span = 0.3 if kind == "spatial6" else 10.0
    poses = robot.default_home() + rng.uniform(-1, 1, (20, robot.dof)) * span * np.r_[
        np.ones(3), 0.3 * np.ones(robot.dof - 3)]
    A = robot.structure_matrices(poses)
    h = 1e-4
    for k in range(robot.dof):
        e = np.zeros(robot.dof)
        e[k] = h

        def L(s, e=e):
            return robot.inverse_kinematics(poses + s * e)[0]
        # Richardson-extrapolated central difference, d/dq_k of every length.
        d1, d2 = (L(1) - L(-1)) / (2 * h), (L(0.5) - L(-0.5)) / h
        dL = (4 * d2 - d1) / 3
        if robot.kind == "spatial6" and k >= 3:
            continue  # a rotation-vector coordinate is not the wrench's moment axis
        np.testing.assert_allclose(dL, -A[:, k, :], atol=1e-9)


def test_without_pulleys_answers_exactly_as_before():
    plain = to.presets.cogiro()
    none = plain.with_(pulleys=[None] * plain.m)
    assert none.pulleys is None and not none.has_pulleys
    rng = np.random.default_rng(0)
    poses = plain.home + rng.uniform(-0.3, 0.3, (30, 6)) * [1, 1, 1, 0.3, 0.3, 0.3]
    for a, b in zip(plain.inverse_kinematics(poses), none.inverse_kinematics(poses),
                    strict=True):
        assert np.array_equal(a, b)
    assert np.array_equal(plain.structure_matrices(poses), none.structure_matrices(poses))


def test_pulleys_lengthen_the_study_robots_cables_by_the_wrapped_arc():
    robot = to.presets.algae_harvester()
    towers = robot.with_(pulleys=[to.Pulley(0.3, [0, 0, -1])] * robot.m)
    poses = np.array([[0.0, 0.0, 0.0], [-29.4, 10.2, 1.5], [35.0, 22.0, 5.0]])
    L0, _ = robot.inverse_kinematics(poses)
    L, _ = towers.inverse_kinematics(poses)
    # At the pond centre every cable leaves the wheel's top at the same wrap angle:
    # the planar closed form in the cable's vertical plane.
    D, H = np.hypot(46.55, 31.1), 7.6
    _, length = planar_case(0.3, D, H)
    np.testing.assert_allclose(L[0], length, atol=1e-9)
    assert ((L - L0) > 0).all() and ((L - L0) < 0.3 * np.pi).all()


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_round_trips_and_equilibrium_over_random_pulleys(seed):
    robot = pulley_robot(seed)
    rng = np.random.default_rng(seed)
    poses = robot.home + rng.uniform(-1, 1, (5, 6)) * [0.5, 0.5, 0.3, 0.1, 0.1, 0.1]
    L, u = robot.inverse_kinematics(poses)
    B = robot.attachment_points(poses)
    # A cable over a wheel is never shorter than the straight line from A to B.
    assert (L >= np.linalg.norm(robot.anchors - B, axis=-1) - 1e-12).all()
    np.testing.assert_allclose(np.linalg.norm(u, axis=-1), 1.0, atol=1e-12)
    fk = robot.forward_kinematics(L, robot.home)
    ok = fk.status == "converged"
    assert ok.mean() >= 0.8
    np.testing.assert_allclose(fk.poses[ok], poses[ok], atol=1e-8)
    sol = to.distribute(robot, poses, "min_norm", "closed_form")
    A, b = robot.structure_matrices(poses), robot.required_wrench(poses)
    good = sol.success
    residual = np.einsum("nij,nj->ni", A, sol.tensions) - b
    assert np.abs(residual[good]).max(initial=0.0) <= 1e-7 * robot.weight


def test_distributor_and_backends_agree_on_a_pulley_robot():
    robot = to.presets.algae_harvester().with_(pulleys=[to.Pulley(0.3, [0, 0, -1])] * 4)
    poses = np.array([[-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [3.0, -4.0, 2.0]] * 7)
    ref = to.distribute(robot, poses, "min_sum", "cvxpy:CLARABEL", accuracy="high")
    exact = to.distribute(robot, poses, "min_sum", "closed_form")
    np.testing.assert_allclose(exact.tensions, ref.tensions, rtol=1e-6)
    one = to.Distributor(robot)(poses[1])
    np.testing.assert_allclose(one.tensions, exact.tensions[1], rtol=1e-9)
    # ... and differ from the robot without pulleys (the exit points moved).
    plain = to.distribute(robot.with_(pulleys=None), poses, "min_sum", "closed_form")
    assert np.abs(plain.tensions - exact.tensions).max() > 1.0


def test_robot_file_round_trip_keeps_the_pulleys(tmp_path):
    robot = pulley_robot(5)
    for suffix in (".yaml", ".json"):
        path = tmp_path / f"robot{suffix}"
        robot.to_file(path)
        back = to.CableRobot.from_file(path)
        assert back.pulleys == robot.pulleys
        poses = robot.home[None]
        assert np.array_equal(back.inverse_kinematics(poses)[0],
                              robot.inverse_kinematics(poses)[0])


def test_bad_pulleys_are_refused_with_the_fix(tmp_path):
    with pytest.raises(InvalidInputError, match="radius"):
        to.Pulley(-0.1, [0, 0, -1])
    with pytest.raises(InvalidInputError, match="axis"):
        to.Pulley(0.1, [0, 0, 0])
    robot = to.presets.algae_harvester()
    with pytest.raises(InvalidInputError, match="one entry per cable"):
        robot.with_(pulleys=[to.Pulley(0.1)] * 3)
    with pytest.raises(InvalidInputError, match=r"pulleys\[2\]"):
        robot.with_(pulleys=[None, None, 0.3, None])
    towers = robot.with_(pulleys=[to.Pulley(0.3, [0, 0, -1])] * 4)
    with pytest.raises(InvalidInputError, match="swivel axis or wheel"):
        towers.inverse_kinematics([-46.55, -31.1, 2.0])  # right below a pulley
    text = (tmp_path / "r.yaml")
    robot.with_(pulleys=[to.Pulley(0.3)] * 4).to_file(text)
    body = text.read_text().replace("pulleys:\n", "pulleys:\n- null\n")
    text.write_text(body)
    with pytest.raises(to.RobotFileError, match="pulleys"):
        to.CableRobot.from_file(text)


def test_sag_models_without_pulleys_refuse_them_instead_of_ignoring_them():
    towers = to.presets.algae_harvester().with_(pulleys=[to.Pulley(0.3)] * 4)
    for call in (lambda: catenary.platform_stiffness(towers, [[0, 0, 0]]),
                 lambda: catenary.coupled_margin(towers, [[0, 0, 0]]),
                 lambda: catenary.sag_workspace(towers, [[0, 0, 0]])):
        with pytest.raises(catenary.InvalidCableError, match="pulleys"):
            call()


def caspr_leaving_point(r_F, v_F, r_B, R):
    """CASPR's BaseRotatingPulleyAttachment.ComputePulleyLeavingLocation, re-derived:
    the centre from the plane of the entry direction and B, the tangent point from the
    ratio rho = R / |B - C|, the arc from the angle between F and A about C (acos, so
    only for wraps up to pi)."""
    n = np.cross(v_F, r_B - r_F)
    n_unit = n / np.linalg.norm(n)
    v_FC = np.cross(n, v_F)
    r_C = r_F + R * v_FC / np.linalg.norm(v_FC)
    rho = R / np.linalg.norm(r_B - r_C)
    r_A = r_C + rho**2 * (r_B - r_C) - rho * np.sqrt(1 - rho**2) * np.cross(n_unit, r_B - r_C)
    n1, n2 = (r_F - r_C) / R, (r_A - r_C) / np.linalg.norm(r_A - r_C)
    return r_A, R * np.arccos(np.clip(n1 @ n2, -1, 1))


def test_caroca_with_rotating_pulleys_matches_caspr_pulley_model():
    """CAROCA's ``with_rotating_pulleys`` cable set imports, and its exit points and arcs
    agree with CASPR's own formulas (an independent derivation) at random poses."""
    from pathlib import Path

    folder = Path(__file__).resolve().parents[1] / "data/caspr/SCDM/spatial_manipulators/CAROCA"
    robot = to.load_caspr(folder / "CAROCA_bodies.xml", folder / "CAROCA_cables.xml",
                          "with_rotating_pulleys")
    assert robot.has_pulleys and all(q.radius == 0.045 for q in robot.pulleys)
    rng = np.random.default_rng(11)
    poses = robot.home + rng.uniform(-1, 1, (30, 6)) * [1.0, 1.0, 0.5, 0.2, 0.2, 0.2]
    geometry = robot.cable_geometry(poses)
    B = geometry.attachment_points
    exits = geometry.vectors + B
    checked = 0
    for k in range(len(poses)):
        for i, q in enumerate(robot.pulleys):
            T, arc = caspr_leaving_point(robot.anchors[i], -q.axis, B[k, i], q.radius)
            np.testing.assert_allclose(exits[k, i], T, atol=1e-9)
            if geometry.wrapped[k, i] < q.radius * (np.pi - 1e-6):
                assert geometry.wrapped[k, i] == pytest.approx(arc, abs=1e-9)
                checked += 1
    assert checked > 100


def _richardson(f, h):
    d1 = (f(h) - f(-h)) / (2 * h)
    d2 = (f(h / 2) - f(-h / 2)) / h
    return (4 * d2 - d1) / 3


@pytest.mark.parametrize("kind", ["point3", "spatial6"])
def test_tension_derivatives_over_pulleys_match_differences(kind):
    """By the pose, the drawing points and the attachments: the wheel turns with the
    platform (the projector's rank-one swivel term), checked against central
    differences of the solver itself."""
    robot = pulley_robot(8, kind)
    rng = np.random.default_rng(2)
    if kind == "point3":
        poses = np.array([[-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [3.0, -4.0, 2.0]])
    else:
        poses = robot.home + rng.uniform(-1, 1, (3, 6)) * [0.5, 0.5, 0.3, 0.05, 0.05, 0.05]
    sol = to.distribute(robot, poses, "min_norm", "cvxpy:CLARABEL", accuracy="high")
    ok = sol.success
    assert ok.sum() >= 2
    solve = lambda r, p: to.distribute(r, p, "min_norm", "closed_form").tensions  # noqa: E731
    J = sol.jacobian("pose", robot=robot, poses=poses)
    for k in (0, 1, 2):
        e = np.zeros(robot.dof)
        e[k] = 1.0
        fd = _richardson(lambda s, e=e: solve(robot, poses + s * e), 1e-4)
        np.testing.assert_allclose(J.jacobian[ok, :, k], fd[ok], rtol=1e-5, atol=1e-5)
    for wrt in ("drawing_points", "attachment_points"):
        J = sol.jacobian(wrt, robot=robot, poses=poses)
        field = "anchors" if wrt == "drawing_points" else "attachments"
        for i, c in ((0, 0), (2, 1), (3, 2)):
            def moved(s, i=i, c=c, field=field):
                pts = np.array(getattr(robot, field))
                pts[i, c] += s
                return solve(robot.with_(**{field: pts}), poses)
            fd = _richardson(moved, 1e-4)
            np.testing.assert_allclose(J.jacobian[ok, :, i, c], fd[ok], rtol=1e-5, atol=1e-5)


def test_straight_stiffness_over_pulleys_is_minus_the_wrench_derivative():
    """Straight elastic cables over swivel pulleys, unstretched lengths held: the
    platform stiffness is minus the derivative of the cables' wrench by the pose (the
    free span's direction turns with the wheel, the whole cable stretches)."""
    base = to.presets.cogiro()
    robot = pulley_robot(4)
    rng = np.random.default_rng(6)
    poses = base.home + rng.uniform(-1, 1, (3, 6)) * [0.5, 0.5, 0.3, 0.05, 0.05, 0.05]
    EA = robot.cable.EA
    assert np.isfinite(EA)
    res = catenary.stiffness_analysis(robot, poses, model="straight")
    assert np.isin(res.status, ("optimal", "converged")).all()
    L0 = res.lengths  # unstretched, arcs included

    def wrench(p):
        L, _ = robot.inverse_kinematics(p)
        T = EA * (L - L0) / L0
        return np.einsum("nij,nj->ni", robot.structure_matrices(p), T)

    for k in range(3):  # translations: plain coordinates
        e = np.zeros(6)
        e[k] = 1.0
        fd = _richardson(lambda s, e=e: wrench(poses + s * e), 1e-5)
        np.testing.assert_allclose(-fd, res.stiffness[:, :, k], rtol=1e-6,
                                   atol=1e-6 * np.abs(res.stiffness).max())
