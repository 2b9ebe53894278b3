"""DAQP's C solver called from compiled code (:mod:`tension_opt.kernels.daqp_native`)
against the Python interface ``daqp.solve``: the same answer to the last bit (solution,
multipliers, exit flag, iterations) on random QPs and for every setting, and the same
:class:`tension_opt.Distributor` results with and without the native path.
"""

from __future__ import annotations

import inspect
from importlib import metadata

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt import presets
from tension_opt.backends.settings import solver_options
from tension_opt.kernels import daqp_native
from tension_opt.kernels.dense_qp import DaqpPose
from tension_opt.workspace.sampling import random_feasible_poses

daqp = pytest.importorskip("daqp")
# On a verified version the native path must load (a failed check fails the tests).
pytestmark = pytest.mark.skipif(
    metadata.version("daqp") not in daqp_native.VERIFIED_VERSIONS,
    reason=f"daqp {metadata.version('daqp')} has no verified C layout")
NATIVE = daqp_native.load()

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
BIG = 1e30  # DAQP's infinity
REL = 1e-9  # DAQP's answers against the numpy path's (as tests/tension_opt/test_realtime.py)


def native_solve(H, f, A, upper, lower, sense, **options):
    """``daqp.solve``'s outputs ``(x, exitflag, iterations, lam)`` through the C call."""
    structs = daqp_native.struct_buffer(NATIVE, options)
    assert structs is not None
    x, lam = np.full(len(f), np.nan), np.full(len(upper), np.nan)
    flag, iterations = daqp_native.quadprog(H, f, A, upper, lower, sense, x, lam, structs)
    return x, flag, iterations, lam


def assert_same(problem, options):
    """Both calls on copies of the same data; every output bit for bit."""
    H, f, A, upper, lower, sense = problem
    x, _, flag, info = daqp.solve(H, f, A, upper, lower, sense.copy(), **options)
    sense_after = sense.copy()
    got_x, got_flag, got_iterations, got_lam = native_solve(H, f, A, upper, lower,
                                                            sense_after, **options)
    assert (got_flag, got_iterations) == (flag, info["iterations"])
    np.testing.assert_array_equal(sense_after, sense)  # DAQP only reads it
    if flag > 0:
        np.testing.assert_array_equal(got_x, x)
        np.testing.assert_array_equal(got_lam, info["lam"])
    return flag, info["iterations"], x


@st.composite
def random_qps(draw):
    """QPs shaped like a pose's: ``m`` variables with simple bounds (finite or not),
    ``n`` rows (equalities or one-sided inequalities), a dense or diagonal Hessian, and a
    working set to start from."""
    m, n = draw(st.integers(3, 8)), draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        root = rng.normal(size=(m, m))
        H = root @ root.T + 0.1 * np.eye(m)
    else:
        H = np.diag(rng.uniform(0.1, 10.0, m))
    f = rng.normal(size=m) * rng.choice([0.1, 1.0, 100.0])
    A = rng.normal(size=(n, m))
    lower = np.where(rng.random(m) < 0.7, rng.uniform(-2.0, 0.0, m), -BIG)
    upper = np.where(rng.random(m) < 0.7, rng.uniform(0.0, 2.0, m), BIG)
    row_upper = np.where(rng.random(n) < 0.8, rng.uniform(-1.0, 1.0, n), BIG)
    equal = rng.random(n) < 0.6
    row_lower = np.where(equal, row_upper, -BIG)
    row_upper[equal & (row_upper >= BIG)] = row_lower[equal & (row_upper >= BIG)] = 0.5
    sense = np.zeros(m + n, dtype=np.intc)
    sense[m:][equal] = 5
    start = rng.random(m) < 0.3  # bounds in the starting working set
    sense[:m][start] = rng.choice([1, 3], start.sum())
    sense[:m][start & (sense[:m] == 1) & (upper >= BIG)] = 0
    sense[:m][start & (sense[:m] == 3) & (lower <= -BIG)] = 0
    return (H, f, A, np.concatenate([upper, row_upper]), np.concatenate([lower, row_lower]),
            sense)


