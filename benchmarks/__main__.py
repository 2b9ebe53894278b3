"""Command line of the benchmark.

::

    python -m benchmarks                      # default suite, then the report (benchmarks/results)
    python -m benchmarks run [--scenario S ...] [--problem P ...] [--backend B ...]
                             [--settings default|high|default/warm ...] [--full] [--redo]
                             [--executor inprocess|processes[:N]|dask[:ADDRESS]]
    python -m benchmarks --executor processes:2   # default suite on a local process pool
    python -m benchmarks report               # rewrite the report from the stored results
    python -m benchmarks list                 # scenarios, problems, installed backends

Without ``--executor`` every cell runs in a forked worker process that is killed when the
cell overruns its time limit. With ``--executor`` the cells go in chunks to a process pool
or a Dask cluster (``pip install "tension-opt[dask]"``); the time limit is then only
checked between chunks of poses and passed to the solvers.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks import harness, report
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from tension_opt.errors import BackendNotAvailableError
from tension_opt.executors import DASK_ADDRESS_VARIABLE, get_executor

EXECUTOR_HELP = (
    "where the cells run: 'processes' or 'processes:N' (a local pool of N processes, "
    "default one per CPU), 'dask:tcp://HOST:8786' (a Dask cluster; 'dask' alone reads the "
    f"address from ${DASK_ADDRESS_VARIABLE}; needs pip install \"tension-opt[dask]\"), or "
    "'inprocess'. The cells are sent in chunks; rows are stored as chunks come back, so an "
    "interrupted run resumes. A pool or cluster worker cannot be killed per cell: the time "
    "limit is then only checked between chunks of poses and passed to the solvers. Rows "
    "record the machine of the worker. Default: each cell in a forked process, killed "
    "after its time limit.")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="Tension-distribution benchmark: problems x backends x settings on "
                    "fixed scenarios. Without a command: run the default suite and report.")
    parser.add_argument("--results", type=Path, default=harness.RESULTS_DIR,
                        help="results directory (default: benchmarks/results)")
    parser.add_argument("--executor", dest="suite_executor", metavar="SPEC",
                        help="where the default suite (no command) runs: processes[:N], "
                             "dask[:ADDRESS] or inprocess; see 'run --help'")
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", help="run cells not yet stored (then write the report)")
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
    sub.add_parser("report", help="write README.md and the plots from the stored results")
    sub.add_parser("list", help="list scenarios, problems and installed backends")
    return parser


def _run(args: argparse.Namespace) -> int:
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
        print(f"report: {report.write_report(args.results)}")
    return 0


def _list() -> int:
    import tension_opt

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


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit code."""
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        if args.command is None:
            args = parser.parse_args([*(argv or []), "run"])
            return _run(args)
        if args.command == "run":
            return _run(args)
        if args.command == "report":
            print(f"report: {report.write_report(args.results)}")
            return 0
        return _list()
    except (ValueError, BackendNotAvailableError) as exc:
        parser.error(str(exc))
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
