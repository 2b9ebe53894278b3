"""Shared fixtures: reference data and random feasible poses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import tension_opt as to

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def snapshots() -> list[dict]:
    return json.loads((DATA / "thesis_snapshots.json").read_text())["snapshots"]


@pytest.fixture(scope="session")
def thesis() -> to.CableRobot:
    return to.presets.algae_harvester()


def random_thesis_poses(N: int, seed: int = 0) -> np.ndarray:
    """Poses over the pond (80.9 x 50 m) at heights 0..5 m; about 77 % are wrench-feasible."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-40.45, 40.45, N), rng.uniform(-25, 25, N),
                            rng.uniform(0, 5, N)])


def random_cogiro_poses(N: int, seed: int = 0) -> np.ndarray:
    """CoGiRo poses near home (0, 0, 2 m), kept where closed_form finds feasible tensions."""
    robot = to.presets.cogiro()
    rng = np.random.default_rng(seed)
    M = 4 * N
    poses = np.column_stack([rng.uniform(-3, 3, M), rng.uniform(-2, 2, M),
                             rng.uniform(0.8, 3.0, M), rng.uniform(-0.1, 0.1, (M, 3))])
    ok = to.distribute(robot, poses, "min_sum", "closed_form").success
    assert ok.sum() >= N
    return poses[ok][:N]