@SETTINGS
@given(random_qps(), st.sampled_from(["default", "high", 1e-5]))
def test_native_call_equals_daqp_solve_on_random_qps(problem, accuracy):
    assert_same(problem, solver_options("daqp", accuracy))


def test_load_is_checked_once_and_gated_on_the_version(monkeypatch):
    assert NATIVE is not None and NATIVE.quadprog != 0
    assert daqp_native.load() is NATIVE  # cached for the process
    uncached = daqp_native.load.__wrapped__
    assert uncached() is not None
    monkeypatch.setattr(daqp_native, "VERIFIED_VERSIONS", frozenset({"0.0.0"}))
    assert uncached() is None


def test_a_settings_layout_that_misses_daqps_defaults_is_refused(monkeypatch):
    fields = dict(daqp_native.SETTINGS_FIELDS)
    fields["primal_tol"] = fields["dual_tol"]  # a field read at another's offset
    monkeypatch.setattr(daqp_native, "SETTINGS_FIELDS", fields)
    assert daqp_native.load.__wrapped__() is None


def test_default_settings_are_those_of_daqp_solve_at_every_offset():
    # daqp.solve's keyword defaults are the settings it hands DAQP: the words written by
    # daqp_default_settings must hold the same values at the offsets the layout names.
    raw = NATIVE.defaults.view(np.uint8)
    for name, parameter in inspect.signature(daqp.solve).parameters.items():
        if name not in daqp_native.SETTINGS_FIELDS:
            continue
        offset, kind = daqp_native.SETTINGS_FIELDS[name]
        dtype = np.int32 if kind == "i" else np.float64
        value = raw[offset:offset + np.dtype(dtype).itemsize].view(dtype)[0]
        assert value == parameter.default, name
    assert 8 * daqp_native.SETTINGS_WORDS == max(
        o + (4 if k == "i" else 8) for o, k in daqp_native.SETTINGS_FIELDS.values())


def soft_pair():
    """``x1 <= -1`` and ``x1 >= 1``, both soft: DAQP's soft weights decide."""
    return (np.eye(2), np.zeros(2), np.array([[1.0, 0.0], [1.0, 0.0]]),
            np.array([BIG, BIG, -1.0, BIG]), np.array([-BIG, -BIG, -BIG, 1.0]),
            np.array([0, 0, 8, 8], dtype=np.intc))


def equality_qp():
    rng = np.random.default_rng(3)
    root = rng.normal(size=(10, 10))
    upper = np.r_[np.full(10, 0.3), rng.uniform(0.1, 1.0, 8)]
    lower = np.r_[np.full(10, -0.3), np.full(8, -BIG)]
    sense = np.zeros(18, dtype=np.intc)
    sense[10:14] = 5
    lower[10:14] = upper[10:14]
    return (root @ root.T + np.eye(10), 10 * rng.normal(size=10), rng.normal(size=(8, 10)),
            upper, lower, sense)


def near_bound():
    """The unconstrained optimum 0 misses the bound ``x0 >= 1e-4`` by 1e-4."""
    return (np.eye(2), np.zeros(2), np.zeros((0, 2)), np.array([BIG, BIG]),
            np.array([1e-4, -BIG]), np.zeros(2, dtype=np.intc))


@pytest.mark.parametrize(("make", "options"), [
    (near_bound, {"primal_tol": 1e-3}),     # the setting the distributor passes
    (equality_qp, {"pivot_tol": 0.1}),
    (equality_qp, {"iter_limit": 1}),       # an int field: DAQP stops at its cap
    (near_bound, {"fval_bound": 0.0}),
    (equality_qp, {"eps_prox": 1.0}),
    (soft_pair, {"rho_soft": 1e-3}),
    (soft_pair, {"sing_tol": 1e-2}),
    (equality_qp, {"refactor_tol": 1.0}),
    (soft_pair, {"w_soft": 5.0}),           # added to the settings in 0.11
    (equality_qp, {"eq_reduction": 1}),     # added to the settings in 0.11
])
def test_every_setting_reaches_daqp_at_its_offset(make, options):
    # Each option changes DAQP's answer, and the native call changes it the same way.
    problem = make()
    plain = assert_same(problem, {})
    asked = assert_same(problem, options)
    assert (plain[0], plain[1]) != (asked[0], asked[1]) or not np.array_equal(plain[2],
                                                                              asked[2])


