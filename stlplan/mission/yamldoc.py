"""Reading a mission file as a YAML document, guarded, with every value's line and column.

The file is read as UTF-8 text and parsed with PyYAML's safe loader, with YAML 1.2's plain
scalars (only ``true``/``false`` are booleans, ``1e-3`` is a number, ``yes`` and ``No`` are text,
and an integer with a leading zero is refused rather than read as octal), after guards that reject
lists and mappings nested too deep, aliases (``*name``) that form cycles or expand the document
too far, and duplicate keys. Syntax errors are rendered as one short phrase with their line and
column; :func:`locate` maps a field path such as ``("agents", 0, "initial_state")`` back to the
line and column of its value, so later stages can point at the offending text.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import yaml

from stlplan.errors import MissionError, StlplanError
from stlplan.mission.yamlerrors import reader_error, syntax_error

FieldPath = tuple[str | int, ...]
"""A field path such as ``("agents", 0, "initial_state")``."""

MAX_NESTING = 32
"""Levels of nested lists and mappings a mission file may have (a mission needs about 6)."""
MAX_SHOWN = 60
"""Characters of a long text a message shows (never a whole file)."""
MAX_VALUES = 200_000
"""Values a mission file may hold once YAML aliases (``*name``) are expanded."""


class MissionLoader(yaml.SafeLoader):
    """PyYAML's safe loader with the YAML 1.2 core schema's booleans, integers and floats; an
    alias (``*name``) becomes a node of its own that starts where the alias is written, so a
    mistake made through an alias is located at the alias, not at its anchor."""

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        """The node at the next event; a shallow copy at the alias's place for an alias."""
        alias = self.peek_event() if self.check_event(yaml.AliasEvent) else None
        node = super().compose_node(parent, index)  # type: ignore[misc]
        if alias is None or node is None:
            return node
        placed = copy.copy(node)
        placed.start_mark, placed.end_mark = alias.start_mark, alias.end_mark
        placed.through_alias = True  # type: ignore[attr-defined]
        return placed


MissionLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag.rsplit(":", 1)[-1] in ("null", "merge")]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
for _tag, _pattern, _first in (
    ("bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
    ("int", r"^[-+]?[0-9]+$", "-+0123456789"),
    (
        "float",
        r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$",
        "-+.0123456789",
    ),
):
    MissionLoader.add_implicit_resolver(
        f"tag:yaml.org,2002:{_tag}", re.compile(_pattern), list(_first)
    )

_LEADING_ZERO = re.compile(r"^[-+]?0[0-9]+$")


def read_text(path: Path) -> str:
    """The text of the mission file at ``path``, or a :class:`MissionError` saying why not."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise MissionError("no such file", source=str(path)) from None
    except IsADirectoryError:
        raise MissionError(
            "is a directory, expected a mission file (.yaml)", source=str(path)
        ) from None
    except OSError as exc:
        reason = (exc.strerror or str(exc)).lower()
        raise MissionError(
            f"cannot read the file ({reason}); expected a readable mission file (.yaml)",
            source=str(path),
        ) from None
    return decode_utf8(raw, str(path), MissionError, "a YAML mission file")


def decode_utf8(raw: bytes, source: str, error: type[StlplanError], expected: str) -> str:
    """``raw`` as UTF-8 text (a leading byte-order mark is dropped), or ``error`` naming the
    line and column of the first byte that is not UTF-8."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        start = raw.rfind(b"\n", 0, exc.start) + 1
        line = raw.count(b"\n", 0, exc.start) + 1
        column = len(raw[start : exc.start].decode("utf-8", errors="replace")) + 1
        raise error(
            f"not UTF-8 text (byte 0x{raw[exc.start]:02x}); expected {expected} in UTF-8",
            source=source,
            where=f"line {line}, column {column}",
        ) from None


def parse_yaml(text: str, source: str) -> tuple[Any, yaml.Node | None]:
    """The document in ``text`` as plain data and as a node tree (for :func:`locate`).

    Raises
    ------
    MissionError
        On a syntax error, a guard that fails, or a top level that is not a mapping.
    """
    try:
        _check_nesting(text, source)
        node = yaml.compose(text, Loader=MissionLoader)
        _check_expansion(node, source)
        _reject_leading_zeros(node, source)
        data = yaml.load(text, Loader=MissionLoader)
    except yaml.MarkedYAMLError as exc:
        raise syntax_error(exc, source) from None
    except yaml.reader.ReaderError as exc:
        raise reader_error(exc, text, source) from None
    except yaml.YAMLError as exc:
        raise MissionError(f"YAML error: {exc}", source=source) from None
    if not isinstance(data, dict):
        found = "an empty file" if data is None else describe_value(data)
        if isinstance(data, str) and data.startswith("agent,k,"):
            found += " (a trajectory CSV: the mission comes first, then the trajectory)"
        raise MissionError(
            f"expected a mapping of mission fields at the top level, found {found}",
            source=source,
            where="line 1, column 1",
        )
    _reject_duplicate_keys(node, (), source)
    return data, node


def _check_nesting(text: str, source: str) -> None:
    """Lists and mappings nest at most ``MAX_NESTING`` deep (checked on the event stream,
    before the recursive composer could exhaust Python's stack)."""
    depth = 0
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_NESTING:
                raise MissionError(
                    f"lists and mappings nested more than {MAX_NESTING} levels deep; expected "
                    "a mission file (about 6 levels)",
                    source=source,
                    where=_mark(event),
                )
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1


def _check_expansion(root: yaml.Node | None, source: str) -> None:
    """Aliases (``*name``) must not form a cycle, nest deeper than ``MAX_NESTING`` or expand
    the document past ``MAX_VALUES`` values; each node is measured once (no recursion)."""
    measured: dict[int, tuple[int, int]] = {}  # id(node) -> (values, depth) once expanded
    open_nodes: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [] if root is None else [(root, False)]
    while stack:
        node, finished = stack.pop()
        kids = _children(node)
        if finished:
            open_nodes.discard(id(node))
            size = 1 + sum(measured[id(k)][0] for k in kids)
            depth = 1 + max((measured[id(k)][1] for k in kids), default=0)
            measured[id(node)] = (size, depth)
            if size > MAX_VALUES or depth > MAX_NESTING:
                raise MissionError(
                    f"this value expands through YAML aliases (*name) to more than "
                    f"{MAX_VALUES} values or {MAX_NESTING} levels; expected a mission file",
                    source=source,
                    where=_mark(node),
                )
        elif id(node) in open_nodes:
            raise MissionError(
                "a YAML alias (*name) refers to a value that contains it; expected no cycles",
                source=source,
                where=_mark(node),
            )
        elif id(node) not in measured:
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((k, False) for k in kids)


def _reject_leading_zeros(root: yaml.Node | None, source: str) -> None:
    """An integer written with a leading zero (``010``) is refused: YAML 1.1 reads it as octal
    (8), YAML 1.2 as decimal (10), and a mission must not depend on which."""
    stack = [] if root is None else [root]
    seen: set[int] = set()
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if (
            isinstance(node, yaml.ScalarNode)
            and node.tag.endswith(":int")
            and _LEADING_ZERO.match(node.value)
        ):
            plain = node.value.replace("0", "", 1).lstrip("0") or "0"
            raise MissionError(
                f"the integer {node.value} has a leading zero, which YAML 1.1 reads as octal; "
                f"expected a decimal integer such as {plain}",
                source=source,
                where=_mark(node),
            )
        stack.extend(_children(node))


def _children(node: yaml.Node) -> list[yaml.Node]:
    """The nodes directly inside ``node``: keys and values of a mapping, items of a list."""
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    return list(node.value) if isinstance(node, yaml.SequenceNode) else []


def _reject_duplicate_keys(node: yaml.Node | None, path: FieldPath, source: str) -> None:
    """YAML silently keeps the last of two equal keys; a mission file must not have any."""
    if isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _reject_duplicate_keys(item, (*path, i), source)
    elif isinstance(node, yaml.MappingNode):
        first: dict[str, yaml.Node] = {}
        for key, value in node.value:
            if key.value in first and key.value != "<<":
                line = first[key.value].start_mark.line + 1
                raise MissionError(
                    f"duplicate key '{key.value}' (first given at line {line})",
                    source=source,
                    where=f"{_mark(key)}: {dotted((*path, key.value))}",
                )
            first[key.value] = key
            _reject_duplicate_keys(value, (*path, key.value), source)


def _mark(node: yaml.Node | yaml.Event) -> str:
    """``line L, column C`` where ``node`` starts (1-based)."""
    mark = node.start_mark
    return "line ?" if mark is None else f"line {mark.line + 1}, column {mark.column + 1}"


def locate(node: yaml.Node | None, path: FieldPath, *, key: bool = False) -> str | None:
    """``line L, column C`` of the YAML node at ``path`` (the deepest node found).

    With ``key=True`` the last step points at the mapping key itself (for unknown keys).
    """
    found, alias = node, None
    for depth, step in enumerate(path):
        match = None
        if isinstance(found, yaml.MappingNode):
            want_key = key and depth == len(path) - 1
            match = next(
                (k if want_key else v for k, v in found.value if k.value == str(step)), None
            )
        elif isinstance(found, yaml.SequenceNode) and isinstance(step, int):
            match = found.value[step] if step < len(found.value) else None
        if match is None:
            break
        found = match
        alias = alias or (found if getattr(found, "through_alias", False) else None)
    if found is None:
        return None
    if alias is not None and alias is not found:
        return f"{_mark(alias)} (an alias; the value is written at {_mark(found)})"
    return _mark(found)


def dotted(path: FieldPath) -> str:
    """``("agents", 1, "initial_state", 0)`` -> ``"agents[1].initial_state[0]"``."""
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


def split_path(text: str) -> FieldPath:
    """``"agents[1].initial_state[0]"`` -> ``("agents", 1, "initial_state", 0)``."""
    keys: list[str | int] = []
    for part in text.replace("[", ".[").split("."):
        if part:
            keys.append(int(part[1:-1]) if part.startswith("[") else part)
    return tuple(keys)


def describe_value(value: Any) -> str:
    """A YAML value in words, as it follows "found" in a message (``nothing (null)``, ...)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "nothing (null)"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        simple = all(isinstance(v, (int, float, str)) for v in value) and len(value) <= 6
        return str(value) if simple else f"a list of {len(value)} item(s)"
    if isinstance(value, str) and len(value) > MAX_SHOWN:
        first = value.splitlines()[0] if value.strip() else value
        return f"{first[:MAX_SHOWN]!r}... (text of {len(value)} characters)"
    return repr(value) if isinstance(value, str) else str(value)
