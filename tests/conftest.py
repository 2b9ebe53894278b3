"""Shared fixtures: reference data and the study's robot."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

import tension_opt as to

DATA = Path(__file__).parent / "data"


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
