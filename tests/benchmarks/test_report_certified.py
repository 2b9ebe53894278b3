"""The harness judges by certificates, measures the machine it runs on, and tells solvers apart.

- A fresh clone's plain run measures every cell, whatever machine label the committed
  rows carry; they stay as a labelled reference. Only an interrupted run of the same
  invocation is resumed.
- Rows carry the certificate's measures; the qpbenchmark-style summary counts a cell
  that certifies fewer poses than the best backend as a failure.
- Each solver has its colour and each backend family its line style.
- The random robots are seeded, and their boundary poses sit at the workspace's edge.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import tension_opt as to
from benchmarks import certify_study, harness, report, runner
from benchmarks.random_robots import (
    EDGE_MARGIN,
    boundary_poses,
    random_robot,
    random_robot_poses,
    random_robot_set,
)
from benchmarks.report_tables import backend_style, certified_summary
from benchmarks.scenarios import PROBLEMS, SCENARIOS
from tension_opt.workspace.sampling import feasible_mask

COMMITTED = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "results.csv"
QP = "qpsolvers:daqp" if "qpsolvers:daqp" in to.available_backends() else "scipy:highs"


def _cells(problems: tuple[str, ...] = ("min_sum", "min_norm")) -> list[harness.Cell]:
    return harness.plan([SCENARIOS["thesis_snapshots"]], [PROBLEMS[p] for p in problems],
                        ["closed_form", QP], [harness.Setting()])


def _counting(monkeypatch: pytest.MonkeyPatch, stop_after: int | None = None
              ) -> list[tuple[str, ...]]:
    calls: list[tuple[str, ...]] = []
    real = runner.run_cell  # the real one, whatever an earlier patch put in the harness

    def run_cell(cell, references, time_limit=harness.TIME_LIMIT):  # type: ignore[no-untyped-def]
        if stop_after is not None and len(calls) == stop_after:
            raise KeyboardInterrupt
        calls.append(cell.key)
        return real(cell, references, time_limit)

    monkeypatch.setattr(harness, "run_cell", run_cell)
    return calls


def test_a_fresh_clone_measures_and_keeps_the_committed_rows_as_a_reference(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(COMMITTED, tmp_path / "results.csv")
    committed = pd.read_csv(COMMITTED)
    cells = _cells()
    keys = {c.key for c in cells}
    assert keys <= {tuple(map(str, r)) for r in committed[list(harness.KEY)].itertuples(
        index=False)}, "the committed results hold these cells"
    store = harness.ResultsStore(tmp_path)
    assert store.done() == set()  # rows that came with the clone are not this machine's
    calls = _counting(monkeypatch)
    frame = harness.run(cells, store, progress=False, isolate=False)
    assert set(calls) == keys  # every cell measured here, none taken from the clone
    runs = store.runs()
    assert len(runs) == 1 and runs["finished"].notna().all()
    mine = frame[frame["run"] == runs["id"].iloc[0]]
    assert {tuple(r) for r in mine[list(harness.KEY)].itertuples(index=False)} == keys
    assert mine["measured_at"].str.endswith("Z").all()
    assert len(store.reference()) == len(committed)  # the reference is kept whole
    text = report.write_report(tmp_path).read_text()
    assert f"run {runs['id'].iloc[0]} (this results database)" in text
    # The committed rows keep the run that measured them, where they name one.
    theirs = committed["run"].dropna().unique() if "run" in committed else []
    labels = [f"reference run {run}" for run in theirs] or ["reference (imported)"]
    assert all(label in text for label in labels), labels
    assert "This machine against the reference" in text


def test_only_an_interrupted_run_of_the_same_invocation_resumes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    store = harness.ResultsStore(tmp_path)
    first, other = _cells(), _cells(("pinv",))
    _counting(monkeypatch, stop_after=1)
    with pytest.raises(KeyboardInterrupt):
        harness.run(first, store, progress=False, isolate=False)
    calls = _counting(monkeypatch)
    harness.run(other, store, progress=False, isolate=False)  # another invocation
    assert set(calls) == {c.key for c in other}
    calls.clear()
    harness.run(first, store, progress=False, isolate=False)  # resumes the interrupted one
    assert len(calls) == len(first) - 1
    calls.clear()
    harness.run(first, store, progress=False, isolate=False)  # finished: measured afresh
    assert len(calls) == len(first)
    runs = store.runs()
    assert len(runs) == 3 and runs["finished"].notna().all()


def test_rows_carry_the_certificate_and_the_summary_judges_by_it(tmp_path: Path) -> None:
    cells = harness.plan([SCENARIOS["thesis_random"]], [PROBLEMS["min_sum"]],
                         ["closed_form", "qpsolvers:osqp"], [harness.Setting()])
    frame = harness.run(cells, harness.ResultsStore(tmp_path), progress=False, isolate=False)
    for row in frame.to_dict("records"):
        assert row["success_rate"] == 1.0 and row["wrong_optimal"] == 0
        assert row["accuracy_target"] == 1e-7
        for name in ("primal_residual", "dual_residual", "duality_gap"):
            assert 0.0 <= row[f"{name}_max"] <= 1e-7
        assert row["objective_excess_max"] <= 1e-7
        # every pose certified: the cost of a certified answer is the mean time per pose,
        # all of it spent inside the cell's wall time
        n_poses = SCENARIOS["thesis_random"].N
        assert 0 < row["certified_us"] * n_poses <= 1e6 * row["wall_time_s"] * (1 + 1e-9)
    table = certified_summary(frame)
    assert set(table.index.get_level_values("backend")) == {"closed_form", "qpsolvers:osqp"}
    assert (table["success"] == 1.0).all() and (table["wrong optimal"] == 0).all()


def test_a_cell_that_certifies_fewer_poses_counts_as_a_failure_in_the_time_ratio() -> None:
    base = {"scenario": "s", "problem": "p", "setting": "default/cold", "status": "ok",
            "iterations_mean": 1.0, "residual_max": 0.0, "objective_excess_max": 0.0,
            "primal_residual_sgm": 1e-9, "dual_residual_sgm": 1e-9, "duality_gap_sgm": 1e-9}
    frame = pd.DataFrame([
        {**base, "backend": "slow", "success_rate": 1.0, "time_us_median": 100.0,
         "certified_us": 100.0, "wrong_optimal": 0},
        {**base, "backend": "fast", "success_rate": 0.5, "time_us_median": 1.0,
         "certified_us": 2.0, "wrong_optimal": 3},
    ])
    table = certified_summary(frame).reset_index(level="setting", drop=True)
    assert table.loc["slow", "time ratio (sgm)"] == 1.0
    # The fast backend's cell is a failure, counted at the slowest time: no faster.
    assert table.loc["fast", "time ratio (sgm)"] == pytest.approx(1.0)
    assert table.loc["fast", "wrong optimal"] == 3 and table.loc["fast", "success"] == 0.5
    assert table.loc["slow", "primal res."] == pytest.approx(1e-9, rel=1e-3)


def test_each_solver_has_its_colour_and_each_family_its_line_style() -> None:
    backends = to.available_backends()
    styles = {b: backend_style(b) for b in backends}
    drawn = {(s["color"], s["linestyle"], s.get("marker")) for s in styles.values()}
    assert len(drawn) == len(backends)  # no two backends look alike
    by_solver: dict[str, set[str]] = {}
    for backend, style in styles.items():
        by_solver.setdefault(backend.split(":")[-1].lower(), set()).add(style["color"])
    assert all(len(colours) == 1 for colours in by_solver.values())
    assert backend_style("cvxpy:CLARABEL")["linestyle"] != backend_style(
        "qpsolvers:highs")["linestyle"]
    assert backend_style("cvxpy:CLARABEL")["color"] != backend_style("cvxpy:HIGHS")["color"]


def test_random_robots_are_seeded_and_their_boundary_poses_sit_at_the_edge() -> None:
    one, two = random_robot_set(4, 3, seed=5), random_robot_set(4, 3, seed=5)
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a.robot.anchors, b.robot.anchors)
        np.testing.assert_array_equal(a.poses, b.poses)
    assert {r.robot.m for r in one} == {4, 5, 6, 7}
    robot = random_robot(11, 4)
    margin = EDGE_MARGIN * robot.weight
    inside = random_robot_poses(robot, 1, 11, boundary=0.0)
    outside = np.array([[0.0, 0.0, 1.5 * robot.anchors[:, 2].max()]])  # above the anchors
    assert feasible_mask(robot, inside, margin=margin)[0]
    assert not feasible_mask(robot, outside, margin=margin)[0]
    edge = boundary_poses(robot, inside, outside, steps=30)
    step = (outside - inside) * 2.0**-29
    assert feasible_mask(robot, edge, margin=margin)[0]
    assert not feasible_mask(robot, edge + step, margin=margin)[0]


def test_the_certify_study_finds_no_wrong_optimal_on_a_small_set() -> None:
    study = to.presets.algae_harvester()
    poses = SCENARIOS["thesis_random"].poses[:40]
    test_set = certify_study.TestSet("study", [(study, poses)])
    for backend in ("qpsolvers:osqp", "qpsolvers:scs"):
        row = certify_study.compare(test_set, "min_sum", backend)
        assert row is not None
        assert row["wrong_optimal"] == 0 and row["share_optimal"] >= 0.95
        assert row["worst_excess"] <= 1e-7


def test_a_database_of_the_earlier_schema_is_migrated(tmp_path: Path) -> None:
    import json
    import sqlite3

    key = ("s", "p", "b", "default/cold")
    row = {"machine": "m", "scenario": key[0], "problem": key[1], "backend": key[2],
           "setting": key[3], "status": "ok"}
    with sqlite3.connect(tmp_path / "results.sqlite") as conn:
        conn.execute("CREATE TABLE results (scenario TEXT NOT NULL, problem TEXT NOT NULL, "
                     "backend TEXT NOT NULL, setting TEXT NOT NULL, machine TEXT NOT NULL, "
                     "row TEXT NOT NULL, trace BLOB, UNIQUE (scenario, problem, backend, "
                     "setting))")
        conn.execute("CREATE TABLE meta (name TEXT PRIMARY KEY, value TEXT)")
        conn.execute("INSERT INTO results VALUES (?, ?, ?, ?, ?, ?, NULL)",
                     (*key, "m", json.dumps(row)))
        conn.execute("PRAGMA user_version = 1")
    store = harness.ResultsStore(tmp_path)
    assert len(store.load()) == 1
    assert store.done({"m"}) == set()  # measured before runs were recorded: not resumed
    assert store.start_run("x", 1)[1] is False and len(store.runs()) == 1
