"""Shared fixtures: reference data and the study's robot."""

from __future__ import annotations

import json
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
