"""The committed notebooks are valid and were saved without error outputs (not executed here)."""

from __future__ import annotations

from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parent.parent / "notebooks").glob("*.ipynb"))


def test_notebooks_exist() -> None:
    names = {p.name for p in NOTEBOOKS}
    assert {"01_reference_study.ipynb", "02_tradeoffs.ipynb"} <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_valid_without_errors(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code_cells = [c for c in nb.cells if c.cell_type == "code"]
    assert code_cells, "notebook has no code cells"
    errors = [
        (i, out.get("ename"), out.get("evalue"))
        for i, cell in enumerate(code_cells)
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors, f"error outputs in {path.name}: {errors}"
    assert all(c.get("execution_count") is not None for c in code_cells), "not fully executed"
