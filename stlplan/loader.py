"""Reading mission files: YAML with positions, pydantic validation, semantic checks.

Every error names the file, the line and column of the offending value, and its field path.
Schema errors are translated from pydantic into short phrases ("expected an integer, found
'eight'"); a misspelt key gets a did-you-mean among the keys allowed at that place.
"""

from __future__ import annotations

import types
from difflib import get_close_matches
from pathlib import Path
from typing import Any, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, ValidationError

from stlplan import mission as schema
from stlplan.errors import MissionError, StlplanError
from stlplan.mission import Mission
from stlplan.problem import Problem, build_problem

Path_ = tuple[str | int, ...]
"""A field path such as ``("agents", 0, "initial_state")``."""

MAX_REPORTED = 5
"""Schema errors listed in one message; the rest are counted."""
MAX_NESTING = 32
"""Levels of nested lists and mappings a mission file may have (a mission needs about 6)."""
MAX_VALUES = 200_000
"""Values a mission file may hold once YAML aliases (``*name``) are expanded."""


def _read_text(path: Path) -> str:
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


def _parse_yaml(text: str, source: str) -> tuple[Any, yaml.Node | None]:
    try:
        _check_nesting(text, source)
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        _check_expansion(node, source)
        data = yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else None
        raise MissionError(
            f"YAML syntax error: {(exc.problem or str(exc)).removeprefix('but ')}"
            f"{_yaml_context(exc)}",
            source=source,
            where=where,
        ) from None
    except yaml.YAMLError as exc:
        raise MissionError(f"YAML error: {exc}", source=source) from None
    if not isinstance(data, dict):
        found = "an empty file" if data is None else _found(data)
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


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    return list(node.value) if isinstance(node, yaml.SequenceNode) else []


def _yaml_context(exc: yaml.MarkedYAMLError) -> str:
    """What YAML was reading when it failed, or a hint for a formula read as a YAML tag."""
    if "for the tag '!" in str(exc.problem):
        return "; a value that starts with '!' (a negated formula) must be quoted: \"!...\""
    if not exc.context or exc.context_mark is None:
        return ""
    return f" ({exc.context} started at line {exc.context_mark.line + 1})"


def _reject_duplicate_keys(node: yaml.Node | None, path: Path_, source: str) -> None:
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
                    where=f"{_mark(key)}: {_dotted((*path, key.value))}",
                )
            first[key.value] = key
            _reject_duplicate_keys(value, (*path, key.value), source)


def _mark(node: yaml.Node | yaml.Event) -> str:
    mark = node.start_mark
    return "line ?" if mark is None else f"line {mark.line + 1}, column {mark.column + 1}"


def locate(node: yaml.Node | None, path: Path_, *, key: bool = False) -> str | None:
    """``line L, column C`` of the YAML node at ``path`` (the deepest node found).

    With ``key=True`` the last step points at the mapping key itself (for unknown keys).
    """
    found = node
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
    return None if found is None else _mark(found)


def _dotted(path: Path_) -> str:
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


# --- where a path leads in the schema -------------------------------------------------------


