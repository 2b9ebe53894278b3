"""Speed of the tension-distribution backends on the reference study's robot.

Run ``python -m benchmarks.bench_tension`` (add ``--poses 100000`` for a quicker run).
Prints, measured in one run:

- the closed form for min-sum, min-norm and the pseudo-inverse over many random
  feasible poses: ns per pose for the solve alone (structure matrices given) and for
  the whole :func:`tension_opt.distribute` call;
- ``qpsolvers:daqp`` through ``distribute``: us per pose, and the ratio to calling
  DAQP directly on the same (scaled) matrices in a plain loop that keeps each solution;
- ``cvxpy`` re-solving one compiled problem with Parameters: us per pose, against
  building and solving a new cvxpy problem per pose.

Medians of repeated runs; the machine is shared, so compare ratios from one run.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from ctypes import c_int
from functools import partial

import numpy as np

import tension_opt as to
from benchmarks.scenarios import POND_HIGH, POND_LOW
from tension_opt.backends import get_backend
from tension_opt.certify.scaling import scaled_batch
from tension_opt.workspace.sampling import random_feasible_poses

# (what was timed, number of poses or "", result)
Row = tuple[str, int | str, str]


def _median_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def closed_form_rows(robot: to.CableRobot, poses: np.ndarray, repeat: int) -> list[Row]:
    backend = get_backend("closed_form")
    rows: list[Row] = []
    for objective in ("min_sum", "min_norm", "pinv"):
        form = to.TensionProblem(objective).standard_form(robot, poses)
        solve = _median_time(partial(backend.solve, form), repeat)
        whole = _median_time(partial(to.distribute, robot, poses, objective, "closed_form"),
                             repeat)
        rows.append((f"closed_form {objective}: solve only", len(poses),
                     f"{solve / len(poses) * 1e9:.0f} ns/pose"))
        rows.append((f"closed_form {objective}: distribute()", len(poses),
                     f"{whole / len(poses) * 1e9:.0f} ns/pose"))
    return rows


def _daqp_loop(solve: Callable[..., tuple], H: list, c: list, A: list, upper: list,
               lower: list, sense: np.ndarray) -> np.ndarray:
    """Call DAQP on each pose in a plain loop, keeping each solution: the baseline."""
    x = np.empty((len(H), len(c[0])))
    for i in range(len(H)):
        x[i] = solve(H[i], c[i], A[i], upper[i], lower[i], sense)[0]
    return x


def daqp_rows(robot: to.CableRobot, poses: np.ndarray, repeat: int) -> list[Row]:
    import daqp

    rows: list[Row] = []
    for objective in ("min_sum", "min_norm"):
        form = to.TensionProblem(objective).standard_form(robot, poses)
        batch = scaled_batch(form)
        k, n = batch.k, batch.Aeq.shape[1]
        H = [np.diag(p) for p in batch.P]
        upper = np.concatenate([np.minimum(batch.ub, 1e30), batch.beq], axis=1)
        lower = np.concatenate([np.maximum(batch.lb, -1e30), batch.beq], axis=1)
        sense = np.zeros(k + n, dtype=c_int)
        sense[k:] = 5
        data = (H, list(batch.c), list(batch.Aeq), list(upper), list(lower))
        t_direct = _median_time(partial(_daqp_loop, daqp.solve, *data, sense), repeat)
        t_ours = _median_time(
            partial(to.distribute, robot, poses, objective, "qpsolvers:daqp"), repeat)
        rows.append((f"qpsolvers:daqp {objective}: distribute()", len(poses),
                     f"{t_ours / len(poses) * 1e6:.1f} us/pose"))
        rows.append((f"daqp.solve {objective}: direct loop, same data", len(poses),
                     f"{t_direct / len(poses) * 1e6:.1f} us/pose"))
        rows.append((f"  ratio distribute / direct ({objective})", "",
                     f"{t_ours / t_direct:.2f}x"))
    return rows


def cvxpy_rows(robot: to.CableRobot, poses: np.ndarray, repeat: int) -> list[Row]:
    import cvxpy as cp

    rows: list[Row] = []
    form = to.TensionProblem("min_norm").standard_form(robot, poses)
    to.distribute(robot, poses[:1], "min_norm", "cvxpy:CLARABEL")  # compile once
    t_param = _median_time(
        lambda: to.distribute(robot, poses, "min_norm", "cvxpy:CLARABEL"), repeat)

    def rebuild() -> None:
        for i in range(len(poses)):
            x = cp.Variable(robot.m)
            prob = cp.Problem(cp.Minimize(cp.sum_squares(x)),
                              [form.A[i] @ x == form.b[i], x >= form.lb[i]])
            prob.solve(solver="CLARABEL")

    t_new = _median_time(rebuild, max(1, repeat // 2))
    rows.append(("cvxpy:CLARABEL min_norm: compiled once, Parameters", len(poses),
                 f"{t_param / len(poses) * 1e6:.0f} us/pose"))
    rows.append(("cvxpy:CLARABEL min_norm: new Problem per pose", len(poses),
                 f"{t_new / len(poses) * 1e6:.0f} us/pose"))
    rows.append(("  ratio new / compiled", "", f"{t_new / t_param:.1f}x"))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1_000_000,
                        help="poses for the closed form (default 10^6)")
    parser.add_argument("--solver-poses", type=int, default=2000,
                        help="poses for the per-pose solvers (default 2000)")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    robot = to.presets.algae_harvester()
    # One round of 1.4 N + 100 draws finds N feasible poses (about 77 % of the pond is).
    poses = random_feasible_poses(robot, args.poses, seed=0, low=POND_LOW, high=POND_HIGH,
                                  batch=int(args.poses * 1.4) + 100)
    few = poses[: args.solver_poses]
    to.distribute(robot, few[:10], "min_sum", "qpsolvers:daqp")  # imports, caches
    rows = closed_form_rows(robot, poses, args.repeat)
    rows += daqp_rows(robot, few, args.repeat)
    rows += cvxpy_rows(robot, few[: max(200, args.solver_poses // 10)], args.repeat)
    threads = os.environ.get("OMP_NUM_THREADS", "unset")
    print(f"thesis robot (4 cables, 3 DOF); median of {args.repeat} runs; "
          f"OMP_NUM_THREADS={threads}")
    print(f"{'measurement':<52} {'poses':>9}  value")
    for name, count, value in rows:
        print(f"{name:<52} {count!s:>9}  {value}")


if __name__ == "__main__":
    main()
