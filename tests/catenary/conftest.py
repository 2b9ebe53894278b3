"""Fixtures of the catenary tests: the swept cable cases and a sag workspace."""

from __future__ import annotations

import numpy as np
import pytest

import catenary as cat
import tension_opt as to
from benchmarks.cable_cases import sweep
from catenary import workspace as cws
from tension_opt import workspace as ws


@pytest.fixture(scope="module")
def swept() -> tuple[dict[str, np.ndarray], cat.ForcesResult]:
    s = sweep()
    return s, cat.solve_forces(**s)


@pytest.fixture(scope="module")
def poses() -> np.ndarray:
    """240 seeded poses under the study robot's towers."""
    return ws.sample_poses([-46.5, -31.0, 0.0], [46.5, 31.0, 7.5], 240, seed=5)


@pytest.fixture(scope="module")
def steel(poses: np.ndarray) -> cws.SagWorkspaceResult:
    """The coupled-sag workspace of the steel-cabled study robot at t_max = 15 kN."""
    return cws.sag_workspace(to.presets.algae_harvester(t_max=15_000.0), poses,
                             chunk_size=120)
