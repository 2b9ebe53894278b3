"""distribute(): statuses, infeasibility, bounds, weights, references, wrenches, tables."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to


def test_infeasible_pose_gives_status_nan_and_distance_without_stopping_the_batch(thesis):
    # (0, 24, 2) lies over the pond but needs a tension below t_min = m g in some cable.
    poses = [[0.0, 0.0, 2.0], [0.0, 24.0, 2.0], [10.0, 5.0, 1.0]]
    for backend in ("closed_form", "qpsolvers:daqp", "cvxpy:CLARABEL", "scipy:highs"):
        sol = to.distribute(thesis, poses, "min_sum", backend)
        assert [str(s) for s in sol.status] == ["optimal", "infeasible", "optimal"], backend
        assert np.isnan(sol.tensions[1]).all()
        assert np.isfinite(sol.tensions[[0, 2]]).all()
    exact = to.distribute(thesis, poses, "min_sum", "closed_form")
    # The distance: lowering t_min by it makes the pose feasible, by a little less not.
    gap = exact.infeasibility[1]
    assert 0 < gap < thesis.t_min[0]
    relaxed = to.TensionProblem("min_sum", t_min=thesis.t_min[0] - gap * (1 + 1e-6))
    tight = to.TensionProblem("min_sum", t_min=thesis.t_min[0] - gap * (1 - 1e-3))
    assert str(to.distribute(thesis, poses[1], relaxed).status[0]) == "optimal"
    assert str(to.distribute(thesis, poses[1], tight).status[0]) == "infeasible"


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "pinv", "min_max"])
@pytest.mark.parametrize("backend", ["closed_form", "cvxpy:CLARABEL"])
def test_pose_at_tower_height_is_infeasible_not_an_exception(thesis, objective, backend):
    # At z = tower height every cable is horizontal: the structure matrix loses its
    # vertical row and no tensions hold the weight.
    poses = np.array([[0.0, 0.0, 7.6], [1.0, 2.0, 3.0], [5.0, 5.0, 7.6]])
    sol = to.distribute(thesis, poses, objective, backend=backend)
    assert [str(s) for s in sol.status] == ["infeasible", "optimal", "infeasible"]
    assert np.isnan(sol.tensions[[0, 2]]).all()
    ref = to.distribute(thesis, poses[1:2], objective, backend=backend)
    np.testing.assert_allclose(sol.tensions[1], ref.tensions[0], rtol=1e-9)
    if backend == "closed_form":
        assert np.isinf(sol.infeasibility[[0, 2]]).all()


def test_per_pose_bounds_and_weights(thesis):
    poses = np.array([[5.0, 3.0, 1.0], [-8.0, 2.0, 2.0]])
    t_max = np.array([[5800.0] * 4, [7000.0] * 4])
    sol = to.distribute(thesis, poses, to.TensionProblem("min_norm", t_max=t_max))
    assert sol.success.all()
    assert (sol.tensions <= t_max + 1e-9).all()
    assert sol.tensions[0].max() == pytest.approx(5800.0)  # the per-pose bound is active
    ref = to.distribute(thesis, poses, to.TensionProblem("min_norm", t_max=t_max),
                        "cvxpy:CLARABEL", accuracy="high")
    np.testing.assert_allclose(sol.tensions, ref.tensions, rtol=1e-6)
    # A heavy weight on cable 1 pushes min-sum to use less of it.
    plain = to.distribute(thesis, poses, "min_sum")
    heavy = to.distribute(thesis, poses, to.TensionProblem("min_sum", weights=[5, 1, 1, 1]))
    assert (heavy.tensions[:, 0] <= plain.tensions[:, 0] + 1e-9).all()
    assert (heavy.residual < 1e-8 * thesis.weight).all()


def test_reference_tension_is_reached_when_it_is_in_equilibrium(thesis):
    pose = [[3.0, -4.0, 2.0]]
    target = to.distribute(thesis, pose, "min_sum").tensions
    sol = to.distribute(thesis, pose, to.TensionProblem("min_norm", reference=target))
    np.testing.assert_allclose(sol.tensions, target, rtol=1e-10)
    assert sol.objective[0] == pytest.approx(0.0, abs=1e-12 * thesis.weight**2)


def test_external_wrench_adds_to_gravity(thesis):
    pose = [[2.0, 1.0, 1.5]]
    # An upward external force equal to half the weight halves the pseudo-inverse tensions.
    half = to.distribute(thesis, pose, "pinv", wrench=[0, 0, thesis.weight / 2])
    full = to.distribute(thesis, pose, "pinv")
    np.testing.assert_allclose(half.tensions, full.tensions / 2, rtol=1e-12)
    # A sideways push, per pose, is balanced too.
    push = np.array([[300.0, -200.0, 0.0]])
    sol = to.distribute(thesis, pose, "min_norm", wrench=push)
    A = thesis.structure_matrices(pose)[0]
    np.testing.assert_allclose(A @ sol.tensions[0] + push[0] + [0, 0, -thesis.weight], 0,
                               atol=1e-8)


def test_centred_objective_sits_mid_range_when_it_can(thesis):
    bounded = to.presets.algae_harvester(t_max=4 * 2536.866)
    sol = to.distribute(bounded, [[0.0, 0.0, 2.0]], "centered")
    mid = 0.5 * (bounded.t_min + bounded.t_max)
    # At the centre the symmetric solution is as close to the middle as equilibrium allows.
    assert np.ptp(sol.tensions) < 1e-9 * mid[0]
    other = to.distribute(bounded, [[0.0, 0.0, 2.0]], "centered", "qpsolvers:daqp")
    np.testing.assert_allclose(sol.tensions, other.tensions, rtol=1e-8)


def test_min_max_lowers_the_largest_tension(thesis, snapshots):
    poses = np.array([s["pose"] for s in snapshots], dtype=float)
    lp = to.distribute(thesis, poses, "min_sum")
    mm = to.distribute(thesis, poses, "min_max")
    pinv = to.distribute(thesis, poses, "min_norm")
    assert (mm.tensions.max(axis=1) <= lp.tensions.max(axis=1) + 1e-9).all()
    assert (mm.tensions.max(axis=1) <= pinv.tensions.max(axis=1) + 1e-9).all()
    assert (lp.tensions.sum(axis=1) <= mm.tensions.sum(axis=1) + 1e-9).all()


def test_solution_table_is_tidy(thesis, snapshots):
    poses = np.array([s["pose"] for s in snapshots], dtype=float)
    sol = to.distribute(thesis, poses, "min_sum", "qpsolvers:daqp")
    frame = sol.to_frame()
    assert list(frame.columns[:6]) == ["pose", "status", "T1", "T2", "T3", "T4"]
    assert len(frame) == 5
    assert frame["unique"].tolist() == [False, True, True, True, True]
    assert (frame["iterations"] > 0).all()
    assert (frame["backend"] == "qpsolvers:daqp").all()
    assert sol.solver_version.startswith("daqp")
    assert sol.setup_time > 0 and sol.solve_time > 0


def test_sequence_is_solved_in_order_against_the_previous_solution(thesis):
    path = np.column_stack([np.linspace(-20, 20, 15), np.linspace(-10, 10, 15),
                            np.full(15, 2.0)])
    problem = to.TensionProblem("min_sum", rate_limit=100.0)
    start = to.distribute(thesis, path[0], "min_sum").tensions[0]
    sol = to.distribute(thesis, path, problem, previous=start)
    ok = sol.success
    steps = np.abs(np.diff(np.vstack([start, sol.tensions[ok]]), axis=0))
    assert steps.max() <= 100.0 + 1e-6
    # Given per pose (shape (N, m)), each pose is independent of the others.
    prev = np.tile(start, (15, 1))
    independent = to.distribute(thesis, path, problem, previous=prev)
    moved = np.abs(independent.tensions - start)
    assert (moved[independent.success] <= 100.0 + 1e-6).all()
