"""Examples for a pip user: the shipped missions and schema from one place, `stlplan example`,
and a README whose mission and Python API are true."""

from __future__ import annotations

import contextlib
import inspect
import io
import json
import re
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from stlplan import api, examples
from stlplan.cli import app
from stlplan.mission.loader import load_problem
from stlplan.mission.schema import json_schema
from tests.helpers.paths import MISSIONS, ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")


def _block(after: str, language: str) -> str:
    """The first fenced ``language`` block after the line containing ``after``."""
    rest = README[README.index(after) :]
    return rest.split(f"```{language}\n", 1)[1].split("```", 1)[0]


def test_the_shipped_missions_and_schema_come_from_one_place() -> None:
    assert examples.missions_dir() == MISSIONS
    assert {e.path for e in examples.examples()} == set(MISSIONS.rglob("*.yaml"))
    assert examples.schema_file().read_text(encoding="utf-8") == json_schema()
    # the wheel copies the same folders into the package (pyproject's force-include)
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert '"missions" = "stlplan/missions"' in pyproject
    assert '"schemas/mission.schema.json" = "stlplan/schemas/mission.schema.json"' in pyproject
    assert not (ROOT / "stlplan" / "missions").exists()  # no second copy to drift


def test_example_lists_the_shipped_missions() -> None:
    found = CliRunner().invoke(app, ["example", "--json"])
    assert found.exit_code == 0
    listed = json.loads(found.stdout)
    assert [e["name"] for e in listed] == [e.name for e in examples.examples()]
    assert listed[0]["description"].startswith("Farmland health monitoring, Case I")


def test_example_offers_every_shipped_mission_with_its_description() -> None:
    found = CliRunner().invoke(app, ["example", "--json"])
    listed = json.loads(found.stdout)
    shipped = sorted(p.relative_to(MISSIONS).as_posix() for p in MISSIONS.rglob("*.yaml"))
    assert sorted(e["file"] for e in listed) == shipped
    assert len({e["name"] for e in listed}) == len(listed)  # a name picks one file
    assert any("/" in e["file"] for e in listed)  # the folders' missions too
    for entry in listed:
        data = yaml.safe_load((MISSIONS / entry["file"]).read_text(encoding="utf-8"))
        assert entry["description"] == " ".join(data.get("description", "").split())
    table = CliRunner().invoke(app, ["example"]).stdout.splitlines()
    assert [line.split()[0] for line in table] == [e["name"] for e in listed]
    for line, entry in zip(table, listed, strict=True):
        assert entry["description"].startswith(line.split(None, 1)[1].removesuffix("."))


@pytest.mark.parametrize("name", ["dwell", "stl/dwell", "stl/dwell.yaml"])
def test_a_mission_in_a_folder_is_written_by_its_name(name: str, tmp_path: Path) -> None:
    target = tmp_path / "mine.yaml"
    found = CliRunner().invoke(app, ["example", name, "--out", str(target)])
    assert found.exit_code == 0, found.output
    written = target.read_text(encoding="utf-8").splitlines()[1:]
    assert written == (MISSIONS / "stl" / "dwell.yaml").read_text(encoding="utf-8").splitlines()[1:]
    assert load_problem(target).mission.name == "dwell"


@pytest.mark.parametrize("inside", [True, False])
def test_an_example_points_at_the_schema_from_where_it_is_written(
    inside: bool, tmp_path: Path
) -> None:
    target = (ROOT / "out" / "examples-test" / "farm.yaml") if inside else tmp_path / "my.yaml"
    target.unlink(missing_ok=True)
    found = CliRunner().invoke(app, ["example", "farm", "--out", str(target)])
    assert found.exit_code == 0, found.output
    first, *rest = target.read_text(encoding="utf-8").splitlines()
    pointer = first.removeprefix("# yaml-language-server: $schema=")
    assert pointer != first
    assert (target.parent / pointer).resolve() == examples.schema_file()
    assert Path(pointer).is_absolute() is not inside
    assert rest == (MISSIONS / "farm.yaml").read_text(encoding="utf-8").splitlines()[1:]
    assert load_problem(target).mission.name == "farm"
    again = CliRunner().invoke(app, ["example", "farm", "--out", str(target)])
    assert again.exit_code == 2 and "--force" in again.output


def test_an_unknown_example_is_a_usage_error() -> None:
    found = CliRunner().invoke(app, ["example", "fram"])
    assert found.exit_code == 2
    assert "did you mean 'farm'?" in found.output


def test_schema_out_dash_prints_the_schema() -> None:
    found = CliRunner().invoke(app, ["schema", "--out", "-"])
    assert found.exit_code == 0 and found.stdout == json_schema()


def test_the_readme_shortened_mission_validates_as_printed(tmp_path: Path) -> None:
    path = tmp_path / "short.yaml"
    path.write_text(_block("A shortened farm mission", "yaml"), encoding="utf-8")
    problem = load_problem(path)
    assert [t.name for t in problem.tasks] == ["crop_A1", "crop_C"]
    assert problem.tasks[1].sync is not None


def test_the_readme_python_api_runs(tmp_path: Path) -> None:
    code = _block("## Python API", "python")
    assert "missions/sync-pair.yaml" in code and "out/sync-pair" in code
    code = code.replace("missions/sync-pair.yaml", str(MISSIONS / "sync-pair.yaml"))
    code = code.replace("out/sync-pair", str(tmp_path / "plan"))
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "README.md", "exec"), {})  # noqa: S102 - the README's own example
    lines = printed.getvalue().splitlines()
    assert lines[0].startswith("PlanStatus.OPTIMAL") and lines[0].endswith("True")
    assert f"It prints `{lines[0]}`" in README  # what the README says it prints
    assert any(line.startswith("meet True") for line in lines[1:])


def test_every_api_function_the_readme_and_docs_name_exists_as_described() -> None:
    start = README.index("## Python API")
    prose = README[start : README.index("\n## ", start)]
    reference = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    named = set(re.findall(r"`api\.(\w+)", prose + reference))
    assert {"solve", "plan", "check", "replan", "sweep", "Overrides"} <= named
    for name in named:
        assert hasattr(api, name), name
    for name, arguments in re.findall(r"`api\.(\w+)\(([^)]*)\)`", reference):
        parameters = inspect.signature(getattr(api, name)).parameters
        for argument in filter(None, (a.split("=")[0].strip() for a in arguments.split(","))):
            assert argument in parameters, (name, argument)
    assert "tuple[Problem, PlanResult]" in str(inspect.signature(api.plan).return_annotation)
    assert "tolerance" in inspect.signature(api.check).parameters
    assert "Problem" in str(inspect.signature(api.solve).parameters["mission"].annotation)


def test_an_example_to_stdout_with_json_is_the_mission_as_json() -> None:
    found = CliRunner().invoke(app, ["example", "sync-pair", "--out", "-", "--json"])
    assert found.exit_code == 0, found.output
    document = json.loads(found.output)
    assert document["example"] == "sync-pair"
    assert document["mission"] == yaml.safe_load((MISSIONS / "sync-pair.yaml").read_text())
