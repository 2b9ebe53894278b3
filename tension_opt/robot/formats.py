"""The text side of robot files: YAML and JSON, line numbers, and file errors.

:mod:`tension_opt.robot.files` holds the schema; this module turns a file's text into
plain data and back, finds the line of each field for error messages, and builds
:class:`~tension_opt.errors.RobotFileError`. YAML is read with PyYAML's safe loader
resolving plain scalars by the YAML 1.2 core schema (``010`` is 10, ``1e5`` a number,
``1:30``, ``1_000`` and ``yes`` text), refusing duplicate keys; floats are written with
Python's shortest round-trip ``repr`` in both formats, and text that YAML 1.1 or 1.2
would read as anything else is quoted.
"""

from __future__ import annotations

import json
import math
import re
from os import PathLike
from pathlib import Path
from typing import Any, ClassVar, NoReturn

import yaml

from tension_opt.errors import RobotFileError

__all__ = ["SUFFIXES", "checked_path", "file_error", "json_text", "line_map", "parse_text",
           "yaml_text"]

#: File name suffixes and their formats.
SUFFIXES = {".yaml": "yaml", ".yml": "yaml", ".json": "json"}
_SHOWN_PROBLEMS = 10

Problem = tuple[str, int, str]
"""(field path, line (0 if unknown), what is wrong and the fix)."""


def file_error(path: str | PathLike[str], problems: list[Problem]) -> RobotFileError:
    """The error of a file with these problems, one line each (the first ten shown)."""
    shown = [f"  {f'line {line}: ' if line else ''}{field}: {text}"
             for field, line, text in problems[:_SHOWN_PROBLEMS]]
    if len(problems) > _SHOWN_PROBLEMS:
        shown.append(f"  ... and {len(problems) - _SHOWN_PROBLEMS} more")
    return RobotFileError(f"robot file {path} is not valid:\n" + "\n".join(shown),
                          str(path), tuple(problems))


def checked_path(path: str | PathLike[str]) -> Path:
    """``path`` as a Path, or the file error if its suffix names no format."""
    file = Path(path)
    if file.suffix.lower() not in SUFFIXES:
        raise RobotFileError(
            f"robot file {file}: unknown suffix {file.suffix!r}; name it .yaml, .yml or "
            ".json", str(file))
    return file


# ------------------------------------------------------------------ YAML dialect
# PyYAML reads YAML 1.1, where 010 is octal 8, 1:30 is 90 (base 60), 1_000 is 1000, 0b10
# is 2, yes/no/on/off are booleans and 2001-12-14 is a date, while 1e5 (no dot) is text.
# These files follow YAML 1.2 and its core schema: the loader resolves plain scalars by
# the core schema's rules only (below), so 010 is 10 and 1:30, 1_000 and yes are text.
# Quoted scalars are text in both.
_CORE_SCHEMA: tuple[tuple[str, str, str], ...] = (
    ("null", r"~|null|Null|NULL|", "~nN"),
    ("bool", r"true|True|TRUE|false|False|FALSE", "tTfF"),
    ("int", r"[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+", "-+0123456789"),
    ("float", r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
     r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)", "-+0123456789."),
)
_RESOLVE = {name: re.compile(f"^(?:{pattern})$") for name, pattern, _ in _CORE_SCHEMA}


def _core_scalar(loader: yaml.BaseLoader, node: yaml.ScalarNode, name: str) -> str:
    """The text of a scalar tagged ``name`` (plain or ``!!name``), refused unless it is
    written as the core schema writes that type."""
    text = str(loader.construct_scalar(node))
    if not _RESOLVE[name].match(text):
        raise yaml.constructor.ConstructorError(
            None, None, f"{text!r} is not a YAML 1.2 {name}", node.start_mark)
    return text


def _core_int(loader: yaml.BaseLoader, node: yaml.ScalarNode) -> int:
    text = _core_scalar(loader, node, "int")
    try:
        if text.startswith(("0o", "0x")):
            return int(text[2:], 8 if text[1] == "o" else 16)
        return int(text, 10)
    except ValueError:  # beyond Python's limit on the digits of an int
        raise yaml.constructor.ConstructorError(
            None, None, f"a number of {len(text)} digits is too long", node.start_mark
        ) from None


def _core_float(loader: yaml.BaseLoader, node: yaml.ScalarNode) -> float:
    text = _core_scalar(loader, node, "float")
    special = text.lstrip("+-").lower()
    if special == ".inf":
        return -math.inf if text.startswith("-") else math.inf
    return math.nan if special == ".nan" else float(text)


def _core_bool(loader: yaml.BaseLoader, node: yaml.ScalarNode) -> bool:
    return _core_scalar(loader, node, "bool").lower() == "true"


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """Safe YAML loader with the YAML 1.2 core schema that refuses duplicate keys."""

    yaml_implicit_resolvers: ClassVar[dict[str | None, list[tuple[str, re.Pattern[str]]]]] = {}

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
                seen.add(key)
            except TypeError:  # an unhashable key: the base class reports it
                continue
            if duplicate:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}: give each field once",
                    key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


