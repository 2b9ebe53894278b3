"""Every backend called from 8 threads at once gives the serial answers and statuses."""

from __future__ import annotations

import random
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import tension_opt as to
from tension_opt.workspace.sampling import random_feasible_poses

THREADS = 8
POSES = 100
OBJECTIVES = ("min_sum", "min_norm")


@pytest.fixture(scope="module")
def study() -> to.CableRobot:
    return to.presets.algae_harvester()


@pytest.fixture(scope="module")
def poses(study: to.CableRobot) -> np.ndarray:
    return random_feasible_poses(study, POSES, seed=16)


def _supported(backend: str, objective: str, robot: to.CableRobot, poses: np.ndarray) -> bool:
    form = to.TensionProblem(objective).standard_form(robot, poses[:1])
    return to.get_backend(backend).unsupported(form) is None


def _same(got: to.TensionSolution, want: to.TensionSolution, label: str) -> None:
    assert got.status.tolist() == want.status.tolist(), label
    np.testing.assert_allclose(got.tensions, want.tensions, rtol=1e-12, atol=0.0,
                               equal_nan=True, err_msg=label)


@pytest.mark.parametrize("backend", to.available_backends())
def test_eight_threads_give_the_serial_answers(backend: str, study: to.CableRobot,
                                               poses: np.ndarray) -> None:
    objectives = [o for o in OBJECTIVES if _supported(backend, o, study, poses)]
    assert objectives, f"{backend} takes neither min_sum nor min_norm"
    serial = {o: to.distribute(study, poses, o, backend=backend) for o in objectives}
    # Each thread solves the whole batch, objectives interleaved, so that several calls
    # run through one backend instance at once.
    jobs = [objectives[k % len(objectives)] for k in range(THREADS)]
    with ThreadPoolExecutor(THREADS) as pool:
        results = list(pool.map(lambda o: to.distribute(study, poses, o, backend=backend),
                                jobs))
    for objective, got in zip(jobs, results, strict=True):
        _same(got, serial[objective], f"{backend} {objective}")


def test_every_backend_at_once_gives_the_serial_answers(study: to.CableRobot,
                                                        poses: np.ndarray) -> None:
    # Different backends (and solver libraries) interleaved in one pool.
    few = poses[:30]
    cells = [(b, o) for b in to.available_backends() for o in OBJECTIVES
             if _supported(b, o, study, few)]
    serial = {cell: to.distribute(study, few, cell[1], backend=cell[0]) for cell in cells}
    jobs = cells * 2
    random.Random(16).shuffle(jobs)
    with ThreadPoolExecutor(THREADS) as pool:
        results = list(pool.map(lambda c: to.distribute(study, few, c[1], backend=c[0]), jobs))
    for cell, got in zip(jobs, results, strict=True):
        _same(got, serial[cell], f"{cell[0]} {cell[1]}")


def test_auto_and_sequences_from_threads(study: to.CableRobot, poses: np.ndarray) -> None:
    # The automatic choice and a smoothed sequence (pose k against pose k - 1).
    problems = [to.TensionProblem("min_sum"), to.TensionProblem("min_norm", smoothing=0.1),
                to.TensionProblem("min_max")]
    serial = [to.distribute(study, poses[:40], p) for p in problems]
    jobs = list(range(len(problems))) * 3
    with ThreadPoolExecutor(THREADS) as pool:
        results = list(pool.map(lambda j: to.distribute(study, poses[:40], problems[j]), jobs))
    for j, got in zip(jobs, results, strict=True):
        _same(got, serial[j], problems[j].name)


def test_qp_sequence_loops_from_threads(study: to.CableRobot, poses: np.ndarray) -> None:
    """Smoothed sequences through the qpsolvers loops (DAQP's compiled one, and the
    others' compiled steps around the solver) from 8 threads at once."""
    problem = to.TensionProblem("min_sum", smoothing=1e-3)
    backends = [b for b in ("qpsolvers:daqp", "qpsolvers:piqp", "qpsolvers:quadprog")
                if b in to.available_backends()]
    serial = {b: to.distribute(study, poses[:40], problem, b) for b in backends}
    jobs = backends * 4
    random.Random(3).shuffle(jobs)
    with ThreadPoolExecutor(THREADS) as pool:
        results = list(pool.map(lambda b: to.distribute(study, poses[:40], problem, b), jobs))
    for backend, got in zip(jobs, results, strict=True):
        _same(got, serial[backend], backend)


def test_warnings_filters_are_left_as_they_were(study: to.CableRobot,
                                                poses: np.ndarray) -> None:
    # The solvers' own warnings are silenced while they run; concurrent calls must not
    # leave the process's warning filters changed.
    import warnings

    before = list(warnings.filters)
    names = [b for b in to.available_backends() if b.startswith(("qpsolvers", "cvxpy"))]
    jobs = [(b, "min_norm") for b in names if _supported(b, "min_norm", study, poses)] * 2
    with ThreadPoolExecutor(THREADS) as pool:
        list(pool.map(lambda c: to.distribute(study, poses[:10], c[1], backend=c[0]), jobs))
    assert warnings.filters == before
