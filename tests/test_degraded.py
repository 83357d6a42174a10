"""Degraded plans: the fewest tasks dropped (by priority, else by count), each named with why."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from stlplan.degraded import (
    Conflict,
    Degraded,
    Undecided,
    cheapest_hitting_set,
    degrade,
    drop_costs,
)
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanStatus
from tests.helpers.missions import mission
from tests.helpers.paths import MISSIONS

DEGRADE = Overrides(time_limit=60, degrade=True)
REGIONS = {
    "West": {"box": [[-2.1, -1.9], [-0.1, 0.1]]},
    "East": {"box": [[1.9, 2.1], [-0.1, 0.1]]},
    "North": {"box": [[-0.1, 0.1], [1.9, 2.1]]},
}


def _at(region: str, priority: int = 0, step: int = 2) -> dict[str, Any]:
    formula = f"F[{step},{step}] in(p, {region})"
    return {"formula": formula, "roles": {"p": {"agent": "a"}}, "priority": priority}


def _one_agent(horizon: int = 2, **tasks: dict[str, Any]) -> Any:
    agents = [{"name": "a", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]}]
    return mission(horizon=horizon, agents=agents, regions=REGIONS, tasks=tasks)


def _far_and_near() -> Any:
    # two agents; `far` needs both at a region neither can reach by step 2, `near` one
    agents = [
        {"name": n, "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]}
        for n in ("a", "b")
    ]
    tasks = {
        "far": {"formula": "F[0,2] in(p, Far)", "count": 2, "roles": {"p": "X"}},
        "near": {"formula": "F[0,2] in(p, East)", "roles": {"p": "X"}},
    }
    regions = {**REGIONS, "Far": {"box": [[4.5, 5], [4.5, 5]]}}
    return mission(horizon=2, agents=agents, regions=regions, tasks=tasks, separation=None)


def test_one_of_two_places_at_once_is_dropped_the_lower_priority_first() -> None:
    problem = _one_agent(west=_at("West", priority=1), east=_at("East"))
    planned, result = plan(problem, DEGRADE)
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["east"]
    assert "cannot be met together with 'west'" in result.dropped[0].reason
    assert [t.name for t in planned.tasks] == ["west"]
    assert result.report is not None and result.report.verdict("west").satisfied


def test_among_equal_priorities_the_fewest_tasks_are_dropped() -> None:
    # west (step 2) conflicts with north (step 2) and east (step 4); north then east can be met
    problem = _one_agent(
        horizon=4,
        west=_at("West", step=2),
        north=_at("North", step=2),
        east=_at("East", step=4),
    )
    _, result = plan(problem, DEGRADE)
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["west"]


def test_a_task_too_few_agents_can_serve_is_named_with_the_cheap_reason() -> None:
    problem = _far_and_near()
    _, result = plan(problem, DEGRADE)
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["far"]
    assert "must reach region 'Far'" in result.dropped[0].reason


def test_without_degrade_an_infeasible_mission_stays_infeasible() -> None:
    problem = _one_agent(west=_at("West"), east=_at("East"))
    _, result = plan(problem, Overrides(time_limit=60))
    assert result.status is PlanStatus.INFEASIBLE and not result.dropped


def test_a_higher_priority_outweighs_every_task_below_it() -> None:
    problem = _one_agent(
        west=_at("West", priority=2), east=_at("East", priority=1), north=_at("North")
    )
    costs = drop_costs(problem)
    assert costs["west"] > costs["east"] + costs["north"]
    assert costs["east"] > costs["north"]


def test_the_cheapest_hitting_set_meets_every_conflict() -> None:
    conflicts = [Conflict(frozenset({"a", "b"})), Conflict(frozenset({"b", "c"}))]
    assert cheapest_hitting_set(conflicts, {"a": 1, "b": 1, "c": 1}) == {"b"}
    assert cheapest_hitting_set(conflicts, {"a": 1, "b": 5, "c": 1}) == {"a", "c"}
    assert (
        cheapest_hitting_set([*conflicts, Conflict(frozenset())], {"a": 1, "b": 1, "c": 1}) is None
    )


@pytest.mark.parametrize("priority", ["high", 1.5])
def test_a_priority_must_be_an_integer(tmp_path: Path, priority: Any) -> None:
    from stlplan.api import validate
    from stlplan.errors import MissionError

    text = (MISSIONS / "sync-pair.yaml").read_text(encoding="utf-8")
    bad = text.replace("    count: 2\n", f"    count: 2\n    priority: {priority!r}\n", 1)
    assert bad != text
    path = tmp_path / "m.yaml"
    path.write_text(bad, encoding="utf-8")
    with pytest.raises(MissionError, match="priority"):
        validate(path)


def test_a_drop_with_no_verdict_in_time_is_undecided_not_infeasible() -> None:
    # the cheap reason names `far`; the mission without it is probed, and the probe runs out
    # of time: the run has no plan in time, where it said "infeasible" (a replan of the farm
    # at 1 s with ir2 lost: crop_B dropped at 3 s)
    problem = _far_and_near()
    probed: list[list[str]] = []

    def out_of_time(kept: Any) -> PlanStatus:
        probed.append([t.name for t in kept.tasks])
        return PlanStatus.NO_PLAN

    assert degrade(problem, out_of_time, 10.0) == Undecided(("far",))
    assert probed == [["near"]]
    assert degrade(problem, lambda kept: PlanStatus.ERROR, 10.0) is None
    found = degrade(problem, lambda kept: PlanStatus.FEASIBLE, 10.0)
    assert isinstance(found, Degraded) and [d.task for d in found.dropped] == ["far"]


def test_a_run_whose_drop_had_no_verdict_in_time_has_no_plan_and_says_so(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stlplan.pipeline

    problem = _one_agent(west=_at("West", priority=1), east=_at("East"))
    monkeypatch.setattr(stlplan.pipeline, "degrade", lambda *args: Undecided(("east",)))
    _, result = plan(problem, DEGRADE)
    assert result.status is PlanStatus.NO_PLAN and result.trajectory is None
    assert "with east dropped, no plan found within the time limit of 60 s" in result.message
