"""Time-optimal timing under tension limits (against toppra), the wrench facets and the
dynamic workspace."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from benchmarks.scenarios import cogiro_path, pick_and_place
from tension_opt import dynamics as dyn
from tension_opt.dynamics import lp as lp_module
from tension_opt.dynamics import timing_rounds
from tension_opt.dynamics.intervals import PathModel, grid_checks
from tension_opt.dynamics.path import PathSpline
from tension_opt.dynamics.reachability import reachability
from tension_opt.dynamics.timing_convex import convex_timing

#: The study robot with a finite upper bound: with t_max = inf nothing limits a lift.
STUDY_T_MAX = 15_000.0


@pytest.fixture(scope="module")
def study() -> tuple[to.CableRobot, np.ndarray]:
    return to.presets.algae_harvester(t_max=STUDY_T_MAX), pick_and_place()


@pytest.fixture(scope="module")
def cogiro() -> tuple[to.CableRobot, np.ndarray]:
    return to.presets.cogiro(), cogiro_path(to.presets.cogiro())


def _toppra_duration(robot: to.CableRobot, path: np.ndarray, grid: np.ndarray) -> float:
    """toppra on the same spline and grid, the wrench-feasible set as its linear
    second-order constraint ``F w <= g`` (hyperplane-shifting facets), each interval
    constrained at both ends (its interpolation scheme)."""
    toppra = pytest.importorskip("toppra")
    import toppra.algorithm as algo
    import toppra.constraint as tc

    spline = PathSpline.through(robot, path)
    big = 1e3 * float(np.abs(robot.t_max[np.isfinite(robot.t_max)]).max(initial=1e4))

    def facets(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        H, h = dyn.wrench_facets(robot, q[None])
        return H[0], np.where(np.isfinite(h[0]), h[0], big)

    constraint = tc.SecondOrderConstraint(
        lambda q, qd, qdd: dyn.required_wrench(robot, q, qd, qdd, rates="pose")[0],
        lambda q: facets(q)[0], lambda q: facets(q)[1], robot.dof,
        discretization_scheme=tc.DiscretizationType.Interpolation)
    instance = algo.TOPPRA([constraint], toppra.SplineInterpolator(spline.s, spline.poses),
                           gridpoints=grid, solver_wrapper="seidel")
    _, sd, _ = instance.compute_parameterization(0, 0)
    assert sd is not None and np.isfinite(sd).all()
    return float(np.sum(2 * np.diff(grid) / (sd[:-1] + sd[1:])))


def _duration(grid: np.ndarray, x: np.ndarray) -> float:
    sd = np.sqrt(np.maximum(x, 0.0))
    return float(np.sum(2 * np.diff(grid) / (sd[:-1] + sd[1:])))


@pytest.mark.parametrize("case", ["study", "cogiro"])
def test_time_optimal_matches_toppra(case: str, request) -> None:
    robot, path = request.getfixturevalue(case)
    spline = PathSpline.through(robot, path)
    grid = np.linspace(0.0, spline.length, 400)
    reference = _toppra_duration(robot, path, grid)
    # Both ends of every interval checked, as toppra's interpolation scheme does.
    checks = grid_checks(PathModel.build(robot, spline, grid))
    inf = np.full(robot.dof, np.inf)
    x, _, _, outcome, fail, _ = reachability(checks, inf, inf, 1e-6)
    assert outcome == "optimal" and fail is None
    # The same greedy scheme as toppra: the same timing.
    assert _duration(grid, x) == pytest.approx(reference, rel=1e-4)
    # The convex program is the global optimum of the same discretisation.
    x_convex, _, outcome = convex_timing(checks, inf, inf, 1e-6)
    assert outcome == "optimal"
    assert _duration(grid, x_convex) == pytest.approx(reference, rel=1e-2)
    assert _duration(grid, x_convex) <= _duration(grid, x) * (1 + 1e-6)
    # The timing itself also checks the spline's knots and points inside the intervals.
    convex = dyn.time_optimal(robot, path, gridpoints=grid)
    reach = dyn.time_optimal(robot, path, gridpoints=grid, method="reachability")
    assert convex.success and reach.success
    assert convex.duration <= reach.duration * (1 + 1e-6)
    assert reference * (1 - 1e-4) <= reach.duration <= reference * 1.02
    assert convex.times[-1] == convex.duration and (np.diff(convex.times) > 0).all()


def _margins_at(robot: to.CableRobot, result: dyn.TimingResult, x: np.ndarray,
                u: np.ndarray, own: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Capacity margins (N) of a profile ``x = s'^2``, ``u = s''`` (``u_k`` kept from grid
    point k to the next) at the points ``at`` of the intervals ``own``, through the path
    spline's own derivatives and the Newton-Euler wrench."""
    spline, s = result.extras["path"], result.s
    xs = np.maximum(x[own] + 2 * (at - s[own]) * u[own], 0.0)
    q, dq, ddq = spline(at), spline(at, 1), spline(at, 2)
    vel = dq * np.sqrt(xs)[:, None]
    acc = dq * u[own][:, None] + ddq * xs[:, None]
    W = dyn.required_wrench(robot, q, vel, acc, rates="pose")
    return to.capacity_margin(robot, q, wrench=robot.required_wrench(q) - W)


