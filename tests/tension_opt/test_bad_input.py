"""Regression tests of hostile but realistic inputs: each gets the right answer or a
clear error of the package that names the argument at fault."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import tension_opt as to
from tension_opt.dynamics.trajectory import smooth_jointly
from tension_opt.workspace.sampling import random_feasible_poses

STUDY_POSE = [[-29.4, 10.2, 1.5]]


@pytest.fixture(scope="module")
def study() -> to.CableRobot:
    return to.presets.algae_harvester()


def _octagon() -> to.CableRobot:
    """Eight cables, anchors on a circle at z = 5, attachments on a circle at z = 0: the
    structure matrix of the centred pose has rank 3 of 6."""
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(8)])
    return to.CableRobot(anchors=5 * ring + [0.0, 0.0, 5.0], attachments=0.5 * ring,
                         mass=10.0, kind="spatial6")


# ------------------------------------------------------------- cables only pull
def test_a_negative_bound_is_refused_where_the_problem_is_made() -> None:
    with pytest.raises(to.InvalidInputError, match=r"t_min.*only pull"):
        to.TensionProblem("min_sum", t_min=-1e5)
    with pytest.raises(to.InvalidInputError, match="t_max"):
        to.TensionProblem("min_sum", t_max=-1.0)
    with pytest.raises(to.InvalidInputError, match="t_min exceeds t_max"):
        to.TensionProblem("min_sum", t_min=10.0, t_max=5.0)


def test_the_study_with_a_negative_bound_never_pushes(study: to.CableRobot) -> None:
    with pytest.raises(to.InvalidInputError, match="only pull"):
        to.distribute(study, STUDY_POSE, to.TensionProblem("min_sum", t_min=-1e5))


def test_references_are_finite_non_negative_and_for_min_norm_only() -> None:
    with pytest.raises(to.InvalidInputError, match="reference"):
        to.TensionProblem("min_norm", reference=[np.nan] * 4)
    with pytest.raises(to.InvalidInputError, match=r"reference.*only pull"):
        to.TensionProblem("min_norm", reference=[-1.0] * 4)
    with pytest.raises(to.InvalidInputError, match="reference"):
        to.TensionProblem("min_sum", reference=[1.0] * 4)


@pytest.mark.parametrize(("field", "value"), [
    ("weights", 2.0), ("weights", "abc"), ("weights", [1.0, -1.0]), ("smoothing", True),
    ("smoothing", "1"), ("rate_limit", np.ones((2, 2))), ("tie_break", "yes"),
    ("t_min", "x"), ("t_max", [np.nan])])
def test_problem_fields_are_checked_and_named(field: str, value: object) -> None:
    with pytest.raises(to.InvalidInputError, match=field):
        to.TensionProblem("min_norm", **{field: value})


def test_an_objective_that_overflows_is_an_input_error(study: to.CableRobot) -> None:
    problem = to.TensionProblem("min_norm", smoothing=1e300)
    with pytest.raises(to.InvalidInputError, match="smoothing"):
        to.distribute(study, STUDY_POSE, problem, previous=[1e10] * 4)


# -------------------------------------------------------- shapes and coercion
@pytest.mark.parametrize(("kwargs", "name"), [
    ({"poses": [[1.0, 2.0, 3.0], [1.0, 2.0]]}, "poses"),
    ({"poses": "abc"}, "poses"),
    ({"poses": np.zeros((2, 4))}, "poses"),
    ({"objective": to.TensionProblem("min_sum", t_min=[1.0, 2.0, 3.0])}, "t_min"),
    ({"wrench": [[1.0, 2.0], [3.0]]}, "wrench"),
    ({"wrench": "abc"}, "wrench"),
    ({"objective": to.TensionProblem("min_norm", smoothing=1.0), "previous": "abc"},
     "previous"),
    ({"objective": to.TensionProblem("min_norm", smoothing=1.0),
      "previous": [[1.0, 2.0], [3.0]]}, "previous"),
    ({"objective": to.TensionProblem("min_norm", smoothing=1.0), "previous": [1.0, 2.0]},
     "previous"),
    ({"objective": to.TensionProblem("min_sum", weights=[1.0, 2.0])}, "weights"),
    ({"objective": to.TensionProblem("min_norm", reference=[1.0, 2.0])}, "reference"),
])
def test_numpy_errors_become_input_errors_naming_the_argument(
        study: to.CableRobot, kwargs: dict, name: str) -> None:
    call = {"poses": STUDY_POSE, **kwargs}
    with pytest.raises(to.InvalidInputError, match=name):
        to.distribute(study, call.pop("poses"), **call)


def test_a_mass_given_as_text_is_named() -> None:
    with pytest.raises(to.InvalidInputError, match="mass"):
        to.CableRobot(np.eye(3), np.zeros((3, 3)), mass="10")  # type: ignore[arg-type]
    with pytest.raises(to.InvalidInputError, match="diameter"):
        to.CableProperties(diameter=-1.0, linear_mass=1.0)


@pytest.mark.parametrize("backend", [None, 3, ["auto"], np.array(["auto", "x"])])
def test_a_backend_that_is_not_a_name_is_named(study: to.CableRobot, backend: object) -> None:
    with pytest.raises(to.BackendNotAvailableError, match="backend"):
        to.distribute(study, STUDY_POSE, backend=backend)  # type: ignore[arg-type]


def test_a_robot_that_is_not_a_robot_is_named() -> None:
    with pytest.raises(to.InvalidInputError, match="robot"):
        to.distribute("study", STUDY_POSE)  # type: ignore[arg-type]


def test_a_pose_too_far_away_overflows_into_an_error(study: to.CableRobot) -> None:
    with pytest.raises(to.InvalidInputError, match="pose 0"):
        to.distribute(study, [[1e300, 0.0, 0.0]])


# ------------------------------------------------------------ options and backends
@pytest.mark.parametrize(("options", "words"), [
    ({"accuracy": "ultra"}, "accuracy.*default.*high"),
    ({"acuracy": "high"}, r"acuracy.*accuracy"),
    ({"time_limit": -1.0}, "time_limit"),
    ({"batch_size": 0}, "batch_size"),
    ({"warm_start": "no"}, "warm_start"),
    ({"solver_options": [("eps_abs", 1.0)]}, "solver_options"),
])
def test_unknown_or_bad_options_are_errors_listing_the_valid_ones(
        study: to.CableRobot, options: dict, words: str) -> None:
    with pytest.raises(to.InvalidInputError, match=words):
        to.distribute(study, STUDY_POSE, **options)


def test_an_unknown_backend_suffix_lists_the_installed_backends(study: to.CableRobot) -> None:
    with pytest.raises(to.BackendNotAvailableError, match=r"suffix.*installed.*closed_form"):
        to.distribute(study, STUDY_POSE, backend="closed_form:foo")


@pytest.mark.parametrize(("backend", "options", "message"), [
    ("qpsolvers:osqp", {"eps_abs": -1}, "OSQP_SETTINGS_VALIDATION_ERROR"),
    ("qpsolvers:osqp", {"eps_abss": 1e-3}, "eps_abss"),
    ("qpsolvers:daqp", {"eps_abss": 1e-3}, "eps_abss"),
    ("qpsolvers:piqp", {"eps_abss": 1e-3}, "eps_abss"),
    ("qpsolvers:highs", {"eps_abss": 1e-3}, "eps_abss"),
    ("cvxpy:CLARABEL", {"eps_abss": 1e-3}, "eps_abss"),
    ("cvxpy:OSQP", {"eps_abs": -1}, "OSQP_SETTINGS_VALIDATION_ERROR"),
    ("cvxpy:DAQP", {"eps_abss": 1e-3}, "eps_abss"),
    ("scipy:highs", {"eps_abss": 1e-3}, "eps_abss"),
])
def test_options_a_solver_rejects_raise_with_its_message(
        study: to.CableRobot, backend: str, options: dict, message: str) -> None:
    if backend not in to.available_backends():
        pytest.skip(f"{backend} is not installed")
    objective = "min_sum" if backend == "scipy:highs" else "min_norm"
    with pytest.raises(to.SolverError, match=message):
        to.distribute(study, STUDY_POSE, objective, backend, solver_options=options)


def test_options_a_solver_accepts_still_solve(study: to.CableRobot) -> None:
    sol = to.distribute(study, STUDY_POSE, "min_norm", "qpsolvers:osqp",
                        solver_options={"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iter": 100000})
    assert sol.success.all()


def test_a_solver_exception_on_a_pose_keeps_its_message() -> None:
    from tension_opt.backends.base import RawResult, honest

    raw = RawResult(np.array([[1.0, np.inf]]), np.array(["optimal"]), None)
    honest(raw)
    assert raw.status[0] == to.Status.SOLVER_ERROR and np.isnan(raw.tensions).all()
    assert "non-finite" in raw.extras["errors"][0]


# --------------------------------------------------------- answers, not statuses
def test_empty_batches_are_empty_solutions_on_every_backend(study: to.CableRobot) -> None:
    for backend in [*to.available_backends(), "auto"]:
        for objective in ("min_sum", "min_norm"):
            form = to.TensionProblem(objective).standard_form(study, np.zeros((1, 3)))
            if backend != "auto" and to.get_backend(backend).unsupported(form):
                continue
            sol = to.distribute(study, np.zeros((0, 3)), objective, backend)
            assert sol.tensions.shape == (0, 4) and sol.status.shape == (0,)


def test_a_huge_smoothing_weight_is_solved_by_every_qp_backend(study: to.CableRobot) -> None:
    poses = random_feasible_poses(study, 3, seed=0)
    problem = to.TensionProblem("min_norm", smoothing=1e10)
    exact = to.distribute(study, poses, problem, "closed_form")
    assert exact.success.all()
    for backend in to.available_backends():
        if backend == "closed_form" or to.get_backend(backend).unsupported(exact.form):
            continue
        sol = to.distribute(study, poses, problem, backend, accuracy="high")
        # Honest at least: never infeasible or failed on these feasible poses.
        assert not np.isin(sol.status, ["infeasible", "solver_error", "max_iter"]).any(), (
            backend, sol.status)
        if backend in ("qpsolvers:daqp", "qpsolvers:quadprog", "qpsolvers:proxqp",
                       "qpsolvers:clarabel", "cvxpy:CLARABEL"):
            assert sol.success.all(), (backend, sol.status)
            np.testing.assert_allclose(sol.tensions, exact.tensions, rtol=1e-6,
                                       err_msg=backend)


def test_a_rank_deficient_robot_is_answered_the_same_by_every_backend() -> None:
    robot = _octagon()
    auto = to.distribute(robot, np.zeros(6), "min_sum")
    assert auto.success.all()
    assert auto.extras["fallback"] == {"qpsolvers:daqp": [0]}  # the closed form cannot
    np.testing.assert_allclose(auto.tensions, 16.4975064873, rtol=1e-8)
    for backend in ("qpsolvers:daqp", "scipy:highs", "cvxpy:CLARABEL", "qpsolvers:highs"):
        if backend not in to.available_backends():
            continue
        # DAQP's equations hold to about 1e-10 of the scaled problem: asked for its floor.
        accuracy = "default" if backend.endswith("daqp") else "high"
        sol = to.distribute(robot, np.zeros(6), "min_sum", backend, accuracy=accuracy)
        assert sol.success.all() and not sol.unique.any()
        np.testing.assert_allclose(sol.tensions, auto.tensions, rtol=1e-6, err_msg=backend)


def test_a_large_optimal_face_is_broken_exactly_by_an_lp_only_backend() -> None:
    # Nine cables on a point mass: a 6-D null space; min-max ties on a large face.
    angles = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    anchors = np.column_stack([10 * np.cos(angles), 10 * np.sin(angles), np.full(9, 5.0)])
    robot = to.CableRobot(anchors, np.zeros((9, 3)), mass=10.0)
    qp = to.distribute(robot, [0.0, 0.0, 0.0], "min_sum", "qpsolvers:daqp")
    lp = to.distribute(robot, [0.0, 0.0, 0.0], "min_sum", "scipy:highs")
    assert "tie_break" not in lp.extras
    np.testing.assert_allclose(lp.tensions, qp.tensions, rtol=1e-7)


def test_optimal_never_comes_with_non_finite_tensions(study: to.CableRobot) -> None:
    form = to.TensionProblem("min_sum").standard_form(study, STUDY_POSE * 2)
    sol = to.TensionSolution.from_form(form, np.array([[np.nan] * 4, [np.inf] * 4]),
                                       ["optimal", "inaccurate"], backend="x", solver="x")
    assert (sol.status == to.Status.SOLVER_ERROR).all() and np.isnan(sol.tensions).all()


def test_a_wrench_near_the_float_limit_is_solved_or_refused_honestly(
        study: to.CableRobot) -> None:
    for backend in ("qpsolvers:daqp", "cvxpy:CLARABEL", "closed_form"):
        sol = to.distribute(study, STUDY_POSE, "min_norm", backend, wrench=[0.0, 0.0, -1e300])
        ok = sol.success
        assert np.isfinite(sol.tensions[ok]).all()
        assert (sol.residual[ok] <= 1e-6 * 1e300).all()


def test_smooth_jointly_checks_its_arguments(study: to.CableRobot) -> None:
    poses = random_feasible_poses(study, 3, seed=1)
    with pytest.raises(to.InvalidInputError, match="weight"):
        smooth_jointly(study, poses, "min_norm", weight="1")  # type: ignore[arg-type]
    with pytest.raises(to.InvalidInputError, match="acuracy"):
        smooth_jointly(study, poses, "min_norm", acuracy="high")
    with pytest.raises(to.InvalidInputError, match="backend"):
        smooth_jointly(study, poses, "min_norm", backend=None)  # type: ignore[arg-type]
    empty = smooth_jointly(study, np.zeros((0, 3)), "min_norm")
    assert empty.tensions.shape == (0, 4)
    huge = smooth_jointly(study, poses, "min_norm", weight=1e10)
    assert huge.success.all()


def test_solver_warnings_stay_quiet_and_filters_untouched(study: to.CableRobot) -> None:
    before = list(warnings.filters)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        to.distribute(study, [[0.0, 0.0, 100.0]], "min_norm", "qpsolvers:osqp")
    assert not [w for w in caught if "qpsolvers" in str(w.filename)]
    assert warnings.filters == before


# ------------------------------------------------------- found by the fuzzed contract
def _two_cable_plane() -> tuple[to.CableRobot, np.ndarray]:
    anchors = np.array([[0.98179808, 0.1899277, 1.0], [-0.98179808, -0.1899277, 1.0]])
    poses = np.array([[0.16136247, 0.1396936], [-0.54080558, -0.15868553]])
    return to.CableRobot(anchors, np.zeros((2, 3)), 1.0, kind="planar_point2"), poses


@pytest.mark.parametrize("weight", [1e-8, 1.0, 1e8])
def test_min_max_weights_of_any_size_are_solved_by_daqp(weight: float) -> None:
    # Weights of 1e8 once left the epigraph rows unscaled: DAQP said "infeasible".
    robot, poses = _two_cable_plane()
    problem = to.TensionProblem("min_max", weights=[weight, weight])
    for backend in ("auto", "qpsolvers:daqp", "scipy:highs"):
        sol = to.distribute(robot, poses, problem, backend)
        assert sol.success.all(), (backend, sol.status)
        np.testing.assert_allclose(sol.tensions, [[7.99189, 6.87631], [3.65601, 8.23413]],
                                   rtol=1e-5)


def test_a_pose_with_nothing_to_hold_is_optimal_not_inaccurate() -> None:
    # Zero wrench and zero lower bounds once gave a tolerance of exactly 0 N.
    anchors = np.array([[1.0, 0.2, 1.0], [-0.2, 1.0, 1.0], [-1.0, -0.2, 1.0], [0.2, -1.0, 1.0]])
    robot = to.CableRobot(anchors, np.zeros((4, 3)), 1.0, kind="planar3")
    sol = to.distribute(robot, [[0.16, -0.27, -0.28]], "min_sum", "qpsolvers:daqp")
    assert sol.success.all()
    np.testing.assert_allclose(sol.tensions, 0.0, atol=1e-12)


@pytest.mark.parametrize("value", [[[1.0, 2.0], [3.0]], "abc", [1.0, "x", 2.0]],
                         ids=["ragged", "string", "mixed"])
@pytest.mark.parametrize("name", ["pose", "wrench", "previous"])
def test_distributor_names_arguments_numpy_cannot_read(study: to.CableRobot, name: str,
                                                       value: object) -> None:
    """A Distributor call meets unreadable input with the package's error naming the
    argument (its fast path once let numpy's ValueError through)."""
    solver = to.Distributor(study, to.TensionProblem("min_norm", smoothing=1.0))
    call = {"pose": study.default_home(), name: value}
    with pytest.raises(to.InvalidInputError, match=name):
        solver(call.pop("pose"), **call)


@pytest.mark.parametrize("backend", ["closed_form", "qpsolvers:daqp", "cvxpy:CLARABEL"])
def test_distributor_refuses_rows_that_do_not_match_the_poses(study: to.CableRobot,
                                                              backend: str) -> None:
    """A wrench or previous tensions with another number of rows than the poses is an
    error naming it (the DAQP and cvxpy paths once used the first rows and dropped the
    rest)."""
    if backend not in to.available_backends():
        pytest.skip(f"{backend} not installed")
    solver = to.Distributor(study, "min_norm", backend)
    poses = np.zeros((2, 3))
    with pytest.raises(to.InvalidInputError, match=r"wrench must have shape \(3,\) or \(2, 3\)"):
        solver(poses, wrench=np.zeros((3, 3)))
    smoothed = to.Distributor(study, to.TensionProblem("min_norm", smoothing=1.0), backend)
    with pytest.raises(to.InvalidInputError, match=r"previous must have shape"):
        smoothed(poses, previous=np.ones((3, 4)))
    rows = smoothed(poses, previous=np.full((2, 4), 3000.0), wrench=np.zeros((2, 3)))
    assert (rows.status == to.Status.OPTIMAL).all()


@pytest.mark.parametrize("poses", [np.array([[1j, 0.0, 0.0]]), [["1", "0", "0"]]],
                         ids=["complex", "text"])
def test_poses_that_are_not_real_numbers_are_named(study: to.CableRobot,
                                                   poses: object) -> None:
    """Complex poses lost their imaginary part with a warning, numbers as text were
    read as numbers: both are errors now."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(to.InvalidInputError, match="poses must be"):
            to.distribute(study, poses)


def test_preset_overrides_and_margin_options_are_checked(study: to.CableRobot) -> None:
    for value in ("80", None, [80.0]):
        with pytest.raises(to.InvalidInputError, match="pond_length"):
            to.presets.algae_harvester(pond_length=value)
    with pytest.raises(to.InvalidInputError, match="offset_x"):
        to.presets.algae_harvester(offset_x="6")
    for options, match in (({"bogus": 1}, "unknown option"), ({"time_limit": -5}, "time_limit"),
                           ({"accuracy": "bogus"}, "accuracy")):
        with pytest.raises(to.InvalidInputError, match=match):
            to.capacity_margin(study, np.zeros((1, 3)), **options)


def test_a_robot_keeps_its_own_copies_of_the_arrays_it_is_given() -> None:
    """The caller's arrays stay theirs and writeable (they were made read-only and
    shared with the robot)."""
    anchors = np.array([[-1.0, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]])
    attachments, home = np.zeros((4, 3)), np.zeros(3)
    robot = to.CableRobot(anchors=anchors, attachments=attachments, mass=1.0,
                          kind="point3", home=home)
    for given, held in ((anchors, robot.anchors), (attachments, robot.attachments),
                        (home, robot.home)):
        assert given.flags.writeable and not held.flags.writeable
        assert not np.shares_memory(given, held)
    anchors[0, 0] = -2.0
    assert robot.anchors[0, 0] == -1.0


@pytest.mark.parametrize("backend", ["qpsolvers:highs", "qpsolvers:daqp"])
def test_silent_solver_failures_on_infeasible_poses_say_infeasible(study: to.CableRobot,
                                                                   backend: str) -> None:
    """HiGHS through qpsolvers fails on an infeasible pose without a status, DAQP with
    an exit flag of its own for equal bounds: both read ``infeasible`` (a feasibility
    LP proves it), as every other backend says, where they read ``solver_error``."""
    if backend not in to.available_backends():
        pytest.skip(f"{backend} not installed")
    rng = np.random.default_rng(0)
    low, high = study.anchors.min(axis=0), study.anchors.max(axis=0)
    poses = rng.uniform(low - [0.0, 0.0, 9.0], high - [0.0, 0.0, 0.5], (120, 3))
    for problem in ("min_sum", "min_max", to.TensionProblem("min_sum", t_min=3000.0,
                                                              t_max=3000.0)):
        got = to.distribute(study, poses, problem, backend)
        reference = to.distribute(study, poses, problem, "scipy:highs")
        assert (reference.status == to.Status.INFEASIBLE).sum() >= 10
        np.testing.assert_array_equal(got.status, reference.status)


def test_an_unbounded_verdict_on_an_objective_bounded_below_is_checked(
        study: to.CableRobot) -> None:
    """A solver's ``unbounded`` on a problem whose objective is bounded below on its
    bounds cannot be right: a feasibility LP makes it ``infeasible`` where proven, else
    ``solver_error`` with a message. A problem that can be unbounded (a negative cost
    on a variable without an upper bound) keeps the verdict."""
    from dataclasses import replace

    from tension_opt.backends.base import RawResult
    from tension_opt.backends.feasibility import settle_failures
    from tension_opt.status import status_array

    rng = np.random.default_rng(0)
    low, high = study.anchors.min(axis=0), study.anchors.max(axis=0)
    poses = rng.uniform(low - [0.0, 0.0, 9.0], high - [0.0, 0.0, 0.5], (60, 3))
    exact = to.distribute(study, poses, "min_sum", "closed_form")
    feasible = int(np.flatnonzero(exact.status == to.Status.OPTIMAL)[0])
    infeasible = int(np.flatnonzero(exact.status == to.Status.INFEASIBLE)[0])
    form = to.TensionProblem("min_norm").standard_form(study, poses[[feasible, infeasible]])
    for kind, expected in ((form, [to.Status.SOLVER_ERROR, to.Status.INFEASIBLE]),
                           (replace(form, q=np.zeros_like(form.q), c=-np.ones_like(form.c)),
                            [to.Status.UNBOUNDED, to.Status.UNBOUNDED])):
        raw = RawResult(np.ones((2, 4)), status_array(2, to.Status.UNBOUNDED),
                        np.zeros(2, dtype=int))
        settle_failures(kind, raw)
        assert raw.status.tolist() == expected
        if expected[0] == to.Status.SOLVER_ERROR:
            assert np.isnan(raw.tensions).all()
            assert "said unbounded" in raw.extras["errors"][0]
            assert 1 not in raw.extras["errors"]
    # Clarabel on a reference of 1e19 N (a feasible problem) said unbounded.
    if "cvxpy:CLARABEL" in to.available_backends():
        sol = to.distribute(study, poses[exact.success][:20], to.TensionProblem(
            "min_norm", reference=1e19), "cvxpy:CLARABEL")
        assert not (sol.status == to.Status.UNBOUNDED).any()
