"""The command line: ``python -m tension_opt check | from-caspr | warmup``.

``check`` validates a robot file (YAML or JSON) and prints a summary of the robot with
its feasibility and capacity margin at the home pose; exit code 0 for a valid file, 2
with the validation message for a bad one. ``from-caspr`` writes a robot file from a
CASPR model (:func:`tension_opt.robot.caspr.load_caspr`). ``warmup`` compiles every
kernel ahead, with a progress bar and the time each family took
(:mod:`tension_opt.warmup`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from tension_opt import warmup
from tension_opt.checks import coincident_pair
from tension_opt.distribution.entry import distribute
from tension_opt.errors import RobotFileError, TensionOptError
from tension_opt.robot import CableRobot
from tension_opt.robot.caspr import load_caspr
from tension_opt.status import Status
from tension_opt.workspace.margin import capacity_margin

PROG = "python -m tension_opt"
#: Exit code of a file that does not describe a valid robot (as argparse's usage errors).
INVALID = 2


def _number(value: float) -> str:
    return f"{value:.6g}"


def _bounds(values: ArrayLike) -> str:
    arr = np.asarray(values, dtype=float)
    low, high = float(arr.min()), float(arr.max())
    return _number(low) if low == high else f"{_number(low)} .. {_number(high)}"


def summary(robot: CableRobot, objective: str = "min_sum", backend: str = "auto") -> str:
    """Text summary of a robot and of its tensions at the home pose.

    Parameters
    ----------
    robot : CableRobot
    objective, backend : str
        Passed to :func:`tension_opt.distribute` for the tensions at home.

    Raises
    ------
    TensionOptError
        If the home pose cannot be evaluated (e.g. it puts a cable on its drawing point).
    """
    home = robot.default_home()
    where = "" if robot.home is not None else " (the anchors' centroid: the file gives none)"
    cable = robot.cable
    lines = [
        f"name:            {robot.name}",
        f"kind:            {robot.kind} (pose {', '.join(robot.pattern.coordinates)})",
        f"cables:          {robot.m}",
        f"DOF:             {robot.dof}",
        f"redundancy:      {robot.redundancy}",
        f"mass:            {_number(robot.mass)} kg (weight {_number(robot.weight)} N at "
        f"g = {_number(robot.g)} m/s^2)",
        f"t_min:           {_bounds(robot.t_min)} N",
        f"t_max:           {_bounds(robot.t_max)} N",
        "cable:           " + ("none given" if cable is None else
                               f"diameter {_number(cable.diameter)} m, "
                               f"{_number(cable.linear_mass)} kg/m, EA {_number(cable.EA)} N"),
        f"home pose:       {[_number(v) for v in home]}{where}".replace("'", ""),
    ]
    if (pair := coincident_pair(robot.anchors)) is not None:
        lines.append(f"shared anchors:  cables {pair[0]} and {pair[1]} leave one drawing point")
    if robot.pulleys is not None:
        count = sum(q is not None for q in robot.pulleys)
        lines.append(f"pulleys:         {count} of {robot.m} cables over a guide pulley")
    solution = distribute(robot, home, objective, backend)
    status = str(solution.status[0])
    if status == Status.OPTIMAL:
        tensions = solution.tensions[0]
        lines.append(f"feasible at home: yes ({objective} tensions {_bounds(tensions)} N, "
                     f"backend {solution.backend})")
    else:
        lines.append(f"feasible at home: no (status {status})")
    margin = float(capacity_margin(robot, home)[0])
    note = {np.inf: " (tensions can grow without bound)",
            -np.inf: " (no tensions balance the load)"}.get(margin, "")
    lines.append(f"capacity margin at home: {_number(margin)} N{note}")
    return "\n".join(lines)


def _check(args: argparse.Namespace) -> int:
    try:
        robot = CableRobot.from_file(args.file)
        text = summary(robot, args.objective, args.backend)
    except RobotFileError as error:
        print(error, file=sys.stderr)
        return INVALID
    except TensionOptError as error:
        print(f"robot file {args.file}: the home pose cannot be evaluated: {error}",
              file=sys.stderr)
        return INVALID
    print(text)
    return 0


def _from_caspr(args: argparse.Namespace) -> int:
    try:
        robot = load_caspr(args.bodies, args.cables, args.cable_set, name=args.name)
        robot.to_file(args.output)
    except TensionOptError as error:
        print(error, file=sys.stderr)
        return INVALID
    print(f"wrote {args.output}: {robot.name}, {robot.kind}, {robot.m} cables")
    return 0


def _warmup(args: argparse.Namespace) -> int:
    try:
        took = warmup.warm(args.family or None, jobs=args.jobs, progress=not args.no_progress)
    except TensionOptError as error:
        print(error, file=sys.stderr)
        return INVALID
    width = max(len(name) for name in took)
    for name, seconds in took.items():
        print(f"{name:<{width}}  {seconds:6.1f} s")
    print(f"{'all, one after the other':<{width}}  {sum(took.values()):6.1f} s")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 valid, 2 invalid)."""
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    check = commands.add_parser("check", help="validate a robot file and summarise it")
    check.add_argument("file", help="robot file (.yaml, .yml or .json)")
    check.add_argument("--objective", default="min_sum",
                       help="objective of the tensions at home (default min_sum)")
    check.add_argument("--backend", default="auto", help="backend (default auto)")
    check.set_defaults(run=_check)
    caspr = commands.add_parser("from-caspr", help="write a robot file from a CASPR model")
    caspr.add_argument("bodies", help="CASPR *_bodies.xml")
    caspr.add_argument("cables", help="CASPR *_cables.xml")
    caspr.add_argument("output", help="robot file to write (.yaml, .yml or .json)")
    caspr.add_argument("--cable-set", default=None, help="cable set id (default: the "
                       "file's default_cable_set)")
    caspr.add_argument("--name", default=None, help="robot name (default: from the file)")
    caspr.set_defaults(run=_from_caspr)
    warm = commands.add_parser(
        "warmup", help="compile every kernel ahead (once per installation), with the "
        "time each family took")
    warm.add_argument("--family", nargs="+", default=None,
                      help="only these families (default: all)")
    warm.add_argument("--jobs", type=int, default=2,
                      help="processes compiling at once (default 2)")
    warm.add_argument("--no-progress", action="store_true", help="no progress bar")
    warm.set_defaults(run=_warmup)
    args = parser.parse_args(argv)
    return int(args.run(args))


if __name__ == "__main__":
    sys.exit(main())
