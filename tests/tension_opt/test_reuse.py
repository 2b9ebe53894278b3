"""``distribute(..., out=earlier)``: the results written into the arrays of an earlier
solution, bit for bit those of a call without ``out``, on every path (the certified
compiled pass of a large batch, one piece, chunks joined, other backends), and bad
``out`` met with the package's error naming it."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import tension_opt as to
from tension_opt import presets
from tension_opt.distribution.certified import CertifiedBatch
from tension_opt.distribution.solution import per_pose_arrays
from tension_opt.errors import InvalidInputError
from tension_opt.problem.form import TensionProblem
from tension_opt.workspace.sampling import default_box

distribute_module = importlib.import_module("tension_opt.distribution.entry")


def box_poses(robot: to.CableRobot, N: int, seed: int) -> np.ndarray:
    """``N`` poses uniform in the robot's default box (some infeasible)."""
    lo, hi = default_box(robot)
    return np.random.default_rng(seed).uniform(lo, hi, (N, len(lo)))


def assert_written_into(fresh: to.TensionSolution, reused: to.TensionSolution,
                        out_arrays: dict[str, np.ndarray]) -> None:
    """``reused`` has ``fresh``'s values bit for bit (NaN as NaN), each array being the
    one ``out`` held before the call, and the same labels and extras."""
    mine, theirs = per_pose_arrays(fresh), per_pose_arrays(reused)
    assert mine.keys() == theirs.keys()
    for name, value in mine.items():
        if value is None:
            assert theirs[name] is None, name
            continue
        assert theirs[name] is out_arrays[name], name
        if value.dtype.kind == "f":
            np.testing.assert_array_equal(value.view(np.int64), theirs[name].view(np.int64),
                                          err_msg=name)
        else:
            np.testing.assert_array_equal(value, theirs[name], err_msg=name)
    for name in ("backend", "solver", "accuracy", "extras"):
        assert getattr(fresh, name) == getattr(reused, name), name


@pytest.mark.parametrize("objective", ["min_sum", "min_norm", "min_max"])
@pytest.mark.parametrize("threads", [1, 2])
def test_certified_batch_writes_into_out(objective: str, threads: int,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A large batch on the certified compiled pass, in tasks on one or two threads:
    out's arrays take exactly the results of a fresh call (an earlier result of other
    poses, overwritten everywhere, iteration counts of another backend reset)."""
    monkeypatch.setattr(distribute_module, "chunk_threads", lambda: threads)
    robot = presets.algae_harvester()
    poses = box_poses(robot, 3000, 4)
    wrench = np.zeros((len(poses), 3))
    wrench[17, 0] = 1e160  # a pose the kernel leaves to the chunk path
    calls: list[slice] = []
    solve = CertifiedBatch.solve
    monkeypatch.setattr(CertifiedBatch, "solve",
                        lambda self, sl: calls.append(sl) or solve(self, sl))
    fresh = to.distribute(robot, poses, objective, "closed_form", wrench=wrench,
                          chunk_size=256)
    assert len(calls) == 12
    assert 0 < fresh.success.sum() < len(poses)
    earlier = to.distribute(robot, poses[::-1] * 0.9, objective, "scipy:highs"
                            if objective == "min_sum" else "closed_form")
    del calls[12:]  # a batch of one chunk on the closed form takes the pass in one task
    if objective == "min_sum":
        assert earlier.iterations is not None and earlier.iterations.any()
    arrays = per_pose_arrays(earlier)
    reused = to.distribute(robot, poses, objective, "closed_form", wrench=wrench,
                           chunk_size=256, out=earlier)
    assert len(calls) == 24
    assert_written_into(fresh, reused, arrays)


def test_default_tasks_are_larger_than_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without ``chunk_size`` the certified pass runs in tasks of ``CERTIFIED_TASK``
    poses; with it, in chunks of that size; the same results either way."""
    monkeypatch.setattr(distribute_module, "CERTIFIED_TASK", 1500)
    robot = presets.algae_harvester()
    poses = box_poses(robot, 4500, 8)
    calls: list[slice] = []
    solve = CertifiedBatch.solve
    monkeypatch.setattr(CertifiedBatch, "solve",
                        lambda self, sl: calls.append(sl) or solve(self, sl))
    monkeypatch.setattr(distribute_module, "CHUNK_SIZE", 1000)
    tasks = to.distribute(robot, poses, "min_norm", "closed_form")
    assert [sl.stop - sl.start for sl in calls] == [1500] * 3
    chunks = to.distribute(robot, poses, "min_norm", "closed_form", chunk_size=1000)
    assert [sl.stop - sl.start for sl in calls[3:]] == [900] * 5
    for name, value in per_pose_arrays(tasks).items():
        np.testing.assert_array_equal(value, per_pose_arrays(chunks)[name], err_msg=name)


