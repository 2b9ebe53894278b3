"""The compiled certificate (its measures and the cheap dual solve) against the numpy
reference."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.certify.certificate import (
    Multipliers,
    certify,
    estimate_multipliers,
    estimate_multipliers_reference,
    measures,
    measures_reference,
)
from tension_opt.certify.scaling import scaled_batch
from tension_opt.problem.form import StandardForm, as_problem
from tension_opt.workspace.sampling import random_feasible_poses


def _assert_same_measures(batch, x, mult) -> None:
    got, want = measures(batch, x, mult), measures_reference(batch, x, mult)
    # The gap is a difference of terms of order one: rounding is judged on their size.
    for name, a, b in zip(("primal", "dual", "gap"), got, want, strict=True):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13, err_msg=name)


def _random_batch(rng: np.random.Generator, n: int, extra: int, rows: int, minmax: bool,
                  quadratic: bool):
    """A random scaled batch of 6 poses: extra rows, a min-max epigraph, infinite bounds."""
    N, m = 6, n + extra
    A = rng.normal(size=(N, n, m))
    b = rng.normal(size=(N, n))
    lb = np.where(rng.random((N, m)) < 0.7, rng.uniform(-1, 1, (N, m)), -np.inf)
    ub = np.where(rng.random((N, m)) < 0.5, rng.uniform(2, 5, (N, m)), np.inf)
    q = rng.uniform(0.1, 2.0, (N, m)) if quadratic else np.zeros((N, m))
    G = rng.normal(size=(N, rows, m)) if rows else None
    h = rng.normal(size=(N, rows)) if rows else None
    form = StandardForm(A, b, lb, ub, q, rng.normal(size=(N, m)),
                        rng.uniform(0.5, 2.0, m) if minmax else None, None, None, G, h)
    return scaled_batch(form)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 5), extra=st.integers(1, 3),
       rows=st.integers(0, 3), minmax=st.booleans(), quadratic=st.booleans(),
       holes=st.sampled_from(["none", "x", "multipliers"]))
def test_the_compiled_measures_agree_with_the_numpy_reference(
        seed: int, n: int, extra: int, rows: int, minmax: bool, quadratic: bool,
        holes: str) -> None:
    """Random scaled batches, multipliers of either sign (the cones clip them),
    unsolved poses and unknown multipliers."""
    rng = np.random.default_rng(seed)
    batch = _random_batch(rng, n, extra, rows, minmax, quadratic)
    N = batch.N
    x = rng.normal(size=(N, batch.k))
    mult = Multipliers(rng.normal(size=(N, batch.Aeq.shape[1])),
                       rng.normal(size=(N, batch.G.shape[1])), rng.normal(size=(N, batch.k)))
    if holes == "x":
        x[1] = np.nan
        x[2, 0] = np.inf
    elif holes == "multipliers":
        mult.y[3, 0] = np.nan
        mult.z[4, -1] = np.nan
        if mult.mu.shape[1]:
            mult.mu[5, 0] = np.nan
    _assert_same_measures(batch, x, mult)


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max"])
def test_the_compiled_measures_agree_on_solved_study_poses(objective: str) -> None:
    """On the backend's own answers, where the measures are near zero."""
    robot = to.presets.algae_harvester()
    poses = random_feasible_poses(robot, 40, seed=5)
    A, b = robot.equilibrium(poses)
    form = as_problem(objective).standard_form_from(robot, A, b)
    raw = to.get_backend("qpsolvers:daqp").solve_stage(form)
    batch = scaled_batch(form)
    x = batch.lift(raw.tensions)
    full = certify(batch, x, raw.multipliers).multipliers
    _assert_same_measures(batch, x, full)
    assert (measures(batch, x, full)[0] <= 1e-7).all()


@settings(max_examples=80, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 5), extra=st.integers(1, 3),
       rows=st.integers(0, 3), minmax=st.booleans(), quadratic=st.booleans(),
       on_bounds=st.booleans())
def test_the_compiled_dual_solve_agrees_with_the_numpy_reference(
        seed: int, n: int, extra: int, rows: int, minmax: bool, quadratic: bool,
        on_bounds: bool) -> None:
    """Random points (one unsolved): the same multipliers, and the same measures with
    them. Points on their bounds leave the fit singular but for its ridge (a bound whose
    multiplier is free costs nothing): the multipliers then differ along the ridge's
    direction by rounding times up to 1e13, and only the measures are compared (to 1e-2:
    both are fits of the same quality)."""
    rng = np.random.default_rng(seed)
    batch = _random_batch(rng, n, extra, rows, minmax, quadratic)
    x = rng.normal(size=(batch.N, batch.k))
    if on_bounds:
        x = np.where(np.isfinite(batch.lb) & (rng.random(x.shape) < 0.5), batch.lb, x)
    x[2] = np.nan
    got, want = estimate_multipliers(batch, x), estimate_multipliers_reference(batch, x)
    for name in ("y", "mu", "z"):
        a, b = getattr(got, name), getattr(want, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        assert np.isnan(a[2]).all()
        if not on_bounds:
            scale = 1.0 + np.nanmax(np.abs(b), initial=0.0)
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * scale, err_msg=name)
    _assert_same_measures(batch, x, got)
    mine, theirs = measures(batch, x, got), measures(batch, x, want)
    for a, b in zip(mine, theirs, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-2 if on_bounds else 1e-9, atol=1e-12)


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max"])
def test_the_compiled_dual_solve_certifies_solutions_as_the_reference_does(
        objective: str) -> None:
    """Closed-form and DAQP optima of the study robot and CoGiRo, whose multipliers
    are estimated: the same multipliers, measures and verdicts."""
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        poses = random_feasible_poses(robot, 60, seed=8)
        A, b = robot.equilibrium(poses)
        form = as_problem(objective).standard_form_from(robot, A, b)
        backend = "closed_form" if objective != "min_max" or robot.m - robot.dof == 1 \
            else "qpsolvers:daqp"
        raw = to.get_backend(backend).solve(form)
        batch = scaled_batch(form)
        x = batch.lift(raw.tensions)
        got, want = estimate_multipliers(batch, x), estimate_multipliers_reference(batch, x)
        for name in ("y", "mu", "z"):
            np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-7,
                                       atol=1e-8, err_msg=name)
        mine, theirs = certify(batch, x, got), certify(batch, x, want)
        np.testing.assert_array_equal(mine.certified, theirs.certified)
        assert mine.certified.mean() > 0.95
        # Near-singular fits (a degenerate vertex) differ by rounding: 1 % of a measure,
        # or three decades below the default target.
        for a, b in zip(measures(batch, x, got), measures(batch, x, want), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-2, atol=1e-10)
