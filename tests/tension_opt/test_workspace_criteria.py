"""Workspace criteria: wrench closure, static, polytopes of wrenches, the wrench-space
margin by hyperplane shifting, orientation workspaces and combined criteria, each
against an independent computation (convex hulls, vertex enumeration, loops)."""

from __future__ import annotations

import itertools

import matplotlib
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, QhullError

import tension_opt as to
from tension_opt import workspace as ws
from tension_opt.robot import CableRobot
from tension_opt.workspace import WrenchPolytope

matplotlib.use("Agg")

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])


def random_robot(rng: np.random.Generator, kind: str, m: int, t_min: float = 1.0,
                 t_max: float = np.inf, mass: float = 2.0) -> CableRobot:
    """Anchors around the origin in every direction (the pose the tests use)."""
    anchors = rng.normal(size=(m, 3)) * 3.0
    attachments = rng.normal(size=(m, 3)) * 0.3
    if kind == "planar_point2":
        anchors[:, 1] = 0.0
    if kind == "planar3":
        anchors[:, 2] = 0.0
        attachments[:, 2] = 0.0
    if kind in ("point3", "planar_point2"):
        attachments[:] = 0.0
    return CableRobot(anchors, attachments, mass, kind=kind, t_min=t_min, t_max=t_max)


def planar_all_around(t_max: float = np.inf) -> CableRobot:
    """A point in the xz plane held by four cables at 0, 90, 180 and 270 degrees."""
    angle = np.arange(4) * np.pi / 2
    anchors = 3.0 * np.column_stack([np.cos(angle), np.zeros(4), np.sin(angle)])
    return CableRobot(anchors, np.zeros((4, 3)), 1.0, kind="planar_point2", t_max=t_max)


def hull_contains_origin(columns: np.ndarray) -> tuple[bool | None, float]:
    """Whether the origin is strictly inside the convex hull of ``columns`` (m, n), and its
    distance to the hull's boundary (negative outside); (None, 0) for a flat hull."""
    try:
        hull = ConvexHull(columns)
    except QhullError:
        return False, 0.0
    depth = float(-hull.equations[:, -1].max())  # normal . 0 + offset <= 0 inside
    return depth > 0, depth


# ------------------------------------------------------------------ wrench closure
@pytest.mark.parametrize("kind,dof", [("planar_point2", 2), ("point3", 3), ("planar3", 3),
                                      ("spatial6", 6)])
def test_closure_agrees_with_the_convex_hull_of_the_columns(kind, dof):
    rng = np.random.default_rng(11 + dof)
    inside = outside = 0
    for trial in range(48):
        m = dof + 1 + trial % 6  # null spaces of dimension 1 to 6: exact and LP paths
        robot = random_robot(rng, kind, m)
        res = ws.wrench_closure_workspace(robot, np.zeros((1, dof)))
        A = robot.structure_matrices(np.zeros((1, dof)))[0]
        rank = np.linalg.matrix_rank(A)
        contains, depth = hull_contains_origin(A.T)
        if abs(depth) < 1e-6:
            continue  # on the hull's boundary, within the solvers' accuracy
        expected = rank == dof and contains
        assert res.feasible[0] == expected, (trial, res.margin[0], depth)
        assert res.extras["rank"][0] == rank
        assert (res.margin[0] > 1e-6) == contains  # the ratio is positive iff inside
        inside += expected
        outside += not expected
    assert inside >= 5 and outside >= 5, (inside, outside)  # both answers are tested


def test_closure_ratio_is_the_best_min_over_max_of_a_null_vector():
    # One null vector (m = n + 1): the ratio is min/max of that vector if it is positive.
    rng = np.random.default_rng(5)
    for _ in range(30):
        robot = random_robot(rng, "point3", 4)
        A = robot.structure_matrices(np.zeros((1, 3)))[0]
        v = np.linalg.svd(A)[2][-1]
        v = v if v.sum() > 0 else -v
        expected = v.min() / v.max() if (v > 0).all() else 0.0
        got = ws.wrench_closure_workspace(robot, np.zeros(3)).margin[0]
        assert got == pytest.approx(expected, abs=1e-12)


