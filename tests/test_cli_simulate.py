"""`stlplan simulate`: bad input refused before anything is written, the JSON document, resume,
run 0's figures and the robustness figure."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.sweep.runner import read_records
from tests.helpers.paths import PAIR

runner = CliRunner()
QUICK = ["--workers", "1", "--threads", "1", "--time-limit", "60"]


def _run(*args: str) -> tuple[int, str, str]:
    result = runner.invoke(app, ["simulate", str(PAIR), *args])
    return result.exit_code, result.stdout, result.stderr if result.stderr_bytes else ""


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--disturbance", "-0.1"], "--disturbance -0.1: expected a finite number >= 0"),
        (["--disturbance", "abc"], "--disturbance abc: expected a number >= 0"),
        (["--robust-to", "-1"], "--robust-to -1: expected a finite number >= 0"),
        (["--lose", "ghost@2"], "--lose ghost@2: no such agent; agents: south, north"),
        (["--lose", "south@8"], "--lose south@8: expected a step in 0..7"),
        (["--lose", "south@-1"], "--lose south@-1: expected a step in 0..7"),
        (["--lose", "south@1", "--lose", "south@3"], "--lose south: lost twice"),
        (["--lose", "south"], "--lose south: expected AGENT@K"),
        (["--close", "Nowhere@2"], "--close Nowhere@2: no such region"),
        (["--runs", "0"], "--runs 0: expected at least 1 run"),
    ],
)
def test_bad_input_exits_3_and_writes_nothing(
    tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "out"
    code, stdout, stderr = _run(*args, "--out", str(out), "--json")
    assert code == 3, stderr
    assert stdout == ""
    error = json.loads(stderr)
    assert error["exit_code"] == 3 and message in error["message"]
    assert not out.exists()


def test_json_prints_one_document_of_runs_and_the_fraction_satisfied(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    args = ["--runs", "3", "--disturbance", "0.05", "--replan", "never", "--seed", "2"]
    code, stdout, stderr = _run(*args, "--out", str(out), "--json", *QUICK)
    assert code == 0, stderr
    document = json.loads(stdout)
    runs = document["runs"]
    assert [r["run"] for r in runs] == [0, 1, 2]
    fraction = sum(r["satisfied"] for r in runs) / 3
    assert document["satisfied_fraction"] == pytest.approx(fraction)
    for run in runs:
        assert run["status"] in ("satisfied", "violated")
        assert run["disturbance"] == 0.05 and run["replan"] == "never" and run["seed"] == 2
        assert run["replans"] == 0 and run["dropped"] == [] and "executed" not in run
        assert set(run) >= {"rho_s", "replan_median_s", "replan_max_s", "failed"}
    assert len({json.dumps(r["rho_s"]) + str(r["failed"]) for r in runs}) > 1  # runs differ
    assert (out / "run-0.png").stat().st_size > 10_000
    assert (out / "table.md").read_text().startswith("| run | status |")


@pytest.mark.heavy
def test_resume_skips_the_runs_on_record(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    args = ["--disturbance", "0.02", "--replan", "on-deviation", "--out", str(out), *QUICK]
    code, _, stderr = _run("--runs", "1", *args, "-q")
    assert code == 0, stderr
    first = (out / "runs.jsonl").read_text()
    code, _, stderr = _run("--runs", "2", *args, "-q")
    assert code == 2 and "pass --resume" in stderr
    code, stdout, stderr = _run("--runs", "2", "--resume", *args, "-q")
    assert code == 0, stderr
    assert (out / "runs.jsonl").read_text().startswith(first)  # run 0 kept as it was
    assert sorted(r["run"] for r in read_records(out)) == [0, 1]
    assert "of 2 runs satisfied" in stdout
    code, _, stderr = _run("--runs", "2", "--resume", "--disturbance", "0.03", "--out", str(out))
    assert code == 2 and "disturbance 0.02 recorded, 0.03 now" in stderr


@pytest.mark.heavy
def test_plot_draws_the_fraction_satisfied_against_the_disturbance(tmp_path: Path) -> None:
    for w, policy in (("0", "never"), ("0.1", "never"), ("0.1", "every")):
        out = tmp_path / f"{policy}-{w}"
        code, _, stderr = _run("--runs", "2", "--disturbance", w, "--replan", policy,
                               "--out", str(out), "-q", *QUICK)  # fmt: skip
        assert code == 0, stderr
    code, stdout, stderr = _run("--plot", "--out", str(tmp_path), "--json")
    assert code == 0, stderr
    points = json.loads(stdout)["points"]
    assert [(p["configuration"], p["disturbance"], p["runs"]) for p in points] == [
        ("every", 0.1, 2),
        ("never", 0.0, 2),
        ("never", 0.1, 2),
    ]
    assert points[1]["satisfied_fraction"] == 1.0
    assert (tmp_path / "robustness.png").stat().st_size > 10_000
    code, _, stderr = _run("--plot", "--out", str(tmp_path / "empty"))
    assert code == 2 and "no simulation of sync-pair is recorded" in stderr


def test_a_mission_without_a_plan_exits_as_solve_does(tmp_path: Path) -> None:
    from tests.helpers.paths import MISSIONS

    text = (MISSIONS / "reach-avoid.yaml").read_text(encoding="utf-8")
    stuck = text.replace("input_bounds: [[-1, 1], [-1, 1]]", "input_bounds: [[0, 0], [0, 0]]")
    assert stuck != text
    mission = tmp_path / "stuck.yaml"
    mission.write_text(stuck, encoding="utf-8")
    found = runner.invoke(
        app, ["simulate", str(mission), "--out", str(tmp_path / "out"), "--json", *QUICK]
    )
    assert found.exit_code == 4, found.output
    document = json.loads(found.stdout)
    assert document["runs"] == [] and document["message"].startswith("no plan to execute")


def test_a_simulation_without_a_plan_to_execute_writes_nothing(tmp_path: Path) -> None:
    # margins for a disturbance of 100 leave the pair no plan
    out = tmp_path / "out"
    code, stdout, stderr = _run("--runs", "1", *QUICK, "--robust-to", "100", "--out", str(out))
    assert code == 4, stdout + stderr
    assert "no plan to execute" in stdout + stderr
    assert not out.exists()


def test_a_disturbance_beyond_a_whole_state_range_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code, stdout, stderr = _run("--disturbance", "50", "--out", str(out))
    assert code == 3, stdout + stderr
    assert "--disturbance 50: larger than south's whole range of state component" in stderr
    assert not out.exists()
