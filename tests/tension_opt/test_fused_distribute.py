"""The certified closed form of large batches (:mod:`tension_opt.distribution.certified`) against
the
chunk-by-chunk path it replaces.

A batch of independent poses larger than ``chunk_size`` on the compiled closed form
goes through one compiled pass per chunk (geometry, closed form, diagnostics,
certificate); the same call with that path switched off (``certified_plan`` made to
decline) goes chunk by chunk through the geometry, the standard form, the backend and
``TensionSolution.from_form``. Every field must agree: statuses, uniqueness, iteration
counts, extras and labels exactly; tensions, objective, distance to feasibility,
certificate measures and multipliers to 1e-12 (they agree bit for bit but where a sum
runs in another order); the equilibrium residual and bound violation, which are
rounding noise of order 1e-13 of the pose's load, to 1e-12 of that load. A pose whose
multipliers are the sign-constrained refit (a bounded least-squares fit, solved by
scipy on one path and by :mod:`tension_opt.kernels.refit` on the other) has them to
:data:`REFIT_REL` and its dual residual and gap each within the target.
"""

from __future__ import annotations

import importlib
import pickle
import threading
import time
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from dataclasses import fields, replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tension_opt as to
from benchmarks.random_robots import random_robot, random_robot_poses
from tension_opt import presets
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.certify.certificate import refit_poses
from tension_opt.distribution.certified import CertifiedBatch, certified_plan
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import StandardForm, TensionProblem
from tension_opt.status import STATUS_DTYPE, STATUS_TABLE, StatusCodes, status_codes
from tension_opt.workspace.sampling import default_box, random_feasible_poses

distribute_module = importlib.import_module("tension_opt.distribution.entry")

REL = 1e-12
#: Agreement of refit multipliers (relative to the largest of a pose's, at least 1): the
#: fit's conditioning times the rounding.
REFIT_REL = 1e-8
#: Fields compared to 1e-12 (relative, or absolute in the scaled units of the
#: certificate, whose values are of order one).
CLOSE = ("tensions", "objective", "infeasibility", "primal_residual", "dual_residual",
         "duality_gap")
#: Fields equal exactly.
EXACT = ("status", "unique", "iterations", "extras", "backend", "solver", "solver_version",
         "accuracy")
OBJECTIVES = ["min_sum", "min_norm", "pinv", "centered", "min_max"]


#: The poses the certified kernel left to the chunk path in the last call of
#: :func:`both_paths`.
LEFT: list[int] = []


def both_paths(robot: to.CableRobot, poses: np.ndarray, problem: object, backend: object,
               monkeypatch: pytest.MonkeyPatch, **kwargs: object
               ) -> tuple[to.TensionSolution, to.TensionSolution, int]:
    """``distribute`` through the certified path and with it switched off, and the
    number of chunks the certified kernel solved (the poses it left: :data:`LEFT`)."""
    calls = []
    solve = CertifiedBatch.solve
    LEFT.clear()

    def counted(self: CertifiedBatch, sl: slice) -> object:
        calls.append(sl)
        left = solve(self, sl)
        if left is not None:
            LEFT.extend(np.arange(self.N)[left].tolist())
        return left

    with monkeypatch.context() as patch:
        patch.setattr(CertifiedBatch, "solve", counted)
        fast = to.distribute(robot, poses, problem, backend, **kwargs)
    with monkeypatch.context() as patch:
        patch.setattr(distribute_module, "certified_plan", lambda *args: None)
        slow = to.distribute(robot, poses, problem, backend, **kwargs)
    return fast, slow, len(calls)


def load_scale(robot: to.CableRobot, poses: np.ndarray, problem: TensionProblem,
               wrench: object) -> StandardForm:
    """The poses' standard form: its ``load_scale()`` is the tolerance scale of each
    pose (N), its load or its largest lower bound."""
    return problem.standard_form(robot, poses, wrench)


