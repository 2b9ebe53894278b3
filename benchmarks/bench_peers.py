"""The toolkit against WireX (Andreas Pott's C++ cable-robot library, MIT licence), same
robots and poses: ``python -m benchmarks.bench_peers --wirex DIR``.

``DIR`` is a checkout of WireX's public source. A small C++ timing driver
(:mod:`benchmarks.wirex_driver`) is written into a temporary folder and built there
against it with the system's C++ compiler (``-O2``; with ``--native`` also
``-O3 -march=native``), and reads the robots and poses from a file written beside it.
Both sides time the same work per pose, the structure matrix included, on one core
(the toolkit with ``NUMBA_NUM_THREADS=1``):

- CoGiRo, the closed form strictly inside the bounds: WireX's closed form and improved
  closed form; the toolkit's ``distribute(robot, poses, "centered", "closed_form")``
  as one batch and a :class:`tension_opt.Distributor` called per pose;
- CoGiRo and IPAnema 3, bounds active: WireX's improved closed form (which may fail on
  a feasible pose: the count it solves is printed); the same toolkit calls, which
  find and certify the exact optimum;
- the stiffness matrix of straight cables with the tensions given (CoGiRo): WireX's
  ``CStiffness::StiffnessMatrixMain``; :func:`catenary.platform_stiffness` as one batch
  and :class:`catenary.PoseStiffness` called per pose.

Each figure is a median over repeats of a pass over all poses, divided by their number
(:mod:`benchmarks.peers_toolkit`). Without ``DIR`` or without a compiler, the command
says what is missing and times the toolkit's side alone (exit code 0).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import wirex_driver as wx

if TYPE_CHECKING:
    from .peers_toolkit import PeerCase

__all__ = ["Row", "WirexSide", "fmt_time", "main", "markdown", "table_rows"]

#: The toolkit's calls per row of the table, with their labels.
TOOLKIT_LABELS = {
    "batch": '`distribute(..., "centered", "closed_form")` batch',
    "loop": "`Distributor` loop",
    "stiffness_batch": "`platform_stiffness` batch",
    "stiffness_loop": "`PoseStiffness` one pose per call",
}
#: Rows: label, case, the WireX works shown (the first is the ratios' reference), and
#: the toolkit's calls.
ROWS = (
    (
        "CoGiRo, closed form strictly inside the bounds",
        "cogiro_inside",
        (("closed_form", "closed form"), ("improved", "improved, checks bounds")),
        ("batch", "loop"),
    ),
    (
        "CoGiRo, bounds active",
        "cogiro_active",
        (("improved", "improved closed form"),),
        ("batch", "loop"),
    ),
    (
        "IPAnema 3, bounds active",
        "ipanema_active",
        (("improved", "improved closed form"),),
        ("batch", "loop"),
    ),
    (
        "stiffness matrix, straight cables, tensions given (CoGiRo)",
        "cogiro_stiffness",
        (("stiffness", ""),),
        ("stiffness_batch", "stiffness_loop"),
    ),
)


@dataclass
class WirexSide:
    """The WireX side of one run: its results per build, or why there are none."""

    results: dict[str, wx.DriverResult] = field(default_factory=dict)
    builds: list[wx.Build] = field(default_factory=list)
    missing: str = ""
    failed: bool = False


@dataclass(frozen=True)
class Row:
    """One line of the table (its four cells)."""

    work: str
    wirex: str
    toolkit: str
    ratio: str


def fmt_time(ns: float) -> str:
    """``850 ns`` below a microsecond, ``3.7 us`` from there."""
    if ns != ns:
        return "n/a"
    return f"{ns:.0f} ns" if ns < 1e3 else f"{ns / 1e3:.3g} us"


def _wirex_cell(
    side: WirexSide, case: str, works: tuple[tuple[str, str], ...]
) -> tuple[str, list[float]]:
    """The WireX cell of a row and the reference times (the first work, per build)."""
    if not side.results:
        return "not run", []
    parts, reference = [], []
    for k, (work, label) in enumerate(works):
        per_build = [(b, r.times.get((case, work))) for b, r in side.results.items()]
        shown = [(b, t) for b, t in per_build if t is not None]
        if not shown:
            continue
        if k == 0:
            reference = [t for _, t in shown]
        if len(shown) == 1:
            text = fmt_time(shown[0][1])
            parts.append(f"{text} ({label})" if label else text)
        else:
            text = ", ".join(f"{fmt_time(t)} ({b})" for b, t in shown)
            parts.append(f"{label}: {text}" if label else text)
    return ("; ".join(parts) or "n/a"), reference


def table_rows(toolkit: dict[tuple[str, str], float], side: WirexSide) -> list[Row]:
    """The rows of the table from the toolkit's times and the WireX side's results."""
    rows = []
    for work, case, wirex_works, calls in ROWS:
        mine = [(c, toolkit[(case, c)]) for c in calls if (case, c) in toolkit]
        if not mine:
            continue
        cell, reference = _wirex_cell(side, case, wirex_works)
        ours = "; ".join(f"{TOOLKIT_LABELS[c]} {fmt_time(t)}" for c, t in mine)
        if reference:
            ratios = []
            for _, t in mine:
                low, high = t / max(reference), t / min(reference)
                ratios.append(
                    f"{low:.1f}x" if f"{low:.1f}" == f"{high:.1f}" else f"{low:.1f}-{high:.1f}x"
                )
            ratio = ", ".join(ratios)
        else:
            ratio = "-"
        rows.append(Row(work, cell, ours, ratio))
    return rows


def markdown(rows: list[Row], notes: list[str], header: str) -> str:
    """The table as Markdown, with the run's header line and notes."""
    lines = [
        header,
        "",
        "| work, per pose | WireX (C++) | toolkit | toolkit / WireX |",
        "|---|---|---|---|",
    ]
    lines += [f"| {r.work} | {r.wirex} | {r.toolkit} | {r.ratio} |" for r in rows]
    lines += [""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def _run_wirex(
    args: argparse.Namespace, checkout: Path | None, cases: list[wx.Case], compiler: str | None
) -> WirexSide:
    """Build and run the driver (one build, or two with ``--native``)."""
    side = WirexSide()
    if checkout is None:
        side.missing = (
            "WireX: no checkout given (--wirex DIR, a checkout of WireX's "
            "public source); the toolkit's side alone"
        )
        return side
    if compiler is None:
        side.missing = (
            f"WireX: no C++ compiler ({args.cxx or os.environ.get('CXX') or 'g++'}"
            " not found; install g++, e.g. apt-get install g++, or pass "
            "--cxx); the toolkit's side alone"
        )
        return side
    variants: list[tuple[tuple[str, ...], str]] = [(wx.DEFAULT_OPT, "-O2")]
    if args.native:
        variants.append((wx.NATIVE_FLAGS, "-O3"))
    with tempfile.TemporaryDirectory(prefix="bench_peers_") as tmp:
        folder = Path(tmp)
        data = folder / "cases.txt"
        wx.write_cases(cases, data, args.repeats)
        try:
            for opt, label in variants:
                print(f"building the WireX driver ({compiler} {' '.join(opt)}) ...", flush=True)
                build = wx.build_driver(checkout, folder, compiler, opt, label, args.eigen)
                side.builds.append(build)
                side.results[label] = wx.run_driver(build, data)
        except wx.DriverError as err:
            side.missing, side.failed = f"WireX: {err}", True
            side.results.clear()
    return side


def _notes(side: WirexSide, checks: dict[str, float], cases: list[PeerCase]) -> list[str]:
    """What the run says besides the table: the WireX side's state and checks."""
    notes = [side.missing] if side.missing else []
    for build in side.builds:
        if build.skipped:
            notes.append(
                f"WireX {build.label}: sources left out (they did not compile; "
                f"the driver needs none of them): {', '.join(build.skipped)}"
            )
        if build.unresolved:
            names = ", ".join(build.unresolved[:6])
            more = f" and {len(build.unresolved) - 6} more" if len(build.unresolved) > 6 else ""
            notes.append(
                f"WireX {build.label}: linked without {len(build.unresolved)} "
                f"symbols of parts the driver never calls ({names}{more})"
            )
    if side.results:
        result = next(iter(side.results.values()))
        for case in cases:
            if case.name in result.solved:
                ok, n = result.solved[case.name]
                notes.append(
                    f"WireX's improved closed form solves {ok} of {n} poses of "
                    f"{case.name} within the bounds (the toolkit: {case.solved} "
                    "certified optimal)"
                )
        for name, value in checks.items():
            notes.append(f"{name}: {value:.2g}")
    return notes


def _checks(side: WirexSide, cases: list[PeerCase]) -> dict[str, float]:
    """Largest differences between WireX's first-pose answers and the toolkit's."""
    out: dict[str, float] = {}
    if not side.results:
        return out
    result = next(iter(side.results.values()))
    for case in cases:
        A = case.robot.structure_matrices(case.poses[:1])[0]
        got = result.checks.get(("matrix", case.name))
        if got is not None and got.size == A.size:
            out[f"structure matrix of {case.name}, first pose, WireX - toolkit (max abs)"] = float(
                np.abs(got.reshape(A.shape) - A).max()
            )
        closed = result.checks.get(("closed_form", case.name))
        if case.name.endswith("inside") and closed is not None:
            out[f"closed form of {case.name}, first pose, WireX - toolkit (max abs, N)"] = float(
                np.abs(closed[1:] - case.tensions[0]).max()
            )
    return out


def _one_core() -> str:
    """Put the toolkit on one core; says how (numba's threads)."""
    if "numba" not in sys.modules:
        os.environ["NUMBA_NUM_THREADS"] = "1"
    import numba

    numba.set_num_threads(1)
    from tension_opt.kernels.launch import configured_threads

    return f"numba threads 1 of {configured_threads()} configured"


def main(argv: list[str] | None = None) -> int:
    """Run the comparison and print its table; returns the exit code (0, or 1 when a
    given WireX checkout did not build or run)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wirex", metavar="DIR", help="a checkout of WireX's public source")
    parser.add_argument(
        "--native", action="store_true", help="also build WireX with -O3 -march=native"
    )
    parser.add_argument("--cxx", help="C++ compiler (default: $CXX, else g++)")
    parser.add_argument(
        "--eigen",
        metavar="DIR",
        help="folder holding Eigen/Eigen (default: the checkout's copy or /usr/include/eigen3)",
    )
    parser.add_argument("--poses", type=int, default=1000, help="poses per case (1000)")
    parser.add_argument("--repeats", type=int, default=7, help="timed passes (7)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the poses (0)")
    parser.add_argument("--out", metavar="FILE", help="also write the table as Markdown")
    args = parser.parse_args(argv)
    if args.poses < 1 or args.repeats < 1:
        parser.error("--poses and --repeats must be at least 1")
    checkout = None
    if args.wirex is not None:
        try:
            checkout = wx.check_checkout(args.wirex)
        except wx.NotACheckoutError as err:
            parser.error(str(err))
    threads = _one_core()
    from . import peers_toolkit as tk

    compiler = wx.find_compiler(args.cxx)
    cases = tk.peer_cases(args.poses, args.seed)
    side = _run_wirex(args, checkout, [tk.wirex_case(c) for c in cases], compiler)
    toolkit = tk.time_toolkit(cases, args.repeats)
    rows = table_rows(toolkit, side)
    header = (
        f"bench_peers: {args.poses} poses per case, median of {args.repeats} passes; "
        f"python {platform.python_version()}, numpy {np.__version__}, {threads}; "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}"
    )
    if side.builds:
        header += (
            f"; WireX built with {wx.compiler_version(compiler or 'g++')}, "
            f"{' and '.join(' '.join(b.flags) for b in side.builds)}"
        )
    notes = _notes(side, _checks(side, cases), cases)
    text = markdown(rows, notes, header)
    print(text, end="")
    if args.out:
        Path(args.out).write_text(text)
        print(f"wrote {args.out}")
    return 1 if side.failed else 0


if __name__ == "__main__":
    sys.exit(main())
