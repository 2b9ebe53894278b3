"""Latency of single calls and throughput of large batches, before and after the
compiled real-time path: ``python -m benchmarks.bench_latency``.

Each row times the numpy reference of a call ("before": the plain call as it was
before the compiled path, kept as ``compiled=False``), the compiled path
(:class:`tension_opt.Distributor`, the plain calls on :mod:`tension_opt.kernels` and
:mod:`catenary.solve.kernels`, :class:`catenary.thesis_ik.ThesisIK`,
:class:`catenary.coupled_ik.CoupledIK`, :class:`catenary.PoseStiffness` and the
compiled batches of :func:`catenary.platform_stiffness`; "after") and raw baselines
(the DAQP call on the same data, plain numpy arithmetic), with p50 and p99 over many
calls. Single calls are timed in CPU time of the calling thread
(``time.thread_time_ns``), so that other load on a shared machine counts less; the
timer's own cost (about 1 us: the clock is a system call) is printed as the first row
and included in every per-call figure.
Batches are timed in wall time per pose (``time.perf_counter``) on one and on all numba
threads: the median of seven calls after one untimed call of the same size, the
variants of a row taken in turn (one call of each per round). A plain
call's results are fresh memory whose page faults it pays (the allocator gives large
arrays back to the system when freed); its statuses are one-byte codes until read, and
the ``.status`` row adds decoding them; the ``out=`` row writes into the arrays of an
earlier result instead.
The first-call cost (compiling the kernels, or loading them from numba's disk
cache) is measured in fresh processes.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from typing import Protocol, cast

import numpy as np

import catenary
import tension_opt as to
from catenary.solve_compiled import PARALLEL_FROM, solve_forces_compiled, solve_length_compiled
from tension_opt import presets
from tension_opt.backends.closed_form import ClosedFormBackend
from tension_opt.distribution.entry import chunk_threads
from tension_opt.kernels import launch
from tension_opt.kernels.launch import PARALLEL_MIN
from tension_opt.workspace.sampling import random_feasible_poses

__all__ = ["main"]

#: Calls per single-call row (fewer for calls over 1 ms).
CALLS = 10_000


class Call(Protocol):
    """A call to time, made without arguments (a lambda may bind its loop's values as
    defaults)."""

    def __call__(self) -> object: ...


class _ChunkThreads(Protocol):
    """The module of ``distribute``, which looks its ``chunk_threads`` up at each call."""

    chunk_threads: Callable[[], int]


class _NumbaConfig(Protocol):
    """``numba.config``, whose ``NUMBA_*`` settings numba sets from the environment at run
    time (attributes no type checker sees)."""

    NUMBA_NUM_THREADS: int


def percentiles(fn: Call, calls: int) -> tuple[float, float]:
    """p50 and p99 (us) of the CPU time of ``calls`` calls of ``fn`` (after a warm-up)."""
    fn()
    times = np.empty(calls)
    for k in range(calls):
        t0 = time.thread_time_ns()
        fn()
        times[k] = time.thread_time_ns() - t0
    return float(np.median(times)) / 1e3, float(np.percentile(times, 99)) / 1e3


def calls_for(fn: Call) -> int:
    """:data:`CALLS`, or fewer for a call over 1 ms (about 2 s of calls, at least 20)."""
    t0 = time.perf_counter()
    fn()
    once = time.perf_counter() - t0
    return CALLS if once < 1e-3 else max(20, int(2.0 / once))


def row(label: str, fn: Call) -> tuple[float, float]:
    """Time one call and print its line; returns (p50, p99) in us."""
    p50, p99 = percentiles(fn, calls_for(fn))
    print(f"  {label:<58s} p50 {p50:10.2f} us   p99 {p99:10.2f} us", flush=True)
    return p50, p99


def ratio(before: tuple[float, float], after: tuple[float, float]) -> None:
    print(f"  {'ratio before / after (p50)':<58s} {before[0] / after[0]:10.1f}x")


def single_pose_rows() -> None:
    """Rows 1-4 of the table: one pose through distribute, the DAQP backend, geometry."""
    study, cogiro = presets.algae_harvester(), presets.cogiro()
    numpy_closed = ClosedFormBackend(compiled=False)
    for robot, name in ((study, "study robot"), (cogiro, "CoGiRo")):
        pose = robot.default_home()
        print(f"distribute({name}, one pose, 'min_norm', 'closed_form')")
        before = row("before: distribute, numpy closed form (compiled=False)",
                     lambda r=robot, p=pose: to.distribute(r, p, "min_norm", numpy_closed))
        row("plain call: tension_opt.distribute (compiled)",
            lambda r=robot, p=pose: to.distribute(r, p, "min_norm", "closed_form"))
        solver = to.Distributor(robot, "min_norm", "closed_form")
        after = row("after: Distributor", lambda s=solver, p=pose: s(p))
        ratio(before, after)
        A, b = robot.structure_matrices(pose)[0], robot.required_wrench(pose)[0]
        row("baseline: numpy pinv (no bounds)", lambda A=A, b=b: np.linalg.pinv(A) @ b)
        print(f"distribute({name}, one pose, 'min_norm', 'qpsolvers:daqp')")
        before = row("before: tension_opt.distribute", lambda r=robot, p=pose: to.distribute(
            r, p, "min_norm", "qpsolvers:daqp"))
        solver = to.Distributor(robot, "min_norm", "qpsolvers:daqp")
        after = row("after: Distributor (compiled QP, DAQP, certificate)",
                    lambda s=solver, p=pose: s(p))
        ratio(before, after)
        raw = raw_daqp_rows(solver, pose)
        print(f"  {'ratio after / raw daqp.solve (p50)':<58s} {after[0] / raw[0]:10.2f}x")
        print(f"geometry ({name}): structure matrix + required wrench, one pose")
        before = row("before: robot.structure_matrices + required_wrench",
                     lambda r=robot, p=pose: (r.structure_matrices(p), r.required_wrench(p)))
        after = row("after: kernels.geometry.geometry_into", geometry_call(robot, pose))
        ratio(before, after)


def raw_daqp_rows(solver: to.Distributor, pose: np.ndarray) -> tuple[float, float]:
    """The raw DAQP baselines of one pose on the very data the distributor hands DAQP
    (the scaled dense QP): through qpsolvers, ``daqp.solve``, and a ``daqp.Model``
    updated and solved. Returns the (p50, p99) of ``daqp.solve``."""
    import daqp
    import qpsolvers

    solver(pose)
    work = solver._local.work  # this thread's DAQP arrays, as of the last pose
    H, f, A = work.H.copy(), work.f.copy(), work.Ad.copy()
    upper, lower, sense = work.upper.copy(), work.lower.copy(), work.sense.copy()
    m = len(f)
    row("raw: qpsolvers.solve_qp(solver='daqp')", lambda: qpsolvers.solve_qp(
        H, f, A=A, b=upper[m:], lb=lower[:m], ub=upper[:m], solver="daqp"))
    raw = row("raw: daqp.solve (same data)", lambda: daqp.solve(H, f, A, upper, lower, sense))
    model = daqp.Model()
    model.setup(H, f, A, upper, lower, sense)
    row("raw: daqp.Model.update + solve (same data)", lambda: (
        model.update(f=f, A=A, bupper=upper, blower=lower), model.solve()))
    return raw


def geometry_call(robot: to.CableRobot, pose: np.ndarray) -> Callable[[], object]:
    """One compiled geometry call of ``robot`` at ``pose`` (arrays made once)."""
    from tension_opt.kernels.geometry import geometry_into, kind_code

    args = (kind_code(robot.kind), np.array(robot.anchors), np.array(robot.attachments),
            np.array(robot.com), robot.mass * robot.g, 1e-12, pose, np.zeros(robot.dof),
            np.empty((robot.dof, robot.m)), np.empty(robot.dof))
    return lambda: geometry_into(*args)


def catenary_rows() -> None:
    """solve_length of four cables, and the sag inverse kinematics of one pose."""
    robot = presets.algae_harvester()
    planes_x = np.array([40.0, 35.0, 30.0, 45.0])
    z = np.array([7.0, 7.5, 6.0, 8.0])
    T = np.array([3000.0, 2500.0, 4000.0, 3500.0])
    w, EA = robot.cable.weight_per_length(robot.g), robot.cable.EA  # type: ignore[union-attr]
    print("catenary.solve_length, 4 cables")
    before = row("before: catenary.solve_length(compiled=False)",
                 lambda: catenary.solve_length(planes_x, z, T, w, EA, compiled=False))
    after = row("after: catenary.solve_length (compiled)",
                lambda: catenary.solve_length(planes_x, z, T, w, EA))
    row("compiled, no result object: catenary.solve_compiled.solve_length_compiled",
        lambda: solve_length_compiled(planes_x, z, T, w, EA))
    ratio(before, after)
    from catenary.solve import kernels

    out, codes = np.zeros((4, 5)), np.empty(4, dtype=np.int64)
    inv = np.full(4, 1.0 / EA)
    ws = np.full(4, w)
    row("kernel alone: catenary.kernels.solve_length_serial", lambda: kernels.
        solve_length_serial(True, planes_x, z, T, ws, inv, 1e-9, 30, out, codes))
    L0 = catenary.solve_length(planes_x, z, T, w, EA).L0
    print("catenary.solve_forces, 4 cables")
    before = row("before: catenary.solve_forces(compiled=False)",
                 lambda: catenary.solve_forces(planes_x, z, L0, w, EA, compiled=False))
    after = row("after: catenary.solve_forces (compiled)",
                lambda: catenary.solve_forces(planes_x, z, L0, w, EA))
    row("compiled, no result object: catenary.solve_compiled.solve_forces_compiled",
        lambda: solve_forces_compiled(planes_x, z, L0, w, EA))
    ratio(before, after)
    out4 = np.zeros((4, 4))
    row("kernel alone: catenary.kernels.solve_forces_batch (serial)", lambda: kernels.
        solve_forces_batch(planes_x, z, L0, ws, inv, 1e-9, 30, out4, codes, False))
    pose = robot.default_home()
    from catenary.thesis_ik import ThesisIK

    print("catenary.inverse_kinematics(model='thesis'), one pose")
    before = row("before: catenary.inverse_kinematics(compiled=False)",
                 lambda: catenary.inverse_kinematics(robot, pose, model="thesis",
                                                     compiled=False))
    row("plain call: catenary.inverse_kinematics (numpy below 16 cables)",
        lambda: catenary.inverse_kinematics(robot, pose, model="thesis"))
    row("plain call: catenary.inverse_kinematics(compiled=True)",
        lambda: catenary.inverse_kinematics(robot, pose, model="thesis", compiled=True))
    ik = ThesisIK(robot)
    after = row("after: catenary.thesis_ik.ThesisIK", lambda: ik(pose))
    ratio(before, after)
    from catenary.coupled_ik import CoupledIK

    print("catenary.inverse_kinematics(model='coupled'), one pose")
    before = row("before: catenary.inverse_kinematics",
                 lambda: catenary.inverse_kinematics(robot, pose, model="coupled"))
    coupled = CoupledIK(robot)
    after = row("after: catenary.coupled_ik.CoupledIK (warm stream)",
                lambda: coupled(pose))
    ratio(before, after)


@contextlib.contextmanager
def _numpy_batches() -> Iterator[None]:
    """Plain batch calls by their numpy references (the size rule set out of reach)."""
    saved = launch.COMPILED_MIN
    launch.COMPILED_MIN = 2**62
    try:
        yield
    finally:
        launch.COMPILED_MIN = saved


def stiffness_rows(count: int) -> None:
    """Platform stiffness of CoGiRo (8 cables, 6 DOF) and the study robot (steel
    cables): one pose per call, straight cables with given tensions and the coupled sag
    model; and a batch of ``count`` poses (at most 10^5) with straight cables."""
    import numba

    from catenary.stiffness_loop import PoseStiffness

    config = cast(_NumbaConfig, numba.config)
    cogiro = presets.cogiro()
    study = presets.algae_harvester(EA=float(catenary.cable_properties("steel", 0.02)[1]))
    for robot in (cogiro, study):
        pose = robot.default_home()
        T = to.distribute(robot, pose, "min_norm", "closed_form").tensions[0]
        print(f"platform stiffness ({robot.name}), one pose, straight cables, tensions given")
        before = row("before: catenary.platform_stiffness",
                     lambda r=robot, p=pose, t=T: catenary.platform_stiffness(
                         r, p, t, "straight"))
        straight = PoseStiffness(robot, "straight")
        after = row("after: catenary.PoseStiffness", lambda s=straight, p=pose, t=T: s(p, t))
        ratio(before, after)
        print(f"platform stiffness ({robot.name}), one pose, coupled sag model")
        before = row("before: catenary.platform_stiffness (coupled IK, numpy)",
                     lambda r=robot, p=pose: catenary.platform_stiffness(r, p))
        coupled = PoseStiffness(robot, "coupled")
        after = row("after: catenary.PoseStiffness (CoupledIK, warm stream)",
                    lambda s=coupled, p=pose: s(p))
        ratio(before, after)
        before = row("before: catenary.platform_stiffness, tensions given",
                     lambda r=robot, p=pose, t=T: catenary.platform_stiffness(r, p, t))
        after = row("after: catenary.PoseStiffness, tensions given",
                    lambda s=coupled, p=pose, t=T: s(p, t))
        ratio(before, after)
    size = min(count, 100_000)
    poses = random_feasible_poses(cogiro, size, seed=0)
    T = to.distribute(cogiro, poses, "min_norm", "closed_form").tensions
    print(f"platform_stiffness (CoGiRo), straight cables, tensions given, {size} poses")
    with _numpy_batches():
        numpy_time = wall_per_item(lambda: catenary.platform_stiffness(
            cogiro, poses, T, "straight"), size, runs=3) / 1e3
    print(f"  before (numpy reference)                    {numpy_time:10.2f} us/pose")
    for threads in sorted({1, config.NUMBA_NUM_THREADS}):
        numba.set_num_threads(threads)
        compiled = wall_per_item(lambda: catenary.platform_stiffness(
            cogiro, poses, T, "straight"), size) / 1e3
        print(f"  after: platform_stiffness, {threads} thread(s)         {compiled:10.2f} "
              f"us/pose  ({numpy_time / compiled:.1f}x)")
    numba.set_num_threads(config.NUMBA_NUM_THREADS)


@contextlib.contextmanager
def _chunk_threads(threads: int) -> Iterator[None]:
    """``distribute`` with its chunks on ``threads`` threads (default: numba's count)."""
    module = importlib.import_module("tension_opt.distribution.entry")
    entry = cast(_ChunkThreads, module)
    saved = entry.chunk_threads
    entry.chunk_threads = lambda: threads
    try:
        yield
    finally:
        entry.chunk_threads = saved


def wall_per_item(fn: Call, count: int, runs: int = 7) -> float:
    """Median wall time (ns) per item of ``fn`` over ``runs`` calls after an untimed
    one (see the module docstring)."""
    return alternated({"": fn}, count, runs)[""]


def alternated(fns: dict[str, Call], count: int, runs: int = 7
               ) -> dict[str, float]:
    """:func:`wall_per_item` of several calls, taken in turn (one call of each per
    round), so that a slower spell of a shared machine falls on all of them alike."""
    for fn in fns.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(runs):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: float(np.median(t)) / count * 1e9 for name, t in times.items()}