@pytest.mark.parametrize("case", ["one_piece", "joined_chunks", "other_backend"])
def test_other_paths_write_into_out(case: str) -> None:
    """Off the certified pass (one piece, chunks with per-pose bounds joined, a solver
    backend), the results are copied into out's arrays, bit for bit."""
    robot = presets.algae_harvester()
    poses = box_poses(robot, 300, 5)
    problem: object = "min_sum"
    kwargs: dict[str, object] = {}
    backend = "closed_form"
    if case == "joined_chunks":
        t_min = np.random.default_rng(1).uniform(5.0, 50.0, (len(poses), robot.m))
        problem = TensionProblem("min_norm", t_min=t_min)
        kwargs["chunk_size"] = 64
    if case == "other_backend":
        backend = "scipy:highs"
    fresh = to.distribute(robot, poses, problem, backend, **kwargs)
    earlier = to.distribute(robot, poses[::-1], problem, backend, **kwargs)
    arrays = per_pose_arrays(earlier)
    reused = to.distribute(robot, poses, problem, backend, out=earlier, **kwargs)
    assert_written_into(fresh, reused, arrays)


def test_bad_out_is_named() -> None:
    """Not a solution, another number of poses, an array shared with an input, a
    problem of other multipliers: the package's error naming ``out``."""
    robot = presets.algae_harvester()
    poses = box_poses(robot, 5000, 6)
    earlier = to.distribute(robot, poses, "min_sum", "closed_form")
    with pytest.raises(InvalidInputError, match=r"out must be a TensionSolution"):
        to.distribute(robot, poses, "min_sum", "closed_form", out=earlier.tensions)
    with pytest.raises(InvalidInputError, match=r"out\.tensions has shape \(5000, 4\).*"
                                                r"\(4999, 4\)"):
        to.distribute(robot, poses[1:], "min_sum", "closed_form", out=earlier)
    with pytest.raises(InvalidInputError, match=r"out\.tensions shares memory"):
        to.distribute(robot, poses, "min_sum", "closed_form",
                      wrench=earlier.tensions[:, :3], out=earlier)
    # min-max has a multiplier per cable for its epigraph rows; min-sum none.
    with pytest.raises(InvalidInputError, match=r"out\.multipliers\.mu has shape \(5000, 0\)"):
        to.distribute(robot, poses, "min_max", "closed_form", out=earlier)
    small = to.distribute(robot, poses[:50], "min_sum", "closed_form")
    with pytest.raises(InvalidInputError, match=r"out\.multipliers\.mu has shape \(50, 0\)"):
        to.distribute(robot, poses[:50], "min_max", "closed_form", out=small)
    read_only = to.distribute(robot, poses, "min_sum", "closed_form")
    read_only.status.flags.writeable = False
    with pytest.raises(InvalidInputError, match=r"out\.status must be a writeable array"):
        to.distribute(robot, poses, "min_sum", "closed_form", out=read_only)


@pytest.mark.parametrize(("count", "backend"), [(2, "cvxpy:CLARABEL"), (10_000, "closed_form")])
def test_a_rejected_out_is_left_as_it_was(count: int, backend: str) -> None:
    """An earlier result of another problem (min-max has other multipliers) is refused
    before anything is written into it (the copy once stopped at the first misfit)."""
    if backend not in to.available_backends():
        pytest.skip(f"{backend} not installed")
    robot = to.presets.algae_harvester()
    poses = np.repeat([[0.0, 0.0, 0.0], [-29.4, 10.2, 1.5]], count // 2, axis=0)
    out = to.distribute(robot, poses, "min_sum", backend)
    before = {name: a.copy() for name, a in per_pose_arrays(out).items() if a is not None}
    with pytest.raises(to.InvalidInputError, match=r"multipliers\.mu"):
        to.distribute(robot, poses, "min_max", backend, out=out)
    for name, array in per_pose_arrays(out).items():
        if array is not None:
            assert array.tobytes() == before[name].tobytes(), name
