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
