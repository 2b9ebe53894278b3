"""Shared fixtures: reference data and the study's robot."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import settings

import tension_opt as to
from tension_opt.kernels import launch

DATA = Path(__file__).parent / "data"

# Plain calls take their compiled kernels at any batch size in the tests and in every
# process they start, so that the tests of a kernel against its numpy reference run the
# kernel on small batches too, and fixtures of any scope agree to the bit (by default
# batches under 16 poses take the numpy path; tests/tension_opt/test_first_call.py
# tests that rule with its default).
os.environ["TENSION_OPT_COMPILED_MIN"] = "1"
launch.COMPILED_MIN = 1


#: Hypothesis profiles. "ci" (the default, what ``python -m pytest`` runs) draws each
#: property test's own number of examples. "thorough"
#: (``python -m pytest --hypothesis-profile=thorough``) draws :data:`THOROUGH_FACTOR`
#: times as many, at random where a test fixed its examples (``derandomize``): the same
#: properties, searched deeper. Measured with line coverage, the counts buy what they
#: cost: the contract test of ``distribute`` reaches 124 lines of the package at 2000
#: examples that it misses at 500 (21 s of its 55 s), and a test's first examples,
#: which load its compiled kernels, cost more than the rest (the real-time test: 25
#: examples in 2.5 s after 17 s of loading), so "ci" keeps them.
settings.register_profile("ci", deadline=None, print_blob=True)
settings.register_profile("thorough", deadline=None, print_blob=True)
settings.load_profile("ci")
THOROUGH_FACTOR = 5


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if settings.get_current_profile_name() != "thorough":
        return
    for test in {id(item.obj): item.obj for item in items if hasattr(item, "obj")}.values():
        own = getattr(test, "_hypothesis_internal_use_settings", None)
        if own is not None:
            test._hypothesis_internal_use_settings = settings(
                own, max_examples=THOROUGH_FACTOR * own.max_examples, derandomize=False)


#: A run of at least this many tests compiles every kernel family first, two families at
#: a time in fresh processes (``python -m tension_opt warmup``): on two cores that halves
#: the compile time a fresh machine pays, which the tests would otherwise pay one kernel
#: at a time. With the kernels in numba's disk cache it costs the processes' start-up.
WARM_UP_FROM = 300


def pytest_collection_finish(session: pytest.Session) -> None:
    if len(session.items) < WARM_UP_FROM:
        return
    import time

    from tension_opt import warmup

    start = time.perf_counter()
    # Under pytest-xdist every worker collects the whole run: the first to take the lock
    # compiles, the others then load what it wrote to numba's disk cache.
    with _one_process_at_a_time(session.config):
        took = warmup.warm(jobs=2, progress=False)
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.write_line(f"kernels compiled or loaded in {time.perf_counter() - start:.0f} s "
                            f"({len(took)} families, two processes at a time)")


@contextmanager
def _one_process_at_a_time(config: pytest.Config) -> Iterator[None]:
    """Hold a lock shared by the workers of one pytest-xdist run (none without xdist)."""
    worker = getattr(config, "workerinput", None)
    try:
        import fcntl
    except ImportError:  # not on POSIX: the workers compile side by side
        fcntl = None  # type: ignore[assignment]
    if worker is None or fcntl is None:
        yield
        return
    path = Path(tempfile.gettempdir()) / f"tension_opt_warmup_{worker['testrunuid']}.lock"
    with path.open("w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def snapshots() -> list[dict]:
    return json.loads((DATA / "thesis_snapshots.json").read_text())["snapshots"]


@pytest.fixture(scope="session")
def thesis() -> to.CableRobot:
    return to.presets.algae_harvester()



@pytest.fixture(scope="session")
def compiled_kernels() -> None:
    """The compiled kernels of the plain calls, loaded (or, with an empty cache,
    compiled) once before tests that time each call: a compilation cut short by their
    watchdog would leave numba's cache half written."""
    from benchmarks.isolation import load_compiled_kernels

    load_compiled_kernels()


#: Prepended to a script by :func:`fresh_process`: numba's compilations, by function name.
_COUNT_COMPILATIONS = """
from numba.core import event

compiled = []


class _Count(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__qualname__)

    def on_end(self, ev):
        pass


event.register("numba:compile", _Count())
"""


@pytest.fixture
def fresh_process() -> Callable[[str], str]:
    """Run a script in a fresh process with an empty kernel cache and the default size
    rule (``TENSION_OPT_COMPILED_MIN`` unset); ``compiled`` (the functions numba
    compiles) is defined for it. Returns its standard output; a failure fails the test."""

    def run(script: str) -> str:
        env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp())
        env.pop("TENSION_OPT_COMPILED_MIN", None)  # the default rule
        done = subprocess.run([sys.executable, "-c", _COUNT_COMPILATIONS + script],
                              capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
        return done.stdout

    return run


@pytest.fixture
def in_threads() -> Callable[[Callable[[int], None], int], None]:
    """Run ``work(k)`` for ``k`` in ``range(count)`` on ``count`` threads at once and
    wait for them all: ``in_threads(work, count)``."""

    def run(work: Callable[[int], None], count: int) -> None:
        threads = [threading.Thread(target=work, args=(k,)) for k in range(count)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()

    return run
