"""Does every "optimal" hold? Each backend's labels against the exact optimum.

``python -m benchmarks.certify_study`` solves random feasible poses of the study's
robot, of CoGiRo and of seeded random suspended robots
(:mod:`benchmarks.random_robots`) for min-sum, min-norm, min-max and centred, on every
installed backend at one accuracy (default: the default target, 1e-7), and compares
each pose labelled ``optimal`` with the exact optimum (the closed form, else HiGHS for
the LPs and Clarabel for the QPs at high accuracy, themselves certified at 1e-10).

The objective excess of a pose is measured as its certificate's duality gap is: on the
scaled problem (:mod:`tension_opt.certify.scaling`), ``(f(T) - f(T*))`` over the objective's
size, relative to ``max(1, |f*|)`` there. A pose labelled optimal whose excess is above
the target is a wrong "optimal". The table gives, per backend, the share of poses
labelled optimal (of those the reference solves), the worst excess among them and the
count of wrong ones; ``--out`` writes the per-(set, objective, backend) rows as CSV.

::

    python -m benchmarks.certify_study                      # 1000 poses per set, 200 robots
    python -m benchmarks.certify_study --poses 200 --robots 40 --backend qpsolvers:osqp
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

import tension_opt as to
from benchmarks.metrics import objective_excess
from benchmarks.random_robots import random_robot_set
from benchmarks.scenarios import COGIRO_HIGH, COGIRO_LOW, POND_HIGH, POND_LOW
from tension_opt.tolerances import accuracy_target
from tension_opt.workspace.sampling import random_feasible_poses

__all__ = ["OBJECTIVES", "TestSet", "compare", "main", "problem_for", "reference", "summary",
           "test_sets"]

#: The objectives compared.
OBJECTIVES = ("min_sum", "min_norm", "min_max", "centered")
#: Reference backends where the closed form does not apply, by problem kind.
REFERENCE = {"lp": "qpsolvers:highs", "qp": "qpsolvers:clarabel"}


@dataclass
class TestSet:
    """Robots and their poses: one entry per robot (the study and CoGiRo have one)."""

    name: str
    robots: list[tuple[to.CableRobot, NDArray]]

    @property
    def N(self) -> int:
        """Number of poses over all robots."""
        return sum(len(p) for _, p in self.robots)


def test_sets(poses: int = 1000, robots: int = 200, seed: int = 7) -> list[TestSet]:
    """The study's robot and CoGiRo with ``poses`` random feasible poses each, and
    ``robots`` random robots sharing ``poses`` poses (at least one each)."""
    study = to.presets.algae_harvester()
    cogiro = to.presets.cogiro()
    per_robot = max(1, poses // max(robots, 1))
    return [
        TestSet("study", [(study, random_feasible_poses(study, poses, seed=seed, low=POND_LOW,
                                                        high=POND_HIGH))]),
        TestSet("cogiro", [(cogiro, random_feasible_poses(cogiro, poses, seed=seed + 1,
                                                          low=COGIRO_LOW, high=COGIRO_HIGH))]),
        TestSet("random robots", [(r.robot, r.poses) for r in
                                  random_robot_set(robots, per_robot, seed=seed + 2)]),
    ]


def problem_for(objective: str, robot: to.CableRobot) -> to.TensionProblem:
    """The problem of ``objective``; the centred one gets ``t_max = 4 m g`` where the
    robot has none."""
    if objective == "centered" and not np.isfinite(robot.t_max).all():
        return to.TensionProblem("centered", t_max=4.0 * robot.weight)
    return to.TensionProblem(objective)


def reference(robot: to.CableRobot, poses: NDArray, problem: to.TensionProblem
              ) -> to.TensionSolution:
    """The exact optimum: the closed form, else HiGHS (LP) or Clarabel (QP) at high accuracy."""
    try:
        return to.distribute(robot, poses, problem, "closed_form")
    except to.UnsupportedProblemError:
        kind = "lp" if problem.is_linear else "qp"
        return to.distribute(robot, poses, problem, REFERENCE[kind], accuracy="high")


def compare(test_set: TestSet, objective: str, backend: str, accuracy: Any = "default"
            ) -> dict[str, Any] | None:
    """One row: the backend's labels on a test set against the exact optimum (None if
    the backend takes none of the set's problems)."""
    labelled = solved = wrong = 0
    worst, seconds = -np.inf, 0.0
    deviation = 0.0
    target = accuracy_target(accuracy)
    taken = False
    for robot, poses in test_set.robots:
        problem = problem_for(objective, robot)
        exact = reference(robot, poses, problem)
        try:
            start = time.perf_counter()
            sol = to.distribute(robot, poses, problem, backend, accuracy=accuracy)
            seconds += time.perf_counter() - start
        except to.UnsupportedProblemError:
            continue
        taken = True
        known = exact.success
        optimal = sol.success & known
        solved += int(known.sum())
        labelled += int(optimal.sum())
        if optimal.any():
            assert sol.form is not None
            gaps = objective_excess(sol.form.subset(optimal), sol.tensions[optimal],
                          exact.tensions[optimal])
            worst = max(worst, float(gaps.max()))
            wrong += int((gaps > target).sum())
            scale = np.abs(exact.tensions[optimal]).max(axis=1)
            deviation = max(deviation, float((np.abs(sol.tensions[optimal]
                                                     - exact.tensions[optimal]).max(axis=1)
                                              / scale).max()))
    if not taken:
        return None
    return {"set": test_set.name, "objective": objective, "backend": backend,
            "poses": solved, "optimal": labelled,
            "share_optimal": labelled / solved if solved else float("nan"),
            "worst_excess": worst if labelled else float("nan"), "wrong_optimal": wrong,
            "worst_tension_deviation": deviation if labelled else float("nan"),
            "us_per_pose": 1e6 * seconds / max(test_set.N, 1)}


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """Per backend over every set and objective: share labelled optimal, worst excess
    among them, wrong "optimal" poses."""
    g = rows.groupby("backend")
    table = pd.DataFrame({
        "poses": g["poses"].sum(), "share optimal": g["optimal"].sum() / g["poses"].sum(),
        "worst excess": g["worst_excess"].max(), "wrong optimal": g["wrong_optimal"].sum(),
        "worst |T - T*| / max T*": g["worst_tension_deviation"].max(),
        "us/pose (median)": g["us_per_pose"].median()})
    return table.sort_values(["wrong optimal", "share optimal"], ascending=[True, False])


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.certify_study",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=1000, help="poses per set (1000)")
    parser.add_argument("--robots", type=int, default=200, help="random robots (200)")
    parser.add_argument("--backend", nargs="+", help="default: every installed backend")
    parser.add_argument("--objective", nargs="+", choices=OBJECTIVES, default=list(OBJECTIVES))
    parser.add_argument("--set", nargs="+", dest="sets", help="study, cogiro, 'random robots'")
    parser.add_argument("--accuracy", default="default", help="default, high or a number")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", type=Path, help="write the rows as CSV here")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the comparison and print its tables; returns the exit code."""
    args = _parser().parse_args(argv)
    accuracy: Any = args.accuracy
    try:
        accuracy = float(accuracy)
    except ValueError:
        pass
    backends = args.backend or to.available_backends()
    sets = [s for s in test_sets(args.poses, args.robots, args.seed)
            if not args.sets or s.name in args.sets]
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for test_set in sets:
            for objective in args.objective:
                for backend in backends:
                    row = compare(test_set, objective, backend, accuracy)
                    if row is not None:
                        rows.append(row)
                        print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
                                       for k, v in row.items()), file=sys.stderr, flush=True)
    frame = pd.DataFrame(rows)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(args.out, index=False)
    with pd.option_context("display.width", 200, "display.max_columns", 20,
                           "display.float_format", "{:.3g}".format):
        print(summary(frame).to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main())
