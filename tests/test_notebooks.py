"""Every notebook runs top to bottom in a fresh kernel, and is committed without outputs."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import pytest

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
EXPECTED = {
    "01_reproduce_study.ipynb",
    "02_solver_comparison.ipynb",
    "03_trajectory_smoothing.ipynb",
    "04_sag_models.ipynb",
    "05_workspace.ipynb",
    "06_dynamics.ipynb",
    "07_explorer.ipynb",
    "08_design.ipynb",
}
# A guard against a hung cell, not a benchmark: each notebook takes well under this.
CELL_TIMEOUT_S = 120


def test_notebooks_exist() -> None:
    assert {p.name for p in NOTEBOOKS} == EXPECTED


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_committed_without_outputs(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, "notebook has no code cells"
    assert all(not c.outputs and c.execution_count is None for c in code), (
        f"{path.name} has stored outputs; clear them before committing"
    )


@functools.cache
def executed(path: Path) -> Any:
    """The notebook executed top to bottom in a fresh kernel (once per test session)."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(NOTEBOOK_DIR)}},
    )
    client.execute()  # raises CellExecutionError with the cell and traceback on failure
    return nb


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path: Path) -> None:
    nb = executed(path)
    errors = [
        out.get("ename")
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors


def test_07_explorer_draws_the_opening_view_without_a_widget_frontend() -> None:
    """Executed without a frontend, the explorer builds its sliders, and its last cell
    draws one figure (the robot and the tension bars) and prints the study's tensions,
    lengths and sag at the pond centre."""
    pytest.importorskip("ipywidgets", reason='the explorer needs ipywidgets (".[notebooks]")')
    nb = executed(NOTEBOOK_DIR / "07_explorer.ipynb")
    state = nb.metadata["widgets"]["application/vnd.jupyter.widget-state+json"]["state"]
    models = [w["model_name"] for w in state.values()]
    # x, y, z; objective, sag model, t_max; the output the views are drawn into.
    assert models.count("FloatSliderModel") == 3, models
    assert models.count("SelectionSliderModel") == 3, models
    assert models.count("OutputModel") == 1, models

    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    assert last.source.strip() == "show(**DEFAULTS)"
    images = [o for o in last.outputs if "image/png" in o.get("data", {})]
    assert len(images) == 1, [o.get("output_type") for o in last.outputs]
    text = "".join(o.get("text", "") for o in last.outputs if o.get("output_type") == "stream")
    assert "thesis / min_sum at (0, 0, 0) m, t_max inf N: converged" in text, text
    rows = [line.split() for line in text.splitlines() if line.split()[:1] in CABLES]
    assert len(rows) == 4, text
    for row in rows:  # the study's Table 4, snapshot 1: 4714.6 N, L 56.70 m, D 207.4 mm
        assert abs(float(row[1]) - 4714.6) < 0.15, text
        assert abs(float(row[3]) - 56.70) < 0.01 and abs(float(row[4]) - 207.4) < 0.2, text
        assert row[-1] == "taut", text


CABLES = [["1"], ["2"], ["3"], ["4"]]