def _step(annotation: Any, key: str | int) -> Any:
    """The annotation one key below ``annotation`` (None when the key leads nowhere)."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin in (Union, types.UnionType):
        return next((s for a in args if (s := _step(a, key)) is not None), None)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        field = annotation.model_fields.get(str(key))
        return None if field is None else field.annotation
    if origin is dict and isinstance(key, str):
        return args[1]
    if origin is list and isinstance(key, int):
        return args[0]
    if origin is tuple and isinstance(key, int) and key < len(args):
        return args[key]
    return None


def _annotation_at(path: Path_) -> Any:
    annotation: Any = Mission
    for key in path:
        annotation = _step(annotation, key)
        if annotation is None:
            return None
    return annotation


def _keys_at(path: Path_) -> list[str]:
    """Keys allowed in the mapping at ``path`` (every schema key when unknown)."""
    annotation = _annotation_at(path)
    options = (
        get_args(annotation)
        if get_origin(annotation) in (Union, types.UnionType)
        else (annotation,)
    )
    for option in options:
        if isinstance(option, type) and issubclass(option, BaseModel):
            return list(option.model_fields)
    names: set[str] = set()
    for obj in vars(schema).values():
        if isinstance(obj, type) and issubclass(obj, BaseModel):
            names.update(obj.model_fields)
    return sorted(names)


def _tuple_size(path: Path_) -> int | None:
    annotation = _annotation_at(path)
    args = get_args(annotation)
    return len(args) if get_origin(annotation) is tuple and Ellipsis not in args else None


# --- pydantic errors in plain words ---------------------------------------------------------

_EXPECTED = {
    kind: text
    for text, kinds in (
        ("an integer", ("int_type", "int_parsing", "int_from_float", "int_parsing_size")),
        ("a number", ("float_type", "float_parsing")),
        ("a finite number (no .inf or .nan)", ("finite_number",)),
        ("true or false", ("bool_type", "bool_parsing")),
        ("text", ("string_type",)),
        ("a list", ("list_type", "tuple_type")),
        ("a mapping of fields", ("dict_type", "model_type", "model_attributes_type")),
    )
    for kind in kinds
}
_MISMATCH = frozenset(_EXPECTED) | {"literal_error"}
_PATTERNS = {
    schema.Agent.model_fields["name"].metadata[0].pattern: (
        "a name of letters, digits, '_' and '-', starting with a letter or '_'"
    ),
}
_UNIONS = {
    frozenset({"str", "list[str]", "PinnedRole"}): (
        "a capability name, a list of capability names, or {agent: NAME}"
    ),
}
_BOUNDS = {
    "greater_than_equal": ">=",
    "greater_than": ">",
    "less_than_equal": "<=",
    "less_than": "<",
}


class _Issue:
    """One pydantic error with its location cleaned of union-branch tags."""

    def __init__(self, error: Any, data: Any) -> None:
        self.kind: str = error["type"]
        self.msg: str = error["msg"]
        self.found: Any = error.get("input")
        self.ctx: dict[str, Any] = error.get("ctx") or {}
        self.path: Path_ = ()
        self.tag: str | None = None
        self.root: Path_ = ()
        current = data
        loc = tuple(error["loc"])
        for i, key in enumerate(loc):
            missing = self.kind == "missing" and i == len(loc) - 1
            if (
                isinstance(key, str)
                and not missing
                and not (isinstance(current, dict) and key in current)
            ):
                if self.tag is None:  # a union branch such as 'str' or 'PinnedRole'
                    self.tag, self.root = key, self.path
                continue
            self.path = (*self.path, key)
            current = _child(current, key)


def _child(data: Any, key: str | int) -> Any:
    if isinstance(data, dict):
        return data.get(key)
    if isinstance(data, list) and isinstance(key, int) and key < len(data):
        return data[key]
    return None


def _found(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "nothing (null)"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        simple = all(isinstance(v, (int, float, str)) for v in value) and len(value) <= 6
        return str(value) if simple else f"a list of {len(value)} item(s)"
    return repr(value) if isinstance(value, str) else str(value)


def _resolve_unions(issues: list[_Issue]) -> list[_Issue]:
    """Keep the union branch that fits the input's type, or merge the branches into one issue."""
    kept: list[_Issue] = []
    done: set[Path_] = set()
    for issue in issues:
        if issue.tag is None:
            kept.append(issue)
            continue
        if issue.root in done:
            continue
        done.add(issue.root)
        group = [i for i in issues if i.tag is not None and i.root == issue.root]
        branches: dict[str, list[_Issue]] = {}
        for i in group:
            branches.setdefault(str(i.tag), []).append(i)
        fitting = [
            b
            for b in branches.values()
            if not all(i.kind in _MISMATCH and i.path == issue.root for i in b)
        ]
        if fitting:
            kept.extend(fitting[0])
            continue
        merged = issue
        merged.kind, merged.path = "union", issue.root
        merged.ctx = {"expected": _UNIONS.get(frozenset(branches), " or ".join(branches))}
        kept.append(merged)
    return kept


def _drop_explained(issues: list[_Issue]) -> list[_Issue]:
    """A missing field next to a misspelt key of that name is one mistake, reported once."""
    extra = [i for i in issues if i.kind == "extra_forbidden"]
    out = []
    for issue in issues:
        if issue.kind == "missing" and any(
            e.path[:-1] == issue.path[:-1]
            and get_close_matches(str(e.path[-1]), [str(issue.path[-1])])
            for e in extra
        ):
            continue
        out.append(issue)
    return sorted(out, key=lambda i: i.kind != "extra_forbidden")


