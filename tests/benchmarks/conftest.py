"""Fixtures of the benchmark tests: the cells of the executor tests and their in-process run."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pandas as pd
import pytest

import tension_opt
from benchmarks import harness
from benchmarks.scenarios import PROBLEMS, SCENARIOS

QP = "qpsolvers:daqp" if "qpsolvers:daqp" in tension_opt.available_backends() else "scipy:highs"
#: Snapshots, the study's 25-pose path (with a sequential problem) and the seeded random set
#: (its poses are rebuilt by each worker); default/cold.
_CELLS = [
    *harness.plan([SCENARIOS["thesis_snapshots"], SCENARIOS["thesis_trajectory"]],
                  [PROBLEMS[p] for p in ("min_sum", "min_norm", "pinv", "smoothed")],
                  ["closed_form", QP], [harness.Setting()]),
    *harness.plan([SCENARIOS["thesis_random"]], [PROBLEMS["min_sum"]], ["closed_form", QP],
                  [harness.Setting()]),
]


@pytest.fixture(scope="session")
def cells() -> list[harness.Cell]:
    """Snapshots, the study's path (with a sequential problem) and the seeded random set."""
    return list(_CELLS)


@pytest.fixture(scope="module")
def inprocess(tmp_path_factory: pytest.TempPathFactory, cells: list[harness.Cell],
              ) -> tuple[harness.ResultsStore, pd.DataFrame]:
    """Store and returned table of today's default run: cells in a forked, killable worker."""
    store = harness.ResultsStore(tmp_path_factory.mktemp("inprocess"))
    frame = harness.run(cells, store, progress=False)
    assert len(frame) == len(cells) == 16
    assert (frame["status"] == "ok").all(), frame[["backend", "problem", "message"]]
    return store, frame


@pytest.fixture(scope="module")
def reference(inprocess: tuple[harness.ResultsStore, pd.DataFrame]) -> harness.ResultsStore:
    """The store of the in-process run."""
    return inprocess[0]


@pytest.fixture(scope="module")
def expected(inprocess: tuple[harness.ResultsStore, pd.DataFrame]) -> pd.DataFrame:
    """The table the in-process run returned (full precision, before the CSV's rounding)."""
    return inprocess[1]


@pytest.fixture(scope="module")
def dask_client() -> Iterator[Any]:
    """A two-worker Dask cluster on loopback."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client
