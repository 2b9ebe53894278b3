"""The contract of ``python -m benchmarks`` under fuzzed argument lists.

Every call of :func:`benchmarks.cli.main` ends with exit code 0 (all arguments good) or
2 (an argparse-style usage error whose message names a bad argument): never a
traceback, never a hang. Argument lists mix valid and invalid commands, scenario,
problem and backend names, settings, time limits (negative, zero, NaN, infinite,
huge), executors, unknown flags, and results directories that are a file or cannot be
made. Valid selections are tiny (the study's snapshots, the closed form, no report), so
that each call takes a fraction of a second.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import sys
import traceback
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from benchmarks.cli import MAX_PROCESSES, MAX_TIME_LIMIT, main
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from benchmarks.study_points import parameter_names

# The kernels compile (minutes on a cold cache and a slow machine) before any call is
# timed: compilation is a one-time cost of the process, not a hang of an argument list.
pytestmark = pytest.mark.usefixtures("compiled_kernels")

#: Longest a single call may take (s) before it counts as a hang.
HANG = 120
COMMANDS = ("run", "report", "list", "study")

# A part of an argument list: its tokens and, if it is bad, words of which the error
# message must name one (the flag, or the bad value itself).
Part = tuple[list[str], frozenset[str]]
GOOD: frozenset[str] = frozenset()


@pytest.fixture(scope="module")
def places(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A results directory, a file, a path under that file and a path that cannot be made."""
    root = tmp_path_factory.mktemp("cli_contract")
    a_file = root / "a_file.txt"
    a_file.write_text("not a directory\n")
    found = {"good": root / "results", "file": a_file, "under_file": a_file / "results",
             "out": root / "study" / "table.csv"}
    if Path("/proc/self").is_dir():  # no directory can be made in /proc, even by root
        found["unmakeable"] = Path("/proc/benchmarks-results/here")
    return found


@pytest.fixture(scope="module", autouse=True)
def no_dask_address() -> Iterator[None]:
    """``--executor dask`` without an address must fail at once, not look for a cluster."""
    saved = os.environ.pop("DASK_SCHEDULER_ADDRESS", None)
    yield
    if saved is not None:
        os.environ["DASK_SCHEDULER_ADDRESS"] = saved


# ------------------------------------------------------------------- strategies
def _bad_word(known: object) -> st.SearchStrategy[str]:
    """A name that is not among ``known`` (letters, digits and '_', so never a flag)."""
    return st.text("abcdefghijklmnopqrstuvwxyz_0123456789", min_size=1, max_size=12).filter(
        lambda w: w not in known and w not in COMMANDS)


def _names(flag: str, valid: list[str], known: object
           ) -> tuple[st.SearchStrategy[Part], st.SearchStrategy[Part]]:
    """Good and bad parts ``flag NAME ...``."""
    good = st.lists(st.sampled_from(valid), min_size=1, max_size=2).map(
        lambda names: ([flag, *names], GOOD))
    wrong = st.tuples(st.lists(st.sampled_from(valid), max_size=1), _bad_word(known)).map(
        lambda p: ([flag, *p[0], p[1]], frozenset({flag, p[1]})))
    missing = st.just(([flag], frozenset({flag})))  # a flag without its values
    return good, st.one_of(wrong, missing)


def _number_text(x: float) -> str:
    return repr(x) if isinstance(x, float) else str(x)


TIME_LIMITS = (
    st.floats(0.5, MAX_TIME_LIMIT).map(lambda x: (["--time-limit", _number_text(x)], GOOD)),
    st.one_of(st.floats(max_value=0.0), st.floats(min_value=MAX_TIME_LIMIT, exclude_min=True),
              st.just(float("nan")), st.sampled_from(["inf", "-inf", "1e999", "abc", "",
                                                      "0x10", "1,5"]))
    .map(lambda x: (["--time-limit", _number_text(x) if not isinstance(x, str) else x],
                    frozenset({"--time-limit"}))),
)
EXECUTORS = (
    st.sampled_from(["inprocess", "processes:1"]).map(lambda e: (["--executor", e], GOOD)),
    st.sampled_from(["processes:0", "processes:-1", "processes:x", "threads", "dask",
                     f"processes:{MAX_PROCESSES + 1}", "processes:99999999", ":"]).map(
        lambda e: (["--executor", e], frozenset({"--executor"}))),
)
SETTINGS = (
    st.lists(st.sampled_from(["default/cold", "high/cold", "default", "high/any"]),
             min_size=1, max_size=2).map(lambda s: (["--settings", *s], GOOD)),
    st.sampled_from(["ultra", "high/lukewarm", "/cold", "default/warm/x", "DEFAULT"]).map(
        lambda s: (["--settings", s], frozenset({"--settings", s}))),
)
UNKNOWN_FLAGS: st.SearchStrategy[Part] = st.sampled_from(
    ["--bogus", "-z", "--scenarios", "--timelimit", "--no-reports", "--results-dir"]).map(
    lambda f: ([f], frozenset({f})))