def assert_same(fast: to.TensionSolution, slow: to.TensionSolution, form: StandardForm
                ) -> None:
    """Every field of the two solutions alike (see the module docstring)."""
    scale = form.load_scale()
    solved = np.isin(slow.status, [to.Status.OPTIMAL.value, to.Status.INACCURATE.value])
    refit = np.zeros(len(solved), dtype=bool)
    refit[solved] = refit_poses(form.subset(np.flatnonzero(solved)), slow.tensions[solved],
                                slow.accuracy)
    assert fast.form is None and slow.form is None
    assert fast.problem is slow.problem
    for name in EXACT:
        a, b = getattr(fast, name), getattr(slow, name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=name)
        else:
            assert a == b, (name, a, b)
    for name in CLOSE:
        a, b = getattr(fast, name), getattr(slow, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        if name in ("dual_residual", "duality_gap"):  # a refit's: within the target
            done = refit & (slow.status == to.Status.OPTIMAL.value)
            assert (a[done] <= slow.accuracy).all() and (b[done] <= slow.accuracy).all()
            a, b = a[~refit], b[~refit]
        np.testing.assert_allclose(a, b, rtol=REL, atol=REL, err_msg=name)
    for name in ("residual", "bound_violation"):
        a, b = getattr(fast, name), getattr(slow, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        known = ~np.isnan(b)
        assert (np.abs(a - b)[known] <= REL * scale[known]).all(), name
    assert fast.multipliers is not None and slow.multipliers is not None
    top = np.ones(len(refit))
    for f in fields(slow.multipliers):
        values = np.abs(np.nan_to_num(getattr(slow.multipliers, f.name)))
        top = np.maximum(top, values.max(axis=1, initial=0.0))
    for f in fields(slow.multipliers):
        a, b = getattr(fast.multipliers, f.name), getattr(slow.multipliers, f.name)
        assert a.shape == b.shape, f.name
        np.testing.assert_allclose(a[~refit], b[~refit], rtol=REL, atol=REL, err_msg=f.name)
        assert (np.abs(a - b)[refit] <= REFIT_REL * top[refit, None]).all(), f.name


def spread_poses(robot: to.CableRobot, count: int, seed: int, spread: float = 1.6
                 ) -> np.ndarray:
    """Poses in (and around) the robot's default box: feasible and infeasible ones."""
    low, high = default_box(robot)
    mid, half = (low + high) / 2, (high - low) / 2 * spread
    return np.random.default_rng(seed).uniform(mid - half, mid + half, (count, robot.dof))


def problem_for(robot: to.CableRobot, objective: str, rng: np.random.Generator,
                bounds: bool) -> TensionProblem:
    """A problem of the robot: per-cable weights and bounds where asked, a reference
    for min-norm, finite upper bounds for the centred objective."""
    m, changes = robot.m, {}
    if objective != "pinv":
        changes["weights"] = rng.uniform(0.5, 2.0, m)
        if bounds:
            changes["t_min"] = np.asarray(robot.t_min) * rng.uniform(0.5, 1.5, m)
            changes["t_max"] = changes["t_min"] + robot.weight * rng.uniform(1.0, 8.0, m)
    if objective == "centered" and "t_max" not in changes and not np.isfinite(
            robot.t_max).all():
        changes["t_max"] = np.asarray(robot.t_min) + 5 * max(robot.weight, 1.0)
    if objective == "min_norm":
        changes["reference"] = rng.uniform(0.0, 2.0, m) * max(robot.weight, 1.0) / m
    return TensionProblem(objective, **changes)


@pytest.mark.parametrize("robot_name", ["algae_harvester", "cogiro"])
@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("wrench", ["none", "one", "per_pose"])
def test_the_certified_path_gives_the_chunk_path(robot_name: str, objective: str,
                                                 wrench: str,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    robot = getattr(presets, robot_name)()
    if objective == "min_max" and robot.m - robot.dof == 2:
        pytest.skip("the closed form takes min-max in one null-space dimension only")
    poses = spread_poses(robot, 700, 7)
    rng = np.random.default_rng(3)
    w = {"none": None, "one": rng.normal(0.0, 0.05 * robot.weight, robot.dof),
         "per_pose": rng.normal(0.0, 0.05 * robot.weight, (len(poses), robot.dof))}[wrench]
    problem = problem_for(robot, objective, rng, bounds=wrench != "none")
    fast, slow, chunks = both_paths(robot, poses, problem, "closed_form", monkeypatch,
                                    wrench=w, chunk_size=97)
    assert chunks == 8  # every chunk went through the certified kernel
    statuses = set(slow.status.tolist())
    assert to.Status.OPTIMAL in statuses, statuses
    assert objective == "pinv" or to.Status.INFEASIBLE in statuses, statuses  # no bounds
    assert_same(fast, slow, load_scale(robot, poses, problem, w))


def planar_robot(kind: str, m: int, seed: int) -> to.CableRobot:
    """A random planar robot: drawing points on a line (``planar_point2``) or a ring in
    the plane (``planar3``, no gravity in its plane)."""
    rng = np.random.default_rng(seed)
    if kind == "planar_point2":
        anchors = np.column_stack([np.sort(rng.uniform(-10, 10, m)), np.zeros(m),
                                   rng.uniform(5, 8, m)])
        return to.CableRobot(anchors, np.zeros((m, 3)), rng.uniform(1, 100), kind=kind,
                             t_min=rng.uniform(0, 50))
    angles = np.sort(rng.uniform(0, 2 * np.pi, m))
    radius = rng.uniform(2, 10)
    anchors = np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(m)])
    turn = angles + rng.uniform(-0.3, 0.3, m)
    attachments = 0.1 * radius * np.column_stack([np.cos(turn), np.sin(turn), np.zeros(m)])
    return to.CableRobot(anchors, attachments, rng.uniform(1, 100), kind=kind, g=0.0,
                         t_min=rng.uniform(1, 50), t_max=rng.uniform(500, 5000))


SHAPES = [("point3", 4), ("point3", 5), ("spatial6", 7), ("spatial6", 8),
          ("planar_point2", 3), ("planar_point2", 4), ("planar3", 4), ("planar3", 5)]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(shape=st.sampled_from(SHAPES), seed=st.integers(0, 10_000),
       objective=st.sampled_from(OBJECTIVES), bounds=st.booleans(), wrench=st.booleans(),
       symmetric=st.booleans())
def test_random_robots_give_the_chunk_path(shape: tuple[str, int], seed: int, objective: str,
                                           bounds: bool, wrench: bool, symmetric: bool,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Random robots of every kind, poses inside, outside and on the edge of the
    workspace (near-degenerate optima), ties of symmetric robots."""
    kind, m = shape
    if kind.startswith("planar"):
        robot = planar_robot(kind, m, seed)
        poses = spread_poses(robot, 150, seed, spread=1.3)
    else:
        robot = random_robot(seed, m, kind, symmetric)
        try:
            edge = random_robot_poses(robot, 20, seed, boundary=0.5, symmetric=symmetric)
        except InvalidInputError:  # a robot without a workspace: spread poses only
            edge = np.empty((0, robot.dof))
        poses = np.concatenate([edge, spread_poses(robot, 130, seed, spread=1.3)])
    if objective == "min_max" and m - robot.dof == 2:
        return  # the closed form takes min-max in one null-space dimension only
    rng = np.random.default_rng(seed + 1)
    problem = problem_for(robot, objective, rng, bounds)
    w = rng.normal(0.0, 0.05 * max(robot.weight, 1.0), (len(poses), robot.dof)) if wrench \
        else None
    fast, slow, chunks = both_paths(robot, poses, problem, "closed_form", monkeypatch,
                                    wrench=w, chunk_size=37)
    assert chunks == -(-len(poses) // 37)
    assert_same(fast, slow, load_scale(robot, poses, problem, w))


def test_poses_the_kernel_leaves_are_solved_by_the_chunk_path(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A singular pose (every cable horizontal), a badly conditioned one and poses whose
    wrench is beyond the kernels' range go to the chunk path on their own, in any
    chunk; with ``auto``, a pose the closed form cannot answer goes on to the next
    backend, numbered in the batch."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 300, 11)
    top, center = robot.anchors[0, 2], robot.anchors[:, :2].mean(axis=0)
    poses[5] = [*center, top]
    poses[133] = [*center, top - 1e-9]
    wrench = np.zeros((len(poses), 3))
    wrench[[40, 250], 2] = -1e160
    for objective in ("min_sum", "min_norm"):
        problem = TensionProblem(objective)
        fast, slow, _ = both_paths(robot, poses, problem, "closed_form", monkeypatch,
                                   wrench=wrench, chunk_size=64)
        assert_same(fast, slow, load_scale(robot, poses, problem, wrench))
        assert fast.status[5] == to.Status.INFEASIBLE
        assert {5, 133, 40, 250} <= set(LEFT) and len(LEFT) < 10, LEFT
    # Cables along one line: singular with the wrench in range, a solver error of the
    # closed form that the automatic choice hands on.
    line = to.CableRobot(np.array([[-5.0, 0, 5], [5, 0, 5], [-2, 0, 5]]), np.zeros((3, 3)),
                         1.0, kind="planar_point2", g=0.0)
    poses = np.column_stack([np.linspace(-4, 4, 50), np.full(50, 2.0)])
    poses[[3, 31]] = [0.0, 5.0]
    problem = TensionProblem("min_norm")
    for backend in ("closed_form", "auto"):
        fast, slow, chunks = both_paths(line, poses, problem, backend, monkeypatch,
                                        chunk_size=16)
        assert chunks == 4
        assert_same(fast, slow, load_scale(line, poses, problem, None))
        if backend == "auto":
            assert [k for ks in fast.extras["fallback"].values() for k in ks] == [3, 31]


@pytest.mark.parametrize(("accuracy", "target"), [("high", 1e-10), (1e-14, 1e-14),
                                                  (1e-3, 1e-3)])
def test_the_closed_form_is_judged_at_the_accuracy_asked(
        accuracy: object, target: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """The closed form honours ``accuracy=`` on every path (the certified pass, the
    chunk path, one small batch, a smoothed sequence): the solution records the target
    and a pose is optimal exactly where its three measures meet it. At the tightest
    target an exact answer that misses it by rounding says so (whether any does depends
    on the machine's vector arithmetic: some did with AVX-512, none do without)."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 600, 5, spread=0.8)
    solutions = list(both_paths(robot, poses, "min_sum", "closed_form", monkeypatch,
                                chunk_size=128, accuracy=accuracy)[:2])
    solutions.append(to.distribute(robot, poses[:50], "min_norm", "closed_form",
                                   accuracy=accuracy))
    solutions.append(to.distribute(robot, poses[:50], TensionProblem("min_norm",
                                                                    smoothing=0.1),
                                   "closed_form", accuracy=accuracy))
    for sol in solutions:
        assert sol.accuracy == target
        solved = np.isin(sol.status, [to.Status.OPTIMAL, to.Status.INACCURATE])
        met = ((sol.primal_residual <= target) & (sol.dual_residual <= target)
               & (sol.duality_gap <= target))
        np.testing.assert_array_equal(sol.status[solved] == to.Status.OPTIMAL, met[solved])
        assert sol.success.sum() > (0 if target < 1e-13 else 0.9 * solved.sum())


@pytest.mark.parametrize("objective", ["min_sum", "min_norm"])
def test_two_threads_give_one_thread(objective: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Chunks of the certified kernel side by side in threads, bit for bit the serial
    result (extras, fallbacks and errors in the batch's order)."""
    robot = presets.cogiro()
    poses = spread_poses(robot, 900, 21)
    wrench = np.zeros((len(poses), robot.dof))
    wrench[[77, 610], 0] = 1e160  # left to the chunk path, from two chunks
    results = []
    for threads in (1, 2, 3):
        monkeypatch.setattr(distribute_module, "chunk_threads", lambda t=threads: t)
        results.append(to.distribute(robot, poses, objective, "closed_form", wrench=wrench,
                                     chunk_size=50))
    for other in results[1:]:
        for f in fields(other):
            if f.name in ("setup_time", "solve_time", "form", "problem"):
                continue
            a, b = getattr(results[0], f.name), getattr(other, f.name)
            if f.name == "multipliers":
                for g in fields(a):
                    np.testing.assert_array_equal(getattr(a, g.name), getattr(b, g.name))
            elif isinstance(a, np.ndarray):
                np.testing.assert_array_equal(a, b, err_msg=f.name)
            else:
                assert a == b, f.name
    poses[801, :3] = robot.anchors[3] - robot.attachments[3]
    poses[801, 3:] = 0.0
    poses[612, 0] = 1e200
    with pytest.raises(InvalidInputError, match=r"pose 612 .*too far"):
        to.distribute(robot, poses, objective, "closed_form", chunk_size=50)


def test_bad_input_raises_as_the_chunk_path_does(monkeypatch: pytest.MonkeyPatch) -> None:
    """Invalid poses, wrenches and bounds raise the package's error naming the argument,
    with the message of the chunk path (poses numbered in the batch)."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 200, 2)
    zero = poses.copy()
    zero[151] = robot.anchors[2]
    nan_wrench = np.zeros((200, 3))
    nan_wrench[9, 1] = np.nan
    cases = [({"poses": zero}, r"pose 151 .* puts cable 2 on its drawing point"),
             ({"wrench": nan_wrench}, "wrench"),
             ({"wrench": np.zeros((199, 3))}, r"wrench must have shape \(3,\) or \(200, 3\)"),
             ({"objective": TensionProblem("centered")}, "centred objective needs finite"),
             ({"objective": TensionProblem("min_sum", t_max=1000.0)},
              r"t_min = 2536.866\d* exceeds t_max = 1000.0 for cable 0 at pose 0"),
             ({"poses": np.where(np.arange(200)[:, None] == 3, np.nan, poses)}, "poses")]
    for changes, message in cases:
        args = {"poses": poses, "objective": "min_sum", "wrench": None} | changes
        errors = []
        for plan in (certified_plan, lambda *a: None):
            monkeypatch.setattr(distribute_module, "certified_plan", plan)
            with pytest.raises(InvalidInputError, match=message) as error:
                to.distribute(robot, args["poses"], args["objective"], "closed_form",
                              wrench=args["wrench"], chunk_size=40)
            errors.append(str(error.value))
        assert errors[0] == errors[1]


def test_what_the_certified_path_takes() -> None:
    """Independent poses on the compiled closed form, one of the package's objectives
    without per-pose rows, smoothing or rate limits; anything else keeps its path."""
    study, cogiro = presets.algae_harvester(), presets.cogiro()
    takes = [(study, "min_sum", "closed_form"), (study, "min_max", "auto"),
             (cogiro, "centered", ClosedFormBackend()), (cogiro, "pinv", "auto")]
    for robot, objective, backend in takes:
        assert certified_plan(robot, TensionProblem(objective), backend) is not None
    declines = [(study, TensionProblem("min_sum", smoothing=1e-3), "closed_form"),
                (study, TensionProblem("min_sum", rate_limit=100.0), "closed_form"),
                (study, TensionProblem("min_sum"), ClosedFormBackend(compiled=False)),
                (cogiro, TensionProblem("min_max"), "closed_form"),  # null space 2
                (study, TensionProblem("centered"), "closed_form")]  # infinite t_max
    if "scipy:highs" in to.available_backends():
        declines.append((study, TensionProblem("min_sum"), "scipy:highs"))
    for robot, problem, backend in declines:
        assert certified_plan(robot, problem, backend) is None, problem.name


def test_fresh_results_hold_one_byte_codes_until_the_statuses_are_read(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A fresh result of the certified path keeps its statuses as one-byte codes:
    ``success`` reads them, and the status array, decoded on first read (once, from any
    number of threads), is the chunk path's, including the statuses of the poses left
    to it; the decoded array is the status from then on."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 700, 5)
    top, center = robot.anchors[0, 2], robot.anchors[:, :2].mean(axis=0)
    poses[17] = [*center, top]  # left to the chunk path: infeasible there
    fast, slow, _ = both_paths(robot, poses, TensionProblem("min_sum"), "closed_form",
                               monkeypatch, chunk_size=64)
    held = vars(fast)["_status"]
    assert isinstance(held, StatusCodes) and held.codes.nbytes == len(poses)
    success = fast.success
    assert isinstance(vars(fast)["_status"], StatusCodes)  # success did not decode
    # Eight threads read at once: one decoding, one array.
    decodings, start = [], threading.Barrier(8)
    decode = StatusCodes.decode

    def counted(codes: StatusCodes) -> np.ndarray:
        decodings.append(1)
        time.sleep(0.05)  # long enough for every thread to arrive
        return decode(codes)

    def read_status(_: int) -> np.ndarray:
        start.wait()
        return fast.status

    monkeypatch.setattr(StatusCodes, "decode", counted)
    with ThreadPoolExecutor(8) as pool:
        read = list(pool.map(read_status, range(8)))
    monkeypatch.undo()
    assert len(decodings) == 1
    assert all(r is read[0] for r in read) and read[0].dtype == STATUS_DTYPE
    np.testing.assert_array_equal(read[0], slow.status)
    np.testing.assert_array_equal(success, slow.status == to.Status.OPTIMAL)
    assert fast.status[17] == to.Status.INFEASIBLE and 0 < success.sum() < len(poses) - 1
    kinds = set(np.unique(slow.status))
    assert {to.Status.OPTIMAL, to.Status.INFEASIBLE} <= kinds
    # The decoded array is the status from then on; copies keep it.
    first = int(np.flatnonzero(success)[0])
    fast.status[first] = to.Status.INACCURATE
    assert not fast.success[first] and fast.success.sum() == success.sum() - 1
    for copy in (replace(fast), pickle.loads(pickle.dumps(fast))):
        np.testing.assert_array_equal(copy.status, fast.status)
    again = pickle.loads(pickle.dumps(both_paths(robot, poses, "min_sum", "closed_form",
                                                 monkeypatch, chunk_size=64)[0]))
    np.testing.assert_array_equal(again.status, slow.status)


def test_an_earlier_result_given_as_out_takes_the_status_array() -> None:
    """``out=`` a fresh result (statuses still codes) decodes them once and writes this
    call's statuses into that array."""
    robot = presets.algae_harvester()
    poses = spread_poses(robot, 500, 6)
    earlier = to.distribute(robot, poses[::-1].copy(), "min_sum", "closed_form",
                            chunk_size=64)
    expected = to.distribute(robot, poses, "min_sum", ClosedFormBackend(compiled=False))
    assert isinstance(vars(earlier)["_status"], StatusCodes)
    result = to.distribute(robot, poses, "min_sum", "closed_form", chunk_size=64,
                           out=earlier)
    assert result.status is earlier.status
    np.testing.assert_array_equal(result.status, expected.status)
    np.testing.assert_array_equal(result.success, expected.success)


@given(st.lists(st.sampled_from(list(to.Status)), max_size=40))
def test_status_codes_round_trip(values: list[to.Status]) -> None:
    """Every status array encodes to one-byte codes and decodes back; the mask of a
    status read from the codes is that of the array."""
    status = np.array([v.value for v in values], dtype=STATUS_DTYPE)
    codes = StatusCodes(status_codes(status))
    assert codes.codes.dtype == np.int8
    np.testing.assert_array_equal(codes.decode(), status)
    for kind in to.Status:
        np.testing.assert_array_equal(codes.equal_to(kind), status == kind)


def test_status_codes_refuse_other_strings() -> None:
    with pytest.raises(ValueError, match="'done' is not a Status value"):
        status_codes(np.array(["optimal", "done"]))
    assert not STATUS_TABLE.flags.writeable


def test_a_result_without_its_status_says_so() -> None:
    """A result object missing its status (made field by field, or an old pickle) has
    no ``status`` attribute: ``AttributeError``, so that ``getattr`` defaults work."""
    bare = object.__new__(to.TensionSolution)
    assert getattr(bare, "status", "none") == "none"
    with pytest.raises(AttributeError, match="status"):
        _ = bare.success


def test_a_fresh_result_holds_about_150_bytes_a_pose() -> None:
    """The results of a large plain call on the study robot: tensions (32 bytes a pose),
    multipliers (56), seven measures (56), uniqueness and a status code (1 each) and
    iteration counts (8, zeros the system gives lazily): 154 bytes a pose, where statuses
    as strings took 60 more, which reading ``.status`` adds."""
    robot = presets.algae_harvester()
    N = 40_000
    poses = random_feasible_poses(robot, N, 9)
    to.distribute(robot, poses[:5000], "min_sum", "closed_form")
    tracemalloc.start()
    try:
        sol = to.distribute(robot, poses, "min_sum", "closed_form")
        held, peak = tracemalloc.get_traced_memory()
        _ = sol.status
        read = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert sol.success.all()
    assert 150 * N < held < 160 * N and peak < held + 2e6, (held / N, peak / N)
    assert read - held == pytest.approx(60 * N, rel=0.02)
