"""Reading mission files: YAML with positions, pydantic validation, semantic checks.

Every error names the file and the line and column of the offending value, plus its field path.
"""

from __future__ import annotations

from difflib import get_close_matches
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from stlplan import mission as schema
from stlplan.errors import MissionError, StlplanError
from stlplan.mission import Mission
from stlplan.problem import Problem, build_problem


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissionError("no such file", source=str(path)) from None
    except IsADirectoryError:
        raise MissionError("is a directory, expected a mission file (.yaml)", source=str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MissionError(f"cannot read the file: {exc}", source=str(path)) from None


def _parse_yaml(text: str, source: str) -> tuple[Any, yaml.Node | None]:
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else None
        raise MissionError(f"YAML syntax error: {exc.problem or exc}", source=source, where=where) from None
    except yaml.YAMLError as exc:
        raise MissionError(f"YAML error: {exc}", source=source) from None
    if not isinstance(data, dict):
        found = "an empty file" if data is None else f"a {type(data).__name__}"
        raise MissionError(f"expected a mapping of mission fields at the top level, found {found}",
                           source=source, where="line 1, column 1")
    return data, node


def locate(node: yaml.Node | None, path: tuple[str | int, ...]) -> str | None:
    """``line L, column C`` of the YAML node at ``path`` (the deepest node found)."""
    found = node
    for key in path:
        if isinstance(found, yaml.MappingNode):
            match = next((v for k, v in found.value if k.value == str(key)), None)
            if match is None:  # an unknown key: point at the key itself
                match = next((k for k, _ in found.value if k.value == str(key)), None)
        elif isinstance(found, yaml.SequenceNode) and isinstance(key, int) and key < len(found.value):
            match = found.value[key]
        else:
            match = None
        if match is None:
            break
        found = match
    if found is None:
        return None
    return f"line {found.start_mark.line + 1}, column {found.start_mark.column + 1}"


def _field_names() -> list[str]:
    names: set[str] = set()
    for obj in vars(schema).values():
        if isinstance(obj, type) and issubclass(obj, BaseModel):
            names.update(obj.model_fields)
    return sorted(names)


def _dotted(path: tuple[str | int, ...]) -> str:
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


def _describe(error: Any) -> str:
    kind, msg = error["type"], error["msg"]
    path = tuple(error["loc"])
    if kind == "extra_forbidden":
        close = get_close_matches(str(path[-1]), _field_names(), n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        return f"unknown key '{path[-1]}'{hint}"
    found = error.get("input")
    shown = repr(found) if not isinstance(found, (dict, list)) else type(found).__name__
    return f"{msg}, found {shown}"


def _clean_loc(loc: tuple[Any, ...]) -> tuple[str | int, ...]:
    # pydantic adds union-branch names such as 'str' or 'list[str]' or 'PinnedRole' to locations
    branch = {"str", "list[str]", "PinnedRole", "tuple[float, float]", "function-after[_one_shape(), Region]"}
    return tuple(k for k in loc if not (isinstance(k, str) and k in branch))


def validate_document(data: dict[str, Any], node: yaml.Node | None, source: str) -> Mission:
    """Validate a parsed YAML document against the schema."""
    try:
        return Mission.model_validate(data)
    except ValidationError as exc:
        lines = []
        for error in exc.errors()[:10]:
            path = _clean_loc(tuple(error["loc"]))
            lines.append(f"{locate(node, path) or 'line ?'}: {_dotted(path) or '(top level)'}: "
                         f"{_describe(error)}")
        first = lines[0]
        more = "".join(f"\n  {source}: {line}" for line in lines[1:])
        raise MissionError(first + more, source=source) from None


def load_mission(path: str | Path) -> Mission:
    """Read and schema-validate a mission file (no semantic checks)."""
    path = Path(path)
    text = _read_text(path)
    data, node = _parse_yaml(text, str(path))
    return validate_document(data, node, str(path))


def load_problem(path: str | Path) -> Problem:
    """Read, validate and check a mission file; errors carry line and column where known."""
    path = Path(path)
    text = _read_text(path)
    data, node = _parse_yaml(text, str(path))
    mission = validate_document(data, node, str(path))
    try:
        return build_problem(mission, source=str(path))
    except StlplanError as exc:
        if exc.where and not exc.where.startswith("line"):
            keys = tuple(int(k[1:-1]) if k.startswith("[") else k
                         for k in exc.where.replace("[", ".[").split(".") if k)
            line = locate(node, keys)
            exc.where = f"{line}: {exc.where}" if line else exc.where
        raise