def _results(kind: str, places: dict[str, Path]) -> Part:
    path = places.get(kind, places["good"])
    return (["--results", str(path)], GOOD if path == places["good"] else
            frozenset({"--results"}))


@st.composite
def run_argv(draw: st.DrawFn, places: dict[str, Path]) -> tuple[list[str], frozenset[str]]:
    """``run`` with every selection given (else the selection would be large); one
    list in three is all good, the others mix good and bad parts."""
    all_good = draw(st.sampled_from([True, False, False]))
    pick = (lambda pair: pair[0]) if all_good else (lambda pair: st.one_of(*pair))
    required = [_names("--scenario", ["thesis_snapshots"], SCENARIOS),
                _names("--problem", ["min_sum", "pinv"], PROBLEMS),
                _names("--backend", ["closed_form"], {"closed_form"}), SETTINGS]
    chosen = [draw(pick(pair)) for pair in required]
    kinds = ["good"] if all_good else sorted(set(places) - {"out"})
    chosen.append(_results(draw(st.sampled_from(kinds)), places))
    for pair in (TIME_LIMITS, EXECUTORS, (UNKNOWN_FLAGS, UNKNOWN_FLAGS)):
        if draw(st.booleans()) and not (all_good and pair[0] is UNKNOWN_FLAGS):
            chosen.append(draw(pick(pair)))
    chosen += [draw(st.sampled_from([(["--redo"], GOOD), (["--full"], GOOD), ([], GOOD)])),
               (["--no-report", "--no-progress"], GOOD)]
    order = draw(st.permutations(range(len(chosen))))
    tokens = ["run"] + [t for i in order for t in chosen[i][0]]
    bad = frozenset().union(*(chosen[i][1] for i in order))
    return tokens, bad


@st.composite
def other_argv(draw: st.DrawFn, places: dict[str, Path]) -> tuple[list[str], frozenset[str]]:
    """``report`` (of a results path that is not a directory: a good one writes a report
    for seconds), ``list``, a small ``study``, or no valid command; one list in three is
    all good."""
    all_good = draw(st.sampled_from([True, False, False]))
    command = draw(st.sampled_from(["list", "study"] if all_good
                                   else ["report", "list", "study", "bad"]))
    if command == "report":
        kind = draw(st.sampled_from(sorted(set(places) - {"good", "out"})))
        tokens, bad = _results(kind, places)
        tokens = [command, *tokens]
    elif command == "list":
        tokens, bad = [command], GOOD
    elif command == "study":
        tokens, bad = draw(_study_argv(places, all_good))
    else:
        word = draw(_bad_word(()))
        tokens, bad = [word], frozenset({word, "command"})
    if not all_good and draw(st.booleans()):
        flag, flag_bad = draw(UNKNOWN_FLAGS)
        tokens, bad = [*tokens, *flag], bad | flag_bad
    return tokens, bad


