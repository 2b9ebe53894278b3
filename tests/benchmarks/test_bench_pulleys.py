"""The pulley benchmark runs and its tables hold what they say."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import bench_pulleys


def test_quick_run_prints_both_tables(capsys: pytest.CaptureFixture[str]) -> None:
    bench_pulleys.main(["--quick"])
    out = capsys.readouterr().out
    assert "CoGiRo straight inverse kinematics" in out and "ratio" in out
    assert "0.3 m pulley at each tower" in out


def test_study_table_adds_the_wrapped_arc_less_the_span_saved() -> None:
    rows = {r[0]: r for r in bench_pulleys.study_table(4)}
    _, n, mean, low, high, *_ = rows["straight"]
    # a 0.3 m wheel: less than half a turn of arc, more than nothing
    assert n == 24 and 0.0 < low <= mean <= high < 0.3 * np.pi
    assert rows["coupled"][1] == n  # the coupled model answers every pose
