"""Benchmark of the sag-aware kinematics: ``python -m benchmarks.bench_kinematics``.

Prints one table: coupled inverse kinematics on 1000 thesis poses (time per pose, SCP
iterations, catenary iterations), thesis-model inverse kinematics on 10^5 poses, and
catenary forward kinematics from the coupled lengths.
"""

from __future__ import annotations

import time

import numpy as np

import tension_opt as to
from catenary import forward_kinematics, inverse_kinematics


def _poses(robot: to.CableRobot, N: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    M = 2 * N
    poses = np.column_stack([rng.uniform(-40.45, 40.45, M), rng.uniform(-25, 25, M),
                             rng.uniform(0, 5, M)])
    return poses[to.distribute(robot, poses).success][:N]


def main() -> None:
    robot = to.presets.algae_harvester()
    rows: list[tuple[str, int, float, str, str]] = []

    poses = _poses(robot, 1000)
    t0 = time.perf_counter()
    ik = inverse_kinematics(robot, poses, model="coupled")
    dt = time.perf_counter() - t0
    ok = ik.success
    cat = ik.catenary_iterations[ok]
    rows.append(("IK coupled (min_sum)", len(poses), dt / len(poses),
                 f"{np.median(ik.iterations[ok]):.0f} / {ik.iterations[ok].max()}",
                 f"{np.median(cat):.0f} / {cat.max()}"))

    t0 = time.perf_counter()
    fk = forward_kinematics(robot, ik.lengths[ok])
    dt = time.perf_counter() - t0
    rows.append(("FK catenary", int(ok.sum()), dt / ok.sum(),
                 f"{np.median(fk.iterations):.0f} / {fk.iterations.max()}", "-"))

    big = _poses(robot, 100_000, 1)
    t0 = time.perf_counter()
    th = inverse_kinematics(robot, big, model="thesis")
    dt = time.perf_counter() - t0
    c = th.catenary_iterations[th.success]
    rows.append(("IK thesis (min_sum)", len(big), dt / len(big), "0 / 0",
                 f"{np.median(c):.0f} / {c.max()}"))

    print(f"{'case':<22} {'poses':>7} {'time/pose':>12} {'SCP or Newton its':>18} "
          f"{'catenary its':>13}")
    print(f"{'':<22} {'':>7} {'':>12} {'(median / max)':>18} {'(med / max)':>13}")
    for name, n, t, its, cits in rows:
        print(f"{name:<22} {n:>7} {t * 1e6:>9.1f} us {its:>18} {cits:>13}")
    print(f"coupled: {int(ok.sum())}/{len(poses)} converged, max equilibrium residual "
          f"{np.nanmax(ik.equilibrium_residual[ok]):.2e} N; FK max pose error "
          f"{np.abs(fk.poses - poses[ok]).max():.2e} m")


if __name__ == "__main__":
    main()
