"""Benchmark of the distances between sagging cables (prints a table).

    python -m benchmarks.bench_interference [--repeat N]

On CoGiRo (8 cables, 28 pairs) at a pose off its home: the certified distances of every
pair of its catenaries (thesis convention), the curves given
(``catenary.interference`` on the curves of one pose), by the numpy reference and by
the compiled kernel (:mod:`catenary.interference_kernels`); then the whole
``catenary.cable_clearance`` of one pose and of 100 poses (sag inverse kinematics
included) both ways. Median wall time of ``--repeat`` calls in a row after an
untimed one (a planner's loop: the caches warm), each variant in turn.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial

import numpy as np

import catenary
import tension_opt as to
from catenary.interference import robot_curves, robot_pair_distances
from catenary.inverse import inverse_kinematics
from tension_opt.workspace.interference import SHARED_TRIM, cable_pairs, pair_ranges, shared_ends

POSE = np.array([0.5, 0.3, 1.0, 0.05, 0.02, 0.1])


def _cases() -> dict[str, Callable[[], object]]:
    robot = to.presets.cogiro()
    one = POSE[None]
    many = POSE + np.random.default_rng(0).uniform(-0.5, 0.5, (100, 6)) * [1, 1, 0.5, 0.1,
                                                                              0.1, 0.1]
    res = inverse_kinematics(robot, one, "thesis")
    curves = robot_curves(robot, one, res.horizontal_tensions, res.platform_forces[..., 2],
                          res.lengths)
    pairs = cable_pairs(robot.m)
    frac = pair_ranges(*shared_ends(robot, pairs), SHARED_TRIM)
    cases: dict[str, Callable[[], object]] = {}
    for compiled in (False, True):
        way = "compiled" if compiled else "numpy"
        cases[f"28 pairs, curves given, {way}"] = partial(robot_pair_distances, curves, pairs, frac,
                                                          33, compiled)
        cases[f"cable_clearance, 1 pose, {way}"] = partial(
            catenary.cable_clearance, robot, one, "thesis", compiled=compiled)
        cases[f"cable_clearance, 100 poses, {way}"] = partial(
            catenary.cable_clearance, robot, many, "thesis", compiled=compiled)
    return cases


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args(argv)
    cases = _cases()
    times: dict[str, list[float]] = {name: [] for name in cases}
    for name, f in cases.items():
        f()  # compile, warm up
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - t0)
    print(f"CoGiRo, thesis convention; median of {args.repeat} calls in a row (one run)")
    print(f"{'call':<44} {'time':>12}")
    for name, values in times.items():
        print(f"{name:<44} {np.median(values) * 1e3:>9.3f} ms")
    for what in ("28 pairs, curves given", "cable_clearance, 1 pose",
                 "cable_clearance, 100 poses"):
        ratio = np.median(times[f"{what}, numpy"]) / np.median(times[f"{what}, compiled"])
        print(f"{what}: numpy / compiled {ratio:.1f}x")


if __name__ == "__main__":
    main()