def test_hand_cases_of_closure():
    study = to.presets.algae_harvester()  # every cable above: gravity is needed
    grid = ws.workspace_grid([-40.0, -25.0, 0.0], [40.0, 25.0, 7.0], counts=[5, 4, 3])
    res = to.wrench_closure_workspace(study, grid)
    assert not res.feasible.any()
    np.testing.assert_array_equal(res.margin, np.zeros(60))
    np.testing.assert_array_equal(res.extras["rank"], np.full(60, 3))
    assert res.volume() == 0.0
    # Cables all around a planar point: closure everywhere inside; equal tensions
    # balance at the centre (ratio 1).
    planar = planar_all_around()
    poses = np.array([[0.0, 0.0], [1.0, 0.5], [-1.5, 1.0], [2.9, 0.0]])
    res = to.wrench_closure_workspace(planar, poses)
    assert res.feasible.all()
    assert res.margin[0] == pytest.approx(1.0, abs=1e-14)
    assert (res.margin[1:] < 1.0).all()
    # Outside the square of anchors (|x| + |z| < 3): no closure.
    out = to.wrench_closure_workspace(planar, [[0.0, 3.5], [3.5, 3.5]])
    assert not out.feasible.any()
    np.testing.assert_array_equal(out.margin, [0.0, 0.0])


def test_closure_implies_static_feasibility_under_any_wrench():
    rng = np.random.default_rng(8)
    closed = opened = 0
    for trial in range(24):
        robot = random_robot(rng, "spatial6", 10 + trial % 3, t_min=2.0, mass=5.0)
        pose = np.zeros((1, 6))
        closure = ws.wrench_closure_workspace(robot, pose).feasible[0]
        wrenches = rng.normal(size=(4, 6)) * 50.0
        static = ws.static_feasible_workspace(robot, pose, wrenches)
        if closure:
            closed += 1
            assert static.feasible[0]
            assert static.margin[0] == np.inf  # tensions grow without bound
        else:  # no positive null vector: the margin is finite
            opened += 1
            assert np.isfinite(static.margin[0])
    assert closed >= 3 and opened >= 3, (closed, opened)


# ------------------------------------------------------------------------- static
def test_static_workspace_is_the_wrench_feasible_one_without_upper_bound():
    robot = to.presets.algae_harvester(t_max=10e3)
    grid = ws.workspace_grid([-46.0, -31.0, 0.0], [46.0, 31.0, 7.0], spacing=[8.0, 8.0, 2.0])
    static = ws.static_feasible_workspace(robot, grid)
    free = to.wrench_feasible_workspace(robot.with_(t_max=np.inf), grid)
    np.testing.assert_array_equal(static.feasible, free.feasible)
    np.testing.assert_array_equal(static.margin, free.margin)
    assert static.robot is robot and static.extras["criterion"] == "static"
    bounded = to.wrench_feasible_workspace(robot, grid)
    assert (static.feasible >= bounded.feasible).all()
    assert static.volume() > bounded.volume() > 0  # t_max = 10 kN cuts the workspace
    # On the vertical axis the four tensions are alike, T_c = m g L / (4 (h - z)), and the
    # null vector (1, -1, 1, -1) cannot raise them all: the margin is T_c - t_min.
    z = np.array([0.0, 1.0, 5.0])
    hx, hy, h = 80.9 / 2 + 6.1, 50 / 2 + 6.1, 7.6
    Tc = robot.weight * np.sqrt(hx**2 + hy**2 + (h - z) ** 2) / (4 * (h - z))
    axis = np.column_stack([np.zeros(3), np.zeros(3), z])
    np.testing.assert_allclose(ws.static_feasible_workspace(robot, axis).margin,
                               Tc - robot.t_min[0], rtol=1e-12)


