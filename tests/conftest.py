"""Shared fixtures: reference data and the study's robot."""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

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
    took = warmup.warm(jobs=2, progress=False)
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.write_line(f"kernels compiled or loaded in {time.perf_counter() - start:.0f} s "
                            f"({len(took)} families, two processes at a time)")


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
