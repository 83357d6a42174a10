"""Every plan of step 1 credited to the stage that found it (stlplan.planner.run.trace): the record,
and on solved missions that the credits are the run's own."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.reached import STAGES
from stlplan.planner.run.trace import Incumbent, Trace
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.missions import crossing_problem, sync_and_errand
from tests.helpers.paths import MISSIONS

EXACT = PlannerConfig().with_overrides({"solver.time_limit": 60.0, "solver.gap": 1e-6})


# ------------------------------------------------------------------------------------ the record
def test_only_a_better_plan_is_credited() -> None:
    trace = Trace()
    for at, objective, stage in [(1, 2.0, "lazy rounds"), (2, 2.0, "held repair"),
                                 (3, 1.0, "held repair"), (4, 3.0, "assembly")]:  # fmt: skip
        trace.credit(Incumbent(at, objective, stage))
    assert [(i.objective, i.stage) for i in trace.incumbents] == [
        (2.0, "lazy rounds"),
        (3.0, "assembly"),
    ]
    record = trace.record([])
    assert record["first_plan"] == "lazy rounds" and record["final_plan"] == "assembly"


def test_a_stage_spends_its_blocks_and_the_rounds_their_solves() -> None:
    clock = Clock.started(None)
    clock.reached.solving(["a", "b"])
    with clock.reached.within("held repair"):
        clock.plan_found(1.0)  # found inside the repair: credited to it
    clock.plan_found(2.0)  # after it, in the lazy rounds again
    rounds = [{"stage": "lazy rounds", "seconds": 1.5}, {"stage": "held repair", "seconds": 9}]
    record = clock.trace.record(rounds)
    assert [i["stage"] for i in record["incumbents"]] == ["held repair", "lazy rounds"]
    assert record["incumbents"][0]["part"] == "a, b"
    assert record["stages"]["lazy rounds"] == 1.5  # a held repair's rounds are in its block
    assert 0 <= record["stages"]["held repair"] < 1.0


def test_a_strict_retry_credits_its_plans_anew() -> None:
    trace = Trace()
    trace.credit(Incumbent(1, 5.0, "lazy rounds"))
    trace.restart()
    trace.credit(Incumbent(2, 4.0, "up front"))
    assert trace.record([])["final_plan"] == "up front"


def test_an_assembly_names_the_stages_of_its_parts_plans() -> None:
    clock = Clock.started(None)
    clock.reached.order = ("a", "b", "c")
    clock.reached.solving(["a", "b"])
    clock.reached.kept()  # a, b kept a plan in their lazy rounds
    clock.reached.solving(["c"])
    with clock.reached.within("repair in turn"):
        clock.reached.kept()
    assert clock.reached.sources([["a", "b"], ["c"]]) == {"lazy rounds": 1, "repair in turn": 1}


# ------------------------------------------------------------------------- solved missions
@pytest.mark.parametrize(
    ("problem", "config", "final"),
    [
        (sync_and_errand, {}, "assembly"),
        (crossing_problem, {}, None),
        (crossing_problem, {"lazy.enabled": False}, "up front"),
    ],
    ids=["parts", "merged", "direct"],
)
def test_the_last_credited_plan_is_the_plan_step_1_ends_with(
    problem: Callable[[], Problem], config: dict[str, Any], final: str | None
) -> None:
    mission = problem()
    result = plan(mission, EXACT.with_overrides(config))
    assert result.status is PlanStatus.OPTIMAL
    trace = result.trace
    found = trace["incumbents"]
    assert found and found[-1]["objective"] == pytest.approx(result.objective, abs=1e-9)
    objectives = [i["objective"] for i in found]
    assert objectives == sorted(objectives) and len(set(objectives)) == len(objectives)
    assert {i["stage"] for i in found} <= set(STAGES)
    assert set(trace["stages"]) <= set(STAGES) and all(s >= 0 for s in trace["stages"].values())
    assert trace["final_plan"] == found[-1]["stage"] and trace["first_plan"] == found[0]["stage"]
    if final is not None:
        assert trace["final_plan"] == final
    if final == "assembly":  # each of the two parts' plans credited to its stage
        assert sum(found[-1]["parts"].values()) == 2


@pytest.mark.heavy
def test_the_summary_and_verbose_show_the_trace(tmp_path: Path) -> None:
    args = ["solve", str(MISSIONS / "warehouse.yaml"), "--out", str(tmp_path), "--no-animation"]
    out = CliRunner().invoke(app, [*args, "--no-html", "--verbose"])
    assert out.exit_code == 0, out.output
    trace = json.loads((tmp_path / "summary.json").read_text())["trace"]
    final = trace["incumbents"][-1]
    lines = [line for line in out.output.splitlines() if line.startswith("plan ")]
    assert len(lines) == len(trace["incumbents"])
    assert f"by {final['stage']} ({final['part']})" in lines[-1]
    assert any(line.startswith("stages ") for line in out.output.splitlines())
