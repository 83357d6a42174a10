"""The model's size is estimated before building, and what cannot fit is refused at once."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.analysis.size import check_size, estimate
from stlplan.cli import app
from stlplan.errors import MissionError
from stlplan.mission.loader import load_problem
from tests.helpers.paths import MISSIONS

runner = CliRunner()


def _with_horizon(tmp: Path, mission: str, horizon: int) -> Path:
    text = (MISSIONS / f"{mission}.yaml").read_text(encoding="utf-8")
    old = next(line for line in text.splitlines() if line.startswith("horizon:"))
    path = tmp / f"{mission}-{horizon}.yaml"
    path.write_text(text.replace(old, f"horizon: {horizon}"), encoding="utf-8")
    return path


@pytest.mark.parametrize("path", sorted(MISSIONS.glob("*.yaml")), ids=lambda p: p.stem)
def test_shipped_missions_fit(path: Path) -> None:
    problem = load_problem(path)
    size = check_size(problem, problem.mission.solver.time_limit)
    assert size.build_seconds < 10
    assert size.variables > 0 and size.rows > 0


def test_the_estimate_grows_with_the_horizon(tmp_path: Path) -> None:
    sizes = [estimate(load_problem(_with_horizon(tmp_path, "farm", h))) for h in (9, 50, 200)]
    assert [s.entries for s in sizes] == sorted(s.entries for s in sizes)
    assert sizes[0].entries < sizes[1].entries < sizes[2].entries
    assert sizes[0].build_seconds < sizes[2].build_seconds


@pytest.mark.parametrize(
    ("mission", "horizon", "why"),
    [
        ("farm", 100_000, "GiB of memory"),
        ("farm", 2_000, "where"),  # memory or time, depending on the machine
        ("sync-pair", 2_000, "s to build where the time limit is 60 s"),
    ],
)
def test_a_model_that_cannot_fit_is_refused_at_once(
    tmp_path: Path, mission: str, horizon: int, why: str
) -> None:
    path = _with_horizon(tmp_path, mission, horizon)
    started = time.perf_counter()
    with pytest.raises(MissionError) as caught:
        api.validate(path)
    assert time.perf_counter() - started < 1.0
    text = str(caught.value)
    assert text.startswith(f"{path}: horizon: the model would have about"), text
    assert f"horizon {horizon}" in text and why in text
    assert "shorten the horizon" in text


def test_solve_refuses_before_creating_the_output_folder(tmp_path: Path) -> None:
    path = _with_horizon(tmp_path, "farm", 2_000)
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(path), "--out", str(out)], env={"COLUMNS": "300"})
    assert result.exit_code == 3, result.output
    assert "the model would have about" in result.output
    assert not out.exists()


def test_a_longer_time_limit_admits_a_slow_build(tmp_path: Path) -> None:
    problem = load_problem(_with_horizon(tmp_path, "sync-pair", 2_000))
    size = estimate(problem)
    with pytest.raises(MissionError):
        check_size(problem, 60)
    assert check_size(problem, size.build_seconds * 2) == size
