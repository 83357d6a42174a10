"""The profile of a solve: rounds, requirements added and binding by kind, nodes."""

from __future__ import annotations

import csv
from pathlib import Path

from stlplan import profile_bench
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from tests.helpers.missions import swap_problem


def test_a_detour_around_the_other_agent_binds_their_separation() -> None:
    used, result = plan(swap_problem(0.5, horizon=2))  # sampled separation, met exactly
    config = PlannerConfig.model_validate(dict(result.config))
    found = profile_bench.binding(used, result, config)
    assert found["separation step"] >= 1
    assert found["separation segment"] == found["constraint step"] == 0


def test_each_state_is_a_row_and_each_case_a_line_of_the_table(tmp_path: Path) -> None:
    profile_bench.main(
        ["--cases", "stl/narrow-passage", "--runs", "1", "--threads", "1",
         "--semantics", "sampled", "--out", str(tmp_path)]
    )  # fmt: skip
    with (tmp_path / "profile.csv").open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and rows[0]["status"] == "optimal"
    assert int(rows[0]["rounds"]) >= 1 and int(rows[0]["nodes"]) >= 0
    added = sum(int(rows[0][f"added {k}"]) for k in profile_bench.KINDS)
    assert added == int(rows[0]["added constraint step"]) > 0  # sampled: steps only
    text = (tmp_path / "profile.md").read_text(encoding="utf-8")
    assert "| stl/narrow-passage | sampled | 1 | optimal |" in text
