"""The backend registry, backend choice and the solver-settings table."""

from __future__ import annotations

import numpy as np
import pytest

import tension_opt as to
from tension_opt.backends import registry
from tension_opt.backends.settings import (
    ACCURACIES,
    SETTINGS,
    check_options,
    solver_options,
    unreachable,
)


def test_every_family_is_listed_and_serves_its_names() -> None:
    names = to.available_backends()
    assert "closed_form" in names and "scipy:highs" in names
    assert len(names) == len(set(names))
    for name in names:
        assert name.partition(":")[0] in registry.FAMILIES
        backend = to.get_backend(name)
        assert backend is to.get_backend(name)  # one instance per name
        assert backend.name.lower() == name.lower() or name == "cvxpy"


def test_unknown_backends_are_errors_that_list_the_installed_ones() -> None:
    with pytest.raises(to.BackendNotAvailableError, match="closed_form"):
        to.get_backend("gurobi")
    with pytest.raises(to.BackendNotAvailableError, match="suffix"):
        to.get_backend("closed_form:foo")
    with pytest.raises(to.BackendNotAvailableError, match="highs"):
        to.get_backend("scipy:glop")


def test_auto_prefers_the_closed_form_and_falls_back_beyond_its_reach() -> None:
    study = to.presets.algae_harvester()
    form = to.TensionProblem("min_sum").standard_form(study, [[1.0, 2.0, 3.0]])
    assert registry.choose_backend("auto", form).name == "closed_form"
    # Nine cables on a point mass: a 6-D null space, beyond the closed form.
    angles = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    anchors = np.column_stack([10 * np.cos(angles), 10 * np.sin(angles), np.full(9, 5.0)])
    robot = to.CableRobot(anchors=anchors, attachments=np.zeros((9, 3)), mass=10.0)
    wide = to.TensionProblem("min_norm").standard_form(robot, [[0.0, 0.0, 0.0]])
    assert to.get_backend("closed_form").unsupported(wide) is not None
    chosen = registry.choose_backend("auto", wide)
    assert chosen.name == next(n for n in registry.AUTO_ORDER
                               if n in to.available_backends() and n != "closed_form")


def test_a_named_backend_that_cannot_take_the_problem_names_those_that_can() -> None:
    study = to.presets.algae_harvester()
    form = to.TensionProblem("min_norm").standard_form(study, [[1.0, 2.0, 3.0]])
    with pytest.raises(to.UnsupportedProblemError, match="closed_form"):
        registry.choose_backend("scipy:highs", form)


def test_settings_translate_one_accuracy_into_each_solvers_words() -> None:
    # The default target is 1e-7 on the certificate's measures: most solvers are asked
    # for a tenth of it in their own words; "high" is 1e-10, a number is the target.
    default = solver_options("osqp", "default")
    assert default["eps_abs"] == pytest.approx(1e-8) and default["polishing"] is True
    high = solver_options("osqp", "high")
    assert high["eps_abs"] == pytest.approx(1e-11) and high["polishing"] is True
    assert solver_options("osqp", 1e-5)["eps_rel"] == pytest.approx(1e-6)
    assert solver_options("OSQP", "high", interface="cvxpy")["polish"] is True
    assert "polish_refine_iter" not in solver_options("OSQP", "high", interface="cvxpy")
    assert solver_options("scs", "default", time_limit=2.0)["time_limit_secs"] == 2.0
    assert solver_options("proxqp", "default")["max_iter"] == 1000
    assert "max_iter" not in solver_options("proxqp", "default", per_pose=False)
    assert "eps_duality_gap_abs" not in solver_options("proxqp", "high", interface="cvxpy")
    assert solver_options("daqp", "high", user={"primal_tol": 1e-6}) == {"primal_tol": 1e-6}
    # HiGHS refuses tolerances below 1e-10: asked for less, it runs at its floor.
    assert solver_options("highs", 1e-12)["primal_feasibility_tolerance"] == 1e-10
    assert unreachable("highs", 1e-12) is not None and unreachable("highs", "high") is None
    assert solver_options("scipy", "high", interface="cvxpy") == {"scipy_options": {
        "primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}}
    assert set(ACCURACIES) == {"default", "high"}
    for name in ("daqp", "osqp", "proxqp", "piqp", "clarabel", "highs", "scs"):
        assert SETTINGS[name].high, name


def test_an_accuracy_names_a_target_the_certificate_is_judged_by() -> None:
    study = to.presets.algae_harvester()
    poses = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]
    for accuracy, target in (("default", 1e-7), ("high", 1e-10), (1e-5, 1e-5)):
        sol = to.distribute(study, poses, "min_norm", "qpsolvers:osqp", accuracy=accuracy)
        assert sol.accuracy == target
        assert sol.success.all()
        assert (sol.primal_residual <= target).all() and (sol.dual_residual <= target).all()
        assert (sol.duality_gap <= target).all()
    for bad in ("ultra", 0.5, 1e-20, -1.0, float("nan")):
        with pytest.raises(to.InvalidInputError, match="accuracy"):
            check_options({"accuracy": bad})


def test_bad_options_are_input_errors_that_list_the_valid_ones() -> None:
    with pytest.raises(to.InvalidInputError, match="high"):
        check_options({"accuracy": "ultra"})
    with pytest.raises(to.InvalidInputError, match="solver_options"):
        check_options({"acuracy": "high"})
    with pytest.raises(to.InvalidInputError, match="time_limit"):
        check_options({"time_limit": -1})
    with pytest.raises(to.InvalidInputError, match="accuracy"):
        to.distribute(to.presets.algae_harvester(), [0.0, 0.0, 1.0], accuracy="ultra")