# ------------------------------------------------------------ polytopes of wrenches
def box_inequalities(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(lower)
    return np.vstack([np.eye(n), -np.eye(n)]), np.concatenate([upper, -lower])


def test_polytope_is_held_through_its_vertices_in_every_form():
    robot = to.presets.algae_harvester(t_max=10e3)
    grid = ws.workspace_grid([-46.0, -31.0, 0.0], [46.0, 31.0, 7.0], spacing=[6.0, 6.0, 1.5])
    lower, upper = np.array([-800.0, -300.0, -500.0]), np.array([800.0, 300.0, 200.0])
    corners = np.array(list(itertools.product(*zip(lower, upper, strict=True))))
    as_list = to.wrench_feasible_workspace(robot, grid, corners)
    forms = [WrenchPolytope.box(lower, upper), box_inequalities(lower, upper), corners,
             WrenchPolytope.from_inequalities(*box_inequalities(lower, upper))]
    for form in forms:
        res = to.wrench_feasible_workspace(robot, grid, wrench_set=form)
        np.testing.assert_array_equal(res.feasible, as_list.feasible)
        # The (H, h) form lists the corners in another order: compare the smallest margin.
        np.testing.assert_allclose(res.margin, as_list.margin, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.sort(res.margins, axis=1),
                                   np.sort(as_list.margins, axis=1), rtol=1e-9, atol=1e-9)
        assert len(res.wrenches) == 8
    assert 0.05 < as_list.fraction() < 0.6
    # Each vertex on its own: the polytope's poses are those feasible under every one.
    each = np.array([ws.capacity_margin(robot, grid.poses, wrench=v) for v in corners])
    np.testing.assert_allclose(as_list.margin, each.min(axis=0), rtol=1e-12)
    assert (to.wrench_feasible_workspace(robot, grid).feasible >= as_list.feasible).all()


def test_inequalities_give_the_vertices_of_their_set():
    rng = np.random.default_rng(2)
    for n in (2, 3, 6):
        points = rng.normal(size=(40, n)) * 100.0
        hull = ConvexHull(points)
        poly = WrenchPolytope.from_inequalities(hull.equations[:, :-1], -hull.equations[:, -1])
        want = points[hull.vertices]
        assert len(poly.vertices) == len(want)
        # Every vertex found is one of the hull's, to 1e-9 of the set's size.
        gap = np.linalg.norm(poly.vertices[:, None] - want[None], axis=2).min(axis=1)
        assert gap.max() < 1e-9 * np.abs(points).max()
        assert poly.contains(poly.vertices).all()
        assert not poly.contains(2.5 * poly.vertices).all()
    # A workspace against such a polytope is that of its vertices as a list.
    robot = to.presets.algae_harvester(t_max=10e3)
    grid = ws.workspace_grid([-46.0, -31.0, 0.0], [46.0, 31.0, 7.0], spacing=[8.0, 8.0, 2.0])
    points = rng.normal(size=(30, 3)) * 200.0
    hull = ConvexHull(points)
    res = to.wrench_feasible_workspace(robot, grid, wrench_set=(
        hull.equations[:, :-1], -hull.equations[:, -1]))
    ref = to.wrench_feasible_workspace(robot, grid, points[hull.vertices])
    np.testing.assert_array_equal(res.feasible, ref.feasible)
    np.testing.assert_allclose(res.margin, ref.margin, rtol=1e-9, atol=1e-9)
    assert 0.05 < ref.fraction() < 0.9


def brute_force_wrench_margin(A: np.ndarray, lb: np.ndarray, ub: np.ndarray,
                              B: np.ndarray) -> tuple[float, int]:
    """Every tension corner, their convex hull, its facets: ``min (offset - max normal .
    b)`` over facets; also the number of distinct facets (coplanar simplices merged)."""
    m = A.shape[1]
    corners = np.array(list(itertools.product([0.0, 1.0], repeat=m)))
    hull = ConvexHull((lb + corners * (ub - lb)) @ A.T)
    normals, offsets = hull.equations[:, :-1], -hull.equations[:, -1]
    facets = len(np.unique(np.round(hull.equations / np.abs(offsets).max(), 8), axis=0))
    return float((offsets - (B @ normals.T).max(axis=0)).min()), facets


@pytest.mark.parametrize("kind,dof,m", [("planar_point2", 2, 4), ("point3", 3, 5),
                                        ("point3", 3, 7), ("planar3", 3, 5),
                                        ("spatial6", 6, 8)])
def test_hyperplane_shifting_margin_agrees_with_the_zonotope_hull(kind, dof, m):
    rng = np.random.default_rng(m + 10 * dof)
    worst = 0.0
    for _ in range(6):
        robot = random_robot(rng, kind, m, t_min=5.0, t_max=60.0, mass=1.5)
        pose = np.zeros((1, dof))
        A = robot.structure_matrices(pose)[0]
        lower = -rng.uniform(0, 20, dof)
        poly = WrenchPolytope.box(lower, lower + rng.uniform(0, 30, dof))
        got = ws.wrench_space_margin(robot, pose, poly)[0]
        B = robot.required_wrench(pose)[0] - poly.vertices
        want, facets = brute_force_wrench_margin(A, robot.t_min, robot.t_max, B)
        worst = max(worst, abs(got - want) / max(abs(want), 1.0))
        # Its sign is that of the tension-space capacity margin.
        tension = to.wrench_feasible_workspace(robot, pose, wrench_set=poly)
        assert (got > 0) == (tension.margin[0] > 0)
        assert tension.extras["wrench_space_margin"][0] == got
        _, _, facet = ws.available_wrench_facets(robot, pose)
        assert facet.sum() == facets  # one row per facet, none missing
    assert worst < 1e-8


def test_repeated_and_dependent_hyperplanes_are_skipped():
    # Three cables in one vertical plane through the pose: their pairs span one plane
    # (three subsets, one facet pair); the fourth and fifth cable point elsewhere.
    anchors = np.array([[2.0, 0.0, 1.0], [-2.0, 0.0, 1.5], [0.5, 0.0, -2.0],
                        [0.0, 2.0, 0.5], [0.3, -2.0, 1.0]])
    robot = CableRobot(anchors, np.zeros((5, 3)), 1.0, t_min=0.0, t_max=40.0)
    pose = np.zeros((1, 3))
    H, h, facet = ws.available_wrench_facets(robot, pose)
    A = robot.structure_matrices(pose)[0]
    _, facets = brute_force_wrench_margin(A, robot.t_min, robot.t_max, np.zeros((1, 3)))
    assert facet.sum() == facets
    assert facet.sum() < len(facet[0])  # the repeats were found
    # A pair of parallel cables (same direction): each spans the same line (n - 1 = 1
    # column per subset), one facet pair counted once.
    par = CableRobot(np.array([[1.0, 0.0, 1.0], [2.0, 0.0, 2.0], [-1.0, 0.0, 0.5],
                               [0.0, 0.0, -1.0]]), np.zeros((4, 3)), 1.0,
                     kind="planar_point2", t_max=10.0)
    H, h, facet = ws.available_wrench_facets(par, np.zeros((1, 2)))
    assert facet.sum() == 6  # 8 rows, the parallel pair's two repeated
    for r in np.flatnonzero(~facet[0]):  # each repeat is a kept row: same plane, offset
        kept = np.flatnonzero(facet[0] & (np.abs(H[0] - H[0, r]).max(axis=1) < 1e-12))
        assert len(kept) == 1 and h[0, kept[0]] == pytest.approx(h[0, r], rel=1e-12)
    margin = ws.wrench_space_margin(par, np.zeros(2))[0]
    A = par.structure_matrices(np.zeros((1, 2)))[0]
    want, _ = brute_force_wrench_margin(A, par.t_min, par.t_max,
                                        par.required_wrench(np.zeros((1, 2))))
    assert margin == pytest.approx(want, rel=1e-10)
    # Three coplanar cables of a point mass: rank 2 < n, the set is flat in the plane
    # y = 0, which holds gravity: margin 0 (the planes y <= 0 and -y <= 0).
    flat = CableRobot(np.array([[1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.0, 0.0, -1.0]]),
                      np.zeros((3, 3)), 1.0, t_max=50.0)
    assert ws.wrench_space_margin(flat, np.zeros(3))[0] == pytest.approx(0.0, abs=1e-12)
    assert ws.wrench_space_margin(flat, np.zeros(3), [[0.0, 1.0, 0.0]])[0] == (
        pytest.approx(-1.0, rel=1e-12))
    # Two opposite cables: rank 1 < n - 1, no facet at all.
    line = CableRobot(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]), np.zeros((2, 3)), 1.0,
                      t_max=50.0)
    assert ws.wrench_space_margin(line, np.zeros(3))[0] == -np.inf


