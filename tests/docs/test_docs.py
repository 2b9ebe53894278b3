"""The documentation's code runs, prints what it says, and the site builds.

(a) Every ```python block of README.md and docs/**/*.md runs: the blocks of a page in
    order, in one namespace, in a fresh Python process per page (working directory: a
    temporary folder holding a link to the repository's ``tests/``, so that examples can
    read ``tests/data`` as from the repository root and write files without touching
    it). A ```text block right after a python block is the output the block prints,
    checked: the text between numbers must match (runs of white space are one space),
    and each number must match to a relative 1e-6 (absolute 1e-12 near zero), so that
    the last bits of a float do not fail the page. A block after the HTML comment
    ``<!-- skip -->`` (on the lines just before its fence) is not run.
(b) ``mkdocs build --strict`` builds the site into a temporary folder: a warning, a
    broken internal link or a page missing from the navigation fails it. Skipped,
    with its reason, only where mkdocs is not installed (``pip install -e ".[docs]"``).
"""

from __future__ import annotations

import ast
import json
import math
import os
import re
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
PAGES = [p for p in PAGES if "notebooks" not in p.relative_to(ROOT).parts[1:2]]
#: Seconds one page's examples may take (first calls may compile kernels).
PAGE_TIMEOUT = 300
REL_TOL, ABS_TOL = 1e-6, 1e-12

_FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)
_SKIP = re.compile(r"<!--\s*skip\b[^>]*-->\s*$")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?\b(?:nan|inf)\b")


@dataclass
class Block:
    line: int
    code: str
    expected: str | None


def blocks(text: str) -> list[Block]:
    """The page's python blocks to run, each with the text block that follows it."""
    fences = list(_FENCE.finditer(text))
    found = []
    for i, fence in enumerate(fences):
        if fence.group(1) != "python":
            continue
        before = text[: fence.start()].rstrip("\n").splitlines()
        if before and _SKIP.search(before[-1]):
            continue
        expected = None
        if i + 1 < len(fences) and fences[i + 1].group(1) == "text":
            between = text[fence.end() : fences[i + 1].start()]
            if not between.strip():
                expected = fences[i + 1].group(2)
        found.append(Block(text.count("\n", 0, fence.start()) + 2, fence.group(2), expected))
    return found


def _tokens(output: str) -> list[str | float]:
    parts: list[str | float] = []
    position = 0
    for match in _NUMBER.finditer(output):
        parts.append(" ".join(output[position : match.start()].split()))
        parts.append(float(match.group(0)))
        position = match.end()
    parts.append(" ".join(output[position:].split()))
    return parts


def same_output(printed: str, expected: str) -> bool:
    """Whether ``printed`` matches ``expected``: text exactly up to white space,
    numbers to :data:`REL_TOL` (:data:`ABS_TOL` near zero)."""
    got, want = _tokens(printed), _tokens(expected)
    if len(got) != len(want):
        return False
    for a, b in zip(got, want, strict=True):
        if isinstance(a, float) and isinstance(b, float):
            if not (
                a == b
                or (math.isnan(a) and math.isnan(b))
                or math.isclose(a, b, rel_tol=REL_TOL, abs_tol=ABS_TOL)
            ):
                return False
        elif a != b:
            return False
    return True


#: Runs a page's blocks in one namespace; prints one JSON list of their outputs.
RUNNER = textwrap.dedent("""
    import contextlib, io, json, sys, traceback
    page, blocks = json.load(sys.stdin)
    namespace = {"__name__": "__main__"}
    outputs = []
    for line, code in blocks:
        buffer = io.StringIO()
        try:
            with contextlib.redirect_stdout(buffer):
                exec(compile(code, f"{page}:{line}", "exec"), namespace)
        except BaseException:
            outputs.append({"out": buffer.getvalue(), "error": traceback.format_exc()})
            break
        outputs.append({"out": buffer.getvalue(), "error": None})
    sys.__stdout__.write(json.dumps(outputs))
""")


def run_page(page: Path, tmp_path: Path) -> tuple[list[Block], list[dict]]:
    """The page's blocks and what each printed (or the error that stopped the page)."""
    found = blocks(page.read_text())
    (tmp_path / "tests").symlink_to(ROOT / "tests")
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    name = str(page.relative_to(ROOT))
    done = subprocess.run(
        [sys.executable, "-c", RUNNER],
        cwd=tmp_path,
        env=env,
        input=json.dumps([name, [(b.line, b.code) for b in found]]),
        capture_output=True,
        text=True,
        timeout=PAGE_TIMEOUT,
        check=False,
    )
    assert done.returncode == 0, f"{name}: the runner failed\n{done.stderr[-3000:]}"
    return found, json.loads(done.stdout)


