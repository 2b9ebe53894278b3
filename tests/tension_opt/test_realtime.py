"""The compiled real-time path against the numpy reference.

Geometry kernels against :meth:`CableRobot.structure_matrices` / ``required_wrench``;
the :class:`tension_opt.Distributor` against :func:`tension_opt.distribute` (statuses
and tensions) one pose at a time, in batches and along smoothed streams; threads.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt import presets
from tension_opt.kernels.geometry import geometry_batch, kind_code

SETTINGS = settings(max_examples=25, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
REL = 1e-12


def suspended_robot(seed: int, m: int, kind: str) -> to.CableRobot:
    """A random suspended robot: drawing points scattered around a ring of radius
    5..20 m at heights 4..10 m, a point mass (``"point3"``) or a body (``"spatial6"``,
    attachments on the upper half of a box facing their drawing points) of 20..500 kg,
    ``t_min`` 2..30 % of the weight, ``t_max`` infinite or 3..8 times it."""
    rng = np.random.default_rng(seed)
    radius, height = rng.uniform(5.0, 20.0), rng.uniform(4.0, 10.0)
    angles = np.sort(rng.uniform(0.0, 2 * np.pi, m))
    ring = radius * rng.uniform(0.85, 1.15, m)
    anchors = np.column_stack([ring * np.cos(angles), ring * np.sin(angles),
                               height * rng.uniform(0.85, 1.15, m)])
    attachments = np.zeros((m, 3))
    if kind == "spatial6":
        half = rng.uniform(0.2, 0.6)
        attachments = rng.uniform(-half, half, (m, 3))
        attachments[:, 2] = np.abs(attachments[:, 2])
        attachments[:, :2] = np.abs(attachments[:, :2]) * np.sign(anchors[:, :2])
    mass = rng.uniform(20.0, 500.0)
    weight = mass * 9.81
    t_max = np.inf if rng.random() < 0.5 else weight * rng.uniform(3.0, 8.0)
    return to.CableRobot(anchors, attachments, mass, kind=kind,
                         t_min=weight * rng.uniform(0.02, 0.3), t_max=t_max)


def planar_robot(seed: int, m: int) -> to.CableRobot:
    """A random planar rigid body (pose x, y, theta) with ``m`` cables."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0, 2 * np.pi, m))
    anchors = np.column_stack([3 * np.cos(angles), 3 * np.sin(angles), np.zeros(m)])
    attachments = np.column_stack([0.3 * np.cos(angles + rng.uniform(-.3, .3, m)),
                                   0.3 * np.sin(angles + rng.uniform(-.3, .3, m)),
                                   np.zeros(m)])
    return to.CableRobot(anchors, attachments, rng.uniform(1, 20), kind="planar3", g=0.0,
                         t_min=rng.uniform(1, 20), t_max=rng.choice([np.inf, 500.0]))


def xz_robot(seed: int, m: int) -> to.CableRobot:
    """A random point mass in the vertical xz plane with ``m`` cables."""
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(-5, 5, m))
    anchors = np.column_stack([x, np.zeros(m), rng.uniform(3, 6, m)])
    return to.CableRobot(anchors, np.zeros((m, 3)), rng.uniform(1, 50), kind="planar_point2",
                         t_min=rng.uniform(0, 30), t_max=rng.choice([np.inf, 2000.0]))


def any_robot(kind: str, seed: int, m: int) -> to.CableRobot:
    if kind in ("point3", "spatial6"):
        return suspended_robot(seed, m, kind)
    return planar_robot(seed, m) if kind == "planar3" else xz_robot(seed, m)


def poses_of(robot: to.CableRobot, seed: int, count: int = 12) -> np.ndarray:
    """Poses in and around the workspace (many infeasible), plus a degenerate one."""
    rng = np.random.default_rng(seed)
    top = float(robot.anchors[:, 2].max())
    radius = float(np.abs(robot.anchors[:, :2]).max())
    if robot.kind in ("point3", "spatial6"):
        p = np.column_stack([rng.uniform(-0.8, 0.8, (count, 2)) * radius,
                             rng.uniform(0.05, 0.95, count) * top])
        if robot.kind == "spatial6":
            p = np.column_stack([p, rng.uniform(-0.3, 0.3, (count, 3))])
            p[0, 3:] = [1e-5, -2e-4, 3e-4]  # the small-angle series of the rotation
    elif robot.kind == "planar3":
        p = np.column_stack([rng.uniform(-1.5, 1.5, (count, 2)), rng.uniform(-.5, .5, count)])
    else:
        p = np.column_stack([rng.uniform(-0.8, 0.8, count) * radius,
                             rng.uniform(0.05, 0.95, count) * top])
    return p


