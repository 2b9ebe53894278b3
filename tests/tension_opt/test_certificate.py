"""Certificates: primal residual, dual residual and duality gap on the scaled problem.

Hand-solved multipliers, the bound they put on the objective's excess (weak duality, a
hypothesis property), the solvers' own multipliers in the certificate's sign
convention, the invariance of the scaled problem to the units of the robot, and the
rule that an answer whose certificate misses the target is ``inaccurate``, never
``optimal``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.backends.base import probe_form
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.certify.certificate import (
    Multipliers,
    certify,
    certify_form,
    estimate_multipliers,
    measures,
)
from tension_opt.certify.scaling import scaled_batch
from tension_opt.distribution.solution import TensionSolution
from tension_opt.problem.form import StandardForm
from tension_opt.status import Status
from tension_opt.tolerances import accuracy_target

SNAPSHOTS = json.loads((Path(__file__).parents[1] / "data" / "thesis_snapshots.json")
                       .read_text())["snapshots"]
POSES = np.array([s["pose"] for s in SNAPSHOTS], dtype=float)
GENERIC = [b for b in to.available_backends() if b != "closed_form"]


def test_the_multipliers_of_a_hand_solved_lp_are_found_exactly() -> None:
    # T1 + T2 = 1, T >= 0, min T1 + 2 T2: optimum (1, 0). Scaled: s = 1, the row over
    # its norm sqrt(2), costs over the largest (2): c = (1/2, 1). Stationarity
    # c + a y + z = 0 gives y = -sqrt(2)/2 and z = (0, -1/2) (on T2's lower bound).
    form = probe_form(0.0)
    certificate = certify_form(form, np.array([[1.0, 0.0]]))
    assert certificate.certified.tolist() == [True]
    np.testing.assert_allclose(certificate.multipliers.y, [[-np.sqrt(0.5)]], atol=1e-12)
    np.testing.assert_allclose(certificate.multipliers.z, [[0.0, -0.5]], atol=1e-12)
    for measure in (certificate.primal_residual, certificate.dual_residual,
                    certificate.duality_gap):
        assert measure[0] <= 1e-12


def test_a_feasible_point_that_is_not_optimal_fails_on_the_gap() -> None:
    # (0.5, 0.5) holds the equation and the bounds, but costs 1.5 against 1.
    certificate = certify_form(probe_form(0.0), np.array([[0.5, 0.5]]))
    assert certificate.primal_residual[0] == 0.0
    assert max(certificate.dual_residual[0], certificate.duality_gap[0]) > 0.1
    assert certificate.certified.tolist() == [False]


def test_an_optimal_label_that_misses_the_target_becomes_inaccurate_with_its_figures() -> None:
    robot = to.presets.algae_harvester()
    exact = to.distribute(robot, POSES, "pinv", "closed_form")
    assert exact.success.all() and (exact.duality_gap <= 1e-12).all()
    # Move every pose along its null space: equilibrium holds (and the pseudo-inverse
    # has no bounds), optimality does not.
    A = robot.structure_matrices(POSES)
    null = np.linalg.svd(A)[2][:, -1, :]
    moved = exact.tensions + 1e-3 * robot.weight * null
    assert exact.form is not None
    sol = TensionSolution.from_form(exact.form, moved, exact.status, backend="test",
                                    solver="test")
    assert (sol.status == Status.INACCURATE).all()
    np.testing.assert_array_equal(sol.tensions, moved)  # the figures are kept
    assert (sol.primal_residual <= 1e-12).all()
    assert (np.maximum(sol.dual_residual, sol.duality_gap) > 1e-6).all()
    frame = sol.to_frame()
    assert {"primal_residual", "dual_residual", "duality_gap", "accuracy"} <= set(frame)
    assert (frame["status"] == "inaccurate").all() and (frame["accuracy"] == 1e-7).all()


def test_a_solution_put_together_without_a_certificate_says_so() -> None:
    sol = TensionSolution(np.ones((2, 4)), np.array(["optimal"] * 2), np.ones(2, bool),
                          np.ones(2), np.zeros(2), np.zeros(2), None, np.full(2, np.nan),
                          0.0, 0.0, "b", "s", "v")
    assert np.isnan(sol.primal_residual).all() and not sol.certified.any()


@pytest.mark.parametrize("backend", GENERIC)
@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max", "centered"])
def test_solvers_multipliers_certify_in_the_certificates_convention(backend: str,
                                                                    objective: str) -> None:
    robot = to.presets.algae_harvester()
    problem = (to.TensionProblem(objective, t_max=4 * robot.weight) if objective == "centered"
               else to.TensionProblem(objective))
    form = problem.standard_form(robot, POSES)
    solver = to.get_backend(backend)
    if solver.unsupported(form) is not None:
        pytest.skip(f"{backend} does not take {objective}")
    raw = solver.solve_stage(form)
    ok = raw.status == Status.OPTIMAL
    assert raw.multipliers is not None and raw.multipliers.known[ok].all()
    batch = scaled_batch(form)
    _, dual, gap = measures(batch, batch.lift(raw.tensions), raw.multipliers)
    # The solver's own multipliers, as given (no estimate): wrong signs would leave a
    # dual residual of order one. HiGHS's QP solver stops at 1e-6 on stationarity.
    loose = 1e-5 if backend.lower().endswith("highs") and not form.is_linear else 1e-6
    assert (dual[ok] <= loose).all() and (gap[ok] <= loose).all(), (dual, gap)


def _random_form(rng: np.random.Generator, quadratic: bool) -> tuple[StandardForm, np.ndarray]:
    """A feasible random problem of 2..4 equations and 4..7 variables with bounds, and a
    point of it."""
    n = int(rng.integers(2, 5))
    m = n + int(rng.integers(2, 4))
    A = rng.normal(size=(1, n, m))
    point = rng.uniform(1.0, 3.0, (1, m))
    lb = np.zeros((1, m))
    ub = np.where(rng.random((1, m)) < 0.5, np.inf, 4.0)
    q = rng.uniform(0.5, 2.0, (1, m)) if quadratic else np.zeros((1, m))
    c = rng.normal(size=(1, m))
    b = np.einsum("nij,nj->ni", A, point)
    return StandardForm(A, b, lb, ub, q, c), point


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.floats(1e-6, 1e-1))
def test_the_gap_and_dual_residual_bound_the_objective_excess(seed: int, quadratic: bool,
                                                               step: float) -> None:
    """Weak duality: for any x and any multipliers, f(x) - f* <= gap + ||r||_inf ||x*||_1
    (scaled units), whatever the estimate's quality."""
    rng = np.random.default_rng(seed)
    form, _ = _random_form(rng, quadratic)
    exact = to.get_backend("qpsolvers:clarabel").solve(form, accuracy="high")
    if exact.status[0] != Status.OPTIMAL:
        return
    batch = scaled_batch(form)
    x_star = batch.lift(exact.tensions)
    x = x_star + step * rng.normal(size=x_star.shape)  # anywhere near, maybe infeasible
    certificate = certify(batch, x, None, 1e-7)
    f, f_star = batch.objective(x)[0], batch.objective(x_star)[0]
    gap = certificate.duality_gap[0] * max(1.0, abs(f))
    bound = gap + certificate.dual_residual[0] * np.abs(x_star).sum()
    assert f - f_star <= bound + 1e-9


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_estimated_multipliers_certify_exact_optima(seed: int, quadratic: bool) -> None:
    rng = np.random.default_rng(seed)
    form, _ = _random_form(rng, quadratic)
    exact = to.get_backend("qpsolvers:quadprog" if quadratic else "qpsolvers:highs").solve(
        form, accuracy="high")
    if exact.status[0] != Status.OPTIMAL:
        return
    batch = scaled_batch(form)
    x = batch.lift(exact.tensions)
    estimate = estimate_multipliers(batch, x)
    assert estimate.known.all()
    assert certify(batch, x, None, 1e-9).certified.all()


