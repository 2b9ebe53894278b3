"""Sagging cables over guide pulleys: each catenary leaves its wheel tangentially.

Checked against the catenary's own sampled shape (the slope at the exit point, by a
second-order difference), the limit of a vanishing wheel (the fixed drawing point), and,
in the coupled model, the platform's equilibrium.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary.elastic import profile
from catenary.pulleys import settle_wraps

POSES = np.array([[0.0, 0.0, 0.0], [-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [10.0, -20.0, 3.0]])


def towers(radius: float = 0.3, sign: float = -1.0, **overrides: float) -> to.CableRobot:
    robot = to.presets.algae_harvester(**overrides)
    return robot.with_(pulleys=[to.Pulley(radius, [0, 0, sign])] * robot.m)


def tangency_gap(robot: to.CableRobot, tensions: np.ndarray) -> tuple[np.ndarray, ...]:
    """Settle the wraps under exit tensions (N, m); then, independently of the
    tangency formula, the catenary's slope at its upper end from its sampled shape (a
    second-order one-sided difference) and the wheel's tangent at the settled wrap
    angle, both as angles from the horizontal (rad), and the cables' lengths (m)."""
    w, EA = robot.cable.weight_per_length(robot.g), robot.cable.EA
    sag = settle_wraps(robot, POSES, tensions, np.ones(len(POSES), bool), w, EA)
    assert sag.settled.all() and (sag.steps[:, 0] <= 10).all()
    c = catenary.solve_length(sag.planes.x, sag.planes.z, tensions, w, EA, "B")
    _, x, z = profile(c.H, c.V_B, c.L0, w, EA, n=200_001)
    dx = 3 * x[..., -1] - 4 * x[..., -2] + x[..., -3]
    dz = 3 * z[..., -1] - 4 * z[..., -2] + z[..., -3]
    sampled = np.arctan2(dz, dx)  # how steeply the cable rises into its exit point
    # The wheel's travel direction -cos(b) axis + sin(b) h (axis = -e_z) descends from
    # the exit point at atan2(-cos b, sin b) below the horizontal: the same angle.
    wheel = np.arctan2(-np.cos(sag.wrap), np.sin(sag.wrap))
    return sampled, wheel, c.L0 + sag.arcs(tensions, EA)


@pytest.mark.parametrize("model", ["thesis", "coupled"])
def test_each_catenary_leaves_its_wheel_tangentially(model):
    robot = towers()
    res = catenary.inverse_kinematics(robot, POSES, model=model)
    assert (res.status == "converged").all()
    sampled, wheel, lengths = tangency_gap(robot, res.tensions)
    np.testing.assert_allclose(sampled, wheel, atol=1e-7)
    # The thesis settling under the coupled answer's exit tensions is the coupled state.
    np.testing.assert_allclose(lengths, res.lengths, atol=1e-9)


def test_a_vanishing_wheel_gives_the_fixed_drawing_point():
    plain = to.presets.algae_harvester()
    for model in ("thesis", "coupled"):
        fixed = catenary.inverse_kinematics(plain, POSES, model=model)
        tiny = catenary.inverse_kinematics(towers(1e-9), POSES, model=model)
        np.testing.assert_allclose(tiny.lengths, fixed.lengths, atol=1e-7)
        np.testing.assert_allclose(tiny.tensions, fixed.tensions, rtol=1e-7)


def test_coupled_model_balances_the_load_over_pulleys():
    robot = towers(0.3)
    res = catenary.inverse_kinematics(robot, POSES, model="coupled")
    assert (res.status == "converged").all()
    assert res.equilibrium_residual.max() <= 1e-9 * robot.weight
    bounds_ok = res.tensions_platform >= robot.t_min * (1 - 1e-9)
    assert bounds_ok.all()


def test_sag_over_pulleys_exceeds_the_straight_pulley_length():
    robot = towers(0.3)
    res = catenary.inverse_kinematics(robot, POSES, model="thesis")
    straight, _ = robot.inverse_kinematics(POSES)
    np.testing.assert_array_equal(res.straight_lengths, straight)
    assert (res.lengths > straight).all()  # an inextensible sagging cable is longer