KINDS = [("point3", 4), ("point3", 5), ("spatial6", 7), ("spatial6", 8), ("planar3", 4),
         ("planar3", 5), ("planar_point2", 3), ("planar_point2", 4)]


@SETTINGS
@given(st.sampled_from(KINDS), st.integers(0, 10_000))
def test_geometry_kernel_matches_the_robot(shape, seed):
    kind, m = shape
    robot = any_robot(kind, seed, m)
    p = poses_of(robot, seed)
    wrench = np.random.default_rng(seed).normal(size=(len(p), robot.dof)) * 10
    A = np.empty((len(p), robot.dof, m))
    b = np.empty((len(p), robot.dof))
    codes = np.empty(len(p), dtype=np.int64)
    geometry_batch(kind_code(robot.kind), robot.anchors, np.array(robot.attachments),
                   np.array(robot.com), robot.mass * robot.g, 1e-12, p, wrench, A, b, codes)
    assert (codes == 0).all()
    A_ref = robot.structure_matrices(p)
    b_ref = robot.required_wrench(p, wrench)
    np.testing.assert_allclose(A, A_ref, rtol=0, atol=REL * np.abs(A_ref).max())
    np.testing.assert_allclose(b, b_ref, rtol=0, atol=REL * np.abs(b_ref).max())


def assert_same(result: to.RealtimeResult, sol: to.TensionSolution) -> None:
    """Statuses equal; tensions equal to 1e-12 of the largest tension of the pose."""
    np.testing.assert_array_equal(np.asarray(result.status, dtype=str).reshape(-1),
                                  sol.status.astype(str))
    T = np.atleast_2d(result.tensions)
    scale = np.nanmax(np.abs(sol.tensions), axis=1, initial=1.0)[:, None]
    np.testing.assert_array_equal(np.isnan(T), np.isnan(sol.tensions))
    ok = np.isfinite(sol.tensions)
    assert (np.abs(T - sol.tensions)[ok] <= (REL * np.broadcast_to(scale, T.shape))[ok]).all()
    np.testing.assert_array_equal(np.atleast_1d(result.unique), sol.unique)
    infeasible = sol.status == to.Status.INFEASIBLE
    np.testing.assert_allclose(np.atleast_1d(result.infeasibility)[infeasible],
                               sol.infeasibility[infeasible], rtol=1e-9, atol=1e-9)


OBJECTIVES = ["min_sum", "min_norm", "pinv", "centered", "min_max"]


@SETTINGS
@given(st.sampled_from(KINDS), st.integers(0, 10_000), st.sampled_from(OBJECTIVES))
def test_distributor_equals_distribute(shape, seed, objective):
    kind, m = shape
    robot = any_robot(kind, seed, m)
    if objective == "centered" and not np.isfinite(robot.t_max).all():
        robot = robot.with_(t_max=50 * robot.t_min + 100.0)
    p = poses_of(robot, seed)
    solver = to.Distributor(robot, objective)
    sol = to.distribute(robot, p, objective, "auto")
    assert_same(solver(p), sol)
    for k in range(3):  # one pose at a time, the same answers
        one = solver(p[k])
        assert one.tensions.shape == (m,)
        assert isinstance(one.status, to.Status)
        assert_same(one, to.distribute(robot, p[k], objective, "auto"))


def test_distributor_on_the_study_robot_and_cogiro():
    for robot in (presets.algae_harvester(), presets.cogiro()):
        p = poses_of(robot, 3, 40)
        for objective in ("min_sum", "min_norm"):
            solver = to.Distributor(robot, objective, "closed_form")
            sol = to.distribute(robot, p, objective, "closed_form")
            assert_same(solver(p), sol)
            assert sol.success.any() and (~sol.success).any()  # both kinds of pose
            assert_same(solver(p[0]), to.distribute(robot, p[0], objective, "closed_form"))


