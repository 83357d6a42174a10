"""Scripting the command line: --json documents, JSON errors, --quiet, --version, plain help,
and piped output that is never wrapped."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import __version__, api
from stlplan.cli import app
from tests.helpers.paths import MISSIONS, PAIR, ROOT

COMMANDS = ["validate", "check", "schema", "example", "export-rtamt", "solve", "sweep"]


def _invoke(*args: str) -> tuple[int, str, str]:
    found = CliRunner().invoke(app, list(args), env={"STLPLAN_DEBUG": ""})
    return found.exit_code, found.stdout, found.stderr


def _process(*args: str) -> subprocess.CompletedProcess[str]:
    """``stlplan ARGS`` as a separate process with its output piped (not a terminal)."""
    return subprocess.run(
        [sys.executable, "-m", "stlplan", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
        env={**os.environ, "COLUMNS": "80", "STLPLAN_DEBUG": ""},
    )


@pytest.fixture(scope="module")
def solved(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    """The pair mission solved by a separate process with --json: its folder and stdout."""
    out = tmp_path_factory.mktemp("solved") / "plan"
    done = _process(
        "solve", str(PAIR), "--out", str(out), "--threads", "1", "--no-animation", "--json"
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # stderr holds errors only, not even the solver's banner
    return out, json.loads(done.stdout)


def test_solve_json_prints_the_summary_and_nothing_else(
    solved: tuple[Path, dict[str, object]],
) -> None:
    out, document = solved
    written = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert document == written
    assert document["status"] == "optimal"
    assert document["options"] == {"threads": 1}


def test_check_json_has_full_precision_robustness(solved: tuple[Path, dict[str, object]]) -> None:
    out, _ = solved
    code, stdout, _ = _invoke("check", str(PAIR), str(out / "trajectory.csv"), "--json")
    assert code == 0
    document = json.loads(stdout)
    _, report = api.check(PAIR, out / "trajectory.csv")
    assert document["satisfied"] is True
    assert [v["name"] for v in document["verdicts"]] == [v.name for v in report.verdicts]
    for entry, verdict in zip(document["verdicts"], report.verdicts, strict=True):
        assert entry["robustness"] == verdict.robustness  # bit for bit, not rounded
    assert document["rho_s"] == report.rho_s


def test_validate_json_gives_the_problem_counts() -> None:
    code, stdout, stderr = _invoke("validate", str(MISSIONS / "farm.yaml"), "--json")
    assert code == 0 and stderr == ""
    document = json.loads(stdout)
    assert document["agents"] == 8 and document["tasks"] == 4
    assert document["synchronous_tasks"] == 1 and document["constraints"] == 1
    assert document["groups"] == {"crop_A1": 3, "crop_A2": 3, "crop_B": 6, "crop_C": 3}


def test_sweep_json_prints_the_table(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    code, stdout, _ = _invoke(
        "sweep", str(PAIR), "--runs", "1", "--workers", "1", "--out", str(out), "--json"
    )
    assert code == 0
    rows = json.loads(stdout)
    assert [row["mission"] for row in rows] == ["sync-pair"]
    assert rows[0]["runs"] == 1 and rows[0]["monitor_ok"] == 1


def test_a_bad_mission_with_json_is_one_json_error_on_stderr(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nhorizon: [1\n", encoding="utf-8")
    code, stdout, stderr = _invoke("validate", str(bad), "--json")
    assert code == 3 and stdout == ""
    error = json.loads(stderr)
    assert error["exit_code"] == 3 and error["error"] == "mission"
    assert error["file"] == str(bad)
    assert error["location"].startswith("line ")
    assert "expected" in error["message"] or "YAML" in error["message"]


def test_a_usage_error_with_json_names_the_option() -> None:
    code, stdout, stderr = _invoke("solve", str(PAIR), "--time-limit", "0", "--json")
    assert code == 2 and stdout == ""
    error = json.loads(stderr)
    assert error == {
        "exit_code": 2,
        "error": "usage",
        "message": error["message"],
        "file": None,
        "location": "--time-limit",
    }
    assert "0.001" in error["message"]


def test_a_violating_trajectory_with_json_exits_1_with_the_verdicts(
    solved: tuple[Path, dict[str, object]], tmp_path: Path
) -> None:
    out, _ = solved
    lines = (out / "trajectory.csv").read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    x0 = header.index("x0")
    moved = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[x0] = repr(float(cells[x0]) + 100.0)  # far outside every region and bound
        moved.append(",".join(cells))
    path = tmp_path / "moved.csv"
    path.write_text("\n".join(moved) + "\n", encoding="utf-8")
    code, stdout, _ = _invoke("check", str(PAIR), str(path), "--json")
    assert code == 1
    document = json.loads(stdout)
    assert document["satisfied"] is False
    verdicts = {v["name"]: v for v in document["verdicts"]}
    assert verdicts["meet"]["satisfied"] is False and verdicts["meet"]["rho_s"] < 0


@pytest.mark.heavy
def test_quiet_prints_exactly_one_line(solved: tuple[Path, dict[str, object]]) -> None:
    out, _ = solved
    checked = _process("check", str(PAIR), str(out / "trajectory.csv"), "--quiet")
    assert checked.returncode == 0
    assert checked.stdout.startswith("satisfied: ") and checked.stdout.count("\n") == 1
    assert checked.stderr == ""
    valid = _process("validate", str(PAIR), "-q")
    assert valid.stdout.count("\n") == 1 and valid.stderr == ""
    solved = _process(
        "solve",
        str(PAIR),
        "--out",
        str(out.parent / "quiet"),
        "--threads",
        "1",
        "--no-animation",
        "-q",
    )
    assert solved.returncode == 0
    assert solved.stdout.startswith("satisfied: ") and solved.stdout.count("\n") == 1
    assert solved.stderr == ""  # not even the solver's banner


def test_version() -> None:
    code, stdout, _ = _invoke("--version")
    assert code == 0 and stdout == f"stlplan {__version__}\n"


@pytest.mark.parametrize("command", [None, *COMMANDS])
def test_help_is_plain_and_lists_the_exit_codes(command: str | None) -> None:
    code, stdout, _ = _invoke(*([command] if command else []), "--help")
    assert code == 0
    assert "Exit codes: 0 " in stdout
    for artefact in ("<bool>", "<path>", "{", "}", "<float", "<int", "╭"):
        assert artefact not in stdout, f"{artefact!r} in the help of {command}"


def test_every_command_the_help_names_takes_json_and_quiet() -> None:
    _, top, _ = _invoke("--help")
    assert "Every command takes --json" in " ".join(top.split())
    listed = top.split("Commands:")[1].split("Exit codes:")[0].split()
    named = [word for word in listed if word in COMMANDS]
    assert sorted(named) == sorted(COMMANDS)
    for command in named:
        _, stdout, _ = _invoke(command, "--help")
        assert "--json" in stdout and "--quiet" in stdout, command


def test_schema_json_names_the_file_written(tmp_path: Path) -> None:
    target = tmp_path / "schema.json"
    code, stdout, stderr = _invoke("schema", "--out", str(target), "--json")
    assert code == 0 and stderr == ""
    assert json.loads(stdout) == {"file": str(target)}
    assert json.loads(target.read_text(encoding="utf-8"))["title"] == "Mission"


@pytest.mark.parametrize("to_file", [False, True])
def test_export_rtamt_json_lists_the_specifications(tmp_path: Path, to_file: bool) -> None:
    out = tmp_path / "specs.txt"
    args = ["export-rtamt", str(MISSIONS / "farm.yaml"), "--json"]
    code, stdout, stderr = _invoke(*args, *(["--out", str(out)] if to_file else []))
    assert code == 0 and stderr == ""
    document = json.loads(stdout)
    specs, text = api.export_rtamt(MISSIONS / "farm.yaml")
    assert document["mission"] == "farm" and document["out"] == (str(out) if to_file else None)
    assert [s["text"] for s in document["specifications"]] == [s.text for s in specs]
    assert document["specifications"][0]["agents"] == list(specs[0].agents)
    assert document["not_exported"] == ["crop_B (several roles)", "crop_C (synchronous)"]
    assert not to_file or out.read_text(encoding="utf-8") == text


def test_piped_output_keeps_a_long_path_on_one_line(tmp_path: Path) -> None:
    deep = tmp_path.joinpath(*(["a-rather-long-folder-name"] * 6))
    deep.mkdir(parents=True)
    mission = deep / "sync-pair.yaml"
    mission.write_text(PAIR.read_text(encoding="utf-8"), encoding="utf-8")
    done = _process("validate", str(mission))
    assert done.returncode == 0
    assert len(str(mission)) > 150
    assert str(mission) in done.stdout.splitlines()[0]
    assert "\x1b[" not in done.stdout  # no colour codes in a pipe


def _columns(source: Path, target: Path, keep: list[str], decimals: int | None = None) -> Path:
    """``source`` with only the ``keep`` columns, numbers rounded to ``decimals``."""
    lines = [line.split(",") for line in source.read_text(encoding="utf-8").splitlines()]
    index = [lines[0].index(name) for name in keep]

    def cell(text: str, i: int) -> str:
        if decimals is None or i < 2 or text == "":
            return text
        return f"{round(float(text), decimals)}"

    rows = [[lines[0][i] for i in index]]
    rows += [[cell(line[i], i) for i in index] for line in lines[1:]]
    target.write_text("\n".join(",".join(r) for r in rows) + "\n", encoding="utf-8")
    return target


def test_a_csv_rounded_to_3_decimals_passes_with_tolerance_1e_3(
    solved: tuple[Path, dict[str, object]], tmp_path: Path
) -> None:
    out, _ = solved
    header = (out / "trajectory.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    coarse = _columns(out / "trajectory.csv", tmp_path / "coarse.csv", header, decimals=3)
    code, _, _ = _invoke("check", str(PAIR), str(coarse), "--json")
    assert code == 1
    code, stdout, _ = _invoke("check", str(PAIR), str(coarse), "--tolerance", "1e-3", "--json")
    assert code == 0
    document = json.loads(stdout)
    assert document["tolerance"] == 1e-3 and document["trajectory_gives"] == "inputs"


@pytest.mark.parametrize(
    ("keep", "gives", "says"),
    [
        (["agent", "step", "x0", "x1", "x2", "x3"], "states", "checked on the states only"),
        (["agent", "t", "x0", "x1"], "positions", "dynamics not checked (positions only)"),
    ],
)
def test_check_says_how_the_dynamics_were_checked(
    solved: tuple[Path, dict[str, object]],
    tmp_path: Path,
    keep: list[str],
    gives: str,
    says: str,
) -> None:
    out, _ = solved
    text = (
        (out / "trajectory.csv")
        .read_text(encoding="utf-8")
        .replace("agent,k,", f"agent,{keep[1]},", 1)
    )
    (tmp_path / "renamed.csv").write_text(text, encoding="utf-8")
    other = _columns(tmp_path / "renamed.csv", tmp_path / "other.csv", keep, decimals=3)
    code, stdout, _ = _invoke("check", str(PAIR), str(other), "--tolerance", "1e-3", "--json")
    assert code == 0, stdout
    document = json.loads(stdout)
    assert document["trajectory_gives"] == gives and says in document["dynamics"]
    code, stdout, _ = _invoke("check", str(PAIR), str(other), "--tolerance", "1e-3")
    assert code == 0 and says in stdout


@pytest.mark.parametrize(
    ("mission", "counts"),
    [
        ("scale/farm-x4.yaml", "(32 agents, 4 tasks, 1 constraint)"),
        ("crowd/crowd-64.yaml", "(64 agents, 64 tasks, 1 constraint)"),
    ],
)
def test_a_quiet_validation_is_one_short_line_whatever_the_team(mission: str, counts: str) -> None:
    valid = _process("validate", str(MISSIONS / mission), "-q")
    assert valid.returncode == 0 and valid.stdout.count("\n") == 1
    assert valid.stdout.strip().endswith(counts)
    assert len(valid.stdout) < 120
    assert "groups" not in valid.stdout  # the per-task counts are the full output's
