"""The compiled parts of the time-optimal timing against their references: the
two-variable LPs and reachability passes (against scipy's HiGHS and the LPs over the
tensions), the facet normals (against the SVD), the facet margins (against the capacity
margin) and the convex program over the rows (against the one over the tensions)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

import tension_opt as to
from benchmarks.scenarios import cogiro_path, pick_and_place
from tension_opt import dynamics as dyn
from tension_opt.dynamics import point_rows as point_rows_module
from tension_opt.dynamics.facets import subset_normals_reference
from tension_opt.dynamics.intervals import PathModel, initial_checks
from tension_opt.dynamics.path import PathSpline
from tension_opt.dynamics.point_rows import point_rows
from tension_opt.dynamics.reachability import polish, reachability
from tension_opt.dynamics.stage_rows import stage_rows
from tension_opt.dynamics.timing_convex import convex_rows_timing, convex_timing
from tension_opt.kernels import reachability as kernel
from tension_opt.kernels.facets import subset_normals
from tension_opt.workspace.margin import margin_solve


def _case(name: str) -> tuple[to.CableRobot, np.ndarray]:
    if name == "study":
        return to.presets.algae_harvester(t_max=15e3), pick_and_place()
    robot = to.presets.cogiro()
    return robot, cogiro_path(robot)


def _checks(robot: to.CableRobot, path: np.ndarray, K: int):
    spline = PathSpline.through(robot, path)
    return initial_checks(PathModel.build(robot, spline, spline.grid(K)))


def _duration(grid: np.ndarray, x: np.ndarray) -> float:
    sd = np.sqrt(np.maximum(x, 0.0))
    return float(np.sum(2 * np.diff(grid) / (sd[:-1] + sd[1:])))


def test_two_variable_lps_match_highs() -> None:
    rng = np.random.default_rng(5)
    box = np.array([-1e3, 1e3, 0.0, 1e3])
    extra = np.zeros((2, 3))
    outcomes = {kernel.OPTIMAL: 0, kernel.INFEASIBLE: 0}
    for _ in range(400):
        R = int(rng.integers(1, 25))
        angle = rng.uniform(0, 2 * np.pi, R)
        rows = np.column_stack([np.cos(angle), np.sin(angle)])
        rhs = rng.normal(0.5, 1.0, R)
        c = rng.normal(size=2)
        out, u, x = kernel.lp2(rows, rhs, 0, R, extra, 0, c[0], c[1], box)
        ref = linprog(c, A_ub=rows, b_ub=rhs, bounds=[(box[0], box[1]), (box[2], box[3])],
                      method="highs")
        assert (out == kernel.OPTIMAL) == (ref.status == 0)
        outcomes[out] += 1
        if out == kernel.OPTIMAL:
            assert c @ [u, x] == pytest.approx(ref.fun, rel=1e-9, abs=1e-9)
            assert (rows @ [u, x] <= rhs + 1e-8).all()
    assert min(outcomes.values()) >= 40


@pytest.mark.parametrize("case", ["study", "cogiro"])
@pytest.mark.parametrize("limits", [None, (2.0, 1.0)])
def test_compiled_passes_match_the_lps_over_the_tensions(case: str, limits) -> None:
    robot, path = _case(case)
    checks = _checks(robot, path, 60)
    v, a = (np.inf, np.inf) if limits is None else limits
    vmax, amax = np.full(robot.dof, v), np.full(robot.dof, a)
    fast = reachability(checks, vmax, amax, 1e-6, compiled=True)
    slow = reachability(checks, vmax, amax, 1e-6, compiled=False)
    assert fast[3] == slow[3] == "optimal"
    scale = np.maximum(1.0, np.abs(slow[2]))
    assert np.abs(fast[2] - slow[2]).max() <= 1e-9 * scale.max()  # controllable sets
    assert fast[0] == pytest.approx(slow[0], rel=1e-9, abs=1e-9 * slow[0].max())
    # Polishing a timing from above gives the same timing both ways.
    cap = 1.01 * slow[0]
    p_fast, p_slow = (polish(checks, cap, vmax, amax, 1e-6, compiled=flag)
                      for flag in (True, False))
    assert p_fast[0] == pytest.approx(p_slow[0], rel=1e-9, abs=1e-9 * slow[0].max())


def test_compiled_passes_tell_infeasible_and_unbounded_paths_alike() -> None:
    robot = to.presets.algae_harvester(t_max=15e3)
    bad = np.array([[-3, -4, 1.0], [-30, -20, 0.5], [-44, -29, 0.2]])
    inf = np.full(3, np.inf)
    checks = _checks(robot, bad, 20)
    fast = reachability(checks, inf, inf, 1e-6, compiled=True)
    slow = reachability(checks, inf, inf, 1e-6, compiled=False)
    assert fast[3] == slow[3] == "infeasible" and fast[4] == slow[4]
    planar = to.presets.kntu_planar()
    planar = planar.with_(t_max=np.full(planar.m, np.inf))
    line = np.column_stack([np.linspace(-0.1, 0.1, 15), np.zeros(15), np.zeros(15)])
    checks = _checks(planar, line, 15)
    for flag in (True, False):
        assert reachability(checks, inf, inf, 1e-6, compiled=flag)[3] == "unbounded"


@pytest.mark.parametrize(("n", "m"), [(2, 4), (3, 4), (3, 6), (6, 8)])
def test_compiled_normals_match_the_svd(n: int, m: int) -> None:
    rng = np.random.default_rng(n * m)
    A = rng.normal(size=(50, n, m))
    if n == 2:
        A[0, :, 0] = 0.0  # a zero column spans no line
    else:
        A[0, :, 1] = 2.0 * A[0, :, 0]  # dependent columns: no plane
    subsets = np.array(list(itertools.combinations(range(m), n - 1)))
    fast = subset_normals(A, subsets)
    slow = subset_normals_reference(A, subsets)
    same = np.minimum(np.abs(fast - slow).max(axis=2), np.abs(fast + slow).max(axis=2))
    assert same.max() < 1e-12
    assert (np.abs(fast).max(axis=2) == 0).sum() == (np.abs(slow).max(axis=2) == 0).sum() > 0


@pytest.mark.parametrize("robot", [to.presets.algae_harvester(t_max=15e3),
                                   to.presets.algae_harvester(), to.presets.cogiro()],
                         ids=["study", "study-no-t_max", "cogiro"])
def test_facet_margins_are_the_capacity_margin(robot: to.CableRobot) -> None:
    """The margin from the facet rows equals the capacity margin's LP (closed form),
    inside and outside the feasible set."""
    path = pick_and_place() if robot.dof == 3 else cogiro_path(robot)
    spline = PathSpline.through(robot, path)
    model = PathModel.build(robot, spline, spline.grid(40))
    rng = np.random.default_rng(2)
    s = rng.uniform(0, spline.length, 300)
    pts = model.at(s)
    offset = rng.uniform(0, 0.1, s.size)
    rows = point_rows(pts, offset)
    u, x = rng.normal(0, 3, s.size), rng.uniform(0, 30, s.size)
    W = (pts.a + 2 * offset[:, None] * pts.b) * u[:, None] + pts.b * x[:, None] + pts.c
    ones = np.ones_like(pts.lb)
    reference = margin_solve(pts.A, W, pts.lb, ones, pts.ub, ones)[0]
    got = rows.margin(u, x)
    scale = float(np.abs(W).max())
    assert (reference > 0).any() and (reference < 0).any()
    assert np.allclose(got, reference, rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("case", ["study", "cogiro"])
def test_convex_over_the_rows_matches_the_convex_over_the_tensions(case: str) -> None:
    robot, path = _case(case)
    checks = _checks(robot, path, 80)
    inf = np.full(robot.dof, np.inf)
    greedy = reachability(checks, inf, inf, 1e-6, compiled=True)
    rows = stage_rows(checks, inf, inf, 1e-6)
    x_rows, _, out_rows = convex_rows_timing(rows, checks.grid, greedy[0], greedy[1])
    x_tau, _, out_tau = convex_timing(checks, inf, inf, 1e-6)
    assert out_rows == out_tau == "optimal"
    exact = [polish(checks, x, inf, inf, 1e-6, compiled=True)[0] for x in (x_rows, x_tau)]
    assert _duration(checks.grid, exact[0]) == pytest.approx(
        _duration(checks.grid, exact[1]), rel=1e-7)
    assert _duration(checks.grid, exact[0]) <= _duration(checks.grid, greedy[0]) * (1 + 1e-9)


def test_the_lps_over_the_tensions_time_a_robot_the_facets_do_not_fit(monkeypatch) -> None:
    """Past FACET_CAP facets a point, the timing runs the LPs over the tensions (HiGHS):
    the same timing."""
    robot, path = _case("study")
    fast = dyn.time_optimal(robot, path, gridpoints=40, method="reachability")
    monkeypatch.setattr(point_rows_module, "FACET_CAP", 0)
    slow = dyn.time_optimal(robot, path, gridpoints=40, method="reachability")
    assert fast.success and slow.success
    assert slow.lp_count > 0 and slow.duration == pytest.approx(fast.duration, rel=1e-7)