def batch_rows(count: int) -> None:
    """Closed-form min-sum over many feasible and infeasible poses; solve_length over
    many cables; wall time per pose on one and on all threads."""
    import numba

    config = cast(_NumbaConfig, numba.config)
    robot = presets.algae_harvester()
    rng = np.random.default_rng(0)
    low, high = robot.anchors.min(axis=0), robot.anchors.max(axis=0)
    draws = rng.uniform(low - np.array([0, 0, 0.95 * (high[2] - low[2]) + 2]),
                        high - np.array([0, 0, 0.5]), (count, 3))
    ok = to.distribute(robot, draws[:20000], "min_sum", "closed_form").success
    share = ok.mean()
    feasible = draws[:20000][ok][rng.integers(0, ok.sum(), count)]
    infeasible = draws[:20000][~ok][rng.integers(0, (~ok).sum(), count)]
    solver = to.Distributor(robot, "min_sum", "closed_form")
    print(f"closed-form min-sum over {count} poses (box: {100 * (1 - share):.0f} % infeasible)")
    for label, poses in (("feasible", feasible), ("infeasible", infeasible)):
        t0 = time.perf_counter()
        to.distribute(robot, poses, "min_sum", ClosedFormBackend(compiled=False))
        before = (time.perf_counter() - t0) / count * 1e9
        print(f"  {label:<11s} before: distribute, numpy closed form {before:10.1f} ns/pose")
        earlier = to.distribute(robot, poses, "min_sum", "closed_form")
        for threads in sorted({1, chunk_threads()}):
            with _chunk_threads(threads):
                timed = alternated({
                    "plain": lambda p=poses: to.distribute(robot, p, "min_sum",
                                                           "closed_form"),
                    "read": lambda p=poses: to.distribute(robot, p, "min_sum",
                                                          "closed_form").status,
                    "reused": lambda p=poses, into=earlier: to.distribute(
                        robot, p, "min_sum", "closed_form", out=into)}, count)
            plain, read, reused = timed["plain"], timed["read"], timed["reused"]
            print(f"  {label:<11s} plain call: distribute (compiled), {threads} thread(s) "
                  f"{plain:10.1f} ns/pose  ({before / plain:.1f}x)")
            print(f"  {label:<11s} plain call, then its .status read, {threads} thread(s) "
                  f"{read:10.1f} ns/pose  ({before / read:.1f}x)")
            print(f"  {label:<11s} plain call, out=earlier result, {threads} thread(s) "
                  f"{reused:10.1f} ns/pose  ({before / reused:.1f}x)")
        for threads in sorted({1, config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(threads)
            solver(poses[:PARALLEL_MIN])  # loads the parallel kernel before timing it
            after = wall_per_item(lambda p=poses: solver(p), count)
            print(f"  {label:<11s} after: Distributor, {threads} thread(s) {after:10.1f} "
                  f"ns/pose  ({before / after:.1f}x)")
    numba.set_num_threads(config.NUMBA_NUM_THREADS)
    x = rng.uniform(1.0, 60.0, count)
    zc = rng.uniform(-5.0, 10.0, count)
    T = rng.uniform(500.0, 5000.0, count)
    w = robot.cable.weight_per_length(robot.g)  # type: ignore[union-attr]
    print(f"catenary.solve_length over {count} cables")
    EA = robot.cable.EA  # type: ignore[union-attr]
    t0 = time.perf_counter()
    catenary.solve_length(x, zc, T, w, EA, compiled=False)
    before = (time.perf_counter() - t0) / count * 1e9
    warm = PARALLEL_FROM + 1  # loads the parallel kernel before timing it
    catenary.solve_length(x[:warm], zc[:warm], T[:warm], w, EA)
    solve_length_compiled(x[:warm], zc[:warm], T[:warm], w, 1e7)
    print(f"  before (compiled=False) {before:10.1f} ns/cable")
    for threads in sorted({1, config.NUMBA_NUM_THREADS}):
        numba.set_num_threads(threads)
        plain = wall_per_item(lambda: catenary.solve_length(x, zc, T, w, EA), count)
        after = wall_per_item(lambda: solve_length_compiled(x, zc, T, w, EA), count)
        print(f"  {threads} thread(s): plain call {plain:10.1f} ns/cable ({before / plain:.1f}x)"
              f"   solve_length_compiled {after:10.1f} ns/cable ({before / after:.1f}x)")
    numba.set_num_threads(config.NUMBA_NUM_THREADS)


_FIRST_CALL = """
import time
t0 = time.perf_counter()
import numpy as np, tension_opt as to
from tension_opt import presets
from tension_opt.backends.closed_form import ClosedFormBackend
robot = presets.algae_harvester()
solver = to.Distributor(robot, "min_sum", "closed_form")
t1 = time.perf_counter()
solver(robot.default_home())
t2 = time.perf_counter()
print(f"{t1 - t0:.3f} {t2 - t1:.3f}")
"""


def first_call(cold: bool) -> None:
    """First-call cost in fresh processes: with the on-disk cache, and (``cold``)
    compiling into an empty cache directory."""
    print("first call of a Distributor (fresh process): import s, first call s")
    cases: list[tuple[str, str | None]] = [("numba disk cache warm", None)]
    if cold:
        cases.append(("empty cache (compiles)", tempfile.mkdtemp(prefix="numba-cache-")))
    for label, cache in cases:
        env = dict(os.environ)
        if cache is not None:
            env["NUMBA_CACHE_DIR"] = cache
        out = subprocess.run([sys.executable, "-c", _FIRST_CALL], env=env, check=True,
                             capture_output=True, text=True).stdout.split()
        print(f"  {label:<30s} import {float(out[0]):8.3f} s   first call "
              f"{float(out[1]):8.3f} s")


def main(argv: list[str] | None = None) -> None:
    """Print every row: single calls, catenary, batches, first-call cost."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1_000_000,
                        help="poses (and cables) of the batch rows (default 10^6)")
    parser.add_argument("--only", choices=["stiffness"],
                        help="print only these rows (after the timer floor)")
    parser.add_argument("--cold", action="store_true",
                        help="also time compiling into an empty cache (minutes)")
    args = parser.parse_args(argv)
    print(f"bench_latency  python {sys.version.split()[0]}  numpy {np.__version__}  "
          f"cores {os.cpu_count()}  load average {os.getloadavg()[0]:.1f}")
    if args.only is None:
        first_call(args.cold)
    print("timer floor (an empty call)")
    row("lambda: None", lambda: None)
    if args.only == "stiffness":
        stiffness_rows(args.poses)
        return
    single_pose_rows()
    catenary_rows()
    stiffness_rows(args.poses)
    batch_rows(args.poses)
    print(f"load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
