"""The command line through typer's CliRunner: outputs, exit codes, nothing half-written."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.outputs.plots import ffmpeg
from tests.helpers.paths import MISSIONS, PAIR, ROOT

runner = CliRunner()


def _run(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, list(args))
    return result.exit_code, result.output + (result.stderr if result.stderr_bytes else "")


@pytest.fixture(scope="module")
def pair_plan(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """The pair mission solved once by ``stlplan solve --no-animation`` (the tests only read
    it): its folder and what the command printed on stdout."""
    out = tmp_path_factory.mktemp("pair") / "plan"
    found = runner.invoke(app, ["solve", str(PAIR), "--out", str(out), "--no-animation"])
    assert found.exit_code == 0, found.output
    return out, found.stdout


@pytest.fixture(scope="module")
def reach_avoid_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """reach-avoid solved once by ``stlplan solve -q`` with its animation, a folder the tests
    copy before they solve into it again."""
    out = tmp_path_factory.mktemp("reach-avoid") / "out"
    code, output = _run("solve", str(MISSIONS / "reach-avoid.yaml"), "--out", str(out), "-q")
    assert code == 0, output
    return out


def test_validate_every_shipped_mission() -> None:
    for path in sorted(MISSIONS.glob("*.yaml")):
        code, output = _run("validate", str(path))
        assert code == 0, output
        assert "valid" in output


def test_validate_reports_bad_file_with_exit_3(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nhorizon: [1\n", encoding="utf-8")
    code, message = _run("validate", str(bad))
    assert code == 3
    assert "bad.yaml" in message and "line" in message


def test_missing_mission_is_bad_input(tmp_path: Path) -> None:
    code, message = _run("validate", str(tmp_path / "nope.yaml"))
    assert code == 3
    assert "no such file" in message


def test_schema_command_writes_the_schema(tmp_path: Path) -> None:
    target = tmp_path / "s.json"
    code, _ = _run("schema", "--out", str(target))
    assert code == 0
    assert json.loads(target.read_text())["title"] == "Mission"


def test_solve_writes_every_output_and_check_accepts_it(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    code, output = _run("solve", str(PAIR), "--out", str(out), "-q")
    assert code == 0, output
    names = sorted(p.name for p in out.iterdir())
    movie = ["plan.gif", "plan.mp4"] if ffmpeg() is not None else ["plan.gif"]
    assert names == [
        "convergence.png",
        *movie,
        "plan.html",
        "plan.png",
        "summary.json",
        "timeline.png",
        "trajectory.csv",
    ]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "optimal"
    assert summary["monitor"]["satisfied"] is True
    code, output = _run("check", str(PAIR), str(out / "trajectory.csv"))
    assert code == 0, output


def test_check_exits_1_on_a_violating_trajectory(
    pair_plan: tuple[Path, str], tmp_path: Path
) -> None:
    out, _ = pair_plan
    rows = (out / "trajectory.csv").read_text().splitlines()
    header, body = rows[0], rows[1:]
    # Freeze every agent at its initial state: no input, position never changes.
    frozen = []
    for row in body:
        cells = row.split(",")
        first = next(r for r in body if r.split(",")[0] == cells[0]).split(",")
        n_state = sum(1 for c in header.split(",") if c.startswith("x"))
        state = first[2 : 2 + n_state]
        inputs = ["0" if c != "" else "" for c in cells[2 + n_state :]]
        frozen.append(",".join(cells[:2] + state + inputs))
    bad = tmp_path / "frozen.csv"
    bad.write_text("\n".join([header, *frozen]) + "\n")
    code, output = _run("check", str(PAIR), str(bad))
    assert code == 1
    assert "FAIL" in output


def test_unwritable_output_fails_before_solving(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, message = _run("solve", str(PAIR), "--out", str(blocker / "sub"))
    assert code == 2
    assert "output directory" in message


def test_infeasible_mission_exits_4_and_writes_only_the_summary(tmp_path: Path) -> None:
    text = PAIR.read_text()
    # An input bound of zero: no agent can move, so the goal cannot be reached.
    import yaml

    data = yaml.safe_load(text)
    for dyn in data["dynamics"].values():
        dyn["input_bounds"] = [[0, 0] for _ in dyn["input_bounds"]]
    path = tmp_path / "stuck.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "plan"
    code, _ = _run("solve", str(path), "--out", str(out), "-q")
    assert code == 4
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]
    assert json.loads((out / "summary.json").read_text())["status"] == "infeasible"


@pytest.mark.parametrize("flag", ["--one-step", "--encoding=standard"])
def test_solve_options(tmp_path: Path, flag: str) -> None:
    out = tmp_path / "plan"
    code, output = _run("solve", str(PAIR), "--out", str(out), "-q", "--no-animation", flag)
    assert code == 0, output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == (1 if flag == "--one-step" else 2)


def test_an_empty_output_directory_is_refused(tmp_path: Path) -> None:
    found = CliRunner().invoke(app, ["solve", str(MISSIONS / "reach-avoid.yaml"), "--out", ""])
    assert found.exit_code == 2
    assert "expected a directory name" in found.output


def test_a_rerun_leaves_only_its_own_outputs(reach_avoid_plan: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(reach_avoid_plan, out)
    assert (out / "trajectory.csv").exists() and (out / "plan.png").exists()
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    # the same mission, infeasible: the goal is out of reach in time
    text = (MISSIONS / "reach-avoid.yaml").read_text(encoding="utf-8")
    infeasible = tmp_path / "late.yaml"
    infeasible.write_text(
        text.replace("F[0,12] in(p, Goal)", "F[0,2] in(p, Goal)"), encoding="utf-8"
    )
    second = CliRunner().invoke(app, ["solve", str(infeasible), "--out", str(out), "-q"])
    assert second.exit_code == 4, second.output
    names = sorted(p.name for p in out.iterdir())
    assert names == ["notes.txt", "summary.json"]
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["status"] == "infeasible"


def test_no_animation_writes_none_and_removes_an_earlier_one(
    reach_avoid_plan: Path, tmp_path: Path
) -> None:
    from PIL import Image

    out = tmp_path / "out"
    mission = str(MISSIONS / "reach-avoid.yaml")
    shutil.copytree(reach_avoid_plan, out)
    with Image.open(out / "plan.gif") as gif:
        assert gif.n_frames == 12 * 3 + 1  # horizon 12, three frames per step, the last step
    code, output = _run("solve", mission, "--out", str(out), "-q", "--no-animation")
    assert code == 0, output
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "convergence.png",
        "plan.html",
        "plan.png",
        "summary.json",
        "timeline.png",
        "trajectory.csv",
    ]


def test_summary_json_is_strict(tmp_path: Path) -> None:
    from stlplan.outputs.directory import write_json

    def refuse(name: str) -> None:
        raise ValueError(f"not strict JSON: {name}")

    path = tmp_path / "x.json"
    write_json({"a": float("inf"), "b": [float("nan"), 1.5], "c": (2.0, -float("inf"))}, path)
    assert json.loads(path.read_text(encoding="utf-8"), parse_constant=refuse) == {
        "a": None,
        "b": [None, 1.5],
        "c": [2.0, None],
    }


def test_the_readme_lists_every_exit_code() -> None:
    import stlplan.errors
    from stlplan.cli import planning, shell

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    table = readme[readme.index("Exit codes:") : readme.index("Errors name the file")]
    listed = {int(code) for code in re.findall(r"`(\d+)`", table)}
    errors = {
        cls.exit_code
        for cls in vars(stlplan.errors).values()
        if isinstance(cls, type) and issubclass(cls, stlplan.errors.StlplanError)
    }
    used = errors | set(planning.STATUS_EXIT.values())
    used |= {0, shell.EXIT_VIOLATED, shell.EXIT_INTERNAL}
    assert used | {143} == listed


def test_a_solve_prints_its_verdict_once_and_where_the_outputs_are(
    pair_plan: tuple[Path, str],
) -> None:
    out, stdout = pair_plan
    lines = stdout.splitlines()
    message = json.loads((out / "summary.json").read_text())["message"]
    assert stdout.count(message) == 1  # on the status line only
    assert [line for line in lines if line.startswith("satisfied")] == [
        next(line for line in lines if line.startswith("satisfied: every task"))
    ]
    assert not [line for line in lines if line.startswith("infeasible")]
    assert lines[-1] == f"outputs in {out}"


def test_an_intermediate_infeasible_verdict_beside_a_plan_is_a_note() -> None:
    import dataclasses
    import io

    from rich.console import Console

    from stlplan import api
    from stlplan.outputs.render import print_plan
    from stlplan.result import Check, Confirmation

    _, result = api.plan(MISSIONS / "reach-avoid.yaml")
    checks = (Check((), "Infeasible", 0.01), Check((("presolve", "off"),), "Infeasible", 0.01))
    confirmed = Confirmation("step2", checks, "confirmed")
    noted = dataclasses.replace(result, confirmations=(confirmed,))
    buffer = io.StringIO()
    print_plan(Console(file=buffer, width=400), noted)
    assert "infeasible" not in buffer.getvalue()  # an internal event: --verbose only
    buffer = io.StringIO()
    print_plan(Console(file=buffer, width=400), noted, verbose=True)
    lines = buffer.getvalue().splitlines()
    assert not [line for line in lines if line.startswith("infeasible")]
    notes = [line for line in lines if line.startswith("note ")]
    assert len(notes) == 1 and "infeasible verdict of step2 confirmed" in notes[0]
    assert notes[0].endswith("the plan comes from a later solve")


def test_a_failed_quiet_solve_prints_its_reason_on_stdout(tmp_path: Path) -> None:
    text = (MISSIONS / "reach-avoid.yaml").read_text(encoding="utf-8")
    late = tmp_path / "late.yaml"  # infeasible: the goal is out of reach by step 2
    late.write_text(text.replace("F[0,12] in(p, Goal)", "F[0,2] in(p, Goal)"), encoding="utf-8")
    found = runner.invoke(app, ["solve", str(late), "--out", str(tmp_path / "o"), "-q"])
    assert found.exit_code == 4, found.output
    assert found.stdout.startswith("infeasible: ") and found.stdout.count("\n") == 1
    assert found.stdout.rstrip().endswith(f"outputs in {tmp_path / 'o'}")
    assert found.stderr == ""
