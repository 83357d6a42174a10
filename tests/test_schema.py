"""The shipped JSON Schema matches the pydantic models, and missions point editors at it."""

from __future__ import annotations

import copy
import json
from typing import Any

import jsonschema
import pytest

from stlplan.errors import StlplanError
from stlplan.mission.loader import validate_document
from stlplan.mission.schema import Mission, json_schema
from stlplan.mission.yamldoc import parse_yaml
from tests.helpers.paths import BROKEN, MISSIONS, ROOT


def test_schema_file_is_up_to_date() -> None:
    shipped = (ROOT / "schemas" / "mission.schema.json").read_text(encoding="utf-8")
    assert shipped == json_schema(), "schema drifted: run `make schema` (stlplan schema)"


def test_every_field_is_documented() -> None:
    schema = json.loads(json_schema())
    for name, definition in {**schema["$defs"], "Mission": schema}.items():
        for field, spec in definition.get("properties", {}).items():
            assert spec.get("description"), f"{name}.{field} has no description"


def test_missions_point_editors_at_the_schema() -> None:
    for path in sorted(MISSIONS.glob("*.yaml")):
        first = path.read_text(encoding="utf-8").splitlines()[0]
        assert first == "# yaml-language-server: $schema=../schemas/mission.schema.json", path


def test_unknown_keys_are_rejected_everywhere() -> None:
    schema = json.loads(json_schema())
    for name, definition in schema["$defs"].items():
        if definition.get("type") == "object":
            assert definition.get("additionalProperties") is False, name
    assert Mission.model_config.get("extra") == "forbid"


def _documents() -> list[tuple[str, Any]]:
    """Every shipped and catalogued mission as YAML reads it, plus documents made to probe the
    types (quoted numbers, true/false for numbers, nulls, out-of-range values)."""
    docs: list[tuple[str, Any]] = []
    for path in sorted([*MISSIONS.glob("*.yaml"), *BROKEN.glob("*.yaml")]):
        try:
            data, _ = parse_yaml(path.read_text(encoding="utf-8"), str(path))
        except StlplanError:
            continue  # not a YAML mapping: nothing to validate
        if _is_json(data):
            docs.append((path.stem, data))
    base = docs[[name for name, _ in docs].index("_base")][1]
    for field, value in PROBES:
        doc = copy.deepcopy(base)
        target = doc
        for key in field[:-1]:
            target = target.setdefault(key, {})
        target[field[-1]] = value
        docs.append((f"{'.'.join(field)}={value!r}", doc))
    return docs


def _is_json(data: Any) -> bool:
    """Whether ``data`` can be written as JSON as it is: no NaN, only text keys."""
    if isinstance(data, dict):
        return all(isinstance(k, str) and _is_json(v) for k, v in data.items())
    if isinstance(data, list):
        return all(_is_json(v) for v in data)
    return not (isinstance(data, float) and data != data)


PROBES: list[tuple[tuple[str, ...], Any]] = [
    (("separation",), True),
    (("separation",), "0.1"),
    (("separation",), None),
    (("separation",), 0.1),
    (("horizon",), 8.0),
    (("horizon",), True),
    (("objective", "beta"), "0.01"),
    (("objective", "beta"), 1e300),
    (("objective", "two_step"), "yes"),
    (("objective", "two_step"), 1),
    (("solver", "gap"), 1),
    (("solver", "gap"), 0.5),
    (("solver", "seed"), 2**31),
    (("solver", "seed"), 2**31 - 1),
    (("solver", "threads"), None),
    (("sweep",), None),
    (("regions", "Goal"), {"box": [[4, 5.5], [1, 3]], "G": [[1, 0]], "h": [1]}),
    (("regions", "Goal"), {"G": [[1, 0]]}),
    (("tasks", "meet", "roles", "p"), []),
    (("objective", "gamma"), -1),
    (("objective", "gamma"), 0),
    (("objective", "gamma"), 2.5),
    (("objective", "beta"), -0.01),
    (("objective", "margin"), {"minimum": -0.1}),
    (("solver", "gap"), -0.5),
    (("tasks", "meet", "synchronous"), {"within": [0, 2], "gamma": -2}),
]


NEGATIVE = [
    (("objective", "gamma"), -1, ">= 0"),
    (("objective", "beta"), -0.01, ">= 0"),
    (("objective", "margin", "minimum"), -0.1, ">= 0"),
    (("objective", "margin", "weight"), -1.0, ">= 0"),
    (("solver", "gap"), -0.5, ">= 0"),
    (("solver", "time_limit"), -5.0, "> 0"),
    (("tasks", "meet", "synchronous", "gamma"), -2, ">= 0"),
    (("separation",), -0.1, ">= 0"),
]


@pytest.mark.parametrize(("field", "value", "expected"), NEGATIVE, ids=lambda v: str(v))
def test_a_value_below_its_range_is_refused(
    field: tuple[str, ...], value: float, expected: str
) -> None:
    """A field's own lower bound holds (never widened to the magnitude limit, -1e6)."""
    doc, _ = parse_yaml((BROKEN / "_base.yaml").read_text(encoding="utf-8"), "base.yaml")
    doc["tasks"]["meet"]["synchronous"] = {"within": [0, 2]}
    target = doc
    for key in field[:-1]:
        target = target.setdefault(key, {})
    target[field[-1]] = value
    with pytest.raises(StlplanError) as caught:
        validate_document(doc, None, "base.yaml")
    assert f"{'.'.join(field)}: expected a value {expected}, found {value:g}" in str(caught.value)
    schema = json.loads(json_schema())
    assert list(jsonschema.Draft202012Validator(schema).iter_errors(doc))


@pytest.mark.parametrize(
    ("name", "data"), _documents(), ids=lambda v: v if isinstance(v, str) else ""
)
def test_json_schema_and_stlplan_agree(name: str, data: Any) -> None:
    """A document the JSON Schema accepts passes stlplan's schema stage, and vice versa."""
    schema = json.loads(json_schema())
    errors = list(jsonschema.Draft202012Validator(schema).iter_errors(data))
    try:
        validate_document(data, None, name)
        accepted = True
    except StlplanError:
        accepted = False
    assert accepted == (not errors), [e.message for e in errors]
    assert not any("is not of type 'null'" in e.message for e in errors)
