"""Large batches in bounded memory, and magnitudes up to the float range.

:func:`tension_opt.distribute` solves a batch larger than ``chunk_size`` chunk by chunk;
its results must be those of one call on the whole batch, and its peak memory that of
the results plus one chunk. The typical tension of a pose (the unit of every tolerance)
must not overflow for wrenches near the float range.
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import warnings
from dataclasses import fields, is_dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.backends.base import RawResult
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.distribution.entry import CHUNK_SIZE
from tension_opt.errors import InvalidInputError
from tension_opt.problem.affine import solution_set
from tension_opt.problem.form import StandardForm, TensionProblem, safe_norm, typical_tension
from tension_opt.workspace.sampling import default_box, feasible_mask, random_feasible_poses

# The module (the package's name ``distribute`` is the function).
distribute_module = importlib.import_module("tension_opt.distribution.entry")

#: Poses of the memory test: above ten chunks, and enough that the unchunked path needs
#: over 2 GB (the two-dimensional closed form holds about 23 kB per pose at once).
MEMORY_POSES = 100_000
#: Peak resident memory allowed to the process (bytes).
MEMORY_LIMIT = 1 << 30

_MEMORY_SCRIPT = r"""
import json, resource, sys
import numpy as np
import tension_opt as to

# A forked child counts its parent's resident pages until it runs a new program, and
# Linux keeps that peak across the exec: reset the high-water mark here (Linux >= 4.0).
try:
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    reset = True
except OSError:
    reset = False

N, sample = int(sys.argv[1]), 256
robot = to.presets.cogiro()
rng = np.random.default_rng(7)
poses = np.column_stack([rng.uniform(-3, 3, N), rng.uniform(-2, 2, N), rng.uniform(1, 4, N),
                         rng.uniform(-0.1, 0.1, (N, 3))])
pick = np.sort(rng.choice(N, sample, replace=False))
report = {}
for objective, backend in (("min_sum", "closed_form"), ("min_norm", "auto")):
    whole = to.distribute(robot, poses, objective, backend)
    few = to.distribute(robot, poses[pick], objective, backend)
    same = {}
    for name in ("tensions", "status", "unique", "objective", "residual",
                 "bound_violation", "infeasibility", "iterations"):
        a, b = getattr(whole, name)[pick], getattr(few, name)
        same[name] = bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
        if name in ("objective", "residual", "bound_violation"):
            # Sums in another order (the certified path of large batches): to rounding
            # of the tensions' size.
            same[name] = bool(np.allclose(a, b, rtol=1e-12, atol=1e-9, equal_nan=True))
    report[f"{objective}/{backend}"] = {
        "same": same, "optimal": int((whole.status == to.Status.OPTIMAL).sum()),
        "form": whole.form is None, "N": whole.N}
    del whole, few
if reset:
    with open("/proc/self/status") as f:
        hwm = next(line for line in f if line.startswith("VmHWM:"))
    report["peak"] = int(hwm.split()[1]) * 1024
else:  # ru_maxrss is in kilobytes on Linux.
    report["peak"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps(report))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ru_maxrss in kB on Linux")
def test_large_batch_runs_in_bounded_memory() -> None:
    """10^5 CoGiRo poses (six degrees of freedom, eight cables), closed form (min-sum)
    and automatic (min-norm): the process stays under 1 GB (unchunked it needs over
    2 GB), and a sample of poses matches a small call of its own exactly. (10^6 poses
    peak at about 0.5 GB but take over a minute.)"""
    assert MEMORY_POSES > 10 * CHUNK_SIZE
    out = subprocess.run([sys.executable, "-c", _MEMORY_SCRIPT, str(MEMORY_POSES)],
                         capture_output=True, text=True, timeout=600, check=True)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["peak"] < MEMORY_LIMIT, report
    for key in ("min_sum/closed_form", "min_norm/auto"):
        part = report[key]
        assert part["N"] == MEMORY_POSES
        assert all(part["same"].values()), (key, part["same"])
        # The box is inside CoGiRo's workspace: every pose is held.
        assert part["optimal"] == MEMORY_POSES
        assert part["form"], "a chunked solution keeps no form"


