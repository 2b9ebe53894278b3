"""Time of the Jacobians of optimal tensions against the time of solving the poses.

``python -m benchmarks.bench_sensitivity [N]``: N closed-form poses (default 10^5) of
the study robot and of CoGiRo, ``min_sum`` and ``min_norm``; prints one line per robot,
objective and ``wrt`` with both times (s) and their ratio (the warm second run of each).
Then one pose through a ``Distributor`` with and without its Jacobian.
Then the coupled sag model (:func:`catenary.coupled_jacobian`) on 200 poses of each
robot against its own solve, and the design criteria's evaluation with their gradients.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import catenary
import tension_opt as to
from catenary import design
from tension_opt.workspace.sampling import random_feasible_poses


def main(N: int = 100_000) -> None:
    """Print the timing table for ``N`` poses of each robot."""
    print("robot     objective  wrt      solve (s)  jacobian (s)  ratio")
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        poses = np.tile(random_feasible_poses(robot, 1000, seed=1), (N // 1000 + 1, 1))[:N]
        for objective in ("min_sum", "min_norm"):
            for _ in range(2):
                t0 = time.perf_counter()
                sol = to.distribute(robot, poses, objective, "closed_form")
                solve = time.perf_counter() - t0
            for wrt in ("wrench", "pose", "t_min", "t_max"):
                for _ in range(2):  # the second: no compiling or loading of kernels
                    t0 = time.perf_counter()
                    sol.jacobian(wrt, robot=robot, poses=poses)
                    jac = time.perf_counter() - t0
                print(
                    f"{robot.kind:9s} {objective:9s}  {wrt:7s}  {solve:9.3f}  {jac:12.3f}  "
                    f"{jac / solve:5.1f}"
                )


def coupled(N: int = 200) -> None:
    """Print the coupled model's solve and Jacobian times for ``N`` poses of each robot."""
    print("robot     wrt               solve (s)  jacobian (s)  ratio  ok")
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        poses = random_feasible_poses(robot, N, seed=1)
        for _ in range(2):
            t0 = time.perf_counter()
            solved = catenary.inverse_kinematics(robot, poses, "coupled", "min_sum")
            solve = time.perf_counter() - t0
        for wrt in ("pose", "drawing_points", "weight_per_length"):
            t0 = time.perf_counter()
            got = catenary.coupled_jacobian(robot, poses, wrt, result=solved)
            jac = time.perf_counter() - t0
            print(f"{robot.kind:9s} {wrt:17s} {solve:9.3f}  {jac:12.3f}  {jac / solve:5.2f}  "
                  f"{int(got.ok.sum())}/{N}")


def realtime(calls: int = 2000) -> None:
    """Print the median time (us) of one pose through a ``Distributor`` alone and with
    its Jacobian (:meth:`~tension_opt.Distributor.with_jacobian`), ``calls`` calls each,
    interleaved, for each robot, objective and ``wrt``."""
    print("robot     objective  wrt      pose (us)  with Jacobian (us)  ratio")
    for robot in (to.presets.algae_harvester(), to.presets.cogiro()):
        pose = np.ascontiguousarray(random_feasible_poses(robot, 1, seed=4)[0])
        for objective in ("min_sum", "min_norm"):
            solver = to.Distributor(robot, objective)
            for wrt in ("wrench", "pose", "t_max"):
                solver.with_jacobian(pose, wrt)
                alone, both = [], []
                for _ in range(calls):
                    t0 = time.perf_counter()
                    solver(pose)
                    t1 = time.perf_counter()
                    solver.with_jacobian(pose, wrt)
                    alone.append(t1 - t0)
                    both.append(time.perf_counter() - t1)
                a, b = 1e6 * float(np.median(alone)), 1e6 * float(np.median(both))
                print(f"{robot.kind:9s} {objective:9s}  {wrt:7s}  {a:9.2f}  {b:18.2f}  "
                      f"{b / a:5.2f}")


def criteria() -> None:
    """Print the time of one evaluation (value and gradient) of each design criterion on
    the study robot: the 25 poses of its path, a 17 x 11 x 3 grid of the pond."""
    from benchmarks.scenarios import pick_and_place

    robot = to.presets.algae_harvester(t_max=15000.0)
    path = pick_and_place()
    xs, ys = np.meshgrid(np.linspace(-40.45, 40.45, 17), np.linspace(-25, 25, 11))
    grid = np.vstack([np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])
                      for z in (0.5, 1.5, 2.5)])
    print("criterion                         poses  time (ms)")
    for name, criterion in (
        ("PeakTension", design.PeakTension(path)),
        ("PeakTension, half weight", design.PeakTension(path, cable_weight=True)),
        ("PeakTension, coupled", design.PeakTension(path, model="coupled")),
        ("TensionEnergy", design.TensionEnergy(path)),
        ("WorkspaceCoverage", design.WorkspaceCoverage(grid, 1.0)),
        ("SagCorrection", design.SagCorrection(path)),
        ("CableMass", design.CableMass(path)),
        ("LowestFrequency (value only)", design.LowestFrequency(path)),
    ):
        criterion.evaluate(robot)
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            criterion.evaluate(robot)
            times.append(time.perf_counter() - t0)
        size = len(getattr(criterion, "poses", path))
        print(f"{name:32s} {size:6d}  {1e3 * float(np.median(times)):9.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000)
    realtime()
    coupled()
    criteria()