def _describe(issue: _Issue) -> tuple[Path_, str]:
    """The path to report and a short phrase: what was found and what was expected."""
    kind, ctx, path = issue.kind, issue.ctx, issue.path
    if kind == "extra_forbidden":
        allowed = _keys_at(path[:-1])
        close = get_close_matches(str(path[-1]), allowed, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else f"; allowed keys: {', '.join(allowed)}"
        return path, f"unknown key '{path[-1]}'{hint}"
    if kind == "missing" and isinstance(path[-1], int):
        size = _tuple_size(path[:-1])
        return path[:-1], f"expected {size or 'more'} values, found {_found(issue.found)}"
    if kind == "missing":
        return path[:-1], f"missing required field '{path[-1]}'"
    if kind == "value_error":
        return path, str(ctx.get("error", issue.msg))
    if kind in ("too_long", "too_short") and ctx.get("field_type") == "Tuple":
        expected = f"{ctx.get('max_length', ctx.get('min_length'))} values"
    elif kind == "too_short":
        expected = f"at least {ctx.get('min_length')} item(s)"
    elif kind == "too_long":
        expected = f"at most {ctx.get('max_length')} item(s)"
    elif kind in _BOUNDS:
        limit = next(iter(v for k, v in ctx.items() if k in ("ge", "gt", "le", "lt")), "?")
        expected = f"a value {_BOUNDS[kind]} {limit}"
    elif kind == "string_pattern_mismatch":
        expected = _PATTERNS.get(ctx.get("pattern"), f"text matching {ctx.get('pattern')}")
    elif kind in ("literal_error", "union"):
        expected = str(ctx.get("expected"))
    else:
        expected = _EXPECTED.get(kind, issue.msg)
    return path, f"expected {expected}, found {_found(issue.found)}"


def validate_document(data: dict[str, Any], node: yaml.Node | None, source: str) -> Mission:
    """Validate a parsed YAML document against the schema.

    Raises
    ------
    MissionError
        Naming the line, column and field path of the first problem, then up to
        ``MAX_REPORTED - 1`` more, one per line.
    """
    try:
        return Mission.model_validate(data)
    except ValidationError as exc:
        raise _schema_error(exc, data, node, source) from None


def _schema_error(
    exc: ValidationError, data: dict[str, Any], node: yaml.Node | None, source: str
) -> MissionError:
    issues = _drop_explained(_resolve_unions([_Issue(e, data) for e in exc.errors()]))
    places = []
    for issue in issues[:MAX_REPORTED]:
        path, phrase = _describe(issue)
        line = locate(node, path, key=issue.kind == "extra_forbidden") or "line ?"
        places.append((f"{line}: {_dotted(path) or '(top level)'}", phrase))
    (where, message), rest = places[0], places[1:]
    message += "".join(f"\n  {more}: {phrase}" for more, phrase in rest)
    if len(issues) > MAX_REPORTED:
        message += f"\n  ... and {len(issues) - MAX_REPORTED} more"
    return MissionError(message, source=source, where=where)


def load_mission(path: str | Path) -> Mission:
    """Read and schema-validate a mission file (no semantic checks)."""
    path = Path(path)
    text = _read_text(path)
    data, node = _parse_yaml(text, str(path))
    return validate_document(data, node, str(path))


def load_problem(path: str | Path) -> Problem:
    """Read, validate and check a mission file; errors carry line and column where known."""
    path = Path(path)
    return problem_from_text(_read_text(path), str(path))


def problem_from_text(text: str, source: str) -> Problem:
    """Validate and check mission ``text``; ``source`` names it in error messages."""
    data, node = _parse_yaml(text, source)
    mission = validate_document(data, node, source)
    try:
        return build_problem(mission, source=source)
    except StlplanError as exc:
        if exc.where and not exc.where.startswith("line"):
            line = locate(node, _split_path(exc.where))
            exc.where = f"{line}: {exc.where}" if line else exc.where
        raise


def _split_path(dotted: str) -> Path_:
    """``"agents[1].initial_state[0]"`` -> ``("agents", 1, "initial_state", 0)``."""
    keys: list[str | int] = []
    for part in dotted.replace("[", ".[").split("."):
        if part:
            keys.append(int(part[1:-1]) if part.startswith("[") else part)
    return tuple(keys)
