"""Schema errors in plain words: pydantic's validation errors as short phrases located in the file.

Each error says what was expected and what was found ("expected an integer, found 'eight'"); a
misspelt key gets a did-you-mean among the keys allowed at that place; the first
:data:`MAX_REPORTED` problems are listed with their line, column and field path.
"""

from __future__ import annotations

import types
from difflib import get_close_matches
from typing import Any, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, ValidationError

from stlplan.errors import MissionError
from stlplan.mission import schema
from stlplan.mission.schema import Mission
from stlplan.mission.yamldoc import FieldPath, describe_value, dotted, locate

MAX_REPORTED = 5
"""Schema errors listed in one message; the rest are counted."""


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


def _annotation_at(path: FieldPath) -> Any:
    """The schema annotation of the value at ``path`` (None when the path leads nowhere)."""
    annotation: Any = Mission
    for key in path:
        annotation = _step(annotation, key)
        if annotation is None:
            return None
    return annotation


def _keys_at(path: FieldPath) -> list[str]:
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


def _tuple_size(path: FieldPath) -> int | None:
    """How many values the fixed-size tuple at ``path`` holds (None when it is no such tuple)."""
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
    schema.FORMULA_NAME: "a name a formula can use: letters, digits and '_', starting with a "
    "letter or '_'",
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
        self.path: FieldPath = ()
        self.tag: str | None = None
        self.root: FieldPath = ()
        current = data
        loc = tuple(error["loc"])
        for i, key in enumerate(loc):
            if key == "[key]" and self.kind != "string_type":  # a name of the wrong form
                self.found = list(self.path)[-1]
                continue
            if key == "[key]":  # a mapping key of the wrong type, such as a number
                self.kind, self.found = "key_type", list(self.path)[-1]
                self.path = (*self.path[:-1], describe_value(self.found))
                continue
            missing = self.kind == "missing" and i == len(loc) - 1
            if isinstance(key, str) and isinstance(current, dict) and key not in current:
                # a key YAML read as null, a number or a boolean, named as text by pydantic
                key = next((k for k in current if not isinstance(k, str) and str(k) == key), key)
            if (
                isinstance(key, str)
                and not missing
                and not (isinstance(current, dict) and key in current)
            ):
                if self.tag is None:  # a union branch such as 'str' or 'PinnedRole'
                    self.tag, self.root = key, self.path
                continue
            if isinstance(current, dict):  # the key as YAML read it (True, not 1)
                key = next((k for k in current if k == key), key)
            self.path = (*self.path, key)
            current = _child(current, key)


def _child(data: Any, key: str | int) -> Any:
    """The value under ``key`` in parsed YAML data, or None when there is none."""
    if isinstance(data, dict):
        return data.get(key)
    if isinstance(data, list) and isinstance(key, int) and key < len(data):
        return data[key]
    return None


def _resolve_unions(issues: list[_Issue]) -> list[_Issue]:
    """Keep the union branch that fits the input's type, or merge the branches into one issue."""
    kept: list[_Issue] = []
    done: set[FieldPath] = set()
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


def _describe(issue: _Issue) -> tuple[FieldPath, str]:
    """The path to report and a short phrase: what was found and what was expected."""
    kind, ctx, path = issue.kind, issue.ctx, issue.path
    if kind == "extra_forbidden":
        allowed = _keys_at(path[:-1])
        close = get_close_matches(str(path[-1]), allowed, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else f"; allowed keys: {', '.join(allowed)}"
        return path, f"unknown key '{path[-1]}'{hint}"
    if kind == "missing" and isinstance(path[-1], int):
        size = _tuple_size(path[:-1])
        return path[:-1], f"expected {size or 'more'} values, found {describe_value(issue.found)}"
    if kind == "missing":
        return path[:-1], f"missing required field '{path[-1]}'"
    if kind == "value_error":
        return path, str(ctx.get("error", issue.msg))
    if kind == "key_type" and issue.found is None:
        null = "a key YAML reads as null ('~', 'null' or nothing before ':'); expected a name"
        return path[:-1], null
    if kind == "key_type":
        return path, (
            f"the name {path[-1]} is read by YAML as a {_yaml_kind(issue.found)}; expected a "
            f"name in text: quote it ('{path[-1]}')"
        )
    if kind in ("too_long", "too_short") and ctx.get("field_type") == "Tuple":
        expected = f"{ctx.get('max_length', ctx.get('min_length'))} values"
    elif kind == "too_short":
        expected = f"at least {ctx.get('min_length')} item(s)"
    elif kind == "too_long":
        expected = f"at most {ctx.get('max_length')} item(s)"
    elif kind in _BOUNDS:
        expected = _bound(kind, ctx)
    elif kind == "string_pattern_mismatch":
        expected = _PATTERNS.get(ctx.get("pattern"), f"text matching {ctx.get('pattern')}")
    elif kind in ("literal_error", "union"):
        expected = str(ctx.get("expected"))
    else:
        expected = _EXPECTED.get(kind, issue.msg)
    return path, f"expected {expected}, found {describe_value(issue.found)}{_hint(issue)}"


def _bound(kind: str, ctx: dict[str, Any]) -> str:
    """What a value out of its range should be: ``a value >= 0``, or within the magnitude limit."""
    limit = next(iter(v for k, v in ctx.items() if k in ("ge", "gt", "le", "lt")), "?")
    if limit in (schema.MAX_MAGNITUDE, -schema.MAX_MAGNITUDE):
        return (
            f"a number between -{schema.MAGNITUDE_TEXT} and {schema.MAGNITUDE_TEXT} "
            "(larger magnitudes break the solver's tolerances; rescale the units)"
        )
    shown = int(limit) if isinstance(limit, float) and limit.is_integer() else limit  # 0, not 0.0
    return f"a value {_BOUNDS[kind]} {shown}"


def _hint(issue: _Issue) -> str:
    """Why a value of the wrong type was probably written so, and how to fix it."""
    found = issue.found
    if issue.kind in ("float_type", "int_type") and isinstance(found, str):
        try:
            float(found)
        except ValueError:
            return ""
        return " (text, because it is quoted; write the number without quotes)"
    if issue.kind == "string_type" and isinstance(found, (bool, int, float)):
        value = describe_value(found)
        return f" (YAML reads it as a {_yaml_kind(found)}; quote it: '{value}')"
    return ""


def _yaml_kind(value: Any) -> str:
    """What YAML read a plain value as: a boolean or a number."""
    return "boolean" if isinstance(value, bool) else "number"


def schema_error(
    exc: ValidationError, data: dict[str, Any], node: yaml.Node | None, source: str
) -> MissionError:
    """One error listing the first ``MAX_REPORTED`` schema problems, located in the file."""
    issues = _drop_explained(_resolve_unions([_Issue(e, data) for e in exc.errors()]))
    places = []
    shown: set[str] = set()
    for issue in issues[:MAX_REPORTED]:
        path, phrase = _describe(issue)
        head, sep, allowed = phrase.partition("; allowed keys: ")
        phrase = head if allowed in shown else phrase  # each list of allowed keys once
        shown.add(allowed)
        key = issue.kind in ("extra_forbidden", "key_type")
        line = locate(node, path, key=key) or "line ?"
        places.append((f"{line}: {dotted(path) or '(top level)'}", phrase))
    (where, message), rest = places[0], places[1:]
    message += "".join(f"\n  {more}: {phrase}" for more, phrase in rest)
    if len(issues) > MAX_REPORTED:
        message += f"\n  ... and {len(issues) - MAX_REPORTED} more"
    return MissionError(message, source=source, where=where)
