"""The fast paths of the time-optimal timing against their references: the compiled
facet rows (against the SVD's), the timing's tensions by the certified pass (against
the plain path) and the margin at the grid points from the rows (against the capacity
margin's LP)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import tension_opt as to
from benchmarks.scenarios import cogiro_path, pick_and_place
from tension_opt import dynamics as dyn
from tension_opt.dynamics.intervals import PathModel
from tension_opt.dynamics.path import PathSpline
from tension_opt.dynamics.point_rows import point_rows, point_rows_reference, tension_gap
from tension_opt.dynamics.timing_tensions import timing_tensions
from tension_opt.problem.form import as_problem
from tension_opt.status import Status
from tension_opt.workspace.margin import margin_solve


def _case(name: str) -> tuple[to.CableRobot, np.ndarray]:
    if name == "study":
        return to.presets.algae_harvester(t_max=15e3), pick_and_place()
    robot = to.presets.cogiro()
    return robot, cogiro_path(robot)


def _pairs_apart(fast: np.ndarray, slow: np.ndarray) -> np.ndarray:
    """Per point and subset, how far the pair of rows ``(s, s + S)`` of ``fast`` is from
    that of ``slow``, in either order (the sign of a normal), shape (P, S)."""
    S = slow.shape[1] // 2
    swapped = np.concatenate([fast[:, S:], fast[:, :S]], axis=1)

    def apart(a: np.ndarray) -> np.ndarray:
        same = (a == slow) | (np.isinf(a) & np.isinf(slow) & (np.sign(a) == np.sign(slow)))
        with np.errstate(invalid="ignore"):  # inf - inf where both are infinite
            d = np.where(same, 0.0, np.abs(a - slow))
        if d.ndim == 3:
            d = d.max(axis=2)
        return np.maximum(d[:, :S], d[:, S:])

    return np.minimum(apart(fast), apart(swapped))


@pytest.mark.parametrize(("n", "m"), [(2, 4), (3, 4), (3, 6), (4, 8), (6, 7), (6, 8)])
def test_compiled_facet_rows_match_the_reference(n: int, m: int) -> None:
    """Rows, weights and slack of random structure matrices (one with two dependent
    columns, one with an absent upper bound) agree with the SVD's to 1e-12."""
    rng = np.random.default_rng(10 * n + m)
    P = 60
    A = rng.normal(size=(P, n, m))
    A[0, :, 1] = 2.0 * A[0, :, 0]  # no plane through these two (n > 2), or one line
    lb = rng.uniform(0.0, 1.0, (P, m))
    ub = lb + rng.uniform(1.0, 3.0, (P, m))
    ub[1, 0] = np.inf
    a, b, c = (rng.normal(size=(P, n)) for _ in range(3))
    pts = dyn.path.PathStages(np.zeros(P), np.zeros((P, n)), np.zeros((P, n)),
                              np.zeros((P, n)), a, b, c, A, lb, ub)
    offset = rng.uniform(0.0, 0.1, P)
    gap = rng.uniform(0.0, 0.01, (P, m))
    fast, slow = point_rows(pts, offset, gap), point_rows_reference(pts, offset, gap)
    assert fast.G.shape == slow.G.shape == (P, 2 * len(list(itertools.combinations(
        range(m), n - 1))), 2)
    for name in ("G", "g", "weight", "moved"):
        assert _pairs_apart(getattr(fast, name), getattr(slow, name)).max() < 1e-12, name
    # The dependent pair gives zero rows in both (n > 2), and the infinite bound +inf.
    if n > 2:
        zero = (slow.weight[0] == 0.0) & (slow.g[0] == 0.0)
        assert zero.sum() == ((fast.weight[0] == 0.0) & (fast.g[0] == 0.0)).sum() > 0
    assert np.isinf(fast.g[1]).sum() == np.isinf(slow.g[1]).sum() > 0
    u, x = rng.normal(0.0, 3.0, P), rng.uniform(0.0, 30.0, P)
    assert np.allclose(fast.margin(u, x), slow.margin(u, x), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("case", ["study", "cogiro"])
def test_compiled_facet_rows_along_a_path(case: str) -> None:
    """On the benchmark paths the compiled rows give the reference's margins."""
    robot, path = _case(case)
    spline = PathSpline.through(robot, path)
    model = PathModel.build(robot, spline, spline.grid(40))
    rng = np.random.default_rng(3)
    s = rng.uniform(0.0, spline.length, 500)
    pts = model.at(s)
    offset = rng.uniform(0.0, 0.1, s.size)
    gap = tension_gap(pts, 1e-6)
    fast, slow = point_rows(pts, offset, gap), point_rows_reference(pts, offset, gap)
    u, x = rng.normal(0.0, 3.0, s.size), rng.uniform(0.0, 30.0, s.size)
    got, want = fast.margin(u, x), slow.margin(u, x)
    assert (want > 0).any() and (want < 0).any()
    assert np.abs(got - want).max() <= 1e-9 * np.abs(want).max()
    assert np.abs(fast.moved - slow.moved).max() <= 1e-12 * slow.moved.max() or np.allclose(
        np.sort(fast.moved, axis=1), np.sort(slow.moved, axis=1), rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("case", ["study", "cogiro"])
@pytest.mark.parametrize("objective", ["min_sum", "min_norm"])
def test_timing_tensions_certified_pass_matches_the_plain_path(case: str,
                                                              objective: str) -> None:
    """The timing's tensions by the certified pass are the plain path's to rounding,
    with the same statuses, and hold the wrenches."""
    robot, path = _case(case)
    res = dyn.time_optimal(robot, path, gridpoints=120, method="reachability",
                           objective=objective)
    assert res.success
    stages, W = res.extras["stages"], res.wrenches
    args = (robot, stages, W, as_problem(objective), False, True, "auto", {})
    T, status = timing_tensions(*args)
    T_ref, status_ref = timing_tensions(*args, certified=False)
    assert (status == status_ref).all() and (status == Status.OPTIMAL).all()
    scale = float(np.abs(T_ref).max())
    assert np.abs(T - T_ref).max() <= 1e-9 * scale
    assert np.abs(np.einsum("kij,kj->ki", stages.A, T) - W).max() <= 1e-9 * scale
    assert np.array_equal(T, res.tensions)


@pytest.mark.parametrize("case", ["study", "cogiro"])
def test_grid_margin_from_the_rows_is_the_capacity_margin(case: str) -> None:
    """The result's margin at the grid points (from the checks' rows) is the capacity
    margin's LP of its wrenches, zero to rounding where the tension limits bind."""
    robot, path = _case(case)
    res = dyn.time_optimal(robot, path, gridpoints=100, method="reachability")
    stages = res.extras["stages"]
    ones = np.ones_like(stages.lb)
    want = margin_solve(stages.A, res.wrenches, stages.lb, ones, stages.ub, ones)[0]
    scale = float(np.abs(res.tensions).max())
    assert np.abs(res.margin - want).max() <= 1e-9 * scale
    assert res.active_tension.sum() > 10
    assert np.abs(res.margin[res.active_tension]).max() <= 1e-5 * scale
