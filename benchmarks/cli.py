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

Arguments are checked before anything runs: a name that is unknown or not installed,
a time limit that is not a number of seconds in (0, MAX_TIME_LIMIT], a results directory
that is a file or cannot be written, or an executor that cannot be made exits with code 2
and a message naming the argument, storing nothing. The rows go to an
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
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

import tension_opt
from benchmarks import harness, report, studies
from benchmarks.isolation import CELL_FAMILIES
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from benchmarks.study_points import ROBOT_OVERRIDES, parameter_names
from tension_opt import warmup
from tension_opt.errors import BackendNotAvailableError
from tension_opt.workspace.executors import DASK_ADDRESS_VARIABLE, get_executor

__all__ = ["EXECUTOR_HELP", "MAX_PROCESSES", "MAX_TIME_LIMIT", "build_parser", "main"]

#: Largest budget of one cell that ``--time-limit`` takes (s): a day.
MAX_TIME_LIMIT = 86400.0
#: Most processes of a local pool (``--executor processes:N``): four per CPU.
MAX_PROCESSES = 4 * (os.cpu_count() or 1)

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
    run.add_argument("--time-limit", type=_time_limit, default=harness.TIME_LIMIT,
                     help="budget of one cell in seconds, at most "
                          f"{MAX_TIME_LIMIT:g} (default %(default)s)")
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
    study.add_argument("--pose", nargs=3, type=_finite, action="append",
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
    study.add_argument("--chunk-size", type=_positive_int, default=1,
                       help="sweep points per chunk")
    study.add_argument("--out", type=Path, help="write the full table as CSV here")
    study.add_argument("--no-progress", action="store_true", help="no progress bar")


def _time_limit(text: str) -> float:
    """``--time-limit``: seconds in (0, MAX_TIME_LIMIT] (a worker's deadline must be a
    finite time the system can wait for)."""
    value = _finite(text)
    if not 0 < value <= MAX_TIME_LIMIT:
        raise argparse.ArgumentTypeError(
            f"must be a number of seconds in (0, {MAX_TIME_LIMIT:g}]; got {text!r}")
    return value


def _finite(text: str) -> float:
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
    return value


def _positive_int(text: str) -> int:
    """A whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1; got {text!r}")
    return value


def _check_results(path: Path) -> None:
    """Raise ValueError naming ``--results`` unless ``path`` is a writable directory
    (made if missing)."""
    if _is_file(path):
        raise ValueError(f"--results: {str(path)!r} is a file, not a directory; give a "
                         "directory")
    _make_directory("--results", path)


def _check_out(path: Path) -> None:
    """Raise ValueError naming ``--out`` unless a file can be written at ``path``."""
    try:
        is_dir = path.is_dir()
    except (OSError, ValueError) as exc:  # ValueError: e.g. a NUL byte in the name
        raise ValueError(f"--out: cannot use {str(path)!r}: {exc}") from None
    if is_dir:
        raise ValueError(f"--out: {str(path)!r} is a directory; give a file name")
    _make_directory("--out", path.parent)


def _is_file(path: Path) -> bool | None:
    """Whether ``path`` is something other than a directory (None: nothing there, or
    not a name the system takes)."""
    try:
        if not path.exists():
            return None
        return not path.is_dir()
    except (OSError, ValueError):  # ValueError: e.g. a NUL byte in the name
        return None


def _make_directory(flag: str, path: Path) -> None:
    """Make the directory ``path`` (and its parents) if missing; raise ValueError led by
    ``flag`` if that fails or the directory cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as exc:
        blocker = next((p for p in (path, *path.parents) if _is_file(p)), None)
        reason = (f"{str(blocker)!r} is a file" if blocker is not None
                  else getattr(exc, "strerror", None) or exc)
        raise ValueError(f"{flag}: cannot make the directory {str(path)!r}: {reason}"
                         ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"{flag}: the directory {str(path)!r} is not writable")


def _check_executor(spec: str | None) -> None:
    """Raise ValueError naming ``--executor`` for a spec that names no executor, or a
    local pool larger than :data:`MAX_PROCESSES`; no worker is started. A Dask
    scheduler is reached only when the run starts."""
    if spec is None:
        return
    kind, _, count = spec.partition(":")
    if kind == "processes" and count.isdigit() and int(count) > MAX_PROCESSES:
        raise ValueError(f"--executor: at most {MAX_PROCESSES} local processes (four per "
                         f"CPU); got {spec!r}")
    if kind in ("dask", "tcp", "tls", "inproc", "ucx"):
        return
    try:
        get_executor(spec).close()
    except (ValueError, BackendNotAvailableError) as exc:
        raise _named("--executor", ValueError(str(exc))) from None


def _named(flag: str, error: ValueError) -> ValueError:
    """``error`` with its message led by the argument it is about."""
    return ValueError(f"{flag}: {error}")


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
    try:
        settings = (harness.ALL_SETTINGS if not args.settings
                    else [s for text in args.settings for s in harness.Setting.parse(text)])
    except ValueError as exc:
        raise _named("--settings", exc) from None
    scenarios, problems = (_select(flag, names, registry, what) for flag, names, registry, what
                           in (("--scenario", args.scenario, SCENARIOS, "scenario"),
                               ("--problem", args.problem, PROBLEMS, "problem")))
    cells = harness.plan(scenarios=scenarios, problems=problems, backends=args.backend,
                         settings=settings)
    if not args.full:
        chosen = [name for name in ("scenario", "backend", "settings") if getattr(args, name)]
        cells = harness.default_suite(cells, chosen)
    spec = args.executor or getattr(args, "suite_executor", None)
    _check_executor(spec)
    _check_results(args.results)
    store = harness.ResultsStore(args.results)
    start = time.perf_counter()
    if spec is None:
        frame = harness.run(cells, store, redo=args.redo, time_limit=args.time_limit,
                            progress=not args.no_progress)
    else:
        try:
            executor = get_executor(spec)
        except OSError as exc:  # e.g. no scheduler at the address
            raise ValueError(f"--executor: cannot reach the Dask scheduler for {spec!r}: "
                             f"{exc}") from exc
        except (ValueError, BackendNotAvailableError) as exc:
            raise _named("--executor", ValueError(str(exc))) from None
        with executor:
            frame = harness.run(cells, store, redo=args.redo, time_limit=args.time_limit,
                                progress=not args.no_progress, executor=executor)
    print(harness.summary(frame, cells, time.perf_counter() - start))
    if not args.no_report:
        _write_report(store)
    return 0


def _select(flag: str, names: Sequence[str] | None, registry: dict[str, Any],
            what: str) -> list[Any]:
    """:func:`harness.select`, its error led by ``flag``."""
    try:
        return harness.select(names, registry, what)
    except ValueError as exc:
        raise _named(flag, exc) from None


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
        values = [float(v) for v in raw]
    except ValueError:
        raise ValueError(f"--values takes numbers; got {raw}") from None
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"--values takes finite numbers; got {raw}")
    return values


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
    if args.out is not None:
        _check_out(args.out)
    table = studies.sweep(args.parameter, values, args.pose, material=args.material,
                          elastic=args.elastic, models=args.models, executor=args.executor,
                          chunk_size=args.chunk_size, progress=not args.no_progress,
                          **_study_overrides(args.set))
    if args.out is not None:
        try:
            table.to_csv(args.out, index=False)
        except (OSError, ValueError) as exc:
            raise ValueError(f"--out: cannot write {str(args.out)!r}: {exc}") from None
        print(f"{len(table)} rows written to {args.out}", file=sys.stderr)
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.float_format", "{:.4g}".format):
        print(studies.summarize(table).to_string(index=False))
    return 0


def _compile_first(progress: bool) -> None:
    """The main job's compile step, before the cells: the kernel families its cells run
    (:data:`benchmarks.isolation.CELL_FAMILIES`) compiled, or loaded from the disk cache,
    in two processes, with its own progress line and the seconds."""
    start = time.perf_counter()
    took = warmup.warm(CELL_FAMILIES, jobs=2, progress=progress)
    slowest = max(took, key=took.__getitem__)
    print(f"kernels ready in {time.perf_counter() - start:.0f} s ({len(took)} families; "
          f"slowest {slowest}: {took[slowest]:.0f} s)", file=sys.stderr)


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
            run = parser.parse_args([*argv, "run"])
            _compile_first(progress=not run.no_progress)
            return _run(run)
        if args.command == "run":
            return _run(args)
        if args.command == "report":
            _check_results(args.results)
            _write_report(harness.ResultsStore(args.results))
            return 0
        if args.command == "study":
            return _study(args)
        return _list()
    except (harness.StoreError, OSError) as exc:  # not a usage error: no usage line
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    except (ValueError, BackendNotAvailableError) as exc:
        parser.error(str(exc))
    return 2
