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
    assert [e.name for e in examples.examples()] == sorted(p.stem for p in MISSIONS.glob("*.yaml"))
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
    code = code.replace("missions/farm.yaml", str(MISSIONS / "sync-pair.yaml"))
    code = code.replace("out/farm", str(tmp_path / "plan"))
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "README.md", "exec"), {})  # noqa: S102 - the README's own example
    lines = printed.getvalue().splitlines()
    assert lines[0].startswith("PlanStatus.OPTIMAL") and lines[0].endswith("True")
    assert any(line.startswith("meet True") for line in lines[1:])


def test_every_api_function_the_readme_names_exists_as_described() -> None:
    prose = README[README.index("## Python API") : README.index("## Development")]
    for name in set(re.findall(r"`api\.(\w+)", prose)):
        assert hasattr(api, name), name
    assert "tuple[Problem, PlanResult]" in str(inspect.signature(api.plan).return_annotation)
    assert "tolerance" in inspect.signature(api.check).parameters
    assert "Problem" in str(inspect.signature(api.solve).parameters["mission"].annotation)