def test_unknown_or_fractional_settings_leave_the_native_path():
    assert daqp_native.struct_buffer(NATIVE, {"no_such_setting": 1.0}) is None
    assert daqp_native.struct_buffer(NATIVE, {"iter_limit": 2.5}) is None
    buffer = daqp_native.struct_buffer(NATIVE, {"iter_limit": 7, "primal_tol": 1e-9})
    template = buffer[daqp_native.TEMPLATE:].view(np.uint8)
    assert template[44:48].view(np.int32)[0] == 7
    assert template[0:8].view(np.float64)[0] == 1e-9


@pytest.mark.parametrize("change", ["strided H", "int64 sense", "short lam", "no structs",
                                    "float32 f"])
def test_arrays_that_are_not_one_qp_are_refused_before_daqp_reads_them(change):
    H, f, A, upper, lower, sense = equality_qp()
    x, lam = np.empty(len(f)), np.empty(len(upper))
    structs = daqp_native.struct_buffer(NATIVE, {})
    if change == "strided H":
        H = np.repeat(H, 2, axis=1)[:, ::2]
    elif change == "int64 sense":
        sense = sense.astype(np.int64)
    elif change == "short lam":
        lam = lam[:-1].copy()
    elif change == "no structs":
        structs = np.zeros_like(structs)  # no address of DAQP in it
    else:
        f = f.astype(np.float32)
    with pytest.raises(to.InvalidInputError, match="quadprog needs"):
        daqp_native.quadprog(H, f, A, upper, lower, sense, x, lam, structs)


# ------------------------------------------------------------------- the Distributor
def random_poses(robot: to.CableRobot, seed: int, count: int) -> np.ndarray:
    """Poses over the footprint (many infeasible near the edges), small rotations."""
    rng = np.random.default_rng(seed)
    low, high = robot.anchors.min(axis=0), robot.anchors.max(axis=0)
    p = np.column_stack([rng.uniform(0.9 * low[0], 0.9 * high[0], count),
                         rng.uniform(0.9 * low[1], 0.9 * high[1], count),
                         rng.uniform(0.05, 0.95, count) * high[2]])
    if robot.dof == 6:
        p = np.column_stack([p, rng.uniform(-0.2, 0.2, (count, 3))])
    return p


@pytest.fixture(params=["study", "cogiro"])
def robot(request) -> to.CableRobot:
    return presets.algae_harvester() if request.param == "study" else presets.cogiro()


def run(robot, poses, native, monkeypatch, wrench=None, **options):
    """Pose by pose (each warm-started from the one before) through a new distributor,
    with or without the native path; the rows and DAQP's iterations per pose."""
    with monkeypatch.context() as patch:
        if not native:
            patch.setattr(daqp_native, "load", lambda: None)
        solver = to.Distributor(robot, "min_norm", "qpsolvers:daqp", **options)
        rows, iterations, senses = [], [], []
        for pose in poses:
            rows.append(solver(pose, wrench))
            work = solver._local.work
            iterations.append(work.iterations)
            senses.append(work.sense.copy())
        assert work.native is native
    return rows, iterations, senses


