"""`stlplan replan`: a plan directory from a step of an executed plan; bad input refused."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from tests.helpers.paths import PAIR

runner = CliRunner()


def _run(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, list(args))
    return result.exit_code, result.output + (result.stderr if result.stderr_bytes else "")


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped pair's plan, as a team would execute it."""
    out = tmp_path_factory.mktemp("pair")
    code, text = _run("solve", str(PAIR), "--out", str(out), "-q", "--no-animation", "--no-html")
    assert code == 0, text
    return out / "trajectory.csv"


def test_a_replan_writes_a_plan_that_keeps_the_executed_past(planned: Path, tmp_path: Path) -> None:
    out = tmp_path / "again"
    code, text = _run(
        "replan", str(PAIR), str(planned), "--at", "3", "--out", str(out), "-q",
        "--no-animation", "--no-html",
    )  # fmt: skip
    assert code == 0, text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["replan"]["step"] == 3 and summary["replan"]["events"] == []
    assert summary["monitor"]["satisfied"]
    before = {(r["agent"], r["k"]): r for r in csv.DictReader(planned.open())}
    for row in csv.DictReader((out / "trajectory.csv").open()):
        if int(row["k"]) <= 3:
            old = before[row["agent"], row["k"]]
            assert float(row["x0"]) == pytest.approx(float(old["x0"]), abs=1e-9)


def test_the_past_alone_may_be_given_without_inputs(planned: Path, tmp_path: Path) -> None:
    rows = [r for r in csv.DictReader(planned.open()) if int(r["k"]) <= 2]
    past = tmp_path / "past.csv"
    with past.open("w", newline="") as f:
        writer = csv.DictWriter(
            f, fieldnames=["agent", "k", "x0", "x1", "x2", "x3"], extrasaction="ignore"
        )
        writer.writeheader()
        writer.writerows(rows)
    code, text = _run(
        "replan", str(PAIR), str(past), "--at", "2", "--out", str(tmp_path / "o"), "-q",
        "--no-animation", "--no-html",
    )  # fmt: skip
    assert code == 0, text


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--at", "99"], "--at 99: expected a step in 0.."),
        (["--at", "2", "--lost", "nobody"], "--lost nobody: no such agent"),
        (["--at", "2", "--closed", "Nowhere"], "--closed Nowhere: no such region"),
    ],
)
def test_bad_events_exit_3_and_write_nothing(
    planned: Path, tmp_path: Path, args: list[str], expected: str
) -> None:
    out = tmp_path / "never"
    code, text = _run("replan", str(PAIR), str(planned), *args, "--out", str(out))
    assert code == 3 and expected in text
    assert not out.exists()


def test_an_executed_file_missing_a_step_before_k_is_refused(planned: Path, tmp_path: Path) -> None:
    lines = planned.read_text().splitlines(keepends=True)
    short = tmp_path / "short.csv"
    short.write_text("".join(line for line in lines if ",2," not in line))
    out = tmp_path / "never"
    code, text = _run("replan", str(PAIR), str(short), "--at", "4", "--out", str(out))
    assert code == 3 and "no row for step(s) 2" in text
    assert not out.exists()


@pytest.mark.parametrize("at", [4, 5])
def test_a_replan_writes_no_coefficient_the_solver_drops(
    planned: Path, tmp_path: Path, at: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the past's states on a predicate's boundary once gave big-M values of round-off, which
    # HiGHS dropped with a warning on the terminal
    from pyomo.environ import Constraint
    from pyomo.repn import generate_standard_repn

    from stlplan.planner.backend.session import HighsSession

    solve, tiny = HighsSession.solve_once, []

    def scanned(self: HighsSession, *args: object, **kwargs: object) -> object:
        for row in self.model.component_data_objects(Constraint, active=True):
            coefs = generate_standard_repn(row.body, quadratic=False).linear_coefs
            tiny.extend(c for c in coefs if c != 0 and abs(c) <= 1e-9)
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(HighsSession, "solve_once", scanned)
    out = tmp_path / "again"
    code, text = _run(
        "replan", str(PAIR), str(planned), "--at", str(at), "--out", str(out),
        "--no-animation", "--no-html",
    )  # fmt: skip
    assert code == 0, text
    assert tiny == [] and "WARNING" not in text


@pytest.mark.parametrize("value", ["nan", "-1", "inf", "abc"])
def test_a_bad_robust_to_is_refused_alike_by_every_command(
    planned: Path, tmp_path: Path, value: str
) -> None:
    commands = {
        "solve": ["solve", str(PAIR)],
        "replan": ["replan", str(PAIR), str(planned), "--at", "3"],
        "simulate": ["simulate", str(PAIR), "--runs", "1"],
    }
    for name, args in commands.items():
        out = tmp_path / name
        code, text = _run(*args, "--robust-to", value, "--out", str(out))
        assert code == 3, (name, text)
        assert f"--robust-to {value}: expected a" in text and "Value error" not in text
        assert not out.exists()
