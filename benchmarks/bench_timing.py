"""Benchmark of the time-optimal timing against toppra (prints a table).

    python -m benchmarks.bench_timing [--repeat N] [--case study|cogiro|both]

On the study robot (``algae_harvester(t_max=15e3)``) and the pick-and-place path of
notebook 06 (and, with ``--case``, CoGiRo's loop), at 50, 200 and 1000 evenly spaced
grid points: the median wall time of a whole :func:`tension_opt.dynamics.time_optimal`
call with each method (the path built, the constraints checked along the whole path,
the tensions distributed), against toppra's TOPP-RA (seidel solver, interpolation
scheme) with its constraints given as arrays (the wrench-feasible set's facets and the
dynamics' coefficients at the grid points, computed beforehand and not timed). The
variants take turns within each repetition, so that a slow spell falls on all alike.
toppra checks the grid points and the ends of the intervals only; the durations are
printed beside the times.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import tension_opt as to
from benchmarks.scenarios import cogiro_path, pick_and_place
from tension_opt import dynamics as dyn
from tension_opt.dynamics.facets import facets_of
from tension_opt.dynamics.path import PathSpline, path_stages

GRIDS = (50, 200, 1000)


def _toppra_solver(robot: to.CableRobot, path: np.ndarray, grid: np.ndarray
                   ) -> Callable[[], float] | None:
    """A toppra solve of ``path`` on ``grid`` with precomputed arrays, returning the
    duration; None without toppra."""
    try:
        import toppra
        import toppra.algorithm as algo
        from toppra.constraint import DiscretizationType, LinearConstraint
        from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate
    except ImportError:
        return None
    spline = PathSpline.through(robot, path)
    st = path_stages(robot, spline, grid)
    H, h = facets_of(st.A, st.lb, st.ub)
    big = 1e3 * float(np.abs(st.ub[np.isfinite(st.ub)]).max(initial=1e4))
    arrays = (st.a, st.b, st.c, H, np.where(np.isfinite(h), h, big))

    class Arrays(LinearConstraint):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.discretization_type = DiscretizationType.Interpolation

        def compute_constraint_params(self, _path: Any, gridpoints: np.ndarray,
                                      *args: Any, **kwargs: Any) -> Any:
            a, b, c, F, g = arrays
            return canlinear_colloc_to_interpolate(a, b, c, F, g, None, None, gridpoints)

    interp = toppra.SplineInterpolator(spline.s, spline.poses)

    def solve() -> float:
        instance = algo.TOPPRA([Arrays()], interp, gridpoints=grid, solver_wrapper="seidel")
        _, sd, _ = instance.compute_parameterization(0, 0)
        if sd is None:
            return float("inf")
        return float(np.sum(2 * np.diff(grid) / (sd[:-1] + sd[1:])))

    return solve


def _ours(robot: to.CableRobot, path: np.ndarray, K: int, method: str
          ) -> Callable[[], float]:
    """A whole ``time_optimal`` call on ``K`` points, returning the duration."""
    def solve() -> float:
        res = dyn.time_optimal(robot, path, gridpoints=K, method=method)  # type: ignore[arg-type]
        return res.duration if res.success else float("nan")
    return solve


def _median_times(variants: dict[str, Callable[[], float]], repeat: int
                  ) -> dict[str, tuple[float, float]]:
    """Median seconds of each variant over ``repeat`` turns (after one untimed run) and
    the duration it returned."""
    durations = {name: f() for name, f in variants.items()}  # warm up, compile
    times: dict[str, list[float]] = {name: [] for name in variants}
    for _ in range(repeat):
        for name, f in variants.items():
            t0 = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(times[name])), durations[name]) for name in variants}


def run(case: str, repeat: int) -> None:
    """Print the table of one case."""
    if case == "study":
        robot, path = to.presets.algae_harvester(t_max=15e3), pick_and_place()
    else:
        robot = to.presets.cogiro()
        path = cogiro_path(robot)
    length = PathSpline.through(robot, path).length
    print(f"\n{case}: {robot.m} cables, {robot.dof} DOF, path {length:.2f} long; median ms "
          f"per solve over {repeat} runs (duration in s)")
    print(f"{'points':>7} {'toppra':>16} {'convex':>16} {'reachability':>16} "
          f"{'convex/toppra':>14} {'reach/toppra':>13}")
    for K in GRIDS:
        grid = np.linspace(0.0, length, K)
        variants: dict[str, Callable[[], float]] = {}
        reference = _toppra_solver(robot, path, grid)
        if reference is not None:
            variants["toppra"] = reference
        for method in ("convex", "reachability"):
            variants[method] = _ours(robot, path, K, method)
        got = _median_times(variants, repeat)
        cells = []
        for name in ("toppra", "convex", "reachability"):
            t, d = got.get(name, (float("nan"), float("nan")))
            cells.append(f"{t * 1e3:8.1f} ({d:.4f})")
        base = got.get("toppra", (float("nan"), 0.0))[0]
        print(f"{K:>7} {cells[0]:>16} {cells[1]:>16} {cells[2]:>16} "
              f"{got['convex'][0] / base:>14.2f} {got['reachability'][0] / base:>13.2f}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--case", choices=("study", "cogiro", "both"), default="study")
    args = parser.parse_args(argv)
    for case in (("study", "cogiro") if args.case == "both" else (args.case,)):
        run(case, args.repeat)


if __name__ == "__main__":
    main()
