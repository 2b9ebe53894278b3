"""Time of the Jacobians of optimal tensions against the time of solving the poses.

``python -m benchmarks.bench_sensitivity [N]``: N closed-form poses (default 10^5) of
the study robot and of CoGiRo, ``min_sum`` and ``min_norm``; prints one line per robot,
objective and ``wrt`` with both times (s) and their ratio (the warm second run of each).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import tension_opt as to
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
            for wrt in ("wrench", "pose"):
                t0 = time.perf_counter()
                sol.jacobian(wrt, robot=robot, poses=poses)
                jac = time.perf_counter() - t0
                print(
                    f"{robot.kind:9s} {objective:9s}  {wrt:7s}  {solve:9.3f}  {jac:12.3f}  "
                    f"{jac / solve:5.1f}"
                )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000)