def _profile_margins(robot: to.CableRobot, result: dyn.TimingResult, x: np.ndarray,
                     u: np.ndarray, per: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_margins_at` the grid points (K,) and at ``per`` evenly spaced points of
    every interval, its end included (K - 1, per)."""
    s = result.s
    t = np.arange(1, per + 1) / per
    own = np.concatenate([np.arange(len(s)), np.repeat(np.arange(len(s) - 1), per)])
    at = np.concatenate([s, (s[:-1, None] + np.diff(s)[:, None] * t).ravel()])
    margin = _margins_at(robot, result, x, u, own, at)
    return margin[:len(s)], margin[len(s):].reshape(len(s) - 1, per)


@pytest.mark.parametrize("case", ["study", "cogiro"])
@pytest.mark.parametrize("method", ["convex", "reachability"])
def test_one_percent_faster_anywhere_is_infeasible(case: str, method: str, request) -> None:
    robot, path = request.getfixturevalue(case)
    res = dyn.time_optimal(robot, path, method=method)
    assert res.success
    x, u = res.sd**2, res.sdd
    typical = float(np.abs(robot.required_wrench(res.poses)).max())
    at_grid, between = _profile_margins(robot, res, x, u)
    assert at_grid.min() >= -1e-6 * typical
    assert between.min() >= -1e-4 * typical
    checks = res.extras["checks"]
    ds = np.diff(res.s)
    # (The greedy reachability pass can bring the platform to rest inside the path,
    # where a faster speed is still zero: those points are skipped.)
    for k in np.flatnonzero(res.sd[1:-1] > 1e-6 * res.sd.max()) + 1:
        xk = x.copy()
        xk[k] *= 1.01**2
        uk = u.copy()
        uk[k - 1] = (xk[k] - xk[k - 1]) / (2 * ds[k - 1])
        uk[k] = (xk[k + 1] - xk[k]) / (2 * ds[k])
        # Where the timing checked the two intervals through point k.
        mine = (checks.owner == k - 1) | (checks.owner == k)
        margins = _margins_at(robot, res, xk, uk, checks.owner[mine],
                              res.s[checks.owner[mine]] + checks.offset[mine])
        assert margins.min() < -1e-4 * typical, k


@pytest.mark.parametrize("case", ["study", "cogiro"])
@pytest.mark.parametrize("method", ["convex", "reachability"])
def test_the_timing_holds_between_grid_points(case: str, method: str, request) -> None:
    """With ``s''`` constant from one grid point to the next, the wrench between them
    must be held too. Checked at the grid points only, the study path's timing on 200
    points needed -11.7 kN of capacity margin (-78 % of t_max) at the end of its first
    interval (s = 0.06 m), CoGiRo's loop -103 N (s = 8.56 m), while every grid point
    had a margin >= 0."""
    robot, path = request.getfixturevalue(case)
    res = dyn.time_optimal(robot, path, gridpoints=200, method=method)
    typical = float(np.abs(robot.required_wrench(res.poses)).max())
    at_grid, between = _profile_margins(robot, res, res.sd**2, res.sdd)
    assert at_grid.min() >= -1e-6 * typical
    # 20 points an interval, not those the timing checked: within 1e-4 of a tension.
    assert between.min() >= -1e-4 * typical, res.s[np.argmin(between.min(axis=1))]
    assert res.success and (res.status == to.Status.OPTIMAL).all()
    assert res.margin_between.shape == (199,)
    # Within the feasibility tolerance of the tension scale there.
    assert res.min_margin_between >= -1e-6 * float(robot.t_max.max())
    k = int(np.nanargmin(res.margin_between))
    assert res.s[k] < res.min_margin_between_at <= res.s[k + 1]
    # The reported figure is the margin of the motion there.
    t = (res.min_margin_between_at - res.s[k]) / (res.s[k + 1] - res.s[k])
    spline = res.extras["path"]
    at = np.array([res.min_margin_between_at])
    xs = res.sd[k] ** 2 + 2 * (at - res.s[k]) * res.sdd[k]
    W = dyn.required_wrench(robot, spline(at), spline(at, 1) * np.sqrt(xs)[:, None],
                            spline(at, 1) * res.sdd[k] + spline(at, 2) * xs[:, None],
                            rates="pose")
    q = spline(at)
    assert 0 < t <= 1
    assert to.capacity_margin(robot, q, wrench=robot.required_wrench(q) - W)[0] == (
        pytest.approx(res.min_margin_between, rel=1e-6, abs=1e-6 * typical))


def test_a_timing_outside_the_tensions_between_grid_points_is_inaccurate(
        study, monkeypatch) -> None:
    """Without the rounds of checks inside the intervals, the timing of the study path
    on 200 points (its grid points, the ends of its intervals and the spline's knots
    checked) needs about -70 N of margin between grid points: its figures are kept,
    as inaccurate, not optimal."""
    robot, path = study
    monkeypatch.setattr(timing_rounds, "BETWEEN_ROUNDS", 0)
    res = dyn.time_optimal(robot, path, gridpoints=200)
    assert not res.success and np.isfinite(res.duration)
    assert res.min_margin_between < -10.0
    assert set(res.status) == {to.Status.OPTIMAL, to.Status.INACCURATE}
    bad = res.margin_between < -1.0
    assert (res.status[:-1][bad] == to.Status.INACCURATE).all()
    assert np.isfinite(res.tensions).all()


@pytest.mark.parametrize("case", ["study", "cogiro"])
@pytest.mark.parametrize("method", ["convex", "reachability"])
@pytest.mark.parametrize("factor", [1e-6, 1e3])
def test_scaling_mass_and_bounds_together_leaves_the_timing_unchanged(
        case: str, method: str, factor: float, request) -> None:
    """Mass, inertia, tension bounds and external wrench times ``factor``: the same
    motion, the same timing. The tension slack was relative to the static wrench
    floored at 1 N, so a light robot (tensions of millinewtons at 1e-6) kept a slack of
    1e-6 N, far more than its 1e-6 of a tension: 9e-5 slower on the study path, 1.7e-3
    on CoGiRo's loop."""
    robot, path = request.getfixturevalue(case)
    wrench = np.array([30.0, -20.0, 10.0, 1.0, -2.0, 3.0])[:robot.dof]
    reference = dyn.time_optimal(robot, path, gridpoints=50, method=method, wrench=wrench)
    scaled = robot.with_(mass=robot.mass * factor, inertia=np.asarray(robot.inertia) * factor,
                         t_min=robot.t_min * factor, t_max=robot.t_max * factor)
    res = dyn.time_optimal(scaled, path, gridpoints=50, method=method, wrench=wrench * factor)
    assert reference.success and res.success
    assert res.duration == pytest.approx(reference.duration, rel=1e-6)
    # On the boundary both, to the feasibility tolerance of the tension scale.
    scale = float(robot.t_max.max())
    assert res.min_margin_between == pytest.approx(factor * reference.min_margin_between,
                                                   abs=1e-6 * factor * scale)


@pytest.mark.parametrize("method", ["convex", "reachability"])
def test_a_timing_that_runs_out_of_time_says_so(study, method: str) -> None:
    """``time_limit`` bounds the whole call: on 3000 grid points a limit of 0.05 s stops
    it, every point ``max_iter``, no figures of a timing cut short. (The limit went to
    the tension backend alone, and the call ran to the end: 51 s convex, 36 s
    reachability, before the compiled passes.)"""
    robot, path = study
    res = dyn.time_optimal(robot, path, gridpoints=3000, method=method, time_limit=0.05)
    assert res.solve_time < 0.05 + 0.5
    assert not res.success and (res.status == to.Status.MAX_ITER).all()
    assert res.duration == np.inf and np.isnan(res.times).all()
    assert res.extras["stopped"] == "time_limit"
    # A limit it keeps changes nothing.
    free = dyn.time_optimal(robot, path, gridpoints=50, method=method)
    timed = dyn.time_optimal(robot, path, gridpoints=50, method=method, time_limit=60.0)
    assert timed.success and timed.duration == free.duration
    for bad in (0.0, -1.0, np.nan, "1"):
        with pytest.raises(to.InvalidInputError, match="time_limit"):
            dyn.time_optimal(robot, path, time_limit=bad)


def test_limits_bind_and_are_reported(study) -> None:
    robot, path = study
    res = dyn.time_optimal(robot, path, v_max=2.0, a_max=1.0)
    assert res.success
    assert np.abs(res.velocities).max() <= 2.0 * (1 + 1e-6)
    assert np.abs(res.accelerations).max() <= 1.0 * (1 + 1e-6)
    assert res.active_velocity.any() and res.active_acceleration.any()
    free = dyn.time_optimal(robot, path)
    assert free.duration < res.duration
    # The tension limits bind along most of it: in most intervals, at a grid point or
    # between.
    typical = float(np.abs(robot.required_wrench(path)).max())
    binds = free.active_tension[:-1] | (free.margin_between <= 1e-5 * typical)
    assert binds.mean() > 0.5
    assert (free.active_cables.sum(axis=1)[free.active_tension] >= 1).all()
    T, lb, ub = free.tensions, robot.t_min, robot.t_max
    assert ((T >= lb - 1e-6 * ub) & (T <= ub * (1 + 1e-9))).all()
    frame = free.to_frame()
    assert set(frame["limit"]) <= {"", "tension"}
    traj = free.trajectory
    assert traj.duration == pytest.approx(free.duration)


def test_highs_through_scipy_gives_the_same_timing(cogiro, monkeypatch) -> None:
    """The LPs over the tensions (the reference of the compiled passes, and what times a
    robot whose facets do not fit) through highspy or through scipy."""
    robot, path = cogiro
    spline = PathSpline.through(robot, path)
    checks = grid_checks(PathModel.build(robot, spline, spline.grid(30)))
    inf = np.full(robot.dof, np.inf)
    fast = reachability(checks, inf, inf, 1e-6, compiled=False)
    monkeypatch.setattr(lp_module, "highspy", None)
    slow = reachability(checks, inf, inf, 1e-6, compiled=False)
    assert fast[3] == slow[3] == "optimal"
    assert _duration(checks.grid, slow[0]) == pytest.approx(_duration(checks.grid, fast[0]),
                                                            rel=1e-7)


def test_paths_that_cannot_be_timed_report_per_point_status(study) -> None:
    robot, _ = study
    # Without gravity and without upper bounds, nothing limits the speed. (A suspended
    # robot without upper bounds is limited: the cables cannot pull it down faster
    # than gravity over a crest or to a stop.)
    planar = to.presets.kntu_planar()
    planar = planar.with_(t_max=np.full(planar.m, np.inf))
    line = np.column_stack([np.linspace(-0.1, 0.1, 15), np.zeros(15), np.zeros(15)])
    unbounded = dyn.time_optimal(planar, line, method="reachability")
    assert not unbounded.success and unbounded.duration == np.inf
    assert (unbounded.status == to.Status.UNBOUNDED).all()
    # Near a tower's foot: the robot cannot hold the platform even at rest there.
    bad = np.array([[-3, -4, 1.0], [-30, -20, 0.5], [-44, -29, 0.2]])
    res = dyn.time_optimal(robot, bad)
    assert res.duration == np.inf and np.isnan(res.times).all()
    assert res.status[-1] == to.Status.INFEASIBLE
    assert set(res.status) <= {to.Status.INFEASIBLE, to.Status.NOT_RUN}
    for method in ("convex", "reachability"):
        assert not dyn.time_optimal(robot, bad, method=method).success


def test_bad_timing_input_raises(study) -> None:
    robot, path = study
    with pytest.raises(to.InvalidInputError, match="poses"):
        dyn.time_optimal(robot, np.where(np.eye(len(path), 3) > 0, np.nan, path))
    with pytest.raises(to.InvalidInputError, match="coincide"):
        dyn.time_optimal(robot, np.vstack([path[:3], path[2:]]))
    with pytest.raises(to.InvalidInputError, match="poses"):
        dyn.time_optimal(robot, path[:, :2])
    with pytest.raises(to.InvalidInputError, match="v_max"):
        dyn.time_optimal(robot, path, v_max=[1.0, 2.0])
    with pytest.raises(to.InvalidInputError, match="a_max"):
        dyn.time_optimal(robot, path, a_max=-1.0)
    with pytest.raises(to.InvalidInputError, match="gridpoints"):
        dyn.time_optimal(robot, path, gridpoints=[0.0, 1.0])
    for bounds, name in ((("a", 1.5e4), "t_min"), ((1j, 1.5e4), "t_min"),
                         ((1.0, 2.0, 3.0), "bounds must be a pair")):
        with pytest.raises(to.InvalidInputError, match=name):
            dyn.time_optimal(robot, path, bounds=bounds)
    with pytest.raises(to.InvalidInputError, match="too far apart"):
        dyn.time_optimal(robot, path * 1e200)
    for grid in (2, 10**6):
        with pytest.raises(to.InvalidInputError, match="gridpoints must be from 3 to"):
            dyn.time_optimal(robot, path, gridpoints=grid)
    for setting in ({"tension_slack": -0.5}, {"tension_slack": np.nan},
                    {"tension_slack": "x"}, {"active_tol": -1.0}, {"active_tol": np.nan}):
        with pytest.raises(to.InvalidInputError, match=next(iter(setting))):
            dyn.time_optimal(robot, path, **setting)
    with pytest.raises(to.InvalidInputError, match="structure"):
        dyn.time_optimal(robot, path, structure=np.zeros((3, 3, 4)))
    with pytest.raises(to.InvalidInputError, match="method"):
        dyn.time_optimal(robot, path, method="fast")


# ------------------------------------------------------------------------ facets
@pytest.mark.parametrize("make", [lambda: to.presets.algae_harvester(t_max=STUDY_T_MAX),
                                  to.presets.algae_harvester, to.presets.cogiro])
def test_wrench_facets_describe_the_feasible_set(make) -> None:
    robot = make()
    rng = np.random.default_rng(3)
    pose = robot.default_home() + np.r_[rng.uniform(-1, 1, 3), np.zeros(robot.dof - 3)]
    H, h = dyn.wrench_facets(robot, pose[None])
    A = robot.structure_matrices(pose)[0]
    hi = np.where(np.isfinite(robot.t_max), robot.t_max, robot.t_min + 4 * robot.weight)
    static = robot.required_wrench(pose)[0]
    counts = {True: 0, False: 0}
    for _ in range(300):  # wrenches of random tensions, pushed out or pulled in
        T = rng.uniform(robot.t_min, hi)
        w = static + rng.uniform(-1.0, 1.5) * (A @ T - static)
        margin = to.capacity_margin(robot, pose, wrench=static - w)[0]
        slack = (H[0] @ w - h[0]).max()
        scale = float(np.abs(w).max())
        if abs(margin) < 1e-6 * scale:
            continue
        assert (slack <= 1e-9 * scale) == (margin > 0)
        counts[bool(margin > 0)] += 1
    assert min(counts.values()) >= 20


# --------------------------------------------------------------- dynamic workspace
def test_dynamic_workspace_of_the_study_robot() -> None:
    robot = to.presets.algae_harvester()
    poses = to.workspace.sample_poses([-40, -25, 0.5], [40, 25, 5.0], 400, seed=2)
    static = to.wrench_feasible_workspace(robot, poses)
    zero = dyn.dynamic_workspace(robot, poses, 0.0)
    assert np.array_equal(zero.feasible, static.feasible)
    assert zero.margin == pytest.approx(static.margin, rel=1e-12, abs=1e-9)
    small, large = (dyn.dynamic_workspace(robot, poses, a) for a in (0.5, 2.0))
    assert small.margins.shape == (400, 8)
    assert not (large.feasible & ~small.feasible).any()  # a larger box, a smaller workspace
    assert not (small.feasible & ~static.feasible).any()
    assert large.fraction() < small.fraction() < static.fraction()
    # Inside the box: any acceleration of a feasible pose can be held.
    rng = np.random.default_rng(0)
    idx = np.flatnonzero(small.feasible)[:40]
    acc = rng.uniform(-0.5, 0.5, (len(idx), 3))
    sol = to.distribute(robot, poses[idx], wrench=dyn.inertia_wrench(
        robot, poses[idx], np.zeros(3), acc))
    assert sol.success.all()


def test_dynamic_workspace_with_orientation_dependent_wrenches(cogiro) -> None:
    robot, _ = cogiro
    poses = np.column_stack([np.random.default_rng(1).uniform(-2, 2, (30, 2)),
                             np.full(30, 2.0), np.random.default_rng(2).uniform(-0.2, 0.2,
                                                                                (30, 3))])
    res = dyn.dynamic_workspace(robot, poses, 1.0, velocity=[0, 0, 0, 0, 0, 1.0])
    assert res.extras["pose_dependent"] and res.margins.shape == (30, 8)
    acc = res.extras["accelerations"]
    for k in (0, 5):
        w = dyn.inertia_wrench(robot, poses, [0, 0, 0, 0, 0, 1.0], acc[k])
        assert res.margins[:, k] == pytest.approx(to.capacity_margin(robot, poses, w),
                                                  rel=1e-9, abs=1e-6)
    static = to.wrench_feasible_workspace(robot, poses)
    assert not (res.feasible & ~static.feasible).any()


def test_planar_body_timing() -> None:
    """A rigid body in a horizontal plane (no gravity): turning costs time too."""
    robot = to.presets.kntu_planar()
    straight = np.column_stack([np.linspace(-0.1, 0.1, 15), np.zeros(15), np.zeros(15)])
    turning = straight.copy()
    turning[:, 2] = np.linspace(0.0, 0.4, 15)
    a, b = (dyn.time_optimal(robot, p, v_max=[1.0, 1.0, 2.0]) for p in (straight, turning))
    assert a.success and b.success
    assert b.duration > a.duration
    greedy = dyn.time_optimal(robot, turning, v_max=[1.0, 1.0, 2.0], method="reachability")
    assert b.duration <= greedy.duration * (1 + 1e-6)


def test_two_poses_are_timed_bang_bang() -> None:
    """A path of two poses gets three grid points (two at rest cannot move): constant
    acceleration to the middle, then braking, with the acceleration limit of the
    coordinate that moves most binding: ``2 sqrt(L max|d_j| / a_max)``. (With two
    points it took infinite time yet read optimal.)"""
    robot = to.presets.algae_harvester()
    path = pick_and_place()[:2]
    result = dyn.time_optimal(robot, path, a_max=1.0)
    step = path[1] - path[0]
    length = float(np.linalg.norm(step))
    expected = 2.0 * np.sqrt(length * np.abs(step / length).max() / 1.0)
    assert result.success and len(result.s) == 3
    assert result.duration == pytest.approx(expected, rel=1e-6)


def test_a_timing_that_stops_the_path_is_no_timing(study, monkeypatch) -> None:
    """A timing with s'^2 zero (to the LPs' tolerance) at two neighbouring points
    inside the path would take forever between them (the greedy pass once stopped the
    path one point before the end, s'^2 = 2e-15, and its last segment took 22 million
    seconds, read optimal): it is no timing, ``STALLED``."""
    robot, path = study

    def stopping(*args):
        x, *rest = reachability(*args)
        x = x.copy()
        x[[10, 11]] = 2e-15 * x.max()
        return (x, *rest)

    monkeypatch.setattr(timing_rounds, "reachability", stopping)
    greedy = dyn.time_optimal(robot, path, method="reachability")
    assert not greedy.success and greedy.duration == np.inf
    assert (greedy.status == to.Status.STALLED).sum() == 1
    assert set(greedy.status) == {to.Status.STALLED, to.Status.NOT_RUN}


def test_a_fine_grid_keeps_the_tensions_feasible(study) -> None:
    """On 3000 points the reachability passes accepted wrenches up to the LPs' tolerance
    (2e-7 of a typical tension) outside the feasible set, beyond the 1e-7 slack then kept:
    two points read infeasible. The slack (1e-6, costing as much time) covers it."""
    robot, path = study
    fine = dyn.time_optimal(robot, path, gridpoints=3000, method="reachability")
    assert fine.success, np.flatnonzero(fine.status != to.Status.OPTIMAL)
    assert (fine.margin >= 0).all()
    coarse = dyn.time_optimal(robot, path, gridpoints=200, method="reachability")
    # Discretisation: with s'' constant over an interval, and feasible along it, a
    # coarser grid is slower (4 % on 200 points).
    assert coarse.duration * 0.95 <= fine.duration <= coarse.duration
