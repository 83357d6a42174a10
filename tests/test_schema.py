"""The shipped JSON Schema matches the pydantic models, and missions point editors at it."""

from __future__ import annotations

import json

from stlplan.mission.schema import Mission, json_schema
from tests.conftest import MISSIONS, ROOT


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
