"""Command line of the benchmarks: ``python -m benchmarks run|report|list|study``.

::

    python -m benchmarks                      # default suite, then the report (benchmarks/results)
    python -m benchmarks run [--scenario S ...] [--problem P ...] [--backend B ...]
                             [--settings default|high|default/warm ...] [--full] [--redo]
                             [--executor inprocess|processes[:N]|dask[:ADDRESS]]
    python -m benchmarks --executor processes:2   # default suite on a local process pool
    python -m benchmarks report               # rewrite the report from the stored results
    python -m benchmarks list                 # scenarios, problems, installed backends
    python -m benchmarks study PARAMETER [--values V ...] [--pose X Y Z ...] [--out CSV]
                                              # a parameter study of the reference robot

Backends, scenarios, problems and settings are checked before anything runs: a name
that is unknown or not installed exits with code 2, storing nothing. The rows go to an
SQLite database in the results directory; after a run ``results.csv``, ``traces.npz``
and the report are exported from it. A store that cannot be read exits with code 1 and
a message naming the file and how to recover.

Without ``--executor`` every cell runs in a forked worker process that is killed when the
cell overruns its time limit. With ``--executor`` the cells go in chunks to a process pool
or a Dask cluster (``pip install "tension-opt[dask]"``); the time limit is then only
checked between chunks of poses and passed to the solvers. ``study`` sweeps one parameter
of the reference robot (:func:`benchmarks.studies.sweep`), prints a summary per sweep
point and pose, and writes the full table with ``--out``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

import tension_opt
from benchmarks import harness, report, studies
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from benchmarks.study_points import ROBOT_OVERRIDES, parameter_names
from tension_opt.errors import BackendNotAvailableError
from tension_opt.executors import DASK_ADDRESS_VARIABLE, get_executor

__all__ = ["EXECUTOR_HELP", "build_parser", "main"]

EXECUTOR_HELP = (
    "where the cells run: 'processes' or 'processes:N' (a local pool of N processes, "
    "default one per CPU), 'dask:tcp://HOST:8786' (a Dask cluster; 'dask' alone reads the "
    f"address from ${DASK_ADDRESS_VARIABLE}; needs pip install \"tension-opt[dask]\"), or "
    "'inprocess'. The cells are sent in chunks; rows are stored as chunks come back, so an "
    "interrupted run resumes. A pool or cluster worker cannot be killed per cell: the time "
    "limit is then only checked between chunks of poses and passed to the solvers. Rows "
    "record the machine of the worker. Default: each cell in a forked process, killed "
    "after its time limit.")


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m benchmarks`` and its commands."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="Tension-distribution benchmark: problems x backends x settings on "
                    "fixed scenarios, and parameter studies of the reference robot. "
                    "Without a command: run the default suite and report.")
    parser.add_argument("--results", type=Path, default=harness.RESULTS_DIR,
                        help="results directory (default: benchmarks/results)")
    parser.add_argument("--executor", dest="suite_executor", metavar="SPEC",
                        help="where the default suite (no command) runs: processes[:N], "
                             "dask[:ADDRESS] or inprocess; see 'run --help'")
    sub = parser.add_subparsers(dest="command")
    _add_run(sub.add_parser("run", help="run cells not yet stored (then write the report)"))
    _add_results(sub.add_parser("report", help="write results.csv, traces.npz, README.md "
                                               "and the plots from the stored results"))
    sub.add_parser("list", help="list scenarios, problems and installed backends")
    _add_study(sub.add_parser(
        "study", help="sweep one parameter of the reference robot (a parameter study)",
        description="Sweep one parameter of the reference algae-harvesting robot and "
                    "tabulate straight and sagging cable lengths and tensions."))
    return parser


def _add_results(command: argparse.ArgumentParser) -> None:
    # Also after the command; when absent there, the value before it stands.
    command.add_argument("--results", type=Path, default=argparse.SUPPRESS,
                         help="results directory (default: benchmarks/results)")


def _add_run(run: argparse.ArgumentParser) -> None:
    _add_results(run)
    run.add_argument("--scenario", nargs="+", metavar="S", help=f"among {list(SCENARIOS)}")
    run.add_argument("--problem", nargs="+", metavar="P", help=f"among {list(PROBLEMS)}")
    run.add_argument("--backend", nargs="+", metavar="B",
                     help="registry names, e.g. closed_form cvxpy:CLARABEL qpsolvers:daqp "
                          "(default: every installed backend)")
    run.add_argument("--settings", nargs="+", metavar="A[/START]",
                     help="accuracy default|high, optionally /cold or /warm (default: all)")
    run.add_argument("--full", action="store_true",
                     help="every combination; without it the selection is cut to the default "
                          "suite (fewer settings, fast backends only on the 10^4-pose path)")
    run.add_argument("--redo", action="store_true", help="run stored cells again")
    run.add_argument("--time-limit", type=float, default=harness.TIME_LIMIT,
                     help="budget of one cell in seconds (default %(default)s)")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--executor", metavar="SPEC", help=EXECUTOR_HELP)
    run.add_argument("--no-report", action="store_true", help="do not rewrite the report")


def _add_study(study: argparse.ArgumentParser) -> None:
    names = parameter_names()
    study.add_argument("parameter", choices=names, metavar="PARAMETER",
                       help=f"one of {names}")
    study.add_argument("--values", nargs="+", metavar="V",
                       help="values to sweep, SI units (material names for 'material'); "
                            "default: the study's range")
    study.add_argument("--materials", nargs="+", metavar="NAME",
                       help="same as --values for the material study")
    study.add_argument("--pose", nargs=3, type=float, action="append",
                       metavar=("X", "Y", "Z"),
                       help="a pose in m (repeat for several); default (0,0,0) and (8,-5,2)")
    study.add_argument("--material", help="cable material for every point (not with "
                                          "'material')")
    study.add_argument("--elastic", action="store_true",
                       help="EA from the material's rope modulus (default: inextensible)")
    study.add_argument("--models", nargs="+", choices=studies.MODELS,
                       default=list(studies.MODELS))
    study.add_argument("--set", nargs="+", default=[], metavar="KEY=VALUE",
                       help=f"fixed robot overrides among {list(ROBOT_OVERRIDES)}")
    study.add_argument("--executor", metavar="SPEC",
                       help="inprocess (default), processes[:N] or dask[:ADDRESS]")
    study.add_argument("--chunk-size", type=int, default=1, help="sweep points per chunk")
    study.add_argument("--out", type=Path, help="write the full table as CSV here")
    study.add_argument("--no-progress", action="store_true", help="no progress bar")


def _check_backends(names: Sequence[str] | None) -> None:
    """Raise ValueError, listing the installed backends, if a named one cannot run here."""
    reasons = []
    for name in names or ():
        try:
            tension_opt.get_backend(name)
        except (BackendNotAvailableError, ValueError) as exc:
            # The registry's message names the backend and may list the installed ones:
            # they are listed once, below.
            reasons.append(str(exc).split("; installed:")[0])
    if reasons:
        raise ValueError(f"--backend: {'; '.join(reasons)}; installed backends: "
                         f"{', '.join(tension_opt.available_backends())}")


def _write_report(store: harness.ResultsStore) -> None:
    """Export the table and write the report from one state of the store.

    Other runs into the same directory wait meanwhile, so the last report written holds
    every row.
    """
    with store.exclusive():
        store.export()
        print(f"report: {report.write_report(store.directory)}")


def _run(args: argparse.Namespace) -> int:
    _check_backends(args.backend)
    settings = (harness.ALL_SETTINGS if not args.settings
                else [s for text in args.settings for s in harness.Setting.parse(text)])
    cells = harness.plan(
        scenarios=harness.select(args.scenario, SCENARIOS, "scenario"),
        problems=harness.select(args.problem, PROBLEMS, "problem"),
        backends=args.backend, settings=settings)
    if not args.full:
        chosen = [name for name in ("scenario", "backend", "settings") if getattr(args, name)]
        cells = harness.default_suite(cells, chosen)
    store = harness.ResultsStore(args.results)
    spec = args.executor or getattr(args, "suite_executor", None)
    start = time.perf_counter()
    if spec is None:
        frame = harness.run(cells, store, redo=args.redo, time_limit=args.time_limit,
                            progress=not args.no_progress)
    else:
        try:
            executor = get_executor(spec)
        except OSError as exc:  # e.g. no scheduler at the address
            raise ValueError(f"cannot reach the Dask scheduler for {spec!r}: {exc}") from exc
        with executor:
            frame = harness.run(cells, store, redo=args.redo, time_limit=args.time_limit,
                                progress=not args.no_progress, executor=executor)
    print(harness.summary(frame, cells, time.perf_counter() - start))
    if not args.no_report:
        _write_report(store)
    return 0


def _list() -> int:
    print("scenarios:")
    for s in SCENARIOS.values():
        print(f"  {s.name:20s} {s.description}")
    print("problems:")
    for p in PROBLEMS.values():
        print(f"  {p.name:20s} {p.description}")
    print("installed backends:")
    for b in tension_opt.available_backends():
        warm = " (warm start)" if harness.supports_warm_start(b) else ""
        print(f"  {b}{warm}")
    return 0


def _study_values(args: argparse.Namespace) -> list[Any] | None:
    """The swept values of ``study``: numbers, or material names for 'material'."""
    if args.materials is not None and args.parameter != "material":
        raise ValueError(f"--materials goes with the 'material' sweep, not {args.parameter!r}")
    raw = args.materials if args.materials is not None else args.values
    if raw is None or args.parameter == "material":
        return raw
    try:
        return [float(v) for v in raw]
    except ValueError:
        raise ValueError(f"--values takes numbers; got {raw}") from None


def _study_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``--set KEY=NUMBER ...`` as preset overrides."""
    overrides: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        try:
            overrides[key] = float(text)
        except ValueError:
            sep = ""
        if not sep:
            raise ValueError(f"--set takes KEY=NUMBER; got {item!r}")
    return overrides


def _study(args: argparse.Namespace) -> int:
    values = _study_values(args)
    table = studies.sweep(args.parameter, values, args.pose, material=args.material,
                          elastic=args.elastic, models=args.models, executor=args.executor,
                          chunk_size=args.chunk_size, progress=not args.no_progress,
                          **_study_overrides(args.set))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out, index=False)
        print(f"{len(table)} rows written to {args.out}", file=sys.stderr)
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.float_format", "{:.4g}".format):
        print(studies.summarize(table).to_string(index=False))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m benchmarks``; returns the process exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments after the program name (default: ``sys.argv[1:]``).
    """
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    try:
        if args.command is None:
            return _run(parser.parse_args([*argv, "run"]))
        if args.command == "run":
            return _run(args)
        if args.command == "report":
            _write_report(harness.ResultsStore(args.results))
            return 0
        if args.command == "study":
            return _study(args)
        return _list()
    except harness.StoreError as exc:  # not a usage error: no usage line
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    except (ValueError, BackendNotAvailableError) as exc:
        parser.error(str(exc))
    return 2
