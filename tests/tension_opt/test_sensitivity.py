"""Sensitivities of a tension solution against finite differences of the solver itself,
against cvxpy's derivative of the same problem, and at poses where they do not exist."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.workspace.sampling import random_feasible_poses

SETTINGS = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
WRT = ("wrench", "pose", "t_min", "t_max", "drawing_points", "attachment_points")
#: Relative step of the central differences.
STEP = 1e-6


def _solve(robot, poses, objective, backend, wrench=None, **fields):
    problem = to.TensionProblem(objective, **fields)
    return to.distribute(robot, poses, problem, backend, wrench=wrench, accuracy="high")


def finite_difference(robot, poses, objective, wrt, backend="closed_form", **fields):
    """Central differences of the solver's tensions, shaped as the Jacobian of ``wrt``."""
    N, n, m = len(poses), robot.dof, robot.m

    def diff(plus, minus, h):
        return (plus.tensions - minus.tensions) / (2 * h)

    if wrt == "wrench":
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = h = STEP * robot.weight
            cols.append(
                diff(
                    _solve(robot, poses, objective, backend, e, **fields),
                    _solve(robot, poses, objective, backend, -e, **fields),
                    h,
                )
            )
        return np.stack(cols, -1)
    if wrt == "pose":
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = h = STEP * max(1.0, np.abs(poses[:, j]).max())
            cols.append(
                diff(
                    _solve(robot, poses + e, objective, backend, **fields),
                    _solve(robot, poses - e, objective, backend, **fields),
                    h,
                )
            )
        return np.stack(cols, -1)
    if wrt in ("t_min", "t_max"):
        base = np.broadcast_to(fields.get(wrt, getattr(robot, wrt)), (N, m)).astype(float)
        cols = []
        for i in range(m):
            if not np.isfinite(base[:, i]).all():  # an absent bound moves nothing
                cols.append(np.zeros((N, m)))
                continue
            h = STEP * max(robot.weight, np.abs(base[:, i]).max())
            up, down = base.copy(), base.copy()
            up[:, i] += h
            down[:, i] -= h
            cols.append(
                diff(
                    _solve(robot, poses, objective, backend, **{**fields, wrt: up}),
                    _solve(robot, poses, objective, backend, **{**fields, wrt: down}),
                    h,
                )
            )
        return np.stack(cols, -1)
    name = "anchors" if wrt == "drawing_points" else "attachments"
    out = np.zeros((N, m, m, 3))
    for i in range(m):
        for c in range(3):
            h = STEP * max(1.0, np.abs(getattr(robot, name)).max())
            moved = []
            for sign in (1, -1):
                points = getattr(robot, name).copy()
                points[i, c] += sign * h
                moved.append(
                    _solve(robot.with_(**{name: points}), poses, objective, backend, **fields)
                )
            out[:, :, i, c] = diff(*moved, h)
    return out


def relative_error(sens, reference) -> float:
    """Largest error over the poses whose derivative exists, relative to the largest
    entry of the reference Jacobian (or 1 where that is zero)."""
    ok = sens.ok
    if not ok.any():
        return 0.0
    scale = max(np.abs(reference[ok]).max(), 1e-9)  # below: a Jacobian that is zero
    return float(np.abs(sens.jacobian[ok] - reference[ok]).max() / scale)


def check(robot, poses, objective, wrts=WRT, backend="closed_form", tol=1e-6, **fields):
    sol = _solve(robot, poses, objective, backend, **fields)
    for wrt in wrts:
        if wrt in ("t_min", "t_max") and objective == "pinv":
            continue
        sens = sol.jacobian(wrt, robot=robot, poses=poses)
        assert sens.jacobian.shape[:2] == (len(poses), robot.m)
        assert np.isnan(sens.jacobian[~sens.ok]).all()
        fd = finite_difference(robot, poses, objective, wrt, backend, **fields)
        assert relative_error(sens, fd) <= tol, (objective, wrt)
    return sol


# --------------------------------------------------------------- the study's robots
@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max", "centered", "pinv"])
def test_study_robot_against_finite_differences(objective):
    fields = {"t_max": 30000.0} if objective == "centered" else {}
    robot = to.presets.algae_harvester()
    poses = random_feasible_poses(robot, 12, seed=3)
    sol = check(robot, poses, objective, **fields)
    assert sol.jacobian("wrench").ok.mean() > 0.9


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "centered", "pinv"])
def test_cogiro_against_finite_differences(objective):
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 8, seed=4)
    poses[:, 3:] += np.random.default_rng(4).uniform(-0.05, 0.05, (8, 3))  # turned platforms
    check(robot, poses, objective)


