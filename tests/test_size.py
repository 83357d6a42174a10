"""The model's size is estimated before building, and what cannot fit is refused at once."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.analysis import size as size_module
from stlplan.analysis.size import check_size, estimate
from stlplan.cli import app
from stlplan.crowd import mission_text
from stlplan.errors import MissionError
from stlplan.mission.loader import load_problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.model import build_model
from stlplan.planner.solve import model_size
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
    size = check_size(problem)
    assert size.build_seconds < 10
    assert size.variables > 0 and size.rows > 0


def test_the_estimate_grows_with_the_horizon(tmp_path: Path) -> None:
    sizes = [estimate(load_problem(_with_horizon(tmp_path, "farm", h))) for h in (9, 50, 200)]
    assert [s.entries for s in sizes] == sorted(s.entries for s in sizes)
    assert sizes[0].entries < sizes[1].entries < sizes[2].entries
    assert sizes[0].build_seconds < sizes[2].build_seconds


def _limited(problem: object, seconds: float) -> PlannerConfig:
    return PlannerConfig.from_mission(problem.mission).with_overrides(  # type: ignore[attr-defined]
        {"solver.time_limit": seconds}
    )


@pytest.mark.parametrize("agents", [16, 32, 64])
def test_the_shipped_crowds_fit_a_minute(agents: int) -> None:
    # lazily, the first model leaves out every pair's separation: 3 to 9 s to build at 64
    problem = load_problem(MISSIONS / "crowd" / f"crowd-{agents}.yaml")
    size = check_size(problem, _limited(problem, 60))
    assert size.build_seconds < 20
    up_front = estimate(problem, _limited(problem, 60).with_overrides({"lazy.enabled": False}))
    assert up_front.entries > 10 * size.entries


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("mission", "lazy"),
    [("farm.yaml", True), ("farm.yaml", False), ("crowd/crowd-16.yaml", True),
     ("crowd/crowd-16.yaml", False), ("warehouse.yaml", False)],
)  # fmt: skip
def test_the_estimate_counts_the_model_built(mission: str, lazy: bool) -> None:
    problem = load_problem(MISSIONS / mission)
    config = PlannerConfig.from_mission(problem.mission).with_overrides(
        {"lazy.enabled": lazy, "model.floors": False}
    )
    built = model_size(build_model(problem, config).model)
    ratio = estimate(problem, config).entries / (built.variables + built.constraints)
    assert 0.7 < ratio < 1.5, ratio


@pytest.mark.parametrize(
    ("mission", "horizon", "why"),
    [
        ("farm", 100_000, "GiB of memory"),
        ("farm", 10_000, "where"),  # memory or time, depending on the machine
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


@pytest.fixture
def plenty_of_memory(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(size_module, "available_memory", lambda: 2**62)


@pytest.mark.usefixtures("plenty_of_memory")
def test_a_long_horizon_is_refused_for_its_effort_floors(tmp_path: Path) -> None:
    # each agent's effort-floor LP is dense in the horizon: about 30 s each to set up at 4000
    problem = load_problem(_with_horizon(tmp_path, "sync-pair", 4_000))
    with pytest.raises(MissionError, match="s to build where the time limit is 60 s"):
        check_size(problem, _limited(problem, 60))
    without = _limited(problem, 60).with_overrides({"model.floors": False})
    assert check_size(problem, without).build_seconds < 60


@pytest.mark.usefixtures("plenty_of_memory")
def test_a_crowd_of_hundreds_is_refused_for_its_pairs(tmp_path: Path) -> None:
    path = tmp_path / "crowd-400.yaml"
    path.write_text(mission_text(400), encoding="utf-8")
    problem = load_problem(path)
    with pytest.raises(MissionError) as caught:
        check_size(problem, _limited(problem, 60))
    text = str(caught.value)
    # 79,800 pairs and 400 agents past 4 pillars, at 21 steps each
    assert "400 agents; 1,709,400 step requirements left for the lazy rounds" in text
    assert "s to build where the time limit is 60 s" in text


def test_solve_refuses_before_creating_the_output_folder(tmp_path: Path) -> None:
    path = _with_horizon(tmp_path, "farm", 10_000)
    out = tmp_path / "out"
    result = runner.invoke(app, ["solve", str(path), "--out", str(out)], env={"COLUMNS": "300"})
    assert result.exit_code == 3, result.output
    assert "the model would have about" in result.output
    assert not out.exists()


@pytest.mark.usefixtures("plenty_of_memory")
def test_a_longer_time_limit_admits_a_slow_build(tmp_path: Path) -> None:
    problem = load_problem(_with_horizon(tmp_path, "sync-pair", 4_000))
    size = estimate(problem)
    with pytest.raises(MissionError):
        check_size(problem, _limited(problem, 60))
    assert check_size(problem, _limited(problem, size.build_seconds * 2)) == size