@pytest.mark.parametrize("backend", ["closed_form", "qpsolvers:osqp", "qpsolvers:scs",
                                     "cvxpy:CLARABEL"])
def test_the_scaled_problem_does_not_depend_on_the_units(backend: str) -> None:
    # A platform a thousand times heavier, with bounds to match: tensions scale by a
    # thousand, the scaled problem (and so statuses and certificates) stays the same.
    light = to.presets.algae_harvester()
    heavy = to.presets.algae_harvester(mass=258.6e3)
    one = to.distribute(light, POSES, "min_norm", backend)
    two = to.distribute(heavy, POSES, "min_norm", backend)
    assert one.success.all() and two.success.all()
    np.testing.assert_allclose(two.tensions, 1e3 * one.tensions, rtol=1e-8)
    assert one.multipliers is not None and two.multipliers is not None
    np.testing.assert_allclose(two.multipliers.y, one.multipliers.y, rtol=1e-6, atol=1e-9)


def test_accuracy_names_and_numbers() -> None:
    assert accuracy_target(None) == accuracy_target("default") == 1e-7
    assert accuracy_target("high") == 1e-10 and accuracy_target(3e-6) == 3e-6
    with pytest.raises(to.InvalidInputError, match="accuracy"):
        accuracy_target("exact")