def _has_python(page: Path) -> bool:
    return bool(blocks(page.read_text()))


@pytest.mark.parametrize(
    "page", [p for p in PAGES if _has_python(p)], ids=lambda p: str(p.relative_to(ROOT))
)
def test_examples_run_and_print_what_the_page_says(page: Path, tmp_path: Path) -> None:
    found, outputs = run_page(page, tmp_path)
    name = page.relative_to(ROOT)
    for block, result in zip(found, outputs, strict=False):
        where = f"{name}:{block.line}"
        assert result["error"] is None, f"{where} raised:\n{result['error']}"
        if block.expected is not None:
            assert same_output(result["out"], block.expected), (
                f"{where} printed\n{result['out']}\ninstead of\n{block.expected}"
            )
    assert len(outputs) == len(found)


def test_the_pages_hold_examples() -> None:
    """The count of examples run (the test above runs each page's)."""
    counts = {str(p.relative_to(ROOT)): len(blocks(p.read_text())) for p in PAGES}
    checked = sum(b.expected is not None for p in PAGES for b in blocks(p.read_text()))
    assert counts["README.md"] >= 1 and counts["docs/getting-started.md"] >= 3
    assert sum(counts.values()) >= 25 and checked >= 15, (counts, checked)


def test_the_output_check_is_what_the_module_says() -> None:
    assert same_output("[ 4714.6  4714.6]\n", "[4714.6 4714.6]")
    assert same_output("0.30000000000000004 s", "0.3 s")
    assert same_output("gap 3e-17", "gap 0.0") and same_output("nan", "nan")
    assert not same_output("4714.7", "4714.6") and not same_output("optimal", "inaccurate")
    assert not same_output("1 2", "1 2 3")
    page = "x\n<!-- skip -->\n```python\nboom()\n```\n\n```python\nprint(1)\n```\n```text\n1\n```\n"
    assert [(b.code, b.expected) for b in blocks(page)] == [("print(1)\n", "1\n")]


def _public(package: str) -> list[str]:
    tree = ast.parse((ROOT / package / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            return list(ast.literal_eval(node.value))
    return []


def test_the_api_pages_name_every_public_name() -> None:
    """Each name of ``__all__`` has its own ``:::`` entry (the site's hook would add a
    missing one under "Other names"; this says which to place)."""
    for package in ("tension_opt", "catenary"):
        text = (ROOT / "docs" / "api" / f"{package}.md").read_text()
        entries = set(re.findall(rf"^::: {package}\.(\w+)", text, re.M))
        assert not set(_public(package)) - entries, package
    text = (ROOT / "docs" / "api" / "benchmarks.md").read_text()
    modules = {p.stem for p in (ROOT / "benchmarks").glob("*.py")} - {"__init__", "__main__"}
    assert not {m for m in modules if not m.startswith("_")} - set(
        re.findall(r"^::: benchmarks\.(\w+)", text, re.M)
    )


def test_the_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    try:
        import mkdocs  # noqa: F401
        import mkdocs_jupyter  # noqa: F401
        import mkdocstrings  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"mkdocs is not installed ({exc.name}): pip install -e '.[docs]'")
    # The notebooks' own test executes them; here the pages are built from their source.
    env = {
        **os.environ,
        "NO_MKDOCS_2_WARNING": "1",
        "PYTHONPATH": str(ROOT),
        "TENSION_OPT_DOCS_EXECUTE": "false",
    }
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-5000:]
    assert (tmp_path / "site" / "index.html").is_file()
    assert (tmp_path / "site" / "benchmarks" / "report" / "index.html").is_file()


def test_the_published_site_shows_the_notebooks_outputs() -> None:
    """``mkdocs build`` executes the notebooks unless told otherwise, so their pages show
    their tables and plots (they are committed without outputs)."""
    config = (ROOT / "mkdocs.yml").read_text()
    assert "execute: !ENV [TENSION_OPT_DOCS_EXECUTE, true]" in config
    assert "allow_errors: false" in config