class _Dumper(getattr(yaml, "CSafeDumper", yaml.SafeDumper)):  # type: ignore[misc]
    """Safe YAML dumper that quotes text which YAML 1.1 or YAML 1.2 would read as
    anything but text (``"yes"``, ``"010"``, ``"1e5"``), so that either reads it back,
    and writes every value out (no aliases, which the loader refuses)."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


for _name, _pattern, _first in _CORE_SCHEMA:
    _tag = f"tag:yaml.org,2002:{_name}"
    _first_chars = [*_first, ""] if _name == "null" else list(_first)
    for _cls in (_Loader, _Dumper):  # the dumper keeps YAML 1.1's rules as well
        _cls.add_implicit_resolver(_tag, _RESOLVE[_name], _first_chars)
_Loader.add_constructor("tag:yaml.org,2002:int", _core_int)
_Loader.add_constructor("tag:yaml.org,2002:float", _core_float)
_Loader.add_constructor("tag:yaml.org,2002:bool", _core_bool)


def line_map(text: str) -> dict[tuple[str | int, ...], int]:
    """Line (1-based) of every field path in a YAML or JSON text; empty if unparsable.

    A mapping member's line is that of its key, a list item's that of its start.
    """
    try:
        root = yaml.compose(text, Loader=_Loader)
    except yaml.YAMLError:
        return {}
    if root is None:
        return {}
    lines: dict[tuple[str | int, ...], int] = {(): root.start_mark.line + 1}
    stack: list[tuple[yaml.Node, tuple[str | int, ...]]] = [(root, ())]
    while stack:
        node, path = stack.pop()
        if isinstance(node, yaml.MappingNode):
            children = [((*path, key.value), key, value) for key, value in node.value]
        elif isinstance(node, yaml.SequenceNode):
            children = [((*path, i), item, item) for i, item in enumerate(node.value)]
        else:
            continue
        for child, marked, value in children:
            lines.setdefault(child, marked.start_mark.line + 1)
            stack.append((value, child))
    return lines


# ------------------------------------------------------------------ reading
def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [key for key, _ in pairs]
    for key in keys:
        if keys.count(key) > 1:
            raise ValueError(f"duplicate key {key!r}: give each field once")
    return dict(pairs)


_TOO_DEEP = "lists or mappings nested too deep for a robot file"


def _refuse_aliases(path: Path, text: str) -> None:
    """Raise at the first YAML alias (``*name``): a robot file writes its values out,
    and aliases of aliases expand without bound (a few lines can stand for billions
    of values)."""
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, yaml.AliasEvent):
            _syntax_error(path, event.start_mark.line + 1,
                          f"alias *{event.anchor} is not allowed in a robot file: write the "
                          "value out")


def _syntax_error(path: Path, line: int, message: str) -> NoReturn:
    raise file_error(path, [("(syntax)", line, message)])


def parse_text(path: Path, text: str) -> Any:
    """The data of a YAML or JSON text (by the suffix of ``path``).

    Raises
    ------
    RobotFileError
        For a syntax error or a duplicate key, with its line.
    """
    if SUFFIXES[path.suffix.lower()] == "json":
        try:
            return json.loads(text, object_pairs_hook=_unique_keys)
        except json.JSONDecodeError as error:
            _syntax_error(path, error.lineno, error.msg)
        except ValueError as error:
            _syntax_error(path, 0, str(error))
        except RecursionError:
            _syntax_error(path, 0, _TOO_DEEP)
    try:
        _refuse_aliases(path, text)
        return yaml.load(text, Loader=_Loader)  # _Loader derives from the safe loader
    except RecursionError:
        _syntax_error(path, 0, _TOO_DEEP)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        problem = getattr(error, "problem", None) or str(error)
        _syntax_error(path, 0 if mark is None else mark.line + 1, str(problem))


# ------------------------------------------------------------------ writing
def _json_ready(value: Any) -> Any:
    """Infinite floats as the text ``"inf"`` (JSON has no infinity)."""
    if isinstance(value, dict):
        return {key: _json_ready(v) for key, v in value.items()}
    if isinstance(value, list):
        return [_json_ready(v) for v in value]
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


def json_text(document: dict[str, Any]) -> str:
    """Compact, diff-friendly JSON: one field per line, one matrix row per line."""
    fields = []
    for key, value in _json_ready(document).items():
        if isinstance(value, list) and value and isinstance(value[0], list):
            rows = ",\n    ".join(json.dumps(row, allow_nan=False) for row in value)
            text = f"[\n    {rows}\n  ]"
        else:
            text = json.dumps(value, allow_nan=False, ensure_ascii=False)
        fields.append(f"  {json.dumps(key)}: {text}")
    return "{\n" + ",\n".join(fields) + "\n}\n"


def yaml_text(document: dict[str, Any], header: str = "") -> str:
    """YAML in field order, matrix rows in flow style, ``header`` lines as comments."""
    comments = "".join(f"# {line}".rstrip() + "\n" for line in header.splitlines())
    return comments + yaml.dump(document, Dumper=_Dumper, sort_keys=False,
                                default_flow_style=None, allow_unicode=True, width=88)
