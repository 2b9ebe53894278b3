"""Wrench-feasible workspace: analytic cases, closed form against LP, monotonicity,
executors, grids, volumes and plots."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

import tension_opt as to
from tension_opt import workspace as ws
from tension_opt.robot import CableRobot

matplotlib.use("Agg")

G = 9.81


def two_cable(a: float = 2.0, h: float = 3.0, mass: float = 10.0, t_max: float = 400.0,
              t_min: float = 0.0) -> CableRobot:
    """Point mass in the xz plane hanging from (-a, h) and (a, h)."""
    return CableRobot(anchors=np.array([[-a, 0.0, h], [a, 0.0, h]]),
                      attachments=np.zeros((2, 3)), mass=mass, kind="planar_point2",
                      t_min=t_min, t_max=t_max)


def two_cable_tensions(x, z, a=2.0, h=3.0, mass=10.0):
    """By hand: tau_i = T_i / L_i from the two balance equations,
    tau_1 (a + x) = tau_2 (a - x) and (tau_1 + tau_2)(h - z) = m g."""
    d = h - z
    L1, L2 = np.hypot(a + x, d), np.hypot(a - x, d)
    T1 = mass * G * (a - x) * L1 / (2 * a * d)
    T2 = mass * G * (a + x) * L2 / (2 * a * d)
    return np.stack([T1, T2], axis=-1)


def test_two_cable_robot_margin_and_boundary_by_hand():
    a, h, mass, t_max = 2.0, 3.0, 10.0, 400.0
    robot = two_cable(a, h, mass, t_max)
    # On the symmetry line T = m g / (2 sin theta) <= t_max  <=>  h - z >= delta*.
    delta = mass * G * a / np.sqrt(4 * t_max**2 - (mass * G) ** 2)
    z_star = h - delta
    assert z_star == pytest.approx(2.752885, abs=1e-6)
    z = np.linspace(0.0, 2.99, 600)
    res = ws.wrench_feasible_workspace(robot, np.column_stack([np.zeros_like(z), z]))
    T = mass * G * np.hypot(a, h - z) / (2 * (h - z))
    np.testing.assert_allclose(res.margin, np.minimum(T, t_max - T), rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(res.feasible, z <= z_star)
    np.testing.assert_allclose(res.tensions[res.feasible], np.column_stack([T, T])[res.feasible],
                               rtol=1e-12)
    # Exactly on the boundary the margin is zero and the pose counts as feasible.
    edge = ws.capacity_margin(robot, [0.0, z_star])
    assert edge[0] == pytest.approx(0.0, abs=1e-9 * t_max)
    assert ws.wrench_feasible_workspace(robot, [0.0, z_star]).feasible[0]
    # Off the symmetry line: the unique tensions, both bounds.
    grid = ws.workspace_grid([-2.5, -1.0], [2.5, 2.9], counts=[41, 40])
    res = ws.wrench_feasible_workspace(robot.with_(t_min=20.0), grid)
    T = two_cable_tensions(grid.poses[:, 0], grid.poses[:, 1], a, h, mass)
    expected = np.minimum(T - 20.0, t_max - T).min(axis=1)
    np.testing.assert_allclose(res.margin, expected, rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(res.feasible, expected >= 0)
    assert 0.2 < res.fraction() < 0.8  # both sides of the boundary are sampled
    # A set of wrenches: feasible only where both are held; margin the smaller one.
    push = np.array([[0.0, 0.0], [15.0, 0.0]])
    both = ws.wrench_feasible_workspace(robot, grid, push)
    m0 = ws.capacity_margin(robot, grid.poses)
    m1 = ws.capacity_margin(robot, grid.poses, wrench=push[1])
    np.testing.assert_allclose(both.margin, np.minimum(m0, m1), rtol=1e-12)
    np.testing.assert_array_equal(both.critical_wrench, np.where(m1 < m0, 1, 0))
    # (t_min = 0: below an anchor a tension is zero, the margin zero up to rounding.)
    np.testing.assert_array_equal(both.feasible, np.minimum(m0, m1) >= -1e-9 * robot.weight)


def test_thesis_robot_on_the_vertical_axis_by_hand(thesis):
    # At (0, 0, z) the four cables are alike: the pseudo-inverse gives T_c = m g L / (4 (h - z))
    # each, and the null vector (1, -1, 1, -1) lowers two as it raises the others, so the
    # largest smallest tension is T_c: margin = min(T_c - t_min, t_max - T_c).
    z = np.array([0.0, 1.0, 2.5, 5.0, 7.0])
    hx, hy, h = 80.9 / 2 + 6.1, 50 / 2 + 6.1, 7.6
    Tc = thesis.weight * np.sqrt(hx**2 + hy**2 + (h - z) ** 2) / (4 * (h - z))
    assert Tc[0] == pytest.approx(4714.6, abs=0.1)  # the study's snapshot 1
    poses = np.column_stack([np.zeros(5), np.zeros(5), z])
    np.testing.assert_allclose(ws.capacity_margin(thesis, poses), Tc - thesis.t_min[0],
                               rtol=1e-12)
    capped = thesis.with_(t_max=10_000.0)
    np.testing.assert_allclose(ws.capacity_margin(capped, poses),
                               np.minimum(Tc - 2536.866, 10_000.0 - Tc), rtol=1e-12)


def test_closed_form_agrees_with_lp_on_ten_thousand_study_poses(thesis):
    rng = np.random.default_rng(7)
    N = 10_000
    poses = np.column_stack([rng.uniform(-46.5, 46.5, N), rng.uniform(-31, 31, N),
                             rng.uniform(0, 7.5, N)])
    robot = thesis.with_(t_max=12_000.0)
    exact = ws.wrench_feasible_workspace(robot, poses)
    lp = ws.wrench_feasible_workspace(robot, poses, backend="qpsolvers:daqp")
    assert exact.backend == "closed_form" and lp.backend == "qpsolvers:daqp"
    scale = np.maximum(np.abs(exact.margin), thesis.weight)
    assert np.all(np.abs(exact.margin - lp.margin) <= 1e-6 * scale)
    differ = exact.feasible != lp.feasible
    assert np.all(np.abs(exact.margin[differ]) <= 1e-6 * thesis.weight)
    assert 0.3 < exact.fraction() < 0.9
    # The infeasibility distance of the closed-form distribution is minus the margin.
    sol = to.distribute(robot, poses[~exact.feasible], "min_sum")
    np.testing.assert_allclose(sol.infeasibility, -exact.margin[~exact.feasible], rtol=1e-9)
    # Min-sum tensions where feasible are those of distribute.
    ref = to.distribute(robot, poses[exact.feasible], "min_sum")
    np.testing.assert_allclose(exact.tensions[exact.feasible], ref.tensions, rtol=1e-12)
    # HiGHS on a subset, to a tighter tolerance.
    highs = ws.capacity_margin(robot, poses[:300], backend="scipy:highs")
    np.testing.assert_allclose(highs, exact.margin[:300], rtol=1e-8, atol=1e-7 * robot.weight)


def test_two_dimensional_null_space_agrees_with_lp():
    robot = to.presets.cogiro()  # 8 cables, 6 DOF, finite t_max
    rng = np.random.default_rng(3)
    N = 600
    poses = np.column_stack([rng.uniform(-7, 7, N), rng.uniform(-5, 5, N),
                             rng.uniform(0.2, 5, N), rng.uniform(-0.2, 0.2, (N, 3))])
    exact = ws.capacity_margin(robot, poses)
    lp = ws.capacity_margin(robot, poses, backend="scipy:highs")
    np.testing.assert_allclose(exact, lp, rtol=1e-8, atol=1e-7 * robot.weight)
    assert (exact > 0).any() and (exact < 0).any()
    # No margin exceeds half the bound range.
    assert exact.max() <= (5000 - 100) / 2 + 1e-9


def test_unbounded_and_singular_margins():
    # A point in the plane pulled by three cables around it (no gravity, no t_max): a
    # strictly positive null vector lets every tension grow without bound.
    ang = np.deg2rad([90.0, 210.0, 330.0])
    star = CableRobot(anchors=np.column_stack([np.cos(ang), np.zeros(3), np.sin(ang)]),
                      attachments=np.zeros((3, 3)), mass=1.0, kind="planar_point2", g=0.0,
                      t_min=1.0)
    pose = [[0.1, -0.05]]
    assert ws.capacity_margin(star, pose)[0] == np.inf
    assert ws.capacity_margin(star, pose, backend="scipy:highs")[0] == np.inf
    # With t_max = 7 N: at the centre all three can sit at 4 N, margin (7 - 1) / 2.
    capped = star.with_(t_max=7.0)
    assert ws.capacity_margin(capped, [0.0, 0.0])[0] == pytest.approx(3.0, rel=1e-12)
    off = ws.capacity_margin(capped, pose)[0]
    assert 0 < off < 3.0
    assert off == pytest.approx(ws.capacity_margin(capped, pose, backend="scipy:highs")[0],
                                rel=1e-8)
    # At the height of the tower tops no tension holds the weight: margin -inf, and the
    # batch goes on.
    thesis = to.presets.algae_harvester()
    res = ws.wrench_feasible_workspace(thesis, [[0.0, 0.0, 7.6], [0.0, 0.0, 1.0]])
    assert res.margin[0] == -np.inf and not res.feasible[0]
    assert str(res.status[0]) == "infeasible" and np.isnan(res.tensions[0]).all()
    assert res.feasible[1] and str(res.status[1]) == "optimal"


def test_raising_t_max_or_lowering_t_min_never_shrinks_the_workspace(thesis):
    poses = ws.sample_poses([-46.5, -31, 0], [46.5, 31, 7.5], 4000, seed=11)
    previous = None
    for t_max in (4000.0, 6000.0, 10_000.0, 30_000.0, np.inf):
        res = ws.wrench_feasible_workspace(thesis.with_(t_max=t_max), poses)
        if previous is not None:
            assert np.all(previous.feasible <= res.feasible)
            assert np.all(res.margin >= previous.margin - 1e-9 * thesis.weight)
            assert res.fraction() >= previous.fraction()
        previous = res
    assert previous is not None and previous.fraction() > 0.6
    previous = None
    for t_min in (3000.0, 2536.866, 1500.0, 500.0, 0.0):
        res = ws.wrench_feasible_workspace(thesis.with_(t_min=t_min), poses)
        if previous is not None:
            assert np.all(previous.feasible <= res.feasible)
            assert np.all(res.margin >= previous.margin - 1e-9 * thesis.weight)
        previous = res


def _same(a: ws.WorkspaceResult, b: ws.WorkspaceResult) -> None:
    for name in ("feasible", "margin", "tensions", "margins", "critical_wrench"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert [str(s) for s in a.status] == [str(s) for s in b.status]


def test_same_result_in_process_with_processes_and_on_dask(thesis):
    grid = ws.workspace_grid([-46.55, -31.1, 0.0], [46.55, 31.1, 7.6], spacing=[3, 3, 1.2])
    wrenches = np.array([[0.0, 0.0, 0.0], [300.0, 0.0, 0.0]])
    kwargs = {"chunk_size": 1000}
    here = ws.wrench_feasible_workspace(thesis, grid, wrenches, **kwargs)
    assert len(grid.poses) > 3000
    pool = ws.wrench_feasible_workspace(thesis, grid, wrenches, executor="processes:2",
                                        **kwargs)
    _same(here, pool)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dask = ws.wrench_feasible_workspace(thesis, grid, wrenches, executor=client, **kwargs)
    _same(here, dask)
    assert here.volume() == dask.volume()


def test_grid_helper_and_volume():
    grid = ws.workspace_grid([-1.0, 0.0, 2.0], [1.0, 3.0, 2.0], spacing=[0.5, 0.7, 0.1])
    assert grid.shape == (4, 5, 1)
    np.testing.assert_allclose(grid.axes[0], [-0.75, -0.25, 0.25, 0.75])
    np.testing.assert_allclose(grid.axes[1], 0.6 * np.arange(5) + 0.3)  # 5 cells of 0.6
    assert grid.poses.shape == (20, 3)
    np.testing.assert_array_equal(grid.poses.reshape(4, 5, 1, 3)[2, 3, 0], [0.25, 2.1, 2.0])
    counts = ws.workspace_grid([0, 0], [1, 2], counts=[3, 5])
    np.testing.assert_allclose(counts.axes[1], [0, 0.5, 1, 1.5, 2])
    with pytest.raises(to.InvalidInputError):
        ws.workspace_grid([0, 0], [1, 1])
    # The cells of a spacing grid tile the box: an everywhere-feasible robot fills it.
    thesis = to.presets.algae_harvester(t_min=0.0)
    box = ([-10.0, -8.0, 0.0], [10.0, 8.0, 6.0])
    res = ws.wrench_feasible_workspace(thesis, ws.workspace_grid(*box, spacing=[1.3, 1.1, 0.7]))
    assert res.feasible.all()
    assert res.volume() == pytest.approx(20 * 16 * 6, rel=1e-12)
    samples = ws.wrench_feasible_workspace(to.presets.algae_harvester(),
                                           ws.sample_poses(*box, 500, seed=1), bounds=box)
    assert samples.volume() == pytest.approx(samples.fraction() * 1920.0)
    frame = samples.to_frame()
    assert list(frame.columns[:6]) == ["x", "y", "z", "feasible", "margin", "status"]
    assert list(frame.columns[6:]) == ["T1", "T2", "T3", "T4"]
    assert frame["feasible"].sum() == samples.feasible.sum()


def test_plots_have_labels_units_and_anchors(thesis):
    import matplotlib.pyplot as plt

    grid = ws.workspace_grid([-46.55, -31.1, 0.0], [46.55, 31.1, 7.6], spacing=[3, 3, 1.9])
    res = ws.wrench_feasible_workspace(thesis.with_(t_max=10_000.0), grid)
    ax = ws.plot_slice(res, z=2.0, quantity="margin")
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    assert "z = 2.85 m" in ax.get_title()  # nearest layer of 0.95, 2.85, ...
    assert ax.figure.axes[-1].get_ylabel() == "capacity margin (N)"
    anchors = [c for c in ax.collections if c.get_label() == "drawing points"]
    np.testing.assert_allclose(anchors[0].get_offsets(), thesis.anchors[:, :2])
    plt.close("all")
    ax = ws.plot_slice(res, z=0.0, quantity="feasible")
    plt.close("all")
    cogiro = to.presets.cogiro()
    box = ws.workspace_grid([-6, -4, 0.5, 0, 0, 0], [6, 4, 4.5, 0, 0, 0], spacing=1.0)
    res3 = ws.wrench_feasible_workspace(cogiro, box)
    assert res3.grid_shape == (12, 8, 4, 1, 1, 1)
    assert res3.volume() == pytest.approx(res3.feasible.sum() * 1.0)
    ax3 = ws.plot_workspace_3d(res3)
    assert ax3.get_zlabel() == "z (m)"
    plt.close("all")


def test_volume_of_spacing_and_counts_grids_is_the_box():
    thesis = to.presets.algae_harvester(t_min=0.0)
    lo, hi = [-10.0, -10.0, 0.0], [10.0, 10.0, 2.0]
    for kw in ({"spacing": 1.0}, {"counts": (21, 21, 3)}, {"counts": (5, 5, 2)},
               {"spacing": [5.0, 5.0, 2.0]}):  # the last: one cell along z
        grid = ws.workspace_grid(lo, hi, **kw)
        np.testing.assert_array_equal(grid.lower, lo)
        np.testing.assert_array_equal(grid.upper, hi)
        res = ws.wrench_feasible_workspace(thesis, grid)
        assert res.feasible.all()
        assert res.volume() == pytest.approx(800.0, rel=1e-12), kw
        # The result's bounds are the box, not the outer cell centres.
        np.testing.assert_array_equal(res.bounds[0], lo)
        np.testing.assert_array_equal(res.bounds[1], hi)
    np.testing.assert_allclose(ws.cell_widths([0.0, 0.5, 1.0], 0.0, 1.0), [0.25, 0.5, 0.25])
    np.testing.assert_allclose(ws.cell_widths([0.25, 0.75], 0.0, 1.0), [0.5, 0.5])
    np.testing.assert_allclose(ws.cell_widths([2.0], 1.0, 3.0), [2.0])
    # A Grid built the old way (no box): the outer cells reach half a gap beyond.
    grid = ws.workspace_grid(lo, hi, spacing=1.0)
    old = ws.Grid(grid.poses, grid.shape, grid.axes)
    res = ws.wrench_feasible_workspace(thesis, old)
    assert res.volume() == pytest.approx(800.0, rel=1e-12)  # cell centres: same box


def test_counts_and_spacing_grids_agree_on_the_study_workspace(thesis):
    robot = thesis.with_(t_max=10_000.0)
    box = ([-46.55, -31.1, 0.0], [46.55, 31.1, 7.6])
    fine = ws.wrench_feasible_workspace(robot, ws.workspace_grid(*box, spacing=0.5))
    counts = ws.wrench_feasible_workspace(robot, ws.workspace_grid(*box, counts=(94, 63, 16)))
    assert 0.05 < fine.fraction() < 0.95  # a real boundary inside the box
    assert counts.volume() == pytest.approx(fine.volume(), rel=0.03)


def test_bounds_are_validated(thesis):
    P = ws.sample_poses([-10, -10, 0], [10, 10, 2], 20, seed=0)
    bad = [([10, 10, 2], [-10, -10, 0]),        # reversed
           ([np.nan, -10, 0], [10, 10, 2]),     # not finite
           ([0, 0], [1, 1]),                    # wrong length
           ([0, 0, 0],)]                        # not a pair
    for bounds in bad:
        with pytest.raises(to.InvalidInputError, match="bounds"):
            ws.wrench_feasible_workspace(thesis, P, bounds=bounds)
    grid = ws.workspace_grid([-10, -10, 0], [10, 10, 2], spacing=2.0)
    with pytest.raises(to.InvalidInputError, match="contain the grid"):
        ws.wrench_feasible_workspace(thesis, grid, bounds=([0, 0, 0], [10, 10, 2]))


def test_no_poses_give_an_empty_result(thesis):
    res = ws.wrench_feasible_workspace(thesis, np.zeros((0, 3)), [[0, 0, 0], [100, 0, 0]])
    assert res.N == 0 and res.fraction() == 0.0
    assert res.margins.shape == (0, 2) and res.tensions.shape == (0, 4)
    assert res.to_frame().shape[0] == 0


def test_a_pose_on_a_drawing_point_does_not_abort_the_batch(thesis):
    P = np.array([[0.0, 0.0, 2.0], thesis.anchors[2], [10.0, 5.0, 1.0]])
    with pytest.raises(to.InvalidInputError):  # the robot itself refuses the pose
        thesis.structure_matrices(P)
    np.testing.assert_array_equal(ws.on_drawing_point(thesis, P), [False, True, False])
    res = ws.wrench_feasible_workspace(thesis, P, [[0, 0, 0], [100, 0, 0]], chunk_size=2)
    alone = ws.wrench_feasible_workspace(thesis, P[[0, 2]], [[0, 0, 0], [100, 0, 0]])
    assert not res.feasible[1] and res.margin[1] == -np.inf
    assert np.isnan(res.tensions[1]).all() and res.status[1] == to.Status.INFEASIBLE
    np.testing.assert_allclose(res.margins[[0, 2]], alone.margins, rtol=1e-12)
    np.testing.assert_allclose(res.tensions[[0, 2]], alone.tensions, rtol=1e-12)
    # The corners of a counts grid over the pond box are the drawing points.
    grid = ws.workspace_grid([-46.55, -31.1, 0], [46.55, 31.1, 7.6], counts=(5, 5, 3))
    res = ws.wrench_feasible_workspace(thesis, grid)
    assert ws.on_drawing_point(thesis, grid.poses).sum() == 4
    assert (res.margin[ws.on_drawing_point(thesis, grid.poses)] == -np.inf).all()
    assert 0 < res.fraction() < 1


def test_grid_and_sample_input_checks():
    box = ([0, 0, 0], [1, 1, 1])
    for kw in ({"counts": [2, 2]}, {"spacing": [0.5, 0.5]}, {"counts": 2.5},
               {"counts": np.nan}, {"counts": 0}, {"spacing": 0.0}, {"spacing": np.inf}):
        with pytest.raises(to.InvalidInputError):
            ws.workspace_grid(*box, **kw)
    with pytest.raises(to.InvalidInputError, match="1e\\+12 points"):
        ws.workspace_grid(*box, spacing=1e-4)
    with pytest.raises(to.InvalidInputError, match="points"):
        ws.workspace_grid(*box, counts=[1000, 1000, 1000])
    for lower, count in (([np.nan], 3), ([0.0], 2.5), ([0.0], 0), ([0.0], "3"), ([2.0], 3),
                         ([0.0], 10**12)):  # 10^12 poses: no MemoryError
        with pytest.raises(to.InvalidInputError):
            ws.sample_poses(lower, [1.0], count)
    assert ws.sample_poses([0.0], [1.0], 3.0).shape == (3, 1)
    # Text, complex and ragged input: the package's error naming the argument.
    for corner, name in (([0.0, 0.0, 1j], "lower"), ("abc", "lower")):
        with pytest.raises(to.InvalidInputError, match=name):
            ws.workspace_grid(corner, [1.0, 1.0, 1.0], counts=3)
    robot = to.presets.algae_harvester()
    for wrenches in ("abc", [0.0, 0.0, 1j], [[0.0, 0.0, 0.0], [0.0, 0.0]]):
        with pytest.raises(to.InvalidInputError, match="wrenches"):
            ws.wrench_feasible_workspace(robot, robot.default_home()[None], wrenches=wrenches)
    for size in (2.5, "a", 0, True):
        with pytest.raises(to.InvalidInputError, match="chunk_size must be a whole number"):
            ws.wrench_feasible_workspace(robot, robot.default_home()[None], chunk_size=size)


def test_vertical_slice_is_drawn_in_y_and_z(thesis):
    import matplotlib.pyplot as plt

    grid = ws.workspace_grid([0, -30, 0], [0, 30, 7], spacing=1.0)
    res = ws.wrench_feasible_workspace(thesis.with_(t_max=10_000.0), grid)
    ax = ws.plot_slice(res)
    assert ax.get_xlabel() == "y (m)" and ax.get_ylabel() == "z (m)"
    assert "x = 0 m" in ax.get_title()
    anchors = [c for c in ax.collections if c.get_label() == "drawing points"]
    np.testing.assert_allclose(anchors[0].get_offsets(), thesis.anchors[:, 1:])
    plt.close("all")
    line = ws.wrench_feasible_workspace(thesis, ws.workspace_grid([0, -30, 2], [0, 30, 2],
                                                                  spacing=1.0))
    with pytest.raises(to.InvalidInputError, match="two position coordinates"):
        ws.plot_slice(line)


def test_a_grid_takes_the_memory_of_its_poses() -> None:
    """The poses of ``numpy.meshgrid(..., indexing="ij")`` in the same order, written in
    place: the peak is the poses (the mesh and its stack took twice as much)."""
    import tracemalloc

    for counts in ([4, 1, 6], [3, 4, 5, 2, 1, 3]):
        n = len(counts)
        upper = np.where(np.array(counts) > 1, 1.0, 0.0)
        g = ws.workspace_grid(np.zeros(n), upper, counts=counts)
        mesh = np.meshgrid(*g.axes, indexing="ij")
        np.testing.assert_array_equal(g.poses, np.stack([m.ravel() for m in mesh], axis=1))
    tracemalloc.start()
    try:
        g = ws.workspace_grid(np.zeros(6), np.ones(6), counts=10)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert g.poses.shape == (10**6, 6)
    assert peak < 1.05 * g.poses.nbytes, peak / g.poses.nbytes