@st.composite
def _study_argv(draw: st.DrawFn, places: dict[str, Path], all_good: bool
                ) -> tuple[list[str], frozenset[str]]:
    """A one-point, one-pose study of the mass, or one with a bad parameter, value or
    output file."""
    parameter = "mass" if all_good else draw(st.one_of(st.just("mass"),
                                                       _bad_word(parameter_names())))
    value = "300" if all_good else draw(st.sampled_from(["300", "abc", "nan", "-5", "inf"]))
    out = draw(st.sampled_from(["out", "none"] if all_good else ["out", "file_parent"]))
    tokens = ["study", parameter, "--values", value, "--pose", "0", "0", "0",
              "--models", "thesis", "--no-progress"]
    bad: frozenset[str] = frozenset()
    if parameter != "mass":
        bad |= {"PARAMETER", parameter}
    if value != "300":
        bad |= {"--values", "mass"}
    if out == "out":
        tokens += ["--out", str(places["out"])]
    elif out == "file_parent":
        tokens += ["--out", str(places["under_file"] / "table.csv")]
        bad |= {"--out"}
    return tokens, bad


# ------------------------------------------------------------------------ the call
class Hang(Exception):
    """A call ran past :data:`HANG` seconds."""


@contextlib.contextmanager
def _deadline(seconds: float) -> Iterator[None]:
    def alarm(signum: int, frame: object) -> None:
        raise Hang(f"no answer after {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def call(argv: list[str]) -> tuple[int, str, str]:
    """Exit code, standard output and error of ``main(argv)``; a traceback fails."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            with _deadline(HANG):
                code = main(argv)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else 1
        except BaseException:
            pytest.fail(f"main({argv!r}) raised:\n{traceback.format_exc()}")
    return code, out.getvalue(), err.getvalue()


def check(argv: list[str], bad: frozenset[str]) -> None:
    code, out, err = call(argv)
    event(f"exit {code}")
    assert "Traceback" not in err + out, (argv, err)
    if bad:
        assert code == 2, (argv, code, err)
        last = err.strip().splitlines()[-1] if err.strip() else ""
        assert "error:" in last, (argv, err)
        assert any(word in last for word in bad), (argv, sorted(bad), last)
    else:
        assert code == 0, (argv, code, err)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGALRM guards against a hang")
@settings(max_examples=45, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_fuzzed_run_exits_0_or_2_naming_the_bad_argument(places: dict[str, Path],
                                                         data: st.DataObject) -> None:
    argv, bad = data.draw(run_argv(places))
    check(argv, bad)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGALRM guards against a hang")
@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_fuzzed_commands_exit_0_or_2_naming_the_bad_argument(places: dict[str, Path],
                                                             data: st.DataObject) -> None:
    argv, bad = data.draw(other_argv(places))
    check(argv, bad)


@pytest.mark.parametrize(("argv", "word"), [
    (["run", "--time-limit", "-1"], "--time-limit"),
    (["run", "--time-limit", "nan"], "--time-limit"),
    (["run", "--time-limit", "1e308"], "--time-limit"),
    (["run", "--time-limit", "inf"], "--time-limit"),
    (["study", "mass", "--chunk-size", "0"], "--chunk-size"),
    (["study", "mass", "--pose", "nan", "0", "0"], "--pose"),
    (["run", "--executor", f"processes:{MAX_PROCESSES + 1}"], "--executor"),
])
def test_numbers_out_of_range_are_usage_errors(argv: list[str], word: str) -> None:
    """Before the fix: a NaN or huge time limit reached the worker's deadline (a
    traceback); a huge pool forked that many processes."""
    code, _, err = call(argv)
    assert code == 2 and word in err.strip().splitlines()[-1], err


def test_results_that_is_a_file_stores_nothing(places: dict[str, Path]) -> None:
    """Before the fix: a traceback (FileExistsError) from the store."""
    before = places["file"].read_text()
    for command in (["report"], ["run", "--scenario", "thesis_snapshots", "--problem",
                                 "min_sum", "--backend", "closed_form", "--no-report"]):
        code, _, err = call([*command, "--results", str(places["file"])])
        assert code == 2 and "is a file, not a directory" in err, err
    assert places["file"].read_text() == before


def test_a_good_call_still_runs(places: dict[str, Path]) -> None:
    """The contract is not met by refusing everything: a tiny run stores its row."""
    results = places["good"] / "plain"
    code, out, _ = call(["run", "--scenario", "thesis_snapshots", "--problem", "min_sum",
                         "--backend", "closed_form", "--settings", "default/cold",
                         "--no-report", "--no-progress", "--results", str(results)])
    assert code == 0 and "1 cells in the selection" in out
    assert (results / "results.csv").is_file()
