"""Objectives as classes: their terms, their values, problems built on them, a new one."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

import tension_opt as to
from tension_opt.problem.objectives import OBJECTIVES, Objective, ObjectiveTerms, get_objective

RNG = np.random.default_rng(7)
N, M = 6, 4
WEIGHTS = RNG.uniform(0.5, 2.0, M)
LB = RNG.uniform(0.0, 10.0, (N, M))
UB = LB + RNG.uniform(5.0, 20.0, (N, M))
REFERENCE = RNG.uniform(0.0, 30.0, (N, M))


@pytest.mark.parametrize("name", sorted(OBJECTIVES))
def test_terms_reproduce_the_value_up_to_a_constant(name: str) -> None:
    # f(T) - (1/2 q T^2 + c T + max v T) must not depend on T.
    objective = OBJECTIVES[name]
    terms = objective.terms(WEIGHTS, LB, UB, REFERENCE)
    values = []
    for T in RNG.uniform(0.0, 40.0, (3, N, M)):
        f = objective.evaluate(T, WEIGHTS, LB, UB, REFERENCE)
        model = (0.5 * terms.q * T**2 + terms.c * T).sum(axis=1)
        if terms.minmax is not None:
            model = model + (T * terms.minmax).max(axis=1)
        values.append(f - model)
    np.testing.assert_allclose(values[0], values[1], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(values[0], values[2], rtol=1e-12, atol=1e-9)


def test_known_values() -> None:
    T = np.array([[1.0, 2.0, 3.0, 4.0]])
    w = np.array([1.0, 2.0, 1.0, 0.5])
    lb, ub = np.zeros((1, 4)), np.full((1, 4), 4.0)
    assert OBJECTIVES["min_sum"].evaluate(T, w, lb, ub, None)[0] == 10.0
    assert OBJECTIVES["min_max"].evaluate(T, w, lb, ub, None)[0] == 4.0
    assert OBJECTIVES["pinv"].evaluate(T, w, lb, ub, None)[0] == 30.0
    assert OBJECTIVES["min_norm"].evaluate(T, w, lb, ub, None)[0] == 1 + 8 + 9 + 8
    assert OBJECTIVES["centered"].evaluate(T, w, lb, ub, None)[0] == 1 + 0 + 1 + 2
    assert OBJECTIVES["min_sum"].linear and OBJECTIVES["min_max"].linear
    assert not OBJECTIVES["min_norm"].linear and not OBJECTIVES["pinv"].bounded


def test_names_compare_and_unknown_names_are_input_errors() -> None:
    assert get_objective("min_norm") == "min_norm"
    assert to.Objective.MIN_SUM is get_objective("min_sum")
    assert to.TensionProblem("centered").objective.name == "centered"
    with pytest.raises(to.InvalidInputError, match="min_sum"):
        to.TensionProblem("min_summ")
    with pytest.raises(to.InvalidInputError, match="finite t_max"):
        to.TensionProblem("centered").standard_form(to.presets.algae_harvester(), [0, 0, 0])


def test_problem_inputs_are_checked_where_they_enter() -> None:
    with pytest.raises(to.InvalidInputError, match="reference"):
        to.TensionProblem("min_norm", reference=[np.nan] * 4)
    with pytest.raises(to.InvalidInputError, match=r"only\s+pull"):
        to.TensionProblem("min_sum", t_min=-1e5).standard_form(
            to.presets.algae_harvester(), [[-29.4, 10.2, 1.5]])
    with pytest.raises(to.InvalidInputError, match="shape"):
        to.TensionProblem("min_sum", t_min=[1.0, 2.0, 3.0]).standard_form(
            to.presets.algae_harvester(), [[0.0, 0.0, 1.0]])


class _MinSquaredSum(Objective):
    """Minimum ``sum_i w_i T_i^2 / 2``: min-norm's minimiser at half its value."""

    name: ClassVar[str] = "half_square"

    def terms(self, weights, lb, ub, reference) -> ObjectiveTerms:  # type: ignore[override]
        return ObjectiveTerms(np.broadcast_to(weights, lb.shape).copy(), np.zeros_like(lb))

    def evaluate(self, tensions, weights, lb, ub, reference):  # type: ignore[override]
        return 0.5 * (tensions**2 * weights).sum(axis=1)


def test_a_new_objective_is_one_class_and_every_qp_backend_takes_it() -> None:
    robot = to.presets.algae_harvester()
    poses = [[-29.4, 10.2, 1.5], [12.0, -8.0, 3.0]]
    w = np.array([1.0, 2.0, 3.0, 4.0])
    problem = to.TensionProblem(_MinSquaredSum(), weights=w)
    reference = to.distribute(robot, poses, to.TensionProblem("min_norm", weights=w),
                              backend="closed_form")
    for backend in ("closed_form", "qpsolvers:daqp", "cvxpy:CLARABEL"):
        sol = to.distribute(robot, poses, problem, backend=backend)
        assert (sol.status == to.Status.OPTIMAL).all()
        # The same minimiser as min_norm with the same weights, at half its value.
        np.testing.assert_allclose(sol.tensions, reference.tensions, rtol=1e-6)
        np.testing.assert_allclose(sol.objective, 0.5 * reference.objective, rtol=1e-6)


@pytest.mark.parametrize("backend", ["closed_form", "cvxpy", "scipy:highs"])
def test_min_max_weights_scale_freely(backend: str) -> None:
    """A common factor of the min-max weights leaves the optimum where it is: weights of
    1e-6 gave 'inaccurate' answers newtons away from it."""
    robot = to.presets.algae_harvester()
    poses = np.array([[5.0, -3.0, 2.0], [-20.0, 10.0, 1.0], [30.0, -15.0, 1.0]])
    if backend == "closed_form":  # both the numpy path and the compiled one (16 poses on)
        poses = np.vstack([poses, np.column_stack([np.linspace(-30, 30, 17),
                                                   np.linspace(-15, 15, 17),
                                                   np.full(17, 1.5)])])
    w = np.array([1.0, 2.0, 1.0, 1.0])
    base = to.distribute(robot, poses, to.TensionProblem("min_max", weights=w), backend)
    assert (base.status == "optimal").all()
    for factor in (1e-6, 1 / 15000, 1e6):
        got = to.distribute(robot, poses, to.TensionProblem("min_max", weights=factor * w),
                            backend)
        assert (got.status == "optimal").all(), (factor, got.status)
        np.testing.assert_allclose(got.tensions, base.tensions, rtol=1e-7)
        np.testing.assert_allclose(got.objective, factor * base.objective, rtol=1e-7)
