"""The compiled path of the plain :func:`tension_opt.distribute` against the numpy path.

The closed-form backend with its compiled kernel (``ClosedFormBackend()``) against the
numpy reference (``ClosedFormBackend(compiled=False)``) on the same standard forms:
statuses, tensions to 1e-12 of the pose's largest tension, uniqueness and distance to
feasibility; the compiled geometry (:meth:`CableRobot.equilibrium`) against
:meth:`CableRobot.structure_matrices` and :meth:`~CableRobot.required_wrench`; and
calls from several threads at once and from a forked child process.
"""

from __future__ import annotations

import importlib
import multiprocessing as mp
import threading

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt import presets
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.backends.qpsolvers_backend import QpsolversBackend
from tension_opt.kernels import closed_form as kernels
from tension_opt.kernels import launch
from tension_opt.problem.form import StandardForm
from tension_opt.workspace.sampling import default_box, random_feasible_poses

SETTINGS = settings(max_examples=30, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
REL = 1e-12
COMPILED, NUMPY = ClosedFormBackend(), ClosedFormBackend(compiled=False)
#: (kind, cables) of the random robots: null spaces of dimension 1 and 2.
SHAPES = [("point3", 4), ("point3", 5), ("planar_point2", 3), ("planar_point2", 4),
          ("planar3", 4), ("planar3", 5), ("spatial6", 7), ("spatial6", 8)]


def random_robot(kind: str, m: int, seed: int) -> to.CableRobot:
    """A random robot of a kind: drawing points scattered around a ring (a line for
    ``planar_point2``), attachments on a small body facing them, 1..500 kg, ``t_min``
    up to 30 % of the weight, ``t_max`` infinite or a few weights."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0.0, 2 * np.pi, m))
    radius = rng.uniform(2.0, 20.0) * rng.uniform(0.85, 1.15, m)
    height = rng.uniform(3.0, 10.0) * rng.uniform(0.85, 1.15, m)
    attachments = np.zeros((m, 3))
    if kind == "planar_point2":
        anchors = np.column_stack([np.sort(rng.uniform(-radius, radius)), np.zeros(m), height])
    elif kind == "planar3":
        anchors = np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                                   np.zeros(m)])
        turn = angles + rng.uniform(-0.3, 0.3, m)
        attachments = 0.1 * radius.min() * np.column_stack([np.cos(turn), np.sin(turn),
                                                            np.zeros(m)])
    else:
        anchors = np.column_stack([radius * np.cos(angles), radius * np.sin(angles), height])
        if kind == "spatial6":
            half = rng.uniform(0.2, 0.6)
            attachments = rng.uniform(-half, half, (m, 3))
            attachments[:, 2] = np.abs(attachments[:, 2])
            attachments[:, :2] = np.abs(attachments[:, :2]) * np.sign(anchors[:, :2])
    mass = rng.uniform(1.0, 500.0)
    g = 0.0 if kind == "planar3" else 9.81
    weight = mass * max(g, 1.0)
    t_max = np.inf if rng.random() < 0.5 else weight * rng.uniform(3.0, 8.0)
    return to.CableRobot(anchors, attachments, mass, kind=kind, g=g,
                         t_min=weight * rng.uniform(0.0, 0.3), t_max=t_max)


def random_poses(robot: to.CableRobot, seed: int, count: int = 24) -> np.ndarray:
    """Poses in a box 20 % larger than the robot's default box (many infeasible)."""
    low, high = default_box(robot)
    mid, half = 0.5 * (low + high), 0.6 * (high - low)
    return np.random.default_rng(seed).uniform(mid - half, mid + half,
                                               (count, robot.dof))


def assert_same_raw(form: StandardForm) -> tuple[to.Status, ...]:
    """Both backends on ``form``: equal statuses, uniqueness, NaN patterns; tensions
    and distances to feasibility within 1e-12 of the pose's scale. Returns the
    statuses."""
    got, want = COMPILED.solve(form), NUMPY.solve(form)
    np.testing.assert_array_equal(got.status.astype(str), want.status.astype(str))
    np.testing.assert_array_equal(got.unique, want.unique)
    np.testing.assert_array_equal(np.isnan(got.tensions), np.isnan(want.tensions))
    scale = np.nanmax(np.abs(want.tensions), axis=1, initial=1.0)[:, None]
    ok = np.isfinite(want.tensions)
    gap = np.abs(got.tensions - want.tensions)
    assert (gap[ok] <= REL * np.broadcast_to(scale, gap.shape)[ok]).all(), gap.max()
    np.testing.assert_array_equal(np.isnan(got.infeasibility), np.isnan(want.infeasibility))
    known = np.isfinite(want.infeasibility)
    typical = form.typical_tension()
    assert (np.abs(got.infeasibility[known] - want.infeasibility[known])
            <= REL * np.maximum(want.infeasibility, typical)[known]).all()
    np.testing.assert_array_equal(np.isinf(got.infeasibility), np.isinf(want.infeasibility))
    return tuple(want.status)


def problem_of(robot: to.CableRobot, objective: str, N: int, rng: np.random.Generator,
               per_pose_bounds: bool, smoothing: bool) -> tuple[to.TensionProblem, object]:
    """A problem of the robot (bounds per pose, smoothing against previous tensions
    per pose where asked) and its previous tensions (or None)."""
    m = robot.m
    changes: dict = {}
    if per_pose_bounds and objective != "pinv":  # the pseudo-inverse takes no bounds
        t_min = np.asarray(robot.t_min) * rng.uniform(0.5, 1.5, (N, m))
        changes["t_min"] = t_min
        changes["t_max"] = t_min + robot.weight * rng.uniform(1.0, 8.0, (N, m))
    elif objective == "centered" and not np.isfinite(robot.t_max).all():
        changes["t_max"] = np.asarray(robot.t_min) + 5 * max(robot.weight, 1.0)
    previous = None
    if smoothing and objective != "min_max":
        changes["smoothing"] = float(rng.uniform(1e-4, 1.0))
        previous = rng.uniform(0.0, 3.0, (N, m)) * max(robot.weight, 1.0) / m
    return to.TensionProblem(objective, **changes), previous


OBJECTIVES = ["min_sum", "min_norm", "pinv", "centered", "min_max"]


@SETTINGS
@given(st.sampled_from(SHAPES), st.integers(0, 100_000), st.sampled_from(OBJECTIVES),
       st.booleans(), st.booleans(), st.booleans())
def test_compiled_closed_form_equals_numpy(shape, seed, objective, per_pose_bounds,
                                           smoothing, wrench):
    kind, m = shape
    robot = random_robot(kind, m, seed)
    p = random_poses(robot, seed)
    rng = np.random.default_rng(seed + 1)
    problem, previous = problem_of(robot, objective, len(p), rng, per_pose_bounds, smoothing)
    w = rng.normal(size=(len(p), robot.dof)) * robot.weight * 0.1 if wrench else None
    form = problem.standard_form(robot, p, w, previous)
    if COMPILED.unsupported(form) is not None:  # min-max in two dimensions
        assert objective == "min_max" and m - robot.dof == 2
        return
    assert_same_raw(form)
    # And through the plain call: the same solution as the numpy backend's.
    sol = to.distribute(robot, p, problem, "closed_form", wrench=w, previous=previous)
    ref = to.distribute(robot, p, problem, NUMPY, wrench=w, previous=previous)
    np.testing.assert_array_equal(sol.status.astype(str), ref.status.astype(str))
    np.testing.assert_allclose(sol.tensions, ref.tensions, rtol=REL,
                               atol=REL * np.nanmax(np.abs(ref.tensions), initial=1.0))


def test_random_batches_reach_every_status_the_closed_form_gives():
    # Guards the generators above: they make optimal and infeasible poses of both
    # null-space dimensions, so the agreement covers both.
    seen = set()
    for kind, m in SHAPES:
        for seed in range(3):
            robot = random_robot(kind, m, seed)
            form = to.TensionProblem("min_sum").standard_form(robot, random_poses(robot, seed))
            seen |= {(m - robot.dof, str(s)) for s in assert_same_raw(form)}
    assert {(1, "optimal"), (1, "infeasible"), (2, "optimal"), (2, "infeasible")} <= seen


def square_robot(kind: str = "point3") -> to.CableRobot:
    """Four drawing points on a square 10 m wide, 6 m up (a line of two for
    ``planar_point2``): the minimum sum is tied wherever the null vector sums to zero."""
    if kind == "planar_point2":
        anchors = np.array([[-5.0, 0, 6], [5.0, 0, 6], [-2.0, 0, 6], [2.0, 0, 6]])
        return to.CableRobot(anchors, np.zeros((4, 3)), 10.0, kind=kind, t_min=1.0)
    anchors = np.array([[-5.0, -5, 6], [5, -5, 6], [5, 5, 6], [-5, 5, 6]])
    return to.CableRobot(anchors, np.zeros((4, 3)), 10.0, t_min=1.0)


def test_ties_of_the_minimum_sum_are_broken_alike():
    robot = square_robot()
    # Under the square's centre the null vector is (1, -1, 1, -1): a flat slope, every
    # tension on the segment costs the same.
    z = np.linspace(0.5, 5.5, 7)
    p = np.concatenate([np.column_stack([0 * z, 0 * z, z]),
                        np.random.default_rng(3).uniform([-4, -4, 0], [4, 4, 5], (20, 3))])
    form = to.TensionProblem("min_sum").standard_form(robot, p)
    assert_same_raw(form)
    raw = COMPILED.solve(form)
    assert (~raw.unique[:7]).all() and raw.unique[7:].all()
    # The tie broken to the minimum 2-norm: the four tensions are equal.
    np.testing.assert_allclose(raw.tensions[:7], raw.tensions[:7, :1] + 0 * raw.tensions[:7],
                               rtol=1e-12)
    # A two-dimensional null space with ties: CoGiRo unrotated on its axes.
    cogiro = presets.cogiro()
    home = cogiro.default_home()
    q = home + np.column_stack([np.linspace(-1, 1, 9), np.zeros((9, 5))])
    assert_same_raw(to.TensionProblem("min_sum").standard_form(cogiro, q))
    assert_same_raw(to.TensionProblem("min_max").standard_form(robot, p))


def test_singular_poses_go_to_the_numpy_path():
    robot = presets.algae_harvester()
    top = robot.anchors[0, 2]
    center = robot.anchors[:, :2].mean(axis=0)
    p = np.array([[*center, top],  # every cable horizontal: rank lost, wrench outside
                  [*center, top - 1e-9],  # nearly so: badly conditioned
                  [*center, top - 2.0]])
    for objective in ("min_sum", "min_norm"):
        form = to.TensionProblem(objective).standard_form(robot, p)
        statuses = assert_same_raw(form)
        assert statuses[0] == to.Status.INFEASIBLE and statuses[2] == to.Status.OPTIMAL
        T, info, codes = np.empty((3, 4)), np.empty((3, 2)), np.empty(3, dtype=np.int64)
        kernels.solve_forms_serial(form.A, form.b, form.lb, form.ub, form.q, form.c,
                                   np.ones((1, 4)), False, form.kind == "qp", 1e-6,
                                   T, info, codes)
        assert codes.tolist()[:2] == [kernels.CODE_FALLBACK] * 2 and codes[2] == 0
    # A planar robot whose cables all lie along one line: singular with the wrench in
    # range (a solver error of the closed form, solved by the next backend in "auto").
    robot2 = to.CableRobot(np.array([[-5.0, 0, 5], [5, 0, 5], [-2, 0, 5]]), np.zeros((3, 3)),
                           1.0, kind="planar_point2", g=0.0)
    form = to.TensionProblem("min_norm").standard_form(robot2, np.array([[0.0, 5.0]]))
    assert assert_same_raw(form) == (to.Status.SOLVER_ERROR,)


def test_huge_wrenches_go_to_the_numpy_path():
    robot = presets.algae_harvester()
    p = np.repeat(robot.default_home()[None], 3, axis=0)
    for scale in (1e120, 1e160, 1e300):
        wrench = np.array([0.0, 0.0, -scale])
        form = to.TensionProblem("min_norm").standard_form(robot, p, wrench)
        assert assert_same_raw(form)[0] == to.Status.OPTIMAL


@SETTINGS
@given(st.sampled_from(SHAPES), st.integers(0, 100_000), st.booleans())
def test_compiled_geometry_equals_numpy(shape, seed, wrench_per_pose):
    kind, m = shape
    robot = random_robot(kind, m, seed)
    p = random_poses(robot, seed, 40)
    if kind == "spatial6":
        p[0, 3:] = [1e-5, -2e-4, 3e-4]  # the small-angle series of the rotation
    rng = np.random.default_rng(seed)
    wrench = rng.normal(size=(len(p), robot.dof) if wrench_per_pose else robot.dof) * 10
    A, b = robot.equilibrium(p, wrench)
    A_ref, b_ref = robot.structure_matrices(p), robot.required_wrench(p, wrench)
    np.testing.assert_allclose(A, A_ref, rtol=0, atol=REL * np.abs(A_ref).max())
    np.testing.assert_allclose(b, b_ref, rtol=0, atol=REL * np.abs(b_ref).max())
    A0, b0 = robot.equilibrium(p)
    np.testing.assert_array_equal(A0, A)
    np.testing.assert_allclose(b0, robot.required_wrench(p), rtol=0,
                               atol=REL * max(np.abs(b_ref).max(), 1.0))


def test_geometry_keeps_the_errors_of_the_numpy_path():
    robot = presets.algae_harvester()
    home = robot.default_home()
    cases = [
        (np.array([home, robot.anchors[2]]), None, "pose 1 .* puts cable 2 on its drawing"),
        (np.array([home, [1e200, 0, 0]]), None, "pose 1 .* lengths overflow"),
        (home, np.zeros(4), r"wrench must have shape \(3,\) or \(1, 3\), got \(4,\)"),
        (home, [0.0, np.nan, 0.0], "wrench"),
        (home, [0.0, 0.0, np.inf], "wrench"),
        ([np.nan, 0.0, 1.0], None, "poses"),
        ([[1.0, 2.0]], None, r"poses of a point3 robot must have shape \(N, 3\)"),
    ]
    for poses, wrench, message in cases:
        with pytest.raises(to.InvalidInputError, match=message) as compiled:
            robot.equilibrium(poses, wrench)
        with pytest.raises(to.InvalidInputError) as reference:
            robot.structure_matrices(poses)
            robot.required_wrench(poses, wrench)
        assert str(compiled.value) == str(reference.value)
    heavy = robot.with_(mass=1e307)  # its weight plus the wrench beyond the float range
    with pytest.raises(to.InvalidInputError, match="wrench overflows when added to gravity"):
        heavy.equilibrium(home, [0.0, 0.0, -9e307])
    # A scalar wrench broadcasts as in the numpy path.
    np.testing.assert_allclose(robot.equilibrium(home, 5.0)[1],
                               robot.required_wrench(home, 5.0), rtol=REL)


def big_batch(robot: to.CableRobot, count: int, seed: int) -> np.ndarray:
    low, high = default_box(robot)
    return np.random.default_rng(seed).uniform(low, high, (count, robot.dof))


def test_threads_calling_distribute_on_batches_at_once():
    robot = presets.cogiro()
    # Batches above and below the parallel threshold, interleaved over six threads.
    sizes = [launch.PARALLEL_MIN + 500, 300, launch.PARALLEL_MIN, 7, 2 * launch.PARALLEL_MIN, 1]
    batches = [big_batch(robot, n, k) for k, n in enumerate(sizes)]
    objectives = ["min_sum", "min_norm"]
    serial = {(k, o): to.distribute(robot, batches[k], o, "closed_form")
              for k in range(len(sizes)) for o in objectives}
    jobs = [(k, o) for k in range(len(sizes)) for o in objectives]
    got: dict[tuple[int, str], to.TensionSolution] = {}
    barrier = threading.Barrier(6)

    def work(part: list[tuple[int, str]]) -> None:
        barrier.wait()
        for _ in range(2):
            for job in part:
                got[job] = to.distribute(robot, batches[job[0]], job[1], "closed_form")

    threads = [threading.Thread(target=work, args=(jobs[t::6],)) for t in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert got.keys() == serial.keys()
    for job, want in serial.items():
        assert got[job].status.tolist() == want.status.tolist()
        np.testing.assert_array_equal(got[job].tensions, want.tensions)  # bit for bit
    assert any((s.status == to.Status.INFEASIBLE).any() for s in serial.values())


def _child(queue: mp.Queue) -> None:
    robot = presets.cogiro()
    sol = to.distribute(robot, big_batch(robot, launch.PARALLEL_MIN + 10, 5), "min_norm")
    queue.put(sol.tensions)


def test_a_forked_child_solves_after_its_parent_ran_in_parallel():
    # With GNU OpenMP as numba's layer, a forked child that launches a parallel kernel
    # after its parent did is terminated: the child runs the serial kernel instead.
    robot = presets.cogiro()
    poses = big_batch(robot, launch.PARALLEL_MIN + 10, 5)
    want = to.distribute(robot, poses, "min_norm").tensions  # in parallel, here
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue,))
    child.start()
    got = queue.get(timeout=600)
    child.join(timeout=60)
    assert child.exitcode == 0
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("objective", ["min_sum", "min_norm"])
def test_study_poses_outside_the_workspace_get_the_numpy_distance(objective: str) -> None:
    """Four cables, three equations: an infeasible pose is settled by the kernel's
    shortcut (no QR) with the distance to feasibility the numpy path finds by its
    general path, to 1e-12 of the pose's scale."""
    robot = to.presets.algae_harvester()
    low, high = robot.anchors.min(axis=0), robot.anchors.max(axis=0)
    poses = np.random.default_rng(5).uniform(low - [0, 0, 30], high - [0, 0, 0.5], (400, 3))
    statuses = assert_same_raw(to.TensionProblem(objective).standard_form(robot, poses))
    assert 50 < statuses.count(to.Status.INFEASIBLE) < 350


