"""Executors: names, chunking, order of results, errors."""

from __future__ import annotations

import math

import pytest

from tension_opt.distribution.chunks import chunk_slices
from tension_opt.errors import InvalidInputError
from tension_opt.workspace.executors import (
    DASK_ADDRESS_VARIABLE,
    InProcessExecutor,
    ProcessPoolExecutor,
    get_executor,
    run_chunks,
)


def _roots(part: slice) -> list[float]:
    return [math.sqrt(i) for i in range(part.start, part.stop)]


def _fail_on_third(part: slice) -> int:
    if part.start == 20:
        raise RuntimeError("chunk 3 failed")
    return part.start


def test_chunk_slices_cover_the_range_in_order() -> None:
    parts = chunk_slices(103, 10)
    assert len(parts) == 11
    assert [i for p in parts for i in range(p.start, p.stop)] == list(range(103))
    assert chunk_slices(0, 5) == []
    with pytest.raises(InvalidInputError, match="chunk_size"):
        chunk_slices(10, 0)


@pytest.mark.parametrize("spec", [None, "inprocess", "processes:2"])
def test_results_come_back_in_chunk_order(spec: str | None) -> None:
    parts = chunk_slices(257, 16)
    results = run_chunks(_roots, parts, spec)
    assert [x for r in results for x in r] == [math.sqrt(i) for i in range(257)]
    assert run_chunks(_roots, [], spec) == []


def test_a_failing_chunk_raises_in_the_caller() -> None:
    with pytest.raises(RuntimeError, match="chunk 3 failed"):
        run_chunks(_fail_on_third, chunk_slices(50, 10), "processes:2")


@pytest.mark.parametrize("spec", ["inprocess", "processes:2"])
def test_results_go_on_after_a_failing_chunk(spec: str) -> None:
    # A caller can record a failed chunk and carry on, without sending the rest again.
    with get_executor(spec) as runner:
        results = runner.map(_fail_on_third, chunk_slices(50, 10))
        outcomes = []
        for _ in range(5):
            try:
                outcomes.append(next(results))
            except RuntimeError as exc:
                outcomes.append(str(exc))
        with pytest.raises(StopIteration):
            next(results)
    assert outcomes == [0, 10, "chunk 3 failed", 30, 40]


def test_executor_names() -> None:
    assert isinstance(get_executor(None), InProcessExecutor)
    assert isinstance(get_executor("serial"), InProcessExecutor)
    with get_executor("processes:3") as pool:
        assert isinstance(pool, ProcessPoolExecutor) and pool.workers == 3
    given = InProcessExecutor()
    assert get_executor(given) is given
    for bad in ("threads", "processes:two", "processes:0", "inprocess:2", 2, object()):
        with pytest.raises(InvalidInputError):
            get_executor(bad)


def test_dask_without_an_address_says_how_to_give_one(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("dask.distributed")
    monkeypatch.delenv(DASK_ADDRESS_VARIABLE, raising=False)
    with pytest.raises(InvalidInputError, match=DASK_ADDRESS_VARIABLE):
        get_executor("dask")