def test_unknown_multipliers_are_estimated_where_the_solver_gave_none() -> None:
    form = probe_form(2.0)  # min |T|^2 / 2 with T1 + T2 = 1: (1/2, 1/2), no bound active
    batch = scaled_batch(form)
    x = batch.lift(np.array([[0.5, 0.5]]))
    given = Multipliers.unknown(batch)
    certificate = certify(batch, x, given, 1e-12)
    assert certificate.certified.all() and certificate.multipliers.known.all()
    np.testing.assert_allclose(certificate.multipliers.z, 0.0, atol=1e-12)


def test_a_smoothed_sequence_is_judged_at_the_accuracy_asked_for() -> None:
    robot = to.presets.algae_harvester()
    poses = np.array([[3.0, 4.0, -2.0], [3.2, 4.1, -2.0], [3.4, 4.2, -2.1]])
    problem = to.TensionProblem("min_norm", smoothing=1.0)
    for accuracy, target in (("default", 1e-7), ("high", 1e-10)):
        sol = to.distribute(robot, poses, problem, "qpsolvers:daqp", accuracy=accuracy)
        assert sol.accuracy == target
        assert (sol.status == to.Status.OPTIMAL).all()
        assert (sol.primal_residual <= target).all()


def test_a_bound_multiplier_barely_charged_takes_the_sign_of_its_bound() -> None:
    """Min-max on kntu_planar near (0.970, 0.169, 0.083): a cable a few 1e-6 (scaled)
    above its lower bound and another at its maximum. Its multiplier is barely charged
    by complementarity, so the sign-constrained refit once gave it a rounding-noise
    sign; a positive one was charged by the far upper bound in the gap, and the exact
    answer read ``inaccurate`` on one path and ``optimal`` on the other (12 % of these
    poses). Within its bound's cone it certifies on both paths, as HiGHS's duals do."""
    robot = to.presets.kntu_planar()
    rng = np.random.default_rng(4)
    poses = np.array([0.970, 0.169, 0.083]) + rng.uniform(-1e-6, 1e-6, (300, 3))
    x, y = np.linspace(-1.12, 1.12, 100)[92], np.linspace(-1.05, 1.05, 100)[62]
    poses[:2] = [[x, -y, -0.1], [x, y, 0.1]]  # two poses of a grid over the default box
    compiled = to.distribute(robot, poses, "min_max", "closed_form")
    reference = to.distribute(robot, poses, "min_max", ClosedFormBackend(compiled=False))
    for sol in (compiled, reference):
        assert (sol.status == Status.OPTIMAL).all(), np.flatnonzero(~sol.success)
        assert sol.duality_gap.max() < 1e-9
    np.testing.assert_allclose(compiled.tensions, reference.tensions, rtol=1e-11)
