"""Command-line input refused with a clear message before anything is written: out-of-range
limits, output paths that are folders or sit under a file, a sweep or simulation that cannot
start (a mission without a sweep region, a malformed scheduler address, runs on record)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.cli import app
from tests.helpers.paths import MISSIONS, PAIR

runner = CliRunner()


def _run(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, list(args))
    return result.exit_code, result.output


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--threads", "100000", "less than or equal to 256"),
        ("--threads", "0", "--threads"),
        ("--time-limit", "inf", "expected seconds from 0.001 to 1e6, found inf"),
        ("--time-limit", "nan", "expected seconds from 0.001 to 1e6, found nan"),
    ],
)
def test_solve_refuses_limits_out_of_range(
    tmp_path: Path, option: str, value: str, message: str
) -> None:
    out = tmp_path / "out"
    code, text = _run("solve", str(PAIR), option, value, "--out", str(out))
    assert code == 2
    assert message in text
    assert not out.exists()


def test_schema_refuses_a_folder_and_an_empty_name(tmp_path: Path) -> None:
    code, text = _run("schema", "--out", str(tmp_path))
    assert code == 2
    assert "is a folder; expected a file name" in text
    code, text = _run("schema", "--out", "")
    assert code == 2
    assert "expected a file name, found an empty string" in text


@pytest.fixture(scope="module")
def pair_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("pair")
    api.solve(PAIR, out, animation=False, viewer=False)
    return out / "trajectory.csv"


def test_check_plot_refuses_a_folder_and_a_path_under_a_file(
    tmp_path: Path, pair_plan: Path
) -> None:
    code, text = _run("check", str(PAIR), str(pair_plan), "--plot", str(tmp_path))
    assert code == 2
    assert f"{tmp_path} is a folder; expected a PNG file name" in text
    blocker = tmp_path / "afile"
    blocker.write_text("", encoding="utf-8")
    code, text = _run("check", str(PAIR), str(pair_plan), "--plot", str(blocker / "map.png"))
    assert code == 2
    assert f"{blocker} is a file" in text
    assert list(tmp_path.iterdir()) == [blocker]


def test_check_plot_creates_its_folder(tmp_path: Path, pair_plan: Path) -> None:
    target = tmp_path / "new" / "map.png"
    code, _ = _run("check", str(PAIR), str(pair_plan), "--plot", str(target), "--quiet")
    assert code == 0
    assert target.stat().st_size > 0


def test_sweep_of_a_mission_without_a_sweep_region_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    code, text = _run("sweep", str(MISSIONS / "reach-avoid.yaml"), "--runs", "1", "--out", str(out))
    assert code == 3
    assert "a sweep needs 'sweep: {initial_region: NAME}'" in text
    assert not out.exists()


@pytest.mark.parametrize("command", ["sweep", "simulate"])
def test_a_malformed_scheduler_address_is_bad_usage_and_writes_nothing(
    tmp_path: Path, command: str
) -> None:
    out = tmp_path / command
    code, text = _run(
        command, str(PAIR), "--scheduler", "notaurl", "--runs", "1", "--out", str(out)
    )
    assert code == 2
    assert "--scheduler notaurl" in text and "expected tcp://HOST:PORT" in text
    assert not out.exists()


def test_a_sweep_refused_for_runs_on_record_says_nothing_of_where_it_runs(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    out.mkdir()
    record = {"mission": "sync-pair", "run": 0, "seed": 0, "status": "optimal"}
    (out / "runs.jsonl").write_text(json.dumps(record) + "\n", encoding="utf-8")
    code, text = _run("sweep", str(PAIR), "--runs", "1", "--workers", "1", "--out", str(out))
    assert code == 2
    assert "pass --resume" in text
    assert "sweep runs" not in text


def test_help_texts_fit_their_commands() -> None:
    _, text = _run("example", "--help")
    assert "example [OPTIONS] [NAME]" in text
    _, text = _run("simulate", "--help")
    assert "Each replan answers within" in " ".join(text.split())
    assert "Only trajectory.csv" not in text