def test_strided_read_only_and_integer_poses_answer_as_contiguous_ones():
    # The one-pose path calls the kernel's machine code without numba's type checks,
    # so every other array type must reach it as a contiguous float64 vector.
    robot = presets.cogiro()
    p = poses_of(robot, 11, 6)
    solver = to.Distributor(robot, "min_norm", "closed_form")
    wide = np.zeros((len(p), 2 * robot.dof))
    wide[:, ::2] = p
    read_only = p.copy()
    read_only.flags.writeable = False
    previous = np.zeros((robot.m, 2))
    previous[:, 0] = 3000.0
    streamed = to.Distributor(robot, to.TensionProblem("min_norm", smoothing=0.1),
                              "closed_form")
    for k in range(len(p)):
        expected = solver(p[k].copy())
        for pose in (wide[k, ::2], read_only[k], list(p[k])):
            assert_same(solver(pose), to.distribute(robot, p[k], "min_norm", "closed_form"))
            np.testing.assert_array_equal(solver(pose).tensions, expected.tensions)
        np.testing.assert_array_equal(
            streamed(wide[k, ::2], previous=previous[:, 0]).tensions,
            streamed(p[k].copy(), previous=previous[:, 0].copy()).tensions)
    integer = to.Distributor(presets.algae_harvester(), "min_sum", "closed_form")
    np.testing.assert_array_equal(integer(np.array([1, 2, 3])).tensions,
                                  integer(np.array([1.0, 2.0, 3.0])).tensions)


def test_singular_and_degenerate_poses_go_through_the_numpy_path():
    robot = presets.algae_harvester()
    anchors_height = robot.anchors[0, 2]
    p = np.array([[0.0, 0.0, anchors_height],  # every cable horizontal: rank lost
                  [*robot.anchors[0, :2], anchors_height - 1.0]])
    solver = to.Distributor(robot, "min_sum")
    result = solver(p)
    assert_same(result, to.distribute(robot, p, "min_sum"))
    assert not result.compiled[0]
    with pytest.raises(to.InvalidInputError, match="zero-length"):
        solver(robot.anchors[0])


@pytest.mark.parametrize("problem", [
    to.TensionProblem("min_sum", smoothing=1e-3),
    to.TensionProblem("min_norm", smoothing=0.5, rate_limit=200.0),
    to.TensionProblem("min_sum", rate_limit=300.0),
])
def test_streams_match_the_sequential_mode_of_distribute(problem):
    robot = presets.algae_harvester()
    t = np.linspace(0, 1, 60)
    home = robot.default_home()
    path = home + np.column_stack([8 * np.sin(6 * t), 6 * np.cos(5 * t) - 6, 0 * t])
    reference = to.distribute(robot, path, problem)
    solver = to.Distributor(robot, problem)
    assert_same(solver(path), reference)  # one call on the whole stream
    solver.reset()
    rows = [solver(pose) for pose in path]  # pose by pose, the stream kept inside
    for k, row in enumerate(rows):
        assert row.status == reference.status[k]
        np.testing.assert_allclose(row.tensions, reference.tensions[k], rtol=REL, atol=0)
    start = reference.tensions[10]
    np.testing.assert_allclose(solver(path[11], previous=start).tensions,
                               to.distribute(robot, path[11:12], problem,
                                             previous=start).tensions[0], rtol=REL)


@pytest.mark.parametrize("problem", [
    to.TensionProblem("min_sum", smoothing=1e-3),
    to.TensionProblem("min_norm", smoothing=0.5, rate_limit=200.0),
    to.TensionProblem("min_sum"),
])
@pytest.mark.parametrize("wrench", [[3.0, -2.0, -50.0], [10.0, 0.0, 0.0]])
def test_a_batch_with_one_wrench_keeps_it_on_the_poses_the_numpy_path_answers(problem,
                                                                             wrench):
    """A batch (N, n) with one wrench (n,) for every pose: the poses the compiled loop
    hands to the numpy path (every cable horizontal at the drawing points' height: the
    structure matrix loses its vertical row) hold the wrench as single calls and
    ``distribute`` do. Without gravity the wrench is the whole load: pulling down, the
    poses below are optimal and those at the drawing points' height infeasible; pulling
    sideways, the other way round."""
    robot = presets.algae_harvester(g=0.0)
    top = robot.anchors[0, 2]
    t = np.linspace(0.0, 1.0, 12)
    path = np.column_stack([6 * np.sin(4 * t), 4 * np.cos(3 * t), 3.0 + 0 * t])
    path[[3, 4, 8], 2] = top
    w = np.array(wrench)
    got = to.Distributor(robot, problem)(path, wrench=w)
    assert not got.compiled[[3, 4, 8]].any() and got.compiled[[0, 1, 2, 5, 6, 7]].all()
    single = to.Distributor(robot, problem)
    last = None  # pose by pose as a stream: smoothed against the last optimal answer
    for k, pose in enumerate(path):
        prev = last if problem.is_sequential else None
        expected = to.distribute(robot, pose, problem, wrench=w, previous=prev)
        one = single(pose, wrench=w)
        for answer in (got.status[k], one.status):
            assert answer == expected.status[0], k
        for tensions in (got.tensions[k], one.tensions):
            np.testing.assert_allclose(tensions, expected.tensions[0], rtol=0, atol=1e-9)
        if expected.status[0] == to.Status.OPTIMAL:
            last = expected.tensions[0]
            A = robot.structure_matrices(pose)[0]
            b = robot.required_wrench(pose, w)[0]
            assert np.linalg.norm(A @ got.tensions[k] - b) <= 1e-9 * np.linalg.norm(w)
    assert (got.status == to.Status.OPTIMAL).sum() >= 3  # both kinds of answer seen
    assert (got.status == to.Status.INFEASIBLE).sum() >= 3


