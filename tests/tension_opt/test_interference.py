"""Interference of straight cables: segment distances against hand cases, dense sampling
and a local solver; clearances and interference-free workspaces of the presets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

import tension_opt as to
from tension_opt import workspace as ws
from tension_opt.errors import InvalidInputError


def sampled(p0, p1, q0, q1, n=801):
    """Smallest distance between ``n`` samples of each segment, and the sampling's
    certified slack ``(|p1 - p0| + |q1 - q0|) / (2 (n - 1))``."""
    u = np.linspace(0.0, 1.0, n)[:, None]
    a = p0 + u * (p1 - p0)
    b = q0 + u * (q1 - q0)
    d = np.linalg.norm(a[:, None] - b[None], axis=-1)
    slack = (np.linalg.norm(p1 - p0) + np.linalg.norm(q1 - q0)) / (2 * (n - 1))
    return float(d.min()), slack


def refined(p0, p1, q0, q1):
    """Dense sampling refined by a bounded local solver (an independent reference)."""
    u = np.linspace(0.0, 1.0, 201)
    a = p0 + u[:, None] * (p1 - p0)
    b = q0 + u[:, None] * (q1 - q0)
    d = np.linalg.norm(a[:, None] - b[None], axis=-1)
    j, k = np.unravel_index(np.argmin(d), d.shape)

    def f(x):
        return float(np.sum((p0 + x[0] * (p1 - p0) - q0 - x[1] * (q1 - q0)) ** 2))

    res = minimize(f, [u[j], u[k]], bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                   options={"ftol": 1e-15, "gtol": 1e-12})
    return float(np.sqrt(min(res.fun, d.min() ** 2)))


@pytest.mark.parametrize(
    ("p0", "p1", "q0", "q1", "expected"),
    [
        ([0, 0, 0], [1, 0, 0], [0.5, -1, 1], [0.5, 1, 1], 1.0),  # crossing, 1 m apart
        ([0, 0, 0], [1, 0, 0], [0.5, -1, 0], [0.5, 1, 0], 0.0),  # crossing, touching
        ([0, 0, 0], [1, 0, 0], [0.5, 0.3, 0], [3, 0.3, 0], 0.3),  # parallel, overlapping
        ([0, 0, 0], [1, 0, 0], [2, 0.3, 0], [3, 0.3, 0], np.hypot(1, 0.3)),  # parallel, apart
        ([0, 0, 0], [1, 0, 0], [0.5, 0, 0], [3, 0, 0], 0.0),  # collinear, overlapping
        ([0, 0, 0], [1, 0, 0], [3, 0, 0], [2, 0, 0], 1.0),  # collinear, disjoint, reversed
        ([0, 0, 0], [1, 0, 0], [1, 0, 0], [1, 2, 0], 0.0),  # touching ends
        ([0, 0, 0], [0, 0, 0], [0.5, 0.3, 0], [3, 0.3, 0], np.hypot(0.5, 0.3)),  # a point
        ([1, 2, 3], [1, 2, 3], [1, 2, 5], [1, 2, 5], 2.0),  # two points
    ],
)
def test_segment_distance_hand_cases(p0, p1, q0, q1, expected):
    res = ws.segment_distance(p0, p1, q0, q1)
    assert res.distance == pytest.approx(expected, abs=1e-12)
    # The points are on the segments, at the fractions, and that far apart.
    assert np.allclose(res.point_a, np.add(p0, res.s * np.subtract(p1, p0)))
    assert np.allclose(res.point_b, np.add(q0, res.t * np.subtract(q1, q0)))
    assert np.linalg.norm(res.point_a - res.point_b) == pytest.approx(expected, abs=1e-12)
    # Symmetric in the two segments and in their directions.
    assert ws.segment_distance(q1, q0, p1, p0).distance == pytest.approx(expected, abs=1e-12)


def test_segment_distance_batches_against_sampling_and_a_local_solver():
    rng = np.random.default_rng(7)
    P = rng.normal(size=(60, 4, 3))
    P[:20, 3] = P[:20, 2] + 0.7 * (P[:20, 1] - P[:20, 0])  # parallel pairs
    P[20:25, 1] = P[20:25, 0]  # zero-length first segments
    res = ws.segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
    assert res.distance.shape == (60,)
    for k in range(60):
        d_grid, slack = sampled(*P[k])
        assert d_grid - slack - 1e-12 <= res.distance[k] <= d_grid + 1e-12
        assert res.distance[k] == pytest.approx(refined(*P[k]), abs=1e-7)


coordinate = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
point = st.tuples(coordinate, coordinate, coordinate)


@settings(max_examples=150, deadline=None)
@given(point, point, point, point)
def test_segment_distance_brackets_the_sampled_minimum(p0, p1, q0, q1):
    p0, p1, q0, q1 = (np.array(v) for v in (p0, p1, q0, q1))
    d = float(ws.segment_distance(p0, p1, q0, q1).distance)
    d_grid, slack = sampled(p0, p1, q0, q1, n=301)
    assert d <= d_grid + 1e-9
    assert d >= d_grid - slack - 1e-9


def test_cogiro_home_clearance_and_its_crossing_cables():
    robot = to.presets.cogiro()
    res = ws.cable_clearance(robot, robot.home)
    clearance, pair = res  # unpacks as the contract says
    # The two cables of one corner leave their drawing points 0.40 m apart.
    assert clearance[0] == pytest.approx(0.397880, abs=1e-6)
    assert pair[0].tolist() == [6, 7]
    assert not res.shared.any()
    A = robot.attachment_points(robot.home)[0]
    B = robot.anchors
    for p, (i, j) in enumerate(res.pairs):  # every pair against the independent reference
        assert res.distances[0, p] == pytest.approx(refined(A[i], B[i], A[j], B[j]), abs=1e-7)
    # Crossing cables (closest points inside both): the smallest is cables 1 and 2.
    L = robot.cable_geometry(robot.home).lengths[0]
    arc = res.arc[0]
    inside = ((arc[:, 0] > 1e-6) & (arc[:, 0] < L[res.pairs[:, 0]] - 1e-6)
              & (arc[:, 1] > 1e-6) & (arc[:, 1] < L[res.pairs[:, 1]] - 1e-6))
    crossing = res.pairs[inside]
    assert {tuple(c) for c in crossing} == {(0, 4), (0, 7), (1, 2), (3, 4), (3, 7), (5, 6)}
    k = np.argmin(np.where(inside, res.distances[0], np.inf))
    assert res.pairs[k].tolist() == [1, 2]
    assert res.distances[0, k] == pytest.approx(0.860968, abs=1e-6)
    d_grid, slack = sampled(A[1], B[1], A[2], B[2], n=2001)
    assert d_grid - slack <= res.distances[0, k] <= d_grid


def test_algae_harvester_cables_share_the_platform_point():
    robot = to.presets.algae_harvester()
    res = ws.cable_clearance(robot, robot.home)
    assert res.shared.all()
    # At home, cables 0 and 1 are 62.2 m apart at the towers; 5 % of each is left out at
    # the platform, so the pieces start 0.05 * 62.2 m apart (equal lengths).
    assert res.clearance[0] == pytest.approx(0.05 * 62.2, abs=1e-9)
    assert res.pair[0].tolist() == [0, 1]
    wider = ws.cable_clearance(robot, robot.home, shared_trim=0.1)
    assert wider.clearance[0] == pytest.approx(0.1 * 62.2, abs=1e-9)
    none = ws.cable_clearance(robot, robot.home, shared_trim=0.0)
    assert none.clearance[0] == pytest.approx(0.0, abs=1e-12)


def test_batches_are_vectorised_and_equal_pose_by_pose():
    robot = to.presets.cogiro()
    poses = np.array([robot.home, [1.0, -1.0, 1.5, 0.1, 0.0, 0.2], [-2.0, 1.0, 2.5, 0, 0.1, 0]])
    batch = ws.cable_clearance(robot, poses)
    for k in range(3):
        one = ws.cable_clearance(robot, poses[k])
        assert np.array_equal(one.distances[0], batch.distances[k])
    assert batch.points.shape == (3, 28, 2, 3)
    assert np.allclose(np.linalg.norm(batch.points[..., 0, :] - batch.points[..., 1, :], axis=-1),
                       batch.distances)


def test_interference_free_workspace_alone_and_with_wrenches():
    robot = to.presets.cogiro()
    grid = ws.workspace_grid([-3, -2, 1, 0, 0, 0], [3, 2, 3, 0, 0, 0],
                             counts=[5, 5, 3, 1, 1, 1])
    alone = ws.interference_free_workspace(robot, grid, clearance=robot.cable.diameter)
    assert alone.N == 75 and alone.cable_clearance.shape == (75,)
    assert np.isfinite(alone.cable_clearance).all()
    assert (alone.cable_clearance > 0.2).all()  # straight cables never come close here
    assert alone.feasible.all() and alone.volume() == pytest.approx(6 * 4 * 2)
    # The two cables of a corner stay about 0.4 m apart: 0.38 m splits the grid.
    assert alone.cable_clearance.min() == pytest.approx(0.314468, abs=1e-6)
    strict = ws.interference_free_workspace(robot, grid, clearance=0.38)
    assert np.array_equal(strict.feasible, strict.cable_clearance > 0.38)
    assert 0 < strict.fraction() < 1
    both = ws.interference_free_workspace(robot, grid, clearance=0.38, with_wrenches=True)
    wrench = ws.wrench_feasible_workspace(robot, grid)
    assert np.array_equal(both.feasible, strict.feasible & wrench.feasible)
    assert np.array_equal(both.margin, wrench.margin)
    frame = both.to_frame()
    assert {"cable_clearance", "interference_free", "wrench_feasible"} <= set(frame.columns)
    home = ws.interference_free_workspace(robot, robot.home, clearance=robot.cable.diameter)
    assert home.feasible.all()


def test_tilted_cogiro_poses_bring_cables_within_a_diameter():
    robot = to.presets.cogiro()
    grid = ws.workspace_grid([-3, -2, 1, -0.3, -0.3, -0.3], [3, 2, 3, 0.3, 0.3, 0.3],
                             counts=[3, 3, 2, 3, 3, 3])
    res = ws.interference_free_workspace(robot, grid, clearance=robot.cable.diameter)
    assert res.cable_clearance.min() == pytest.approx(0.002807, abs=1e-6)
    assert 0.9 < res.fraction() < 1.0
    k = int(np.argmin(res.cable_clearance))
    i, j = res.pair[k]
    A = robot.attachment_points(res.poses[k])[0]
    B = robot.anchors
    assert res.cable_clearance[k] == pytest.approx(refined(A[i], B[i], A[j], B[j]), abs=1e-7)


@pytest.mark.parametrize(
    ("call", "word"),
    [
        (lambda r: ws.cable_clearance(r, r.home, model="coupled"), "model"),
        (lambda r: ws.cable_clearance(r, r.home, shared_trim=0.6), "shared_trim"),
        (lambda r: ws.cable_clearance(r, r.home, shared_trim="a"), "shared_trim"),
        (lambda r: ws.cable_clearance(r, [0.0, 1.0]), "poses"),
        (lambda r: ws.cable_clearance(r, [[np.nan] * 6]), "poses"),
        (lambda r: ws.interference_free_workspace(r, r.home, clearance=-0.1), "clearance"),
        (lambda r: ws.interference_free_workspace(r, r.home, clearance=np.inf), "clearance"),
    ],
)
def test_bad_input_raises_the_package_error_naming_the_argument(call, word):
    with pytest.raises(InvalidInputError, match=word):
        call(to.presets.cogiro())


# ------------------------------------------------------------------ the platform
from tension_opt.workspace.platform import hull_triangles, segment_triangle_distance  # noqa: E402


def triangle_samples(tri, n=60):
    """Points of triangles (F, 3, 3) on a barycentric grid, shape (F * k, 3)."""
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    keep = u + v <= 1
    u, v = u[keep], v[keep]
    pts = tri[:, None, 0] + u[:, None] * (tri[:, None, 1] - tri[:, None, 0]) + v[:, None] * (
        tri[:, None, 2] - tri[:, None, 0])
    return pts.reshape(-1, 3)


def test_segment_triangle_distance_hand_cases_and_sampling():
    tri = np.array([[-1.0, -1, 0], [1, -1, 0], [0, 1, 0]])
    assert segment_triangle_distance([0, 0, 1], [0, 0, -1], *tri) == 0.0  # pierces
    assert segment_triangle_distance([0, 0, 1], [0, 0, 2], *tri) == pytest.approx(1.0)
    assert segment_triangle_distance([3, 0, 1], [3, 0, -1], *tri) == pytest.approx(np.sqrt(5))
    assert segment_triangle_distance([-2, -1, 0], [2, -1, 0], *tri) == 0.0  # along an edge
    rng = np.random.default_rng(3)
    for _ in range(20):
        p = rng.normal(size=(2, 3))
        t = rng.normal(size=(3, 3))
        d = float(segment_triangle_distance(p[0], p[1], *t))
        seg = p[0] + np.linspace(0, 1, 300)[:, None] * (p[1] - p[0])
        pts = triangle_samples(t[None], 80)
        d_grid = np.linalg.norm(seg[:, None] - pts[None], axis=-1).min()
        assert d <= d_grid + 1e-12
        assert d >= d_grid - 0.05  # the sampling's spacing


def test_hull_triangles_of_a_box_a_plate_and_a_point():
    box = np.array([[x, y, z] for x in (0, 1) for y in (0, 2) for z in (0, 3)], float)
    tri = hull_triangles(box)
    assert tri.shape == (12, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert area.sum() == pytest.approx(2 * (1 * 2 + 2 * 3 + 1 * 3))
    plate = hull_triangles(box[box[:, 2] == 0])
    assert plate.shape == (2, 3, 3)
    assert hull_triangles(np.zeros((4, 3))).shape == (0, 3, 3)


def test_cogiro_cables_against_its_platform():
    robot = to.presets.cogiro()
    home = ws.platform_clearance(robot, robot.home)
    assert home.triangles.shape == (12, 3, 3)
    assert home.exclude == pytest.approx(0.086648, abs=1e-6)
    assert home.clearance[0] == pytest.approx(0.052124, abs=1e-6)
    assert home.cable[0] == 7
    # Cross-check cable 7 by sampling its remaining piece and the hull's faces.
    A = robot.attachment_points(robot.home)[0, 7]
    B = robot.anchors[7]
    u = (B - A) / np.linalg.norm(B - A)
    seg = (A + home.exclude * u) + np.linspace(0, 1, 400)[:, None] * (B - A - home.exclude * u)
    pts = triangle_samples(home.triangles, 60) + robot.home[:3]
    d_grid = min(np.linalg.norm(seg[k:k + 40, None] - pts[None], axis=-1).min()
                 for k in range(0, 400, 40))
    assert home.clearance[0] <= d_grid + 1e-12
    assert home.clearance[0] == pytest.approx(d_grid, abs=0.02)
    # Turned 1.2 rad about z, the lower cables cut through the platform.
    turned = ws.platform_clearance(robot, [0, 0, 2, 0, 0, 1.2])
    assert np.array_equal(turned.distances[0] == 0, robot.attachments[:, 2] < 0.5)
    res = ws.interference_free_workspace(robot, [robot.home, [0, 0, 2, 0, 0, 1.2]],
                                         robot.cable.diameter, with_platform=True)
    assert res.feasible.tolist() == [True, False]
    assert res.cable_clearance[1] > robot.cable.diameter  # the cables clear each other
    # A point-mass platform has no faces.
    harvester = to.presets.algae_harvester()
    assert np.isinf(ws.platform_clearance(harvester, harvester.home).clearance).all()


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [({"platform_hull": np.zeros((4, 2))}, "platform_hull"),
     ({"platform_hull": [[np.nan, 0, 0]]}, "platform_hull"),
     ({"exclude": -1.0}, "exclude")],
)
def test_platform_bad_input(kwargs, word):
    robot = to.presets.cogiro()
    with pytest.raises(InvalidInputError, match=word):
        ws.platform_clearance(robot, robot.home, **kwargs)


def test_the_platform_hull_of_a_robot_file(tmp_path):
    robot = to.presets.cogiro()
    box = np.array([[x, y, z] for x in (-0.52, 0.52) for y in (-0.5, 0.5) for z in (-0.01, 1.01)])
    boxed = robot.with_(platform_hull=box)
    for name in ("robot.yaml", "robot.json"):
        boxed.to_file(tmp_path / name)
        back = to.CableRobot.from_file(tmp_path / name)
        assert np.array_equal(back.platform_hull, box)
    assert robot.platform_hull is None
    # The robot's hull is the default of platform_clearance; the box holds the
    # attachments just inside its faces, so the cables leave it near their attachments.
    mine = ws.platform_clearance(boxed, boxed.home)
    given = ws.platform_clearance(robot, robot.home, platform_hull=box)
    assert np.array_equal(mine.distances, given.distances)
    assert mine.triangles.shape == (12, 3, 3)
    assert mine.clearance[0] == pytest.approx(0.009772, abs=1e-6)
    with pytest.raises(InvalidInputError, match="platform_hull"):
        robot.with_(platform_hull=np.zeros((3, 2)))