def test_cogiro_min_max_from_an_active_set_solver():
    # The closed form solves min-max for one-dimensional null spaces only: DAQP (an
    # active-set solver, exact to rounding) solves it and its differences.
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 6, seed=5)
    check(robot, poses, "min_max", ("wrench", "pose", "t_min"), backend="qpsolvers:daqp")


def test_generic_backend_multipliers_give_the_closed_form_jacobian():
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 6, seed=6)
    for objective in ("min_sum", "min_norm"):
        exact = to.distribute(robot, poses, objective, "closed_form")
        ipm = to.distribute(robot, poses, objective, "qpsolvers:clarabel", accuracy="high")
        for wrt in ("wrench", "pose"):
            a = exact.jacobian(wrt, robot=robot, poses=poses)
            b = ipm.jacobian(wrt, robot=robot, poses=poses)
            both = a.ok & b.ok
            assert both.sum() >= 4
            scale = np.abs(a.jacobian[both]).max()
            assert np.abs(a.jacobian[both] - b.jacobian[both]).max() <= 1e-6 * scale


# ------------------------------------------------------------------ random robots
@st.composite
def random_robot(draw, m=4):
    """A point mass under ``m`` anchors of a random frame, bounds active or not."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    angles = np.linspace(0, 2 * np.pi, m, endpoint=False) + rng.uniform(-0.3, 0.3, m)
    radius, height = rng.uniform(2, 50), rng.uniform(1, 20)
    anchors = np.column_stack(
        [radius * np.cos(angles), radius * np.sin(angles), height * rng.uniform(0.9, 1.1, m)]
    )
    mass = rng.uniform(1, 500)
    robot = to.CableRobot(
        anchors,
        np.zeros((m, 3)),
        mass,
        t_min=rng.uniform(0, 0.5) * mass * 9.81,
        t_max=rng.uniform(2, 20) * mass * 9.81,
    )
    poses = np.column_stack(
        [rng.uniform(-0.4, 0.4, (6, 2)) * radius, height * rng.uniform(0.1, 0.8, 6)]
    )
    return robot, poses


@SETTINGS
@given(random_robot(), st.sampled_from(["min_sum", "min_norm", "min_max", "centered"]))
def test_random_robots_against_finite_differences(case, objective):
    robot, poses = case
    solved = to.distribute(robot, poses, objective, "closed_form").success
    assume(solved.sum() >= 2)
    check(robot, poses[solved], objective, ("wrench", "pose", "t_min", "t_max", "drawing_points"))


@SETTINGS
@given(random_robot(m=5), st.sampled_from(["min_sum", "min_norm"]))
def test_random_five_cable_robots_against_finite_differences(case, objective):
    robot, poses = case
    solved = to.distribute(robot, poses, objective, "closed_form").success
    assume(solved.sum() >= 2)
    check(robot, poses[solved], objective, ("wrench", "pose", "t_min"))


@SETTINGS
@given(random_robot(), st.sampled_from(["min_sum", "min_norm", "centered"]))
def test_random_robots_compiled_jacobian_is_the_numpy_one(case, objective):
    """A batch solved in chunks (no form kept) takes the compiled kernel, with its
    four-cable lanes; the whole batch the numpy path: the same statuses and numbers."""
    robot, poses = case
    whole = to.distribute(robot, poses, objective, "closed_form")
    chunked = to.distribute(robot, poses, objective, "closed_form", chunk_size=2)
    assume(whole.success.sum() >= 2)
    for wrt in ("wrench", "pose"):
        a = whole.jacobian(wrt, robot=robot, poses=poses)
        b = chunked.jacobian(wrt, robot=robot, poses=poses)
        np.testing.assert_array_equal(a.status, b.status)
        ok = a.ok
        scale = max(np.abs(a.jacobian[ok]).max(initial=0.0), 1e-12)
        np.testing.assert_allclose(b.jacobian[ok], a.jacobian[ok], rtol=0, atol=1e-9 * scale)
        assert np.isnan(b.jacobian[~ok]).all()


# ------------------------------------------------------- where no derivative exists
def test_symmetric_min_sum_is_non_unique():
    robot = to.presets.algae_harvester()
    centre = robot.anchors.mean(axis=0)
    poses = np.array([[centre[0], centre[1], 1.0]])
    sol = to.distribute(robot, poses, "min_sum", "closed_form")
    assert not sol.unique[0]
    sens = sol.jacobian("wrench")
    assert list(sens.status) == ["non_unique"] and np.isnan(sens.jacobian).all()


def test_a_bound_just_touching_is_degenerate():
    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 6, seed=7)
    free = to.distribute(robot, poses, to.TensionProblem("min_norm", t_min=0.0), "closed_form")
    low = free.tensions.min(axis=1)
    for factor in (1.0, 1.0 - 1e-9, 1.0 + 1e-9):  # on the bound, just inside, just past
        t_min = np.tile((low * factor)[:, None], (1, robot.m))
        sol = to.distribute(robot, poses, to.TensionProblem("min_norm", t_min=t_min), "closed_form")
        sens = sol.jacobian("t_min")
        assert (sens.status == "degenerate").all(), factor
        assert np.isnan(sens.jacobian).all()


@SETTINGS
@given(random_robot(), st.sampled_from(["min_norm", "centered"]), st.floats(-1e-5, 1e-5))
def test_near_a_kink_a_finite_jacobian_is_one_sided_right(case, objective, offset):
    """Bounds set near the unbounded optimum's smallest tension: a finite answer must be
    the derivative on both sides (never a wrong number), else a non-ok status."""
    robot, poses = case
    free = to.distribute(robot, poses, to.TensionProblem(objective, t_min=0.0), "closed_form")
    # A smallest tension well above zero: the differences of t_min stay >= 0.
    ok = free.success & (free.tensions.min(axis=1) > 1e-3 * robot.weight)
    assume(ok.sum() >= 2)
    poses = poses[ok]
    t_min = np.tile((free.tensions[ok].min(axis=1) * (1 + offset))[:, None], (1, robot.m))
    sol = _solve(robot, poses, objective, "closed_form", t_min=t_min)
    sens = sol.jacobian("wrench")
    fd = finite_difference(robot, poses, objective, "wrench", t_min=t_min)
    assert relative_error(sens, fd) <= 1e-6


# ---------------------------------------------------------- cvxpy's own derivative
@pytest.mark.parametrize("objective", ["min_sum", "min_max", "min_norm"])
def test_against_cvxpy_derivative(objective):
    pytest.importorskip("diffcp", reason="cvxpy's derivative needs diffcp (pip install diffcp)")
    import cvxpy as cp

    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 3, seed=5)
    sol = to.distribute(robot, poses, objective, "auto", accuracy="high")
    ours = {wrt: sol.jacobian(wrt).jacobian for wrt in ("wrench", "t_min")}
    n, m = robot.dof, robot.m
    # diffcp differentiates the second-order cone of a quadratic objective only as
    # accurately as the cone solver solves it; the LPs are exact at their vertex.
    tol = 1e-5 if objective != "min_norm" else 1e-3
    for k in range(len(poses)):
        A = robot.structure_matrices(poses[k : k + 1])[0]
        b = robot.required_wrench(poses[k : k + 1])[0]
        t, w = cp.Variable(m), cp.Parameter(n)
        lo, hi = cp.Parameter(m), cp.Parameter(m)
        s = np.abs(b).max()
        cost = {
            "min_sum": cp.sum(t / s),
            "min_max": cp.max(t / s),
            "min_norm": cp.sum_squares(t / s),
        }[objective]
        problem = cp.Problem(cp.Minimize(cost), [A @ t == b - w, t >= lo, t <= hi])
        w.value, lo.value, hi.value = np.zeros(n), robot.t_min.copy(), robot.t_max.copy()
        problem.solve(
            requires_grad=True,
            mode="dense",
            solve_method="CLARABEL",
            tol_gap_abs=1e-10,
            tol_gap_rel=1e-10,
            tol_feas=1e-10,
        )
        theirs = {"wrench": np.zeros((m, n)), "t_min": np.zeros((m, m))}
        for wrt, param, size in (("wrench", w, n), ("t_min", lo, m)):
            for j in range(size):
                w.delta, lo.delta, hi.delta = np.zeros(n), np.zeros(m), np.zeros(m)
                param.delta = np.eye(size)[j]
                problem.derivative()
                theirs[wrt][:, j] = t.delta
        for wrt in ours:
            # Bounds move tensions one for one: their derivatives are of order one.
            scale = max(np.abs(ours[wrt]).max(), 1.0 if wrt == "t_min" else 0.0)
            assert np.abs(ours[wrt][k] - theirs[wrt]).max() <= tol * scale, (wrt, k)


# ------------------------------------------------------------------------ the API
def test_bad_input_is_named():
    robot = to.presets.algae_harvester()
    poses = random_feasible_poses(robot, 3, seed=1)
    sol = to.distribute(robot, poses, "min_norm", "closed_form")
    with pytest.raises(to.InvalidInputError, match="wrt must be one of"):
        sol.jacobian("speed")
    with pytest.raises(to.InvalidInputError, match="robot="):
        sol.jacobian("pose")
    with pytest.raises(to.InvalidInputError, match="poses that were solved"):
        sol.jacobian("pose", robot=robot, poses=poses + 1.0)
    from dataclasses import replace

    with pytest.raises(to.InvalidInputError, match="multipliers"):
        replace(sol, multipliers=None).jacobian("wrench")


def test_a_batch_solved_in_chunks_rebuilds_its_form():
    robot = to.presets.algae_harvester()
    poses = random_feasible_poses(robot, 40, seed=2)
    whole = to.distribute(robot, poses, "min_sum", "closed_form")
    chunked = to.distribute(robot, poses, "min_sum", "closed_form", chunk_size=16)
    assert chunked.form is None
    with pytest.raises(to.InvalidInputError, match="chunks"):
        chunked.jacobian("wrench")
    a = whole.jacobian("pose", robot=robot, poses=poses)
    b = chunked.jacobian("pose", robot=robot, poses=poses)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_allclose(
        a.jacobian, b.jacobian, rtol=1e-9, atol=1e-9 * np.abs(a.jacobian).max()
    )


def test_unsolved_poses_are_not_optimal():
    robot = to.presets.algae_harvester()
    poses = np.vstack([random_feasible_poses(robot, 2, seed=1), [[0.0, 0.0, -50.0]]])
    sol = to.distribute(robot, poses, "min_norm", "closed_form")
    sens = sol.jacobian("wrench")
    assert sens.status[-1] == "not_optimal" and np.isnan(sens.jacobian[-1]).all()
    assert sens.ok[:2].all()


@pytest.mark.parametrize("backend", ["closed_form", "cvxpy:CLARABEL"])
@pytest.mark.parametrize(("objective", "fields"), [
    ("min_norm", {"smoothing": 0.5}),
    ("min_sum", {"smoothing": 2e-4}),
    ("min_sum", {"rate_limit": 300.0}),
    ("min_norm", {"smoothing": 0.1, "rate_limit": 250.0}),
])
def test_previous_tensions_derivative_matches_differences(objective, fields, backend):
    """d T / d T_prev of smoothed and rate-limited poses (the smoothing's cost and the
    active rate-limit band), against Richardson-extrapolated central differences of the
    solver: the exact closed form, and a generic backend's certified multipliers."""
    robot = to.presets.algae_harvester()
    poses = np.array([[-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [3.0, -4.0, 2.0],
                      [10.0, 5.0, 1.0]])
    plain = to.distribute(robot, poses, "min_norm").tensions
    previous = plain + np.array([[400.0, -300.0, 200.0, -100.0]])
    problem = to.TensionProblem(objective, **fields)

    def solve(prev):
        return to.distribute(robot, poses, problem, backend, previous=prev, accuracy="high")

    J = solve(previous).jacobian("previous")
    assert J.jacobian.shape == (4, 4, 4)
    assert J.ok.all()
    h = 1e-3
    for j in range(4):
        e = np.zeros(4)
        e[j] = h
        d1 = (solve(previous + e).tensions - solve(previous - e).tensions) / (2 * h)
        d2 = (solve(previous + e / 2).tensions - solve(previous - e / 2).tensions) / h
        fd = (4 * d2 - d1) / 3
        np.testing.assert_allclose(J.jacobian[:, :, j], fd,
                                   atol=1e-7 if backend == "closed_form" else 1e-6)
    if "rate_limit" in fields:  # some tension rides its band: it follows T_prev one to one
        assert np.isclose(np.abs(J.jacobian), 1.0, atol=1e-9).any()


@pytest.mark.parametrize(("fields", "tol"), [({"rate_limit": 300.0}, 1e-5),
                                            ({"smoothing": 2e-4}, 1e-3)])
def test_previous_against_cvxpy_derivative(fields, tol):
    """d T / d T_prev against cvxpy's derivative of the same parametrised problem
    (diffcp): a rate-limited LP (exact at its vertex) and a smoothed min-sum QP (as
    accurate as the cone solver solves its second-order cone)."""
    pytest.importorskip("diffcp", reason="cvxpy's derivative needs diffcp (pip install diffcp)")
    import cvxpy as cp

    robot = to.presets.algae_harvester()
    poses = np.array([[-29.4, 10.2, 1.5], [35.0, 22.0, 5.0], [3.0, -4.0, 2.0]])
    shift = np.array([400.0, -300.0, 200.0, -100.0])
    previous = to.distribute(robot, poses, "min_norm").tensions + shift
    problem = to.TensionProblem("min_sum", **fields)
    ours = to.distribute(robot, poses, problem, "closed_form", previous=previous).jacobian(
        "previous")
    assert ours.ok.all()
    m = robot.m
    for k in range(len(poses)):
        A = robot.structure_matrices(poses[k : k + 1])[0]
        b = robot.required_wrench(poses[k : k + 1])[0]
        # In tensions over s (about the weight): the cone solver sees numbers near one.
        s = np.abs(b).max()
        x, prev = cp.Variable(m), cp.Parameter(m)
        cost = cp.sum(x)
        constraints = [A @ x == b / s, x >= robot.t_min / s]
        if "rate_limit" in fields:
            rate = fields["rate_limit"] / s
            constraints += [x >= prev - rate, x <= prev + rate]
        else:  # sum T + smoothing ||T - T_prev||^2, over s
            cost = cost + fields["smoothing"] * s * cp.sum_squares(x - prev)
        cvx = cp.Problem(cp.Minimize(cost), constraints)
        prev.value = previous[k] / s
        cvx.solve(requires_grad=True, mode="dense", solve_method="CLARABEL",
                  tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
        theirs = np.zeros((m, m))
        for j in range(m):
            prev.delta = np.eye(m)[j]
            cvx.derivative()
            theirs[:, j] = x.delta  # d(T/s)/d(T_prev/s) = dT/dT_prev
        assert np.abs(ours.jacobian[k] - theirs).max() <= tol * max(
            np.abs(ours.jacobian[k]).max(), 1.0), k


def test_previous_of_a_smoothed_path_is_each_poses_own_partial():
    """Along a smoothed path each pose was solved against the answer before it: its
    derivative by those previous tensions is the one-pose derivative there."""
    robot = to.presets.algae_harvester()
    path = np.column_stack([np.linspace(-20, 20, 30), np.linspace(-10, 10, 30),
                            np.full(30, 2.0)])
    problem = to.TensionProblem("min_norm", smoothing=0.5)
    sol = to.distribute(robot, path, problem, "closed_form")
    J = sol.jacobian("previous")
    assert J.ok.all()
    for k in (5, 17, 29):
        one = to.distribute(robot, path[k], problem, "closed_form",
                            previous=sol.tensions[k - 1]).jacobian("previous")
        np.testing.assert_allclose(J.jacobian[k], one.jacobian[0], atol=1e-12)
        h = 1e-3
        fd = np.zeros((4, 4))
        for j in range(4):
            e = np.zeros(4)
            e[j] = h
            ends = [to.distribute(robot, path[k], problem, "closed_form",
                                  previous=sol.tensions[k - 1] + sign * e).tensions[0]
                    for sign in (1.0, -1.0)]
            fd[:, j] = (ends[0] - ends[1]) / (2 * h)
        np.testing.assert_allclose(J.jacobian[k], fd, atol=1e-8)


def test_jacobian_chunks_give_the_same_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    """Large batches are differentiated in chunks: the same Jacobians and statuses."""
    robot = to.presets.cogiro()
    rng = np.random.default_rng(5)
    poses = np.column_stack([rng.uniform(-2, 2, (9, 2)), rng.uniform(1.5, 2.5, 9),
                             rng.uniform(-0.1, 0.1, (9, 3))])
    sol = to.distribute(robot, poses, "min_norm")
    whole = sol.jacobian("pose", robot=robot, poses=poses)
    monkeypatch.setattr("tension_opt.distribution.sensitivity.CHUNK", 4)
    parts = sol.jacobian("pose", robot=robot, poses=poses)
    np.testing.assert_array_equal(parts.status, whole.status)
    np.testing.assert_allclose(parts.jacobian, whole.jacobian, rtol=1e-12, atol=1e-9)