def test_other_backends_fall_back_to_distribute():
    robot = presets.cogiro()
    p = poses_of(robot, 1, 5)
    # An LP through DAQP needs the two-stage tie-break: the numpy path answers.
    solver = to.Distributor(robot, "min_sum", "qpsolvers:daqp")
    reference = to.distribute(robot, p, "min_sum", "qpsolvers:daqp")
    result = solver(p)
    np.testing.assert_array_equal(result.status.astype(str), reference.status.astype(str))
    np.testing.assert_allclose(result.tensions, reference.tensions, rtol=1e-6)
    assert not result.compiled.any()
    one = solver(p[0])
    assert not one.compiled
    np.testing.assert_allclose(one.tensions, reference.tensions[0], rtol=1e-6)


DAQP_REL = 1e-9  # DAQP stops at its tolerances; its active set makes the rest exact


@SETTINGS
@given(st.sampled_from(KINDS), st.integers(0, 10_000),
       st.sampled_from(["min_norm", "pinv", "centered"]), st.booleans())
def test_daqp_path_equals_distribute_through_daqp(shape, seed, objective, warm):
    kind, m = shape
    robot = any_robot(kind, seed, m)
    if not np.isfinite(robot.t_max).all():
        robot = robot.with_(t_max=50 * robot.t_min + 100.0)
    p = poses_of(robot, seed)
    solver = to.Distributor(robot, objective, "qpsolvers:daqp", warm_start=warm)
    reference = to.distribute(robot, p, objective, "qpsolvers:daqp")
    exact = to.distribute(robot, p, objective, "closed_form") if m - robot.dof <= 2 else None
    compiled = 0
    for k in range(len(p)):  # pose by pose, each warm-started from the one before
        one = solver(p[k])
        assert one.status == reference.status[k]
        assert one.tensions.shape == (m,)
        if one.status != to.Status.OPTIMAL:
            assert np.isnan(one.tensions).all()
            continue
        compiled += one.compiled
        scale = np.abs(reference.tensions[k]).max()
        assert np.abs(one.tensions - reference.tensions[k]).max() <= DAQP_REL * scale
        if exact is not None and exact.success[k]:
            assert np.abs(one.tensions - exact.tensions[k]).max() <= DAQP_REL * scale
        assert one.residual <= 1e-9 * max(1.0, scale)
    assert compiled >= reference.success.sum() // 2  # most optimal poses stayed compiled


def test_daqp_path_on_the_study_robot_and_cogiro_with_a_stream():
    problem = to.TensionProblem("min_sum", smoothing=1e-3)  # quadratic once a stream runs
    for robot in (presets.algae_harvester(), presets.cogiro()):
        t = np.linspace(0, 1, 30)
        path = robot.default_home() + np.column_stack(
            [2 * np.sin(3 * t), np.cos(2 * t) - 1, 0 * t] + [0 * t] * (robot.dof - 3))
        reference = to.distribute(robot, path, problem, "qpsolvers:daqp")
        solver = to.Distributor(robot, problem, "qpsolvers:daqp", accuracy="high")
        rows = [solver(pose) for pose in path]
        assert not rows[0].compiled  # the first pose of a stream is an LP
        assert all(row.compiled for row in rows[1:] if row.status == to.Status.OPTIMAL)
        for k, row in enumerate(rows):
            assert row.status == reference.status[k]
            np.testing.assert_allclose(row.tensions, reference.tensions[k], rtol=1e-7)