# ------------------------------------------------------------ chunked == unchunked
def _poses(robot: to.CableRobot, N: int, seed: int, spread: float = 1.0) -> np.ndarray:
    """Poses in (and, with ``spread`` > 1, around) the robot's default box."""
    low, high = default_box(robot)
    mid, half = (low + high) / 2, (high - low) / 2 * spread
    return np.random.default_rng(seed).uniform(mid - half, mid + half, (N, robot.dof))


def assert_same(a: to.TensionSolution, b: to.TensionSolution, rounding: bool = False) -> None:
    """Every per-pose field, labels and extras equal (NaN where NaN).

    The min-sum objective is a matrix product, whose BLAS kernel for one to three rows
    (a chunk that small) may round the last bit otherwise: it is compared to 1e-15.
    With ``rounding`` (one solution from the certified path of large batches, whose sums
    run in another order), the objective is compared to 1e-12 and the equilibrium
    residual and bound violation to 1e-12 of the pose's largest tension.
    """
    for f in fields(a):
        if f.name in ("form", "setup_time", "solve_time", "problem"):
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if is_dataclass(x) and not isinstance(x, type):  # e.g. per-pose multipliers
            assert type(x) is type(y), f.name
            for g in fields(x):
                u, v = getattr(x, g.name), getattr(y, g.name)
                assert np.array_equal(u, v, equal_nan=True), (f.name, g.name)
        elif f.name == "objective":
            np.testing.assert_allclose(x, y, rtol=1e-12 if rounding else 1e-15, atol=0.0)
        elif rounding and f.name in ("residual", "bound_violation"):
            size = np.nanmax(np.abs(b.tensions), axis=1, initial=1.0)
            np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=f.name)
            assert (np.abs(x - y)[~np.isnan(y)] <= 1e-12 * size[~np.isnan(y)]).all(), f.name
        elif isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray) and x.shape == y.shape, f.name
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), f.name
        else:
            assert x == y, (f.name, x, y)


@pytest.fixture(scope="module")
def cogiro() -> to.CableRobot:
    return to.presets.cogiro()


@settings(max_examples=12, deadline=None, derandomize=True)
@given(size=st.integers(1, 70), seed=st.integers(0, 2**16),
       objective=st.sampled_from(["min_sum", "min_norm", "centered", "pinv"]))
def test_chunks_give_the_unchunked_result(size: int, seed: int, objective: str) -> None:
    """Any chunk size, on a mix of feasible and infeasible CoGiRo poses."""
    robot = to.presets.cogiro()
    poses = _poses(robot, 60, seed, spread=1.6)
    whole = to.distribute(robot, poses, objective, "closed_form")
    chunked = to.distribute(robot, poses, objective, "closed_form", chunk_size=size)
    # Whole, the batch takes the certified pass in one task (objective and residuals to
    # rounding), its form kept.
    assert_same(whole, chunked, rounding=True)
    assert chunked.problem is whole.problem or chunked.problem.name == whole.problem.name
    assert (chunked.form is None) == (size < len(poses)) and whole.form is not None