@pytest.mark.parametrize("warm", [True, False])
def test_distributor_with_and_without_the_native_path_equals_distribute(robot, warm,
                                                                         monkeypatch):
    poses = random_poses(robot, 11, 40)
    reference = to.distribute(robot, poses, "min_norm", "qpsolvers:daqp")
    native, native_its, native_senses = run(robot, poses, True, monkeypatch,
                                            warm_start=warm)
    python, python_its, python_senses = run(robot, poses, False, monkeypatch,
                                            warm_start=warm)
    assert reference.success.sum() >= 10
    for k in range(len(poses)):
        for row in (native[k], python[k]):
            assert row.status == reference.status[k]
            if row.status == to.Status.OPTIMAL:
                scale = np.abs(reference.tensions[k]).max()
                assert np.abs(row.tensions - reference.tensions[k]).max() <= REL * scale
            else:
                assert np.isnan(row.tensions).all()
        # The same solve to the last bit: tensions, working sets, iterations.
        np.testing.assert_array_equal(native[k].tensions, python[k].tensions)
        assert native[k].compiled == python[k].compiled
        np.testing.assert_array_equal(native_senses[k], python_senses[k])
    assert native_its == python_its
    assert sum(row.compiled for row in native) >= reference.success.sum() // 2


def test_a_wrench_no_tensions_hold_gets_the_same_status_both_ways(robot, monkeypatch):
    lift = np.zeros(robot.dof)
    lift[2] = 5 * robot.mass * robot.g  # pushes the platform up: cables cannot push
    home = robot.default_home()[None, :]
    reference = to.distribute(robot, home, "min_norm", "qpsolvers:daqp", wrench=lift)
    assert reference.status[0] == to.Status.INFEASIBLE
    for native in (True, False):
        (row,), _, _ = run(robot, home, native, monkeypatch, wrench=lift)
        assert row.status == to.Status.INFEASIBLE
        assert not row.compiled and np.isnan(row.tensions).all()


def test_threads_sharing_a_distributor_answer_as_one_thread(in_threads):
    robot = presets.cogiro()
    poses = random_poses(robot, 5, 60)
    solver = to.Distributor(robot, "min_norm", "qpsolvers:daqp")
    expected = np.array([solver(p).tensions for p in poses])
    assert solver._local.work.native
    out = np.full((4, *expected.shape), -1.0)

    def work(k: int) -> None:
        for _ in range(3):
            for i, p in enumerate(poses):
                out[k, i] = solver(p).tensions

    in_threads(work, 4)
    for k in range(4):
        np.testing.assert_allclose(out[k], expected, rtol=REL, atol=0.0, equal_nan=True)


def test_daqp_pose_falls_back_to_daqp_solve(monkeypatch):
    assert DaqpPose(4, 3, {"primal_tol": 1e-8}, True, 100).native
    # A setting the verified layout does not name, or no verified C solver.
    assert not DaqpPose(4, 3, {"primal_tol": 1e-8, "no_such_setting": 1}, True, 100).native
    monkeypatch.setattr(daqp_native, "load", lambda: None)
    assert not DaqpPose(4, 3, {"primal_tol": 1e-8}, True, 100).native


@pytest.mark.parametrize("objective", ["min_norm", "min_sum", "min_max"])
def test_the_daqp_backend_answers_alike_with_and_without_the_native_path(
        robot, objective, monkeypatch):
    """The ``qpsolvers:daqp`` backend's batch loop: every pose in one compiled call, or
    ``daqp.solve`` per pose: the same tensions, statuses, iterations and multipliers
    (infeasible poses included: a wrench lifting the platform)."""
    assert NATIVE is not None  # the first call below runs the compiled loop
    poses = random_feasible_poses(robot, 30, seed=11)
    wrench = np.zeros((30, robot.dof))
    wrench[::7, 2] = 5.0 * robot.weight
    native = to.distribute(robot, poses, objective, "qpsolvers:daqp", wrench=wrench)
    with monkeypatch.context() as patch:
        patch.setattr(daqp_native, "load", lambda: None)
        python = to.distribute(robot, poses, objective, "qpsolvers:daqp", wrench=wrench)
    np.testing.assert_array_equal(native.status, python.status)
    assert (native.status[::7] != to.Status.OPTIMAL).all()
    np.testing.assert_array_equal(native.tensions, python.tensions)
    np.testing.assert_array_equal(native.iterations, python.iterations)
    np.testing.assert_array_equal(native.multipliers.y, python.multipliers.y)
