"""The profile of a solve: rounds, requirements held and binding by kind, nodes."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from stlplan import profile_bench
from stlplan.bench import initial_problem
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from tests.helpers.missions import swap_problem


def test_a_detour_around_the_other_agent_binds_their_separation() -> None:
    used, result = plan(swap_problem(0.5, horizon=2))  # sampled separation, met exactly
    config = PlannerConfig.model_validate(dict(result.config))
    found = profile_bench.binding(used, result, config)
    assert found["separation step"] >= 1
    assert found["separation segment"] == found["constraint step"] == 0


@pytest.mark.heavy
def test_with_a_maximized_margin_binding_is_measured_from_the_plans_margin() -> None:
    used, result = plan(initial_problem("stl/narrow-passage", 0, 0))
    config = PlannerConfig.model_validate(dict(result.config))
    assert result.margin is not None and result.margin > 0.1  # the mission maximizes its margin
    assert sum(profile_bench.binding(used, result, config).values()) >= 1


def test_the_requirements_of_merged_parts_are_counted_once() -> None:
    # a and b are parts of their own whose plans collide between steps: merged, then solved
    _, result = plan(swap_problem(0.5, horizon=3, inter_sample=True))
    assert [r["part"] for r in result.round_log][-1] == "a, b"
    assert sum(result.requirements_by_kind.values()) == result.requirements_added > 0


def test_a_state_with_no_value_is_an_error() -> None:
    problem = swap_problem(0.5, horizon=2)
    with pytest.raises(ValueError, match="no value"):
        profile_bench.step1_states(problem, {})


@pytest.mark.heavy
def test_each_state_is_a_row_and_each_case_a_line_of_the_table(tmp_path: Path) -> None:
    profile_bench.main(
        ["--cases", "stl/narrow-passage", "--runs", "1", "--threads", "1",
         "--semantics", "sampled", "--out", str(tmp_path)]
    )  # fmt: skip
    with (tmp_path / "profile.csv").open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and rows[0]["status"] == "optimal"
    assert int(rows[0]["rounds"]) >= 1 and int(rows[0]["nodes"]) >= 1
    added = sum(int(rows[0][f"added {k}"]) for k in profile_bench.KINDS)
    assert added == int(rows[0]["added constraint step"]) > 0  # sampled: steps only
    assert sum(int(rows[0][f"binding {k}"]) for k in profile_bench.KINDS) >= 1
    text = (tmp_path / "profile.md").read_text(encoding="utf-8")
    assert "| stl/narrow-passage | sampled | 1 | optimal |" in text
