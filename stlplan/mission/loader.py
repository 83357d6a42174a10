"""Loading mission files: schema validation with errors in plain words, then semantic checks.

:mod:`stlplan.mission.yamldoc` reads the file as a guarded YAML document; here pydantic validates it
against :class:`~stlplan.mission.schema.Mission`. Every error names the file, the line and column of the
offending value, and its field path; :mod:`stlplan.mission.schema_errors` puts pydantic's
errors in plain words. :func:`load_problem` then runs the semantic checks of
:func:`~stlplan.mission.problem.build_problem` and locates their field paths in the file too.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from stlplan.errors import MissionError, StlplanError
from stlplan.mission.formula_checks import check_group_count
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.mission.schema_errors import schema_error
from stlplan.mission.yamldoc import (
    FieldPath,
    dotted,
    locate,
    parse_yaml,
    read_text,
    split_path,
)


def _first_null(data: Any, path: FieldPath = ()) -> FieldPath | None:
    """The path of the first null value in ``data`` (None when there is none)."""
    items = (
        data.items()
        if isinstance(data, dict)
        else enumerate(data)
        if isinstance(data, list)
        else ()
    )
    for key, value in items:
        found = (*path, key) if value is None else _first_null(value, (*path, key))
        if found is not None:
            return found
    return None


def _reject_null(data: dict[str, Any], node: yaml.Node | None, source: str) -> None:
    """A key in a mission file is given a value or left out; null (``key:`` with nothing) is
    refused rather than read as "the default"."""
    path = _first_null(data)
    if path is not None:
        line = locate(node, path) or "line ?"
        raise MissionError(
            "expected a value, found nothing (null); give a value or leave the key out",
            source=source,
            where=f"{line}: {dotted(path)}",
        )


def _not_a_mission(data: dict[str, Any], source: str) -> None:
    """A JSON Schema given where a mission is expected is named as such."""
    if "$schema" in data and "properties" in data:
        raise MissionError(
            "this is a JSON Schema (it has '$schema' and 'properties'), not a mission; expected "
            "a mission file such as missions/sync-pair.yaml",
            source=source,
            where="line 1, column 1",
        )


def validate_document(data: dict[str, Any], node: yaml.Node | None, source: str) -> Mission:
    """Validate a parsed YAML document against the schema.

    Raises
    ------
    MissionError
        Naming the line, column and field path of the first problem, then a few more
        (:data:`stlplan.mission.schema_errors.MAX_REPORTED` in all), one per line.
    """
    _not_a_mission(data, source)
    _reject_null(data, node, source)
    try:
        return Mission.model_validate(data)
    except ValidationError as exc:
        raise schema_error(exc, data, node, source) from None


def load_mission(path: str | Path) -> Mission:
    """Read and schema-validate a mission file (no semantic checks)."""
    path = Path(path)
    text = read_text(path)
    data, node = parse_yaml(text, str(path))
    return validate_document(data, node, str(path))


def load_problem(path: str | Path) -> Problem:
    """Read, validate and check a mission file; errors carry line and column where known."""
    path = Path(path)
    return problem_from_text(read_text(path), str(path))


def problem_from_text(text: str, source: str) -> Problem:
    """Validate and check mission ``text``; ``source`` names it in error messages."""
    data, node = parse_yaml(text, source)
    mission = validate_document(data, node, source)
    try:
        return build_problem(mission, source=source)
    except StlplanError as exc:
        _add_line(exc, node)
        raise


def _add_line(exc: StlplanError, node: yaml.Node | None) -> None:
    """Prefix the error's field path with its line and column in the mission file."""
    if exc.where and not exc.where.startswith("line"):
        line = locate(node, split_path(exc.where))
        exc.where = f"{line}: {exc.where}" if line else exc.where


def check_enumerable(problem: Problem) -> None:
    """Every task's groups can be enumerated (the group encoding's size guard), with the line of
    the offending ``count`` when the mission came from a file."""
    for task in problem.tasks:
        try:
            check_group_count(problem.mission, task.name, task.elements, problem.source)
        except StlplanError as exc:
            if problem.source is not None and Path(problem.source).is_file():
                _add_line(exc, parse_yaml(read_text(Path(problem.source)), problem.source)[1])
            raise