# --------------------------------------------------------- criteria imply each other
@st.composite
def robot_pose_and_box(draw):
    """A random point-mass or spatial robot at the origin and a box of wrenches."""
    seed = draw(st.integers(0, 2**32 - 1))
    kind, dof = draw(st.sampled_from([("point3", 3), ("planar3", 3), ("spatial6", 6)]))
    rng = np.random.default_rng(seed)
    m = dof + draw(st.integers(1, 4))
    robot = random_robot(rng, kind, m, t_min=rng.uniform(0, 5), t_max=rng.uniform(40, 200),
                         mass=rng.uniform(0.5, 5))
    lower = -rng.uniform(0, 15, dof)
    return robot, np.zeros((1, dof)), WrenchPolytope.box(lower, lower + rng.uniform(0, 25, dof))


@SETTINGS
@given(robot_pose_and_box())
def test_criteria_imply_each_other(case):
    robot, pose, box = case
    held = to.wrench_feasible_workspace(robot, pose, wrench_set=box)
    static = ws.static_feasible_workspace(robot, pose, wrench_set=box)
    closure = ws.wrench_closure_workspace(robot, pose)
    # Bounded tensions that hold every wrench of the set are also unbounded ones.
    assert static.feasible[0] >= held.feasible[0]
    assert static.margin[0] >= held.margin[0] - 1e-9 * robot.weight
    # Closure: tensions large enough hold any wrench, so a wide enough box of tensions
    # holds the whole polytope.
    if closure.feasible[0]:
        assert static.feasible[0] and static.margin[0] == np.inf
        if closure.margin[0] > 1e-3:
            wide = robot.with_(t_max=1e7)
            assert to.wrench_feasible_workspace(wide, pose, wrench_set=box).feasible[0]
    # The polytope holds iff each of its vertices does, the margin the smallest.
    each = np.array([ws.capacity_margin(robot, pose, wrench=v)[0] for v in box.vertices])
    assert held.margin[0] == pytest.approx(each.min(), rel=1e-9, abs=1e-9)
    scale = robot.t_max[0]
    if abs(held.margin[0]) > 1e-7 * scale:
        assert held.feasible[0] == (each >= 0).all()
        # The wrench-space margin has the sign of the tension-space margin.
        assert (held.extras["wrench_space_margin"][0] > 0) == (held.margin[0] > 0)