def test_elastic_cables_stretch_over_the_wheel_too():
    robot = to.presets.algae_harvester()
    cable = to.CableProperties(robot.cable.diameter, robot.cable.linear_mass, 2.0e6)
    stiff, soft = towers(0.3), towers(0.3).with_(cable=cable)
    a = catenary.inverse_kinematics(stiff, POSES, model="thesis")
    b = catenary.inverse_kinematics(soft, POSES, model="thesis")
    # The elastic cable is shorter unstretched, by at least the arc's stretch T r beta / EA.
    assert (b.lengths < a.lengths).all()


def tilted(tilt: float = 0.25, radius: float = 0.3) -> to.CableRobot:
    """The study robot whose tower pulleys' axes lean inwards by ``tilt`` (rad)."""
    robot = to.presets.algae_harvester()
    inward = -robot.anchors[:, :2] / np.linalg.norm(robot.anchors[:, :2], axis=1)[:, None]
    axes = np.column_stack([np.sin(tilt) * inward, -np.full(robot.m, np.cos(tilt))])
    return robot.with_(pulleys=[to.Pulley(radius, a) for a in axes])


def test_tilted_axes_swivel_the_wheel_out_of_the_straight_plane_and_stay_tangent():
    """A tilted swivel axis: the wheel's direction and wrap both move; the catenary's
    own direction at its exit point (sampled shape) is the wheel's tangent there."""
    robot = tilted()
    w, EA = robot.cable.weight_per_length(robot.g), robot.cable.EA
    T = to.distribute(robot, POSES).tensions
    sag = settle_wraps(robot, POSES, T, np.ones(len(POSES), bool), w, EA)
    assert sag.settled.all()
    c = catenary.solve_length(sag.planes.x, sag.planes.z, T, w, EA, "B")
    _, x, z = profile(c.H, c.V_B, c.L0, w, EA, n=200_001)
    dx = 3 * x[..., -1] - 4 * x[..., -2] + x[..., -3]
    dz = 3 * z[..., -1] - 4 * z[..., -2] + z[..., -3]
    # the cable runs from its exit point towards B: against the profile's end tangent
    travel = -(dx[..., None] * sag.planes.e_h + dz[..., None] * np.array([0.0, 0.0, 1.0]))
    travel /= np.linalg.norm(travel, axis=-1, keepdims=True)
    axes = np.array([np.asarray(q.axis) for q in robot.pulleys])
    beta = sag.wrap[..., None]
    wheel = -np.cos(beta) * axes + np.sin(beta) * sag.directions
    np.testing.assert_allclose(travel, wheel, atol=1e-7)
    # the wheel swivelled out of the plane of the straight cable's wheel
    straight = robot.cable_geometry(POSES)
    assert np.isfinite(straight.wrapped).all()
    res = catenary.inverse_kinematics(robot, POSES, model="coupled")
    assert (res.status == "converged").all()
    assert res.equilibrium_residual.max() <= 1e-9 * robot.weight


def test_tilted_vanishing_wheels_give_the_fixed_drawing_points():
    plain = to.presets.algae_harvester()
    for model in ("thesis", "coupled"):
        fixed = catenary.inverse_kinematics(plain, POSES, model=model)
        tiny = catenary.inverse_kinematics(tilted(0.4, 1e-9), POSES, model=model)
        np.testing.assert_allclose(tiny.lengths, fixed.lengths, atol=1e-7)


@settings(max_examples=15, deadline=None)
@given(radius=st.floats(0.01, 1.0), height=st.floats(5.0, 15.0),
       x=st.floats(-35.0, 35.0), y=st.floats(-20.0, 20.0), z=st.floats(0.0, 4.0),
       winch_above=st.booleans(), tilt=st.floats(0.0, 0.5))