SEQUENCE_PROBLEMS = [to.TensionProblem("min_sum", smoothing=1e-3),
                     to.TensionProblem("min_norm", smoothing=0.5),
                     to.TensionProblem("min_sum", rate_limit=300.0),
                     to.TensionProblem("centered", smoothing=0.1, rate_limit=500.0,
                                       t_max=1e5)]


@pytest.mark.parametrize("robot_name", ["algae_harvester", "cogiro"])
@pytest.mark.parametrize("problem", SEQUENCE_PROBLEMS, ids=lambda p: p.name)
@pytest.mark.parametrize("start", [False, True])
def test_compiled_sequence_equals_pose_by_pose(robot_name: str, problem: to.TensionProblem,
                                               start: bool,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A smoothed or rate-limited path through the compiled sequence kernel gives what
    the backend gives pose by pose on each pose's own form (the path before the kernel):
    every status, tension, diagnostic and certificate field, bit for bit. The path
    leaves the workspace and comes back, so the chain restarts from older tensions."""
    robot = getattr(presets, robot_name)()
    ends = random_feasible_poses(robot, 2, 4)
    poses = ends[0] + np.linspace(0.0, 1.0, 90)[:, None] * (ends[1] - ends[0])
    low, high = default_box(robot)
    poses[30:45] = poses[30:45] + 2.0 * (high - low)  # out of the workspace and back
    first = to.distribute(robot, poses[:1], problem.with_(smoothing=0.0, rate_limit=None))
    previous = first.tensions[0] + 100.0 if start else None
    # Pose 60 carries a wrench beyond the kernels' range: the run stops there, the
    # numpy path answers that pose, and the next run goes on from the chain.
    wrench = np.zeros((len(poses), robot.dof))
    wrench[60, 0] = 1e160
    fast = to.distribute(robot, poses, problem, "closed_form", wrench=wrench,
                         previous=previous)
    distribute_module = importlib.import_module("tension_opt.distribution.sequence")
    monkeypatch.setattr(distribute_module, "_compiled_sequence", lambda *args: None)
    slow = to.distribute(robot, poses, problem, "closed_form", wrench=wrench,
                         previous=previous)
    statuses = set(slow.status.tolist())
    assert to.Status.OPTIMAL in statuses and len(statuses) > 1, statuses
    for name in ("tensions", "status", "unique", "objective", "residual", "bound_violation",
                 "infeasibility", "primal_residual", "dual_residual", "duality_gap"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    for name in ("y", "z"):
        assert np.array_equal(getattr(fast.multipliers, name), getattr(slow.multipliers, name),
                              equal_nan=True), name
    np.testing.assert_array_equal(fast.form.previous, slow.form.previous)


@pytest.mark.parametrize("backend", ["closed_form", "qpsolvers:osqp"])
def test_the_size_rule_counts_the_poses_of_a_sequence(backend: str,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """Under the default size rule a smoothed path of at least ``COMPILED_MIN`` poses
    runs in the backend's compiled loop (its one-pose forms do not count as batches of
    one), a shorter one pose by pose (by the numpy references where the backend has
    them); the first poses' statuses are the same, their tensions to 1e-12."""
    if backend not in to.available_backends():
        pytest.skip(f"{backend} is not installed")
    robot = presets.algae_harvester()
    ends = random_feasible_poses(robot, 2, 8)
    poses = ends[0] + np.linspace(0.0, 1.0, launch.DEFAULT_COMPILED_MIN)[:, None] * (
        ends[1] - ends[0])
    problem = to.TensionProblem("min_norm", smoothing=0.5)
    loops: list[int] = []
    cls = ClosedFormBackend if backend == "closed_form" else QpsolversBackend
    original = cls.solve_sequence

    def counted(self: object, *args: object, **kwargs: object) -> int:
        loops.append(1)
        return original(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(cls, "solve_sequence", counted)
    monkeypatch.setattr(launch, "COMPILED_MIN", launch.DEFAULT_COMPILED_MIN)
    short = to.distribute(robot, poses[:-1], problem, backend)
    assert not loops
    full = to.distribute(robot, poses, problem, backend)
    assert loops
    assert (full.status == to.Status.OPTIMAL).all()
    np.testing.assert_array_equal(short.status, full.status[:-1])
    np.testing.assert_allclose(short.tensions, full.tensions[:-1], rtol=1e-12)


DAQP_SEQUENCES = [to.TensionProblem("min_sum", smoothing=1e-3),
                  to.TensionProblem("min_norm", smoothing=0.5),
                  to.TensionProblem("min_sum", rate_limit=300.0),  # LPs: pose by pose
                  to.TensionProblem("centered", smoothing=0.1, rate_limit=500.0, t_max=1e5)]


QP_SOLVERS = [("qpsolvers:daqp", "default"), ("qpsolvers:daqp", "high"),
              ("qpsolvers:piqp", "default"), ("qpsolvers:proxqp", "default"),
              ("qpsolvers:osqp", "default"), ("qpsolvers:clarabel", "high"),
              ("qpsolvers:quadprog", "default"), ("qpsolvers:scs", "default")]


@pytest.mark.parametrize("robot_name", ["algae_harvester", "cogiro"])
@pytest.mark.parametrize("problem", DAQP_SEQUENCES, ids=lambda p: p.name)
@pytest.mark.parametrize("start", [False, True])
@pytest.mark.parametrize(("backend", "accuracy"), QP_SOLVERS)
def test_qp_sequence_equals_pose_by_pose(robot_name: str, problem: to.TensionProblem,
                                         start: bool, backend: str, accuracy: str,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A smoothed path through a qpsolvers backend runs its smoothed poses in one loop
    (DAQP's C solver called from compiled code; any other solver called per pose
    between the compiled QP and verdict): every status, tension, iteration count,
    diagnostic and certificate field is what the backend gives pose by pose on each
    pose's own form, bit for bit (the path of the previous test, leaving the workspace
    and coming back, with a wrench near the float range on one pose)."""
    if backend not in to.available_backends():
        pytest.skip(f"{backend} is not installed")
    if backend in ("qpsolvers:quadprog", "qpsolvers:proxqp") and not problem.smoothing:
        pytest.skip(f"{backend} takes QPs only")
    if backend == "qpsolvers:daqp":
        from tension_opt.kernels import daqp_native

        if daqp_native.load() is None:
            pytest.skip("DAQP's C solver cannot be called from compiled code here")
    robot = getattr(presets, robot_name)()
    ends = random_feasible_poses(robot, 2, 4)
    poses = ends[0] + np.linspace(0.0, 1.0, 90)[:, None] * (ends[1] - ends[0])
    low, high = default_box(robot)
    poses[30:45] = poses[30:45] + 2.0 * (high - low)
    first = to.distribute(robot, poses[:1], problem.with_(smoothing=0.0, rate_limit=None))
    previous = first.tensions[0] + 100.0 if start else None
    wrench = np.zeros((len(poses), robot.dof))
    wrench[60, 0] = 1e160
    settled = []
    run = QpsolversBackend.solve_sequence

    def counted(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        stop = run(self, *args, **kwargs)
        settled.append(stop - args[4])
        return stop

    monkeypatch.setattr(QpsolversBackend, "solve_sequence", counted)
    fast = to.distribute(robot, poses, problem, backend, wrench=wrench,
                         previous=previous, accuracy=accuracy)
    distribute_module = importlib.import_module("tension_opt.distribution.sequence")
    monkeypatch.setattr(distribute_module, "_compiled_sequence", lambda *args: None)
    slow = to.distribute(robot, poses, problem, backend, wrench=wrench,
                         previous=previous, accuracy=accuracy)
    statuses = set(slow.status.tolist())
    assert len(statuses) > 1, statuses
    if problem.smoothing:  # QPs once smoothed: most poses in the compiled loop
        assert to.Status.OPTIMAL in statuses
        assert sum(settled) >= (slow.status == to.Status.OPTIMAL).sum() // 2, settled
    assert (fast.iterations is None) == (slow.iterations is None)
    for name in ("tensions", "status", "unique", "iterations", "objective", "residual",
                 "bound_violation", "infeasibility", "primal_residual", "dual_residual",
                 "duality_gap"):
        a, b = getattr(fast, name), getattr(slow, name)
        if a is None:
            continue
        if backend == "qpsolvers:proxqp" and a.dtype.kind == "f":
            # ProxQP itself answers the same QP differently from call to call (by 1e-13
            # of the tensions, measured), so only to its rounding.
            # The diagnostics move with the tensions: to 1e-12 of the largest tension.
            scale = max(1.0, float(np.nanmax(np.abs(slow.tensions))))
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * scale, err_msg=name)
            continue
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    for name in ("y", "z"):
        a, b = getattr(fast.multipliers, name), getattr(slow.multipliers, name)
        if backend == "qpsolvers:proxqp":
            np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9, err_msg=name)
        else:
            assert np.array_equal(a, b, equal_nan=True), name
    assert fast.accuracy == slow.accuracy
    np.testing.assert_allclose(fast.form.previous, slow.form.previous,
                               rtol=1e-9 if backend == "qpsolvers:proxqp" else 0.0)


def test_daqp_sequence_checks_the_options_as_pose_by_pose() -> None:
    """Every pose of a compiled DAQP run may be smoothed (a start is given): the call's
    options are still checked, with the package's error."""
    pytest.importorskip("daqp")
    robot = presets.algae_harvester()
    poses = robot.default_home() + np.linspace(0.0, 1.0, 5)[:, None] * [1.0, 0.5, 0.0]
    problem = to.TensionProblem("min_sum", smoothing=1e-3)
    start = to.distribute(robot, poses[:1], "min_sum").tensions[0]
    with pytest.raises(to.SolverError):
        to.distribute(robot, poses, problem, "qpsolvers:daqp", previous=start,
                      solver_options={"no_such_setting": 1})