# ------------------------------------------------------------- orientation workspaces
def test_orientation_workspaces_are_the_criterion_at_each_orientation():
    robot = to.presets.kntu_planar()  # planar3, no gravity
    theta = np.linspace(-0.6, 0.6, 13)
    at = ws.orientation_workspace(robot, [0.2, -0.1], theta, "wrench_closure")
    poses = np.column_stack([np.full(13, 0.2), np.full(13, -0.1), theta])
    ref = ws.wrench_closure_workspace(robot, poses)
    np.testing.assert_array_equal(at.poses, poses)
    np.testing.assert_array_equal(at.margin, ref.margin)
    np.testing.assert_array_equal(at.extras["orientations"], theta[:, None])
    # Total orientation: every orientation must pass; a loop over them as reference.
    grid = ws.workspace_grid([-0.6, -0.6], [0.6, 0.6], counts=[9, 9])
    push = [[2.0, 0.0, 0.0], [0.0, -2.0, 0.1]]
    total = ws.total_orientation_workspace(robot, grid, theta, "wrench_feasible",
                                           wrenches=push)
    per = np.array([to.wrench_feasible_workspace(
        robot, np.column_stack([grid.poses, np.full(81, t)]), push).margin for t in theta])
    ok = np.array([to.wrench_feasible_workspace(
        robot, np.column_stack([grid.poses, np.full(81, t)]), push).feasible for t in theta])
    np.testing.assert_array_equal(total.feasible, ok.all(axis=0))
    np.testing.assert_array_equal(total.margin, per.min(axis=0))
    np.testing.assert_array_equal(total.extras["critical_orientation"], per.argmin(axis=0))
    np.testing.assert_allclose(total.extras["orientation_fraction"], ok.mean(axis=0))
    assert 0.1 < total.fraction() < 0.9
    # Inclusion: some orientation passes; its margin the largest.
    some = ws.inclusion_orientation_workspace(robot, grid, theta, "wrench_feasible",
                                              wrenches=push)
    np.testing.assert_array_equal(some.feasible, ok.any(axis=0))
    np.testing.assert_array_equal(some.margin, per.max(axis=0))
    np.testing.assert_array_equal(some.extras["critical_orientation"], per.argmax(axis=0))
    assert some.fraction() > total.fraction()
    assert some.extras["criterion"] == "inclusion_orientation_wrench_feasible"
    # The positions' grid: volume (m^2) is that of the feasible cells, plots draw it.
    cells = ws.cell_widths(grid.axes[0], -0.6, 0.6)[:, None] * ws.cell_widths(
        grid.axes[1], -0.6, 0.6)[None, :]
    assert total.volume() == pytest.approx(cells.ravel()[total.feasible].sum(), rel=1e-12)
    assert total.grid_shape == (9, 9, 1)
    ws.plot_slice(total, quantity="orientation_fraction")