@pytest.mark.parametrize("objective", ["min_sum", "min_norm"])
def test_chunks_in_threads_give_the_serial_result(cogiro: to.CableRobot, objective: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Chunks of the compiled closed form run side by side in threads (whatever this
    machine's core count, three here) and join to the serial loop's result exactly; an
    invalid pose in a later chunk still raises, numbered in the batch."""
    poses = _poses(cogiro, 300, 21, spread=1.6)
    monkeypatch.setattr(distribute_module, "chunk_threads", lambda: 1)
    serial = to.distribute(cogiro, poses, objective, "closed_form", chunk_size=23)
    assert 0 < (serial.status == to.Status.OPTIMAL).sum() < len(poses)
    monkeypatch.setattr(distribute_module, "chunk_threads", lambda: 3)
    threaded = to.distribute(cogiro, poses, objective, "closed_form", chunk_size=23)
    assert_same(serial, threaded)
    poses[251, :3] = cogiro.anchors[3] - cogiro.attachments[3]
    poses[251, 3:] = 0.0
    with pytest.raises(InvalidInputError, match=r"pose 251 .*cable 3"):
        to.distribute(cogiro, poses, objective, "closed_form", chunk_size=23)


def test_per_pose_inputs_are_cut_with_the_poses(cogiro: to.CableRobot) -> None:
    """Wrenches, bounds and references with one row per pose go with their poses."""
    N = 50
    rng = np.random.default_rng(3)
    poses = _poses(cogiro, N, 3)
    wrench = rng.normal(0.0, 30.0, (N, 6))
    t_min = np.asarray(cogiro.t_min) + rng.uniform(0.0, 20.0, (N, cogiro.m))
    problem = TensionProblem("min_norm", t_min=t_min, reference=rng.uniform(300, 900, (N, 8)))
    whole = to.distribute(cogiro, poses, problem, "auto", wrench=wrench)
    assert_same(whole, to.distribute(cogiro, poses, problem, "auto", wrench=wrench,
                                     chunk_size=7))
    # Each pose really used its own row: pose 0 alone gives the same tensions.
    alone = to.distribute(cogiro, poses[:1], problem.with_(t_min=t_min[:1],
                                                             reference=problem.reference[:1]),
                          "auto", wrench=wrench[:1])
    np.testing.assert_array_equal(alone.tensions[0], whole.tensions[0])


@pytest.mark.parametrize("problem", [TensionProblem("min_sum", smoothing=1e-3),
                                     TensionProblem("min_sum", rate_limit=400.0)],
                         ids=["smoothed", "rate_limited"])
def test_a_sequence_carries_on_across_chunks(cogiro: to.CableRobot,
                                             problem: TensionProblem) -> None:
    """Each pose of a sequence is smoothed against the one before, also at the first
    pose of a chunk; independent previous tensions (N, m) are cut with the poses."""
    poses = np.sort(_poses(cogiro, 120, 5), axis=0)
    start = np.full(cogiro.m, 800.0)
    whole = to.distribute(cogiro, poses, problem, "closed_form", previous=start)
    assert (whole.status == to.Status.OPTIMAL).sum() > 20
    assert_same(whole, to.distribute(cogiro, poses, problem, "closed_form", previous=start,
                                     chunk_size=17))
    rows = np.random.default_rng(1).uniform(500, 1500, (len(poses), cogiro.m))
    assert_same(to.distribute(cogiro, poses, problem, "closed_form", previous=rows),
                to.distribute(cogiro, poses, problem, "closed_form", previous=rows,
                              chunk_size=17))


def test_extras_count_poses_over_the_whole_batch(cogiro: to.CableRobot,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Poses handed to a fallback backend, and per-pose error messages, are numbered in
    the batch, not in their chunk. The closed form is made to fail on the poses whose
    first cable points least along -x (a property of the pose, whatever its chunk)."""
    solve = ClosedFormBackend.solve

    def failing(self: ClosedFormBackend, form: StandardForm, **options: object) -> RawResult:
        raw = solve(self, form, **options)
        bad = np.flatnonzero(form.A[:, 0, 0] > -0.3)
        raw.status[bad] = to.Status.SOLVER_ERROR
        raw.extras["errors"] = {int(i): f"failed at x-cosine {form.A[i, 0, 0]:.6f}"
                                for i in bad}
        return raw

    monkeypatch.setattr(ClosedFormBackend, "solve", failing)
    # The certified path of large batches does not call the backend's solve: off here
    # (its poses handed on are numbered in tests/tension_opt/test_fused_distribute.py).
    monkeypatch.setattr(distribute_module, "certified_plan", lambda *args: None)
    monkeypatch.setattr(distribute_module, "plan_of", lambda *args: None)
    poses = _poses(cogiro, 40, 11)
    whole = to.distribute(cogiro, poses, "min_sum", "auto")
    moved = [k for ks in whole.extras["fallback"].values() for k in ks]
    assert 2 <= len(moved) < 30 and max(moved) > 6, moved
    assert sorted(whole.extras["errors"]) == moved[:len(whole.extras["errors"])]
    assert_same(whole, to.distribute(cogiro, poses, "min_sum", "auto", chunk_size=6))


def test_errors_name_the_pose_in_the_batch(cogiro: to.CableRobot) -> None:
    """An invalid pose or bound in a later chunk is named by its number in the batch."""
    poses = _poses(cogiro, 40, 2)
    poses[33, :3] = cogiro.anchors[3] - cogiro.attachments[3]
    poses[33, 3:] = 0.0
    with pytest.raises(InvalidInputError, match=r"pose 33 .*cable 3"):
        to.distribute(cogiro, poses, chunk_size=8)
    t_min = np.full((40, cogiro.m), 100.0)
    t_min[29, 2] = 2.0 * float(np.max(cogiro.t_max))
    with pytest.raises(InvalidInputError, match="cable 2 at pose 29"):
        to.distribute(cogiro, _poses(cogiro, 40, 2), TensionProblem("min_sum", t_min=t_min),
                      chunk_size=8)
    with pytest.raises(InvalidInputError, match=r"wrench must have shape \(6,\) or \(40, 6\)"):
        to.distribute(cogiro, poses, wrench=np.zeros((8, 6)), chunk_size=8)


@pytest.mark.parametrize("size", [0, -3, 2.5, "8", True, None.__class__])
def test_chunk_size_must_be_a_whole_number(cogiro: to.CableRobot, size: object) -> None:
    with pytest.raises(InvalidInputError, match="chunk_size must be a whole number >= 1"):
        to.distribute(cogiro, cogiro.home, chunk_size=size)


def test_feasible_mask_in_chunks_matches_one_call(cogiro: to.CableRobot) -> None:
    """Feasibility checked chunk by chunk gives the same mask as one call."""
    poses = _poses(cogiro, CHUNK_SIZE + 300, 9, spread=1.6)
    mask = feasible_mask(cogiro, poses)
    np.testing.assert_array_equal(mask, to.distribute(cogiro, poses, backend="closed_form")
                                  .success)
    assert 0 < mask.sum() < len(poses)


# ------------------------------------------------------------------- no overflow
def test_typical_tension_does_not_overflow_at_1e300() -> None:
    """||b|| of a 1e300 wrench is 1e300 * sqrt(k), not inf (squares overflow beyond
    1e154); tiny wrenches are not lost to underflow either."""
    A = np.zeros((3, 6, 8))
    A[:, 0, :], A[:, 2, :] = 1.0, 0.5  # every column of norm sqrt(1.25)
    b = np.zeros((3, 6))
    b[0, :3] = 1e300
    b[1, 2] = -1e308
    b[2, :2] = 3e-170, 4e-170
    lb = np.zeros((3, 8))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = typical_tension(A, b, lb)
        np.testing.assert_allclose(s, [np.sqrt(3) * 1e300 / np.sqrt(1.25),
                                       1e308 / np.sqrt(1.25), 1e-12], rtol=1e-14)
        np.testing.assert_allclose(safe_norm(b, axis=1), [np.sqrt(3) * 1e300, 1e308, 5e-170],
                                   rtol=1e-14)
        # A norm beyond the float range is inf, honestly.
        assert safe_norm(np.full((1, 4), 1e308), axis=1)[0] == np.inf
        # Consistency of b with a singular A is decided at that scale too.
        sing = np.zeros((2, 3, 4))
        sing[:, 0, :] = 1.0
        wrenches = np.array([[1e300, 0, 0], [1e300, 1e300, 0]])
        np.testing.assert_array_equal(solution_set(sing, wrenches).consistent, [True, False])


@pytest.mark.parametrize("robot_name", ["cogiro", "algae_harvester"])
def test_distribute_reports_a_1e300_wrench_infeasible(robot_name: str) -> None:
    robot = getattr(to.presets, robot_name)()
    wrench = np.zeros(robot.dof)
    wrench[: min(3, robot.dof)] = 1e300
    sol = to.distribute(robot, robot.home, "min_sum", "closed_form", wrench=wrench)
    assert sol.status[0] == to.Status.INFEASIBLE
    assert np.isnan(sol.tensions).all()


def test_capacity_margin_in_chunks_equals_one_batch(monkeypatch: pytest.MonkeyPatch) -> None:
    import tension_opt.workspace.margin as margin_module

    robot = to.presets.cogiro()
    poses = random_feasible_poses(robot, 50, seed=3)
    wrenches = np.random.default_rng(3).normal(scale=50.0, size=(50, 6))
    whole = to.capacity_margin(robot, poses, wrenches)
    monkeypatch.setattr(margin_module, "MARGIN_CHUNK", 7)
    chunked = to.capacity_margin(robot, poses, wrenches)
    np.testing.assert_array_equal(chunked, whole)
    assert np.isfinite(whole).all() and (whole > 0).sum() > 10
