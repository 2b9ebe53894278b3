"""Benchmark of guide pulleys: ``python -m benchmarks.bench_pulleys [--quick]``.

Two tables, measured in one run:

1. The straight inverse kinematics of CoGiRo (8 cables) per pose, with fixed drawing
   points and with a 0.1 m swivel pulley on every cable: medians of repeated batches,
   and their ratio.
2. The study robot with a 0.3 m pulley at each tower (vertical axes) over a grid of
   pond poses: what the wheels add to the lengths, straight and in both sag models,
   and the time per pose of each model with and without pulleys.
"""

from __future__ import annotations

import argparse
import time
import timeit

import numpy as np

import catenary
import tension_opt as to


def _median_per_pose(fn: object, N: int) -> float:
    """Median wall time per pose (s) of ``fn()`` over five autoranged repeats."""
    timer = timeit.Timer(fn)  # type: ignore[arg-type]
    number, _ = timer.autorange()
    return float(np.median(timer.repeat(5, number))) / number / N


def straight_table(sizes: tuple[int, ...]) -> list[tuple[int, float, float]]:
    """Per-pose times (s) of CoGiRo's straight inverse kinematics, fixed and with
    pulleys, for each batch size."""
    robot = to.presets.cogiro()
    wheels = robot.with_(pulleys=[to.Pulley(0.1, [0, 0, -1])] * robot.m)
    rng = np.random.default_rng(0)
    rows = []
    for N in sizes:
        poses = robot.default_home() + rng.uniform(-1, 1, (N, 6)) * [1, 1, 0.5, 0.1, 0.1, 0.1]
        fixed = _median_per_pose(lambda p=poses: robot.inverse_kinematics(p), N)
        over = _median_per_pose(lambda p=poses: wheels.inverse_kinematics(p), N)
        rows.append((N, fixed, over))
    return rows


def study_table(grid: int) -> list[tuple[str, int, float, float, float, float, float]]:
    """Per model: poses answered by both robots, the added length's mean, min and max
    (m), and the time per pose without and with the pulleys (s)."""
    robot = to.presets.algae_harvester()
    towers = robot.with_(pulleys=[to.Pulley(0.3, [0, 0, -1])] * robot.m)
    poses = np.array([[x, y, z] for x in np.linspace(-35, 35, grid)
                      for y in np.linspace(-20, 20, max(grid // 2 + 1, 2))
                      for z in (0.5, 3.0)])
    rows = []
    L0, _ = robot.inverse_kinematics(poses)
    L1, _ = towers.inverse_kinematics(poses)
    d = L1 - L0
    rows.append(("straight", len(poses), d.mean(), d.min(), d.max(), np.nan, np.nan))
    for model in ("thesis", "coupled"):
        for r in (robot, towers):  # kernels loaded, caches warm: the times are steady state
            catenary.inverse_kinematics(r, poses, model=model)
        t0 = time.perf_counter()
        a = catenary.inverse_kinematics(robot, poses, model=model)
        t1 = time.perf_counter()
        b = catenary.inverse_kinematics(towers, poses, model=model)
        t2 = time.perf_counter()
        ok = a.success & b.success
        d = (b.lengths - a.lengths)[ok]
        rows.append((model, int(ok.sum()), d.mean(), d.min(), d.max(),
                     (t1 - t0) / len(poses), (t2 - t1) / len(poses)))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_pulleys")
    parser.add_argument("--quick", action="store_true", help="small batches (a smoke run)")
    args = parser.parse_args(argv)
    sizes = (1, 100) if args.quick else (1, 100, 10_000)
    print("CoGiRo straight inverse kinematics, time per pose (median of 5 repeats)")
    print(f"{'poses':>7} {'fixed points':>14} {'pulleys':>12} {'ratio':>7}")
    for N, fixed, over in straight_table(sizes):
        print(f"{N:>7} {fixed * 1e6:>11.2f} us {over * 1e6:>9.2f} us {over / fixed:>7.2f}")
    print()
    print("Study robot, 0.3 m pulley at each tower: what the wheels add to the lengths")
    print(f"{'model':<9} {'poses':>6} {'mean (m)':>9} {'min (m)':>8} {'max (m)':>8} "
          f"{'time/pose fixed':>16} {'with pulleys':>13}")
    for model, n, mean, low, high, t_fixed, t_wheels in study_table(4 if args.quick else 8):
        times = ("" if np.isnan(t_fixed) else
                 f"{t_fixed * 1e3:>13.2f} ms {t_wheels * 1e3:>10.2f} ms")
        print(f"{model:<9} {n:>6} {mean:>9.3f} {low:>8.3f} {high:>8.3f} {times}")


if __name__ == "__main__":
    main()