def test_total_orientation_of_a_spatial_robot_and_of_interference():
    robot = to.presets.cogiro()
    rotations = np.array([[0.0, 0.0, 0.0], [0.15, 0.0, 0.0], [0.0, -0.15, 0.0],
                          [0.0, 0.0, 0.3]])
    grid = ws.workspace_grid([-5.0, -3.0, 1.0], [5.0, 3.0, 4.0], counts=[5, 3, 4])
    total = ws.total_orientation_workspace(robot, grid, rotations, "static")
    for r in rotations:
        one = ws.static_feasible_workspace(robot, np.column_stack(
            [grid.poses, np.tile(r, (len(grid.poses), 1))]))
        assert (one.feasible >= total.feasible).all()
        assert (one.margin >= total.margin).all()
    clear = ws.total_orientation_workspace(robot, grid, rotations, "interference_free",
                                           clearance=0.01)
    both = total & clear
    np.testing.assert_array_equal(both.feasible, total.feasible & clear.feasible)
    ws.plot_workspace_3d(both)
    assert 0 < both.volume() <= min(total.volume(), clear.volume())


# ---------------------------------------------------------------- combined criteria
def test_combined_results_keep_every_criterion():
    robot = to.presets.algae_harvester(t_max=10e3)
    grid = ws.workspace_grid([-46.0, -31.0, 0.0], [46.0, 31.0, 7.0], spacing=[8.0, 8.0, 2.0])
    feasible = to.wrench_feasible_workspace(robot, grid, wrench_set=WrenchPolytope.box(
        [-300.0] * 3, [300.0] * 3))
    clear = ws.interference_free_workspace(robot, grid, clearance=0.5)
    static = ws.static_feasible_workspace(robot, grid)
    both = feasible & clear
    np.testing.assert_array_equal(both.feasible, feasible.feasible & clear.feasible)
    assert both.extras["criteria"] == ("wrench_feasible", "interference_free")
    np.testing.assert_array_equal(both.quantity("interference_free_margin"), clear.margin)
    np.testing.assert_array_equal(both.margin, feasible.margin)
    three = both & static
    assert three.extras["criteria"] == ("wrench_feasible", "interference_free", "static")
    np.testing.assert_array_equal(three.feasible, both.feasible & static.feasible)
    assert ws.combine_workspaces(feasible, feasible).extras["criteria"] == (
        "wrench_feasible", "wrench_feasible_2")
    frame = three.to_frame()
    assert {"static_margin", "interference_free_feasible", "wrench_space_margin"} - set(
        frame.columns) == {"wrench_space_margin"}  # a part's extras stay with the part
    assert "wrench_space_margin" in feasible.to_frame()
    assert three.volume() <= min(feasible.volume(), clear.volume(), static.volume())
    status = np.asarray(three.status)
    assert (status[~three.feasible] != to.Status.OPTIMAL).all()
    ws.plot_slice(three, z=3.0, quantity="wrench_feasible_margin")


