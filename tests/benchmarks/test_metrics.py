"""Metrics of the benchmark on hand-made series with known totals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks import metrics
from benchmarks.scenarios import pick_and_place, snapshot_poses
from tension_opt import distribute, presets
from tension_opt.problem.form import StandardForm

# Two cables over five poses: steps (+1, +2, -4, +1) and (0, +10, 0, -10).
SERIES = np.array([[0.0, 5.0], [1.0, 5.0], [3.0, 15.0], [-1.0, 15.0], [0.0, 5.0]])


def test_total_variation_sums_absolute_steps() -> None:
    assert metrics.total_variation(SERIES) == pytest.approx(8.0 + 20.0)
    assert metrics.total_variation(SERIES[:, 0]) == pytest.approx(8.0)
    assert metrics.total_variation(SERIES[:1]) == 0.0


def test_max_step_and_second_difference() -> None:
    assert metrics.max_step(SERIES) == pytest.approx(10.0)
    # second differences: cable 1 (1, -6, 5), cable 2 (10, -10, -10)
    assert metrics.max_second_difference(SERIES) == pytest.approx(10.0)
    assert metrics.max_second_difference(SERIES[:2]) == 0.0


def test_jump_count_counts_steps_not_cables() -> None:
    assert metrics.jump_count(SERIES, threshold=3.0) == 3  # steps 2, 3 and 4
    assert metrics.jump_count(SERIES, threshold=9.5) == 2
    assert metrics.jump_count(SERIES, threshold=100.0) == 0
    with pytest.raises(ValueError):
        metrics.jump_count(SERIES, threshold=0.0)


def test_nan_poses_do_not_count() -> None:
    T = np.array([[1.0], [np.nan], [4.0], [6.0]])
    assert metrics.total_variation(T) == pytest.approx(2.0)
    assert metrics.max_step(T) == pytest.approx(2.0)
    assert metrics.jump_count(T, 1.5) == 1


def test_shifted_geometric_mean_known_values() -> None:
    # exp(mean(log([20, 110]))) - 10 = sqrt(2200) - 10
    assert metrics.shifted_geometric_mean([10.0, 100.0]) == pytest.approx(np.sqrt(2200) - 10)
    assert metrics.shifted_geometric_mean([5.0, 5.0, 5.0]) == pytest.approx(5.0)
    assert metrics.shifted_geometric_mean([1.0, 4.0], shift=0.0) == pytest.approx(2.0)
    assert np.isnan(metrics.shifted_geometric_mean([]))


def test_relative_sgm_penalises_failures() -> None:
    frame = pd.DataFrame({
        "scenario": ["s"] * 4, "setting": ["d"] * 4, "problem": ["a", "b", "a", "b"],
        "backend": ["fast", "fast", "slow", "slow"], "t": [10.0, 10.0, 30.0, np.nan]})
    ratios = metrics.relative_shifted_geometric_means(frame, "t")
    # fast: sgm(10, 10) = 10; slow: the failure counts as the largest value 30 -> 30.
    assert ratios["fast"] == pytest.approx(1.0)
    assert ratios["slow"] == pytest.approx(3.0)
    # A solver without a row for instance "b" (cannot express it) is averaged over "a".
    partial = pd.concat([frame, frame.iloc[[0]].assign(backend="partial", t=20.0)])
    ratios = metrics.relative_shifted_geometric_means(partial, "t")
    assert ratios["partial"] == pytest.approx(2.0)


def test_performance_profile_fractions() -> None:
    ratios = np.array([1.0, 2.0, np.inf, np.nan])
    prof = metrics.performance_profile(ratios, [1.0, 1.5, 2.0, 10.0])
    np.testing.assert_allclose(prof, [0.25, 0.25, 0.5, 0.5])


def test_percentiles_and_gap() -> None:
    np.testing.assert_allclose(metrics.percentiles(np.arange(101.0)), [50.0, 95.0])
    assert np.isnan(metrics.percentiles([np.nan])).all()
    np.testing.assert_allclose(metrics.relative_gap([101.0, 0.5], [100.0, 0.0]), [0.01, 0.5])


def test_thesis_sag_reproduces_the_study() -> None:
    robot = presets.algae_harvester()
    poses = snapshot_poses()[:1]  # (0, 0, 0): D = 207.4 mm on all four cables
    T = distribute(robot, poses, "min_sum", backend="closed_form").tensions
    sag = metrics.thesis_sag(robot, poses, T)
    assert sag["sag_max_mm"] == pytest.approx(207.4, abs=0.2)
    assert sag["sag_mean_mm"] == pytest.approx(207.4, abs=0.2)
    assert sag["catenary_length_mean"] == pytest.approx(56.70, abs=0.01)
    assert sag["catenary_converged"] == 1.0
    # The imposed tensions balance the weight in the straight model only.
    assert sag["thesis_residual_max"] > 0.5 * robot.weight


def test_pick_and_place_path() -> None:
    p = pick_and_place()
    assert p.shape == (25, 3)
    np.testing.assert_allclose(p[12], [0.0, 0.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), 0.5)
    assert pick_and_place(dip_both_ways=True).shape == (29, 3)


def test_objective_excess_is_measured_on_the_scaled_problem() -> None:
    from tension_opt.backends.base import probe_form

    # T1 + T2 = 1, T >= 0, min T1 + 2 T2; scaled costs (1/2, 1): f* = 1/2 at (1, 0),
    # f = 3/4 at (1/2, 1/2), relative to max(1, |f*|) = 1.
    form = probe_form(0.0)
    excess = metrics.objective_excess(form, np.array([[0.5, 0.5]]), np.array([[1.0, 0.0]]))
    assert excess == pytest.approx([0.25])
    same = metrics.objective_excess(form, np.array([[1.0, 0.0]]), np.array([[1.0, 0.0]]))
    assert same == pytest.approx([0.0])
    # A thousand times the weight (bounds and all): the same excess.
    big = StandardForm(form.A, 1e3 * form.b, form.lb, form.ub, form.q, form.c)
    assert metrics.objective_excess(big, np.array([[500.0, 500.0]]),
                                    np.array([[1e3, 0.0]])) == pytest.approx([0.25])
