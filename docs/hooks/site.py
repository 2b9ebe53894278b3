"""MkDocs hooks of the documentation site (``hooks:`` in ``mkdocs.yml``).

- The benchmark report (``benchmarks/results/README.md`` and its plots) is published as
  the page ``benchmarks/report.md``, read where ``python -m benchmarks`` writes it.
- The API pages cover every name of ``tension_opt.__all__`` and ``catenary.__all__``:
  a name the page does not document yet is appended under "Other names", so a name
  added to a package is never missing from the reference.
- The robot views (``views.md`` and the pictures in ``images/``) are written
  separately: while one of them is missing, its navigation entry is left out and a link
  or picture pointing at it is shown as its text, so the build does not depend on them.
"""

from __future__ import annotations

import ast
import logging
import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

log = logging.getLogger("mkdocs.hooks.site")

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
REPORT_DIR = ROOT / "benchmarks" / "results"
REPORT_PAGE = "benchmarks/report.md"

#: Pages and pictures of the robot views, written apart from the rest of the site.
OPTIONAL = (
    "views.md",
    "images/study_pond_sag.png",
    "images/cogiro_rotated.png",
    "images/pick_and_place_frame.png",
)

#: API page -> the package whose ``__all__`` it must cover.
API_PAGES = {"api/tension_opt.md": "tension_opt", "api/catenary.md": "catenary"}


def _missing_optional() -> set[str]:
    return {name for name in OPTIONAL if not (DOCS / name).is_file()}


def _public_names(package: str) -> list[str]:
    """``__all__`` of a package's ``__init__.py``, read without importing it."""
    tree = ast.parse((ROOT / package / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            return [str(v) for v in ast.literal_eval(node.value)]
    return []


def _prune(nav: Any, missing: set[str]) -> Any:
    """The navigation without entries pointing at missing optional pages."""
    if isinstance(nav, list):
        kept = [_prune(item, missing) for item in nav]
        return [item for item in kept if item is not None]
    if isinstance(nav, dict):
        out = {key: _prune(value, missing) for key, value in nav.items()}
        return out if all(value is not None for value in out.values()) else None
    if isinstance(nav, str) and nav in missing:
        log.info("%s is not written yet: left out of the navigation", nav)
        return None
    return nav


def on_config(config: Any) -> Any:
    missing = _missing_optional()
    if missing and config.nav is not None:
        config.nav = _prune(config.nav, missing)
    return config


def on_files(files: Files, config: Any) -> Files:
    report = REPORT_DIR / "README.md"
    if report.is_file():
        files.append(File.generated(config, REPORT_PAGE, abs_src_path=str(report)))
        for picture in sorted(REPORT_DIR.glob("*.png")):
            files.append(
                File.generated(config, f"benchmarks/{picture.name}", abs_src_path=str(picture))
            )
    return files


_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")


def _unlink_missing(markdown: str, page_path: str, missing: set[str]) -> str:
    base = Path(page_path).parent

    def replace(match: re.Match[str]) -> str:
        bang, text, target = match.groups()
        path = target.split("#")[0]
        if not path or "://" in path:
            return match.group(0)
        resolved = (base / path).as_posix()
        parts: list[str] = []
        for part in resolved.split("/"):
            if part == "..":
                parts = parts[:-1]
            elif part not in ("", "."):
                parts.append(part)
        if "/".join(parts) not in missing:
            return match.group(0)
        log.info("%s: %s is not written yet: shown as text", page_path, target)
        return f"*({text})*" if bang else text

    return _LINK.sub(replace, markdown)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    path = page.file.src_uri
    missing = _missing_optional()
    if missing:
        markdown = _unlink_missing(markdown, path, missing)
    package = API_PAGES.get(path)
    if package:
        documented = set(re.findall(rf"^::: {package}\.(\w+)", markdown, re.M))
        rest = [name for name in _public_names(package) if name not in documented]
        if rest:
            markdown += "\n## Other names\n\n" + "".join(
                f"::: {package}.{name}\n\n" for name in rest
            )
    return markdown