def test_new_criteria_run_in_chunks_on_every_executor():
    robot = to.presets.cogiro()
    rng = np.random.default_rng(4)
    poses = np.column_stack([rng.uniform(-7, 7, 300), rng.uniform(-5, 5, 300),
                             rng.uniform(0.2, 5, 300), rng.uniform(-0.2, 0.2, (300, 3))])
    box = WrenchPolytope.box([-50.0] * 6, [50.0] * 6)
    whole = to.wrench_feasible_workspace(robot, poses, wrench_set=box)
    parts = to.wrench_feasible_workspace(robot, poses, wrench_set=box, chunk_size=70,
                                         executor="processes:2")
    np.testing.assert_array_equal(parts.feasible, whole.feasible)
    np.testing.assert_array_equal(parts.extras["wrench_space_margin"],
                                  whole.extras["wrench_space_margin"])
    closure = to.wrench_closure_workspace(robot, poses)
    chunked = to.wrench_closure_workspace(robot, poses, chunk_size=64, executor="processes:2")
    np.testing.assert_array_equal(chunked.margin, closure.margin)
    np.testing.assert_array_equal(chunked.extras["rank"], closure.extras["rank"])
    assert 0.0 < (whole.extras["wrench_space_margin"] > 0).mean() < 1.0


# --------------------------------------------------------------------- bad input
@pytest.mark.parametrize("call,words", [
    (lambda r: to.wrench_feasible_workspace(r, [0, 0, 1], wrench_set=np.ones((2, 2))),
     "wrench_set"),
    (lambda r: to.wrench_feasible_workspace(r, [0, 0, 1], [0, 0, 1],
                                            wrench_set=[[0, 0, 1]]), "not both"),
    (lambda r: WrenchPolytope.from_inequalities(np.eye(3), np.ones(3)), "unbounded"),
    (lambda r: WrenchPolytope.from_inequalities(np.vstack([np.eye(3), -np.eye(3)]),
                                                -np.ones(6)), "empty"),
    (lambda r: WrenchPolytope.from_inequalities(np.eye(3), np.ones(2)), "h must"),
    (lambda r: WrenchPolytope.from_vertices([[0.0, np.nan]]), "vertices must be finite"),
    (lambda r: WrenchPolytope.box([1.0, 0.0], [0.0, 1.0]), "lower[0]"),
    (lambda r: to.wrench_feasible_workspace(r, [0, 0, 1], wrench_set=(
        np.vstack([np.eye(3), -np.eye(3)]), np.ones(5))), "wrench_set: h must"),
    (lambda r: to.wrench_feasible_workspace(r, [0, 0, 1], wrench_space=True), "t_max"),
    (lambda r: ws.wrench_space_margin(r, [0, 0, 1]), "t_max"),
    (lambda r: ws.orientation_workspace(r, [0, 0, 1], [0.0]), "robot: orientation"),
    (lambda r: ws.orientation_workspace(to.presets.kntu_planar(), [0, 0], [[0.0, 1.0]]),
     "orientations must have shape"),
    (lambda r: ws.total_orientation_workspace(to.presets.kntu_planar(), [[0, 0, 0]],
                                              [0.0]), "positions must have shape"),
    (lambda r: ws.orientation_workspace(to.presets.kntu_planar(), [0, 0], [0.0], "reach"),
     "criterion must be one of"),
    (lambda r: ws.combine_workspaces(), "results"),
    (lambda r: ws.combine_workspaces(ws.wrench_closure_workspace(r, [0, 0, 1]),
                                     ws.wrench_closure_workspace(r, [0, 0, 2])),
     "results[1] has other poses"),
])
def test_bad_input_names_the_argument(call, words):
    with pytest.raises(to.InvalidInputError) as info:
        call(to.presets.algae_harvester())
    assert words in str(info.value)