def test_a_daqp_stream_in_one_call_answers_as_its_poses_one_by_one():
    """A batch of a smoothed stream on the compiled DAQP path runs its poses in order
    through the compiled call: the same answers, bit for bit, as calling the poses one
    by one, a stream that goes on after it, and ``previous`` and wrenches as given."""
    problem = to.TensionProblem("min_sum", smoothing=1e-2)
    for robot in (presets.algae_harvester(), presets.cogiro()):
        t = np.linspace(0, 1, 40)
        path = robot.default_home() + np.column_stack(
            [2 * np.sin(3 * t), np.cos(2 * t) - 1, 0 * t] + [0 * t] * (robot.dof - 3))
        wrench = np.zeros((len(path), robot.dof))
        wrench[:, 0] = 50.0 * np.sin(5 * t)
        reference = to.distribute(robot, path, problem, "qpsolvers:daqp", wrench=wrench)
        one_by_one = to.Distributor(robot, problem, "qpsolvers:daqp")
        rows = [one_by_one(pose, wrench=w) for pose, w in zip(path, wrench, strict=True)]
        batch = to.Distributor(robot, problem, "qpsolvers:daqp")
        got = batch(path, wrench=wrench)
        np.testing.assert_array_equal(got.tensions, [row.tensions for row in rows])
        assert [str(s) for s in got.status] == [row.status.value for row in rows]
        np.testing.assert_array_equal(got.compiled, [row.compiled for row in rows])
        np.testing.assert_array_equal(got.residual, [row.residual for row in rows])
        assert not got.compiled[0] and got.compiled[1:].all()  # the first pose is an LP
        np.testing.assert_array_equal(got.status, reference.status)
        np.testing.assert_allclose(got.tensions, reference.tensions, rtol=1e-7)
        # The stream goes on from the batch's last answer, as after single calls.
        np.testing.assert_array_equal(batch(path[0]).tensions, one_by_one(path[0]).tensions)
        # A given start: every pose smoothed, the first against it.
        start = reference.tensions[-1]
        fresh = to.Distributor(robot, problem, "qpsolvers:daqp")
        from_start = fresh(path, previous=start)
        assert from_start.compiled.all()
        expected = to.distribute(robot, path, problem, "qpsolvers:daqp", previous=start)
        np.testing.assert_allclose(from_start.tensions, expected.tensions, rtol=1e-7)
        with pytest.raises(to.InvalidInputError, match="previous"):
            fresh(path, previous=start[:-1])


def test_one_instance_shared_by_threads_answers_as_alone(in_threads):
    robot = presets.cogiro()
    p = poses_of(robot, 7, 200)
    solver = to.Distributor(robot, "min_norm")
    expected = to.distribute(robot, p, "min_norm").tensions
    out = np.full((4, len(p), robot.m), -1.0)

    def work(k: int) -> None:
        for i in range(len(p)):
            out[k, i] = solver(p[i]).tensions

    in_threads(work, 4)
    for k in range(4):
        np.testing.assert_allclose(out[k], expected, rtol=REL, atol=REL * 1e4)


def test_streams_are_kept_per_thread():
    robot = presets.algae_harvester()
    problem = to.TensionProblem("min_sum", smoothing=1e-3)
    home = robot.default_home()
    path_a = home + np.outer(np.linspace(0, 1, 20), [5.0, 0, 0])
    path_b = home + np.outer(np.linspace(0, 1, 20), [0, -5.0, 0])
    solver = to.Distributor(robot, problem)
    got: dict[str, np.ndarray] = {}

    def work(name: str, path: np.ndarray) -> None:
        got[name] = np.array([solver(pose).tensions for pose in path])

    threads = [threading.Thread(target=work, args=a) for a in (("a", path_a), ("b", path_b))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    np.testing.assert_allclose(got["a"], to.distribute(robot, path_a, problem).tensions,
                               rtol=REL)
    np.testing.assert_allclose(got["b"], to.distribute(robot, path_b, problem).tensions,
                               rtol=REL)


def test_bad_input_raises_the_package_error():
    robot = presets.algae_harvester()
    solver = to.Distributor(robot)
    with pytest.raises(to.InvalidInputError, match="poses"):
        solver([np.nan, 0.0, 1.0])
    with pytest.raises(to.InvalidInputError, match="wrench"):
        solver(robot.default_home(), wrench=[0.0, np.inf, 0.0])
    with pytest.raises(to.InvalidInputError, match="robot"):
        to.Distributor("robot")  # type: ignore[arg-type]