def test_random_wheels_and_poses_balance_and_leave_tangentially(radius, height, x, y, z,
                                                                 winch_above, tilt):
    base = to.presets.algae_harvester(tower_height=height)
    inward = -base.anchors[:, :2] / np.linalg.norm(base.anchors[:, :2], axis=1)[:, None]
    sign = 1.0 if winch_above else -1.0
    axes = np.column_stack([np.sin(tilt) * inward, np.full(base.m, sign * np.cos(tilt))])
    robot = base.with_(pulleys=[to.Pulley(radius, a) for a in axes])
    pose = np.array([[x, y, z]])
    res = catenary.inverse_kinematics(robot, pose, model="coupled")
    if res.status[0] != "converged":
        return  # outside the sag-aware workspace: nothing to check
    assert res.equilibrium_residual[0] <= 1e-9 * robot.weight
    thesis = catenary.inverse_kinematics(robot, pose, model="thesis")
    straight, _ = robot.inverse_kinematics(pose)
    if thesis.status[0] == "converged":
        assert (thesis.lengths >= straight - 1e-9).all()  # inextensible: sag lengthens


def test_a_pose_sag_holds_is_never_called_infeasible_over_wheels():
    """Where the fixed drawing points' coupled model holds a pose that has no
    straight-line tensions, the pulley robot either holds it too or says its iteration
    did not settle, never "infeasible" (its margin search spans fixed points)."""
    plain = to.presets.algae_harvester()
    rng = np.random.default_rng(0)
    poses = np.column_stack([rng.uniform(-40, 40, 300), rng.uniform(-25, 25, 300),
                             rng.uniform(0, 6, 300)])
    fixed = catenary.inverse_kinematics(plain, poses, model="coupled")
    wheels = catenary.inverse_kinematics(towers(), poses, model="coupled")
    held = fixed.status == "converged"
    assert held.all()
    assert not (wheels.status[held] == "infeasible").any()
    assert (wheels.status == "converged").mean() > 0.99


@pytest.mark.parametrize("model", ["thesis", "coupled"])
def test_sagging_cable_clearance_over_wheels(model):
    """The clearance of cables leaving their wheels: a vanishing wheel gives the fixed
    drawing points' answer, and the certified distance brackets dense sampling of the
    curves themselves (their ends: the attachment and the exit point)."""
    poses = np.array([[-29.4, 10.2, 1.5], [10.0, -5.0, 2.0]])
    fixed = catenary.cable_clearance(to.presets.algae_harvester(), poses, model=model)
    tiny = catenary.cable_clearance(towers(1e-9), poses, model=model)
    np.testing.assert_allclose(tiny.distances, fixed.distances, atol=1e-7)
    robot = tilted(0.25)
    res = catenary.cable_clearance(robot, poses, model=model)
    assert (res.lower_bound <= res.distances + 1e-12).all()
    ik = catenary.inverse_kinematics(robot, poses, model=model)
    w, EA = robot.cable.weight_per_length(robot.g), robot.cable.EA
    sag = settle_wraps(robot, poses, ik.tensions, ik.success, w, EA)
    free = ik.lengths - sag.arcs(ik.tensions, EA)
    curves = catenary.interference.curves_in(sag.planes, ik.horizontal_tensions,
                                             ik.platform_forces[..., 2], free, w, EA)
    ends = curves.points(free[..., None])[..., 0, :]
    tops = sag.planes.position[:, None] + sag.planes.arms + sag.planes.x[..., None] * (
        sag.planes.e_h) + sag.planes.z[..., None] * np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(ends, tops, atol=1e-9)  # the curves end on the exit points
    # The study's cables meet at the platform point: compared away from it, as the
    # clearance does (shared_trim of each cable's length left out there).
    from tension_opt.workspace.interference import SHARED_TRIM

    s = np.linspace(SHARED_TRIM, 1.0, 2001)
    pts = curves.points(free[..., None] * s)  # (N, m, k, 3)
    for p in range(len(poses)):
        for q, (i, j) in enumerate(res.pairs):
            gap = np.linalg.norm(pts[p, i][:, None] - pts[p, j][None], axis=-1).min()
            assert res.distances[p, q] <= gap + 1e-9
            assert res.lower_bound[p, q] <= gap + 1e-9