def test_numpy_and_compiled_facet_normals_agree(monkeypatch):
    from tension_opt.kernels import launch
    from tension_opt.workspace import hyperplane

    rng = np.random.default_rng(21)
    A = rng.normal(size=(50, 6, 9))
    A[:5, :, 1] = 2.0 * A[:5, :, 0]  # dependent pairs of columns
    subsets = np.array(list(itertools.combinations(range(9), 5)))
    ref, ind = hyperplane.subset_normals(A, subsets)
    got, ind_c = hyperplane.normals_of(A, subsets)  # compiled (COMPILED_MIN = 1 here)
    np.testing.assert_array_equal(ind, ind_c)
    assert (~ind).sum() == 5 * 35  # the subsets holding both columns 0 and 1
    np.testing.assert_allclose(np.abs((ref * got).sum(axis=2))[ind], 1.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(ref[~ind]), 0.0)
    robot, poses = to.presets.cogiro(), np.array([[1.0, -2.0, 2.0, 0.1, 0.0, -0.1],
                                                 [-5.0, 3.0, 4.0, 0.0, 0.2, 0.0]])
    box = WrenchPolytope.box([-40.0] * 6, [40.0] * 6)
    compiled = ws.wrench_space_margin(robot, poses, box)
    monkeypatch.setattr(launch, "COMPILED_MIN", 10**9)
    np.testing.assert_allclose(ws.wrench_space_margin(robot, poses, box), compiled,
                               rtol=1e-12)


def test_plots_draw_each_criterion_with_its_own_boundary_and_label():
    planar = planar_all_around(t_max=30.0)
    grid = ws.workspace_grid([-3.0, -3.0], [3.0, 3.0], counts=[25, 25])
    closure = ws.wrench_closure_workspace(planar, grid)
    # Outside, the ratio is 0, as on the boundary: the boundary follows `feasible`.
    np.testing.assert_array_equal(closure.boundary_values(), closure.feasible - 0.5)
    assert closure.label("margin") == "closure ratio (min T / max T)"
    held = to.wrench_feasible_workspace(planar, grid)
    np.testing.assert_array_equal(held.boundary_values(), held.margin)
    assert held.label("margin") == "capacity margin (N)"
    both = held & closure
    assert both.label("margin") == "capacity margin (N)"
    np.testing.assert_array_equal(both.boundary_values(), both.feasible - 0.5)
    for result in (closure, held, both, ws.static_feasible_workspace(planar, grid)):
        ax = ws.plot_slice(result)
        assert ax.get_title().startswith(result.label("margin"))
        assert len(ax.collections) >= 2  # the heat map and the boundary's contour
