"""The compiled scaling kernel against its numpy reference, ``StandardForm.scaling``,
and the memoised scaled batch."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.certify.scaling import compiled_scaling, scaled_batch, scaling_reference
from tension_opt.problem.form import StandardForm, as_problem
from tension_opt.workspace.sampling import random_feasible_poses


def _assert_same_scaling(form: StandardForm) -> None:
    reference, compiled = scaling_reference(form), compiled_scaling(form)
    for name in ("tension", "rows", "top"):
        want, got = getattr(reference, name), getattr(compiled, name)
        assert want.shape == got.shape
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0.0, err_msg=name)
    np.testing.assert_array_equal(compiled.quadratic, reference.quadratic)
    assert compiled.vmax == reference.vmax


@settings(max_examples=80, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 6), extra=st.integers(1, 3),
       exponent=st.sampled_from([-160.0, -8.0, 0.0, 4.0, 160.0, 300.0]),
       quadratic=st.booleans(), minmax=st.sampled_from([None, "ones", "zeros"]),
       lower=st.sampled_from(["none", "zero", "some"]), upper=st.booleans())
def test_the_compiled_scaling_agrees_with_the_numpy_reference(
        seed: int, n: int, extra: int, exponent: float, quadratic: bool, minmax: str | None,
        lower: str, upper: bool) -> None:
    """Random forms over 600 decades of wrench and matrix size (squares that overflow
    and underflow, a wrench near the float limit, short rows): the same scaling."""
    rng = np.random.default_rng(seed)
    N, m = 3, n + extra
    A = rng.normal(size=(N, n, m)) * np.where(rng.random((N, n, 1)) < 0.2, 1e-6, 1.0)
    A[0, -1] = 0.0  # a zero row
    b = rng.normal(size=(N, n)) * 10.0 ** exponent
    lb = {"none": np.full((N, m), -np.inf), "zero": np.zeros((N, m)),
          "some": np.where(rng.random((N, m)) < 0.5, rng.uniform(1, 100, (N, m)),
                           -np.inf)}[lower]
    ub = np.where(rng.random((N, m)) < 0.7, rng.uniform(1e3, 1e7, (N, m)),
                  np.inf) if upper else np.full((N, m), np.inf)
    q = rng.uniform(0.5, 2.0, (N, m)) if quadratic else np.zeros((N, m))
    c = rng.normal(size=(N, m))
    weights = None if minmax is None else (np.ones(m) if minmax == "ones" else np.zeros(m))
    _assert_same_scaling(StandardForm(A, b, lb, ub, q, c, weights))


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max", "centered"])
def test_the_compiled_scaling_agrees_on_the_study_and_cogiro(objective: str) -> None:
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        poses = random_feasible_poses(robot, 50, seed=3)
        A, b = robot.equilibrium(poses)
        problem = as_problem(objective)
        if objective == "centered":
            problem = problem.with_(t_max=5.0 * robot.weight)
        _assert_same_scaling(problem.standard_form_from(robot, A, b))


def test_the_scaled_batch_is_built_once_per_form_and_cannot_be_changed() -> None:
    robot = to.presets.algae_harvester()
    A, b = robot.equilibrium(robot.default_home()[None])
    form = as_problem("min_norm").standard_form_from(robot, A, b)
    batch = scaled_batch(form)
    assert scaled_batch(form) is batch
    with pytest.raises(ValueError):
        batch.lb[0, 0] = 1.0
    other = as_problem("min_norm").standard_form_from(robot, A, b)
    assert scaled_batch(other) is not batch
    np.testing.assert_array_equal(scaled_batch(other).Aeq, batch.Aeq)