def _on_wheel_and_tangent(robot: to.CableRobot, exits: np.ndarray, H: np.ndarray,
                          V_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far each exit point (N, m, 3) is off its wheel (m), and the cosine between the
    catenary's direction there, ``(H e - V_B e_z) / T``, and the wheel's radius."""
    A = np.asarray(robot.anchors, dtype=float)
    axes = np.array([np.asarray(q.axis, dtype=float) for q in robot.pulleys])
    r = np.array([q.radius for q in robot.pulleys])
    d = exits - A
    along = np.einsum("nki,ki->nk", d, axes)
    perp = d - along[..., None] * axes
    size = np.linalg.norm(perp, axis=-1)
    centre = A + r[:, None] * perp / size[..., None]
    off = np.abs(np.linalg.norm(exits - centre, axis=-1) - r)
    e = np.zeros_like(exits)
    e[..., :2] = -d[..., :2] / np.linalg.norm(d[..., :2], axis=-1)[..., None]  # towards B
    # The chord's horizontal direction: from the exit point towards the attachment.
    B = robot.cable_geometry(POSES).attachment_points
    e[..., :2] = (B - exits)[..., :2]
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    c = (H[..., None] * e - V_B[..., None] * np.array([0.0, 0.0, 1.0]))
    c /= np.linalg.norm(c, axis=-1, keepdims=True)
    radius = (exits - centre) / r[:, None]
    return off, np.abs(np.einsum("nki,nki->nk", c, radius))


@pytest.mark.parametrize("model", ["thesis", "coupled"])
def test_the_result_says_where_each_cable_leaves_its_wheel(model):
    robot = towers()
    res = catenary.inverse_kinematics(robot, POSES, model=model)
    assert res.exit_points.shape == (len(POSES), robot.m, 3)
    V_B = np.sqrt(res.tensions**2 - res.horizontal_tensions**2)  # the upper end pulls up
    off, cos = _on_wheel_and_tangent(robot, res.exit_points, res.horizontal_tensions, V_B)
    assert off.max() < 1e-12 and cos.max() < 1e-9
    # The wrap angles are the wheels' own: the arc on the wheel is the length's share.
    w, EA = robot.cable.weight_per_length(robot.g), robot.cable.EA
    free = catenary.solve_length(*_spans(robot, res.exit_points), res.tensions, w, EA, "B")
    arcs = 0.3 * res.wrap_angles / (1.0 + res.tensions / EA)
    np.testing.assert_allclose(free.L0 + arcs, res.lengths, rtol=1e-12)
    plain = catenary.inverse_kinematics(to.presets.algae_harvester(), POSES, model=model)
    assert plain.exit_points is None and plain.wrap_angles is None


def _spans(robot: to.CableRobot, exits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal span and height of each exit point over its attachment point (m)."""
    d = exits - robot.cable_geometry(POSES).attachment_points
    return np.hypot(d[..., 0], d[..., 1]), d[..., 2]


@pytest.mark.parametrize("model", ["coupled", "thesis", "straight"])
def test_a_view_draws_the_free_span_the_wrapped_arc_and_the_wheel(model):
    from catenary.viz import robot_scenes
    from catenary.viz.wheels import ARC_SAMPLES

    robot = towers()
    scenes = robot_scenes(robot, POSES, model=model, samples=61)
    if model != "straight":
        res = catenary.inverse_kinematics(robot, POSES, model=model)
    for k, scene in enumerate(scenes):
        assert scene.curves.shape == (robot.m, 61 + ARC_SAMPLES - 1, 3)
        np.testing.assert_allclose(scene.curves[:, 0], scene.attachments, atol=1e-12)
        np.testing.assert_allclose(scene.curves[:, -1], scene.anchors, atol=1e-12)
        np.testing.assert_allclose(scene.curves[:, 60], scene.exits, atol=1e-9)
        # The arc and the outline lie on the wheel: a circle of radius 0.3 about its
        # centre, in the plane of the axis (vertical here) and the wheel's direction.
        centre = scene.wheels[:, :-1].mean(axis=1, keepdims=True)  # the outline closes
        for points in (scene.curves[:, 60:], scene.wheels):
            np.testing.assert_allclose(np.linalg.norm(points - centre, axis=-1), 0.3,
                                       atol=1e-9)
        if model == "straight":
            np.testing.assert_allclose(scene.lengths, robot.inverse_kinematics(POSES)[0][k],
                                       rtol=1e-12)
        else:
            np.testing.assert_allclose(scene.lengths, res.lengths[k], rtol=1e-12)
            np.testing.assert_allclose(scene.exits, res.exit_points[k], atol=1e-9)
            # The same cables drawn from the given tensions.
            again = robot_scenes(robot, POSES[k], res.tensions[k], model, samples=61)[0]
            np.testing.assert_allclose(again.lengths, scene.lengths, rtol=1e-9)
            np.testing.assert_allclose(again.curves, scene.curves, atol=1e-6)


def test_a_pulley_robot_is_drawn_by_matplotlib_and_plotly():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from catenary.viz import plot_robot

    robot = towers()
    fig = plot_robot(robot, POSES[1], view="3d")
    gids = {a.get_gid() for a in fig.axes[0].get_children()}
    assert {f"pulley {i}" for i in range(4)} <= gids
    plt.close(fig)
    pytest.importorskip("plotly")
    fig = plot_robot(robot, POSES[1], engine="plotly")
    assert sum(t.name == "guide pulleys" for t in fig.data) == 4


@pytest.mark.parametrize("robot", [towers(), towers(1.0), tilted()],
                         ids=["vertical axes", "1 m wheels", "tilted axes"])
def test_sag_forward_kinematics_over_pulleys_inverts_the_coupled_model(robot):
    """The lengths of the coupled model over pulleys give back their poses and tensions:
    the catenaries balance the load, and each leaves its wheel tangentially."""
    res = catenary.inverse_kinematics(robot, POSES, model="coupled", tol=1e-13)
    assert res.success.all()
    fk = catenary.forward_kinematics(robot, res.lengths)
    assert (fk.status == "converged").all(), fk.status
    np.testing.assert_allclose(fk.poses, POSES, atol=1e-7)
    np.testing.assert_allclose(fk.tensions, res.tensions, rtol=1e-6)
    assert fk.residual.max() < 1e-6 * robot.weight and fk.span_residual.max() < 1e-9
    # The straight model: the straight lengths (arcs and free spans) give their poses.
    straight = catenary.forward_kinematics(robot, robot.inverse_kinematics(POSES)[0],
                                           model="straight")
    np.testing.assert_allclose(straight.poses, POSES, atol=1e-8)


def test_forward_kinematics_over_pulleys_reports_what_it_cannot_solve():
    """A cable shorter than the arc it wraps has no free span: that pose reads
    not_converged and the others are solved, as without pulleys; a wrench of another
    shape is the package's error."""
    robot = towers()
    L = catenary.inverse_kinematics(robot, POSES[:2], "coupled", tol=1e-13).lengths
    L[1, 0] = 0.4
    fk = catenary.forward_kinematics(robot, L)
    assert list(fk.status) == ["converged", "not_converged"]
    np.testing.assert_allclose(fk.poses[0], POSES[0], atol=1e-7)
    with pytest.raises(to.InvalidInputError, match="wrench"):
        catenary.forward_kinematics(robot, L, wrench=np.zeros((3, 3)))


@pytest.mark.parametrize("slack", [0.0, 1.0])
def test_a_view_of_given_tensions_draws_a_slack_cable_over_its_pulley(slack):
    """Given tensions whose catenary does not exist (no tension, or too little for the
    span) leave that cable at its straight exit point, drawn slack or infeasible, as
    without pulleys."""
    from catenary.viz import robot_scenes

    robot = towers()
    T = [3000.0, slack, 3000.0, 3000.0]
    scene = robot_scenes(robot, POSES[1], T, "thesis")[0]
    plain = robot_scenes(to.presets.algae_harvester(), POSES[1], T, "thesis")[0]
    np.testing.assert_array_equal(scene.state, plain.state)
    assert scene.state[1] in ("slack", "infeasible") and np.isfinite(scene.curves).all()
