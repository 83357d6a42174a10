"""The prioritized repair: parts planned one after another, each around those before it."""

from __future__ import annotations

import contextlib
from typing import Any

import numpy as np
import pytest

from stlplan import crowd
from stlplan.mission.loader import load_problem, problem_from_text
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from stlplan.planner.first_plan import hooks, prioritized
from stlplan.planner.first_plan.prioritized import first_order, plan_in_order, raised
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.budget import Budget
from stlplan.planner.strategy import policy_of
from tests.helpers.paths import MISSIONS

ROOM = crowd.Room(side=4.0, radius=1.6, pillar_offset=0.6, pillar_half=0.25, horizon=12, hold=2)


@pytest.fixture(scope="module")
def small_crowd() -> Any:
    return problem_from_text(crowd.mission_text(6, ROOM), "crowd-6.yaml")


class _Turn:
    """A turn that fails the first ``fails`` times, else plans its agent at ``value``."""

    def __init__(self, name: str, value: float, fails: int = 0) -> None:
        self.name, self.value, self.fails, self.seen = name, value, fails, []

    def solve(
        self, fixed: dict[str, np.ndarray], budget: Budget, exact: bool = True
    ) -> dict[str, np.ndarray] | None:
        self.seen.append(sorted(fixed))
        if self.fails:
            self.fails -= 1
            return None
        return {self.name: np.full((3, 2), self.value)}


def _names(planned: list[tuple[int, dict[str, np.ndarray]]]) -> list[str]:
    return [name for _, states in planned for name in states]


class _Guided:
    """A part of one agent whose own plan goes from ``start`` to ``end``."""

    def __init__(self, start: tuple[float, float], end: tuple[float, float], guided: bool = True):
        self.own = {"a": np.array([start, end], dtype=float)}
        self.guided = guided


def test_guided_parts_are_first_ordered_by_the_direction_they_travel() -> None:
    # west (angle pi), north (pi/2), south-east (-pi/4), east (0): ordered by angle, the
    # mission's listing left out
    parts = [
        _Guided((4, 4), (1, 4)),
        _Guided((4, 1), (4, 7)),
        _Guided((0, 8), (3, 5)),
        _Guided((1, 1), (5, 1)),
    ]
    assert first_order(parts) == [2, 3, 1, 0]
    assert first_order(parts[::-1]) == [1, 0, 2, 3]  # the same parts, listed the other way


def test_parts_that_are_not_all_guided_keep_their_own_order() -> None:
    parts = [_Guided((4, 4), (1, 4)), _Guided((1, 1), (5, 1), guided=False)]
    assert first_order(parts) == [0, 1]


def test_each_part_is_planned_around_the_parts_before_it() -> None:
    turns = [_Turn("a", 0.0), _Turn("b", 1.0), _Turn("c", 2.0)]
    planned, failed = plan_in_order(turns, [2, 0, 1], Budget.of_seconds(10))
    assert failed is None and _names(planned) == ["c", "a", "b"]
    assert [t.seen for t in turns] == [[["c"]], [["a", "c"]], [[]]]


def test_a_part_without_a_plan_ends_the_order_and_goes_before_the_parts_in_its_way() -> None:
    turns = [_Turn("a", 0.0), _Turn("b", 1.0, fails=1), _Turn("c", 2.0)]
    planned, failed = plan_in_order(turns, [0, 1, 2], Budget.of_seconds(10))
    assert failed == 1 and _names(planned) == ["a"] and turns[2].seen == []
    assert raised([0, 1, 2], 1) == [1, 0, 2]  # nothing known in its way: first
    # before the last part in its way, then the one before it, then first
    assert raised([0, 1, 2, 3], 3, [2, 1]) == [0, 1, 3, 2]
    assert raised([0, 1, 2, 3], 3, [2, 1], tries=2) == [0, 3, 1, 2]
    assert raised([0, 1, 2, 3], 3, [2, 1], tries=3) == [3, 0, 1, 2]


def test_the_next_order_keeps_the_plans_of_the_parts_it_starts_with() -> None:
    turns = [_Turn("a", 0.0), _Turn("b", 1.0), _Turn("c", 2.0, fails=1), _Turn("d", 3.0)]
    planned, failed = plan_in_order(turns, [0, 1, 2, 3], Budget.of_seconds(10))
    assert failed == 2 and _names(planned) == ["a", "b"]
    planned, failed = plan_in_order(turns, [0, 2, 1, 3], Budget.of_seconds(10), before=planned)
    assert failed is None and _names(planned) == ["a", "c", "b", "d"]
    assert len(turns[0].seen) == 1  # kept: "a" was first in both orders
    assert len(turns[1].seen) == 2  # planned again: "c" is now before it


def test_each_turn_may_use_what_is_left_of_the_order_time() -> None:
    # an order fails with any of its turns, so a turn is not held to an equal share (with 64
    # parts, a share shorter than one least solve ended every turn after its first solve)
    budgets: list[float] = []

    class Timed(_Turn):
        def solve(self, fixed: dict[str, np.ndarray], budget: Budget, exact: bool = True) -> Any:
            budgets.append(budget.remaining())
            return super().solve(fixed, budget, exact)

    turns = [Timed(name, float(i)) for i, name in enumerate("abcd")]
    planned, failed = plan_in_order(turns, [0, 1, 2, 3], Budget.of_seconds(8))
    assert failed is None and len(planned) == 4
    assert min(budgets) > 7.0  # not 8 / 4


def _merge_repairs(config: PlannerConfig) -> list[str]:
    return [r.describe() for r, _ in policy_of(config).merge_repairs(9)]


def test_crowd_merges_try_the_prioritized_repair_first_unless_switched_off() -> None:
    names = _merge_repairs
    assert names(PlannerConfig()) == ["prioritized", "in turn", "held"]
    assert names(PlannerConfig().with_overrides({"repair.orders": 0})) == ["in turn", "held"]
    assert [r.describe() for r, _ in policy_of(PlannerConfig()).merge_repairs(2)] == ["held"]


def test_a_colliding_crowd_gets_its_plan_from_the_prioritized_repair(
    small_crowd: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    found: list[Any] = []
    real = hooks.prioritized

    def spy(*args: Any) -> Any:
        found.append(real(*args))
        return found[-1]

    monkeypatch.setattr(hooks, "prioritized", spy)
    overrides = Overrides(
        time_limit=120,
        threads=1,
        first_plan=True,
        config={"repair.crowd_agents": 2, "repair.crowd_team": None},
    )
    _, result = plan(small_crowd, overrides)
    assert found and found[0] is not None and found[0].meets_all
    assert result.status.has_plan and result.report is not None and result.report.satisfied


def test_merges_of_larger_parts_skip_the_prioritized_repair() -> None:
    def names(config: PlannerConfig, largest: int) -> list[str]:
        return [r.describe() for r, _ in policy_of(config).merge_repairs(9, largest)]

    default = PlannerConfig()
    assert names(default, default.repair.part_agents) == ["prioritized", "in turn", "held"]
    assert names(default, default.repair.part_agents + 1) == ["in turn", "held"]
    wider = default.with_overrides({"repair.part_agents": 9})
    assert names(wider, 9) == ["prioritized", "in turn", "held"]


def _guided_turns(small_crowd: Any, monkeypatch: pytest.MonkeyPatch, config: dict) -> Any:
    """The plan of the small crowd by the prioritized repair, and the guided turns' results."""
    sided: list[Any] = []
    real = prioritized.Turn.sided

    def spy(self: Any, *args: Any) -> Any:
        sided.append(real(self, *args))
        return sided[-1]

    monkeypatch.setattr(prioritized.Turn, "sided", spy)
    overrides = Overrides(
        time_limit=120, threads=1, first_plan=True,
        config={"repair.crowd_agents": 2, "repair.crowd_team": None, **config},
    )  # fmt: skip
    _, result = plan(small_crowd, overrides)
    return result, sided


def test_single_integrators_turns_are_solved_on_the_sides_of_a_guide_path(
    small_crowd: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    result, sided = _guided_turns(small_crowd, monkeypatch, {})
    assert sum(found is not None for found in sided) >= 2
    assert result.status.has_plan and result.report is not None and result.report.satisfied
    # the parts' bound stays with the plan, and the gap printed is the written plan's own
    assert result.bound is not None and result.objective is not None
    own = (result.bound - result.objective) / abs(result.objective)
    assert result.gap == pytest.approx(max(0.0, own))
    assert f"gap {result.gap:.2%}" in result.message  # the message speaks of the same plan


@pytest.mark.heavy
def test_turns_without_the_guide_solve_their_disjunctions(
    small_crowd: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # (agents of other dynamics than a single integrator in the plane get no guide)
    monkeypatch.setattr(prioritized, "single_integrator", lambda agent: False)
    result, sided = _guided_turns(small_crowd, monkeypatch, {})
    assert sided == []
    assert result.status.has_plan and result.report is not None and result.report.satisfied


@pytest.mark.slow
@pytest.mark.timeout(600)
@pytest.mark.parametrize("agents", [32, 64])
def test_the_32_and_64_agent_crowds_have_a_first_plan_within_a_minute(agents: int) -> None:
    # crowd-32's turns' MILPs took 76 s of 150 before they were guided; crowd-64 had none in
    # 60 s until its guide paths kept the task's witness and a failed part moved only before
    # the parts in its way
    # (deterministic: the decisions read the solver's work, not the clock, so a loaded machine
    # takes the same path, on one thread; the limit leaves room for that path to take longer)
    problem = load_problem(MISSIONS / "crowd" / f"crowd-{agents}.yaml")
    overrides = Overrides(time_limit=120, first_plan=True, deterministic=True)
    _, result = plan(problem, overrides)
    assert result.status.has_plan and result.report is not None and result.report.satisfied
    assert result.first_plan_seconds is not None and result.first_plan_seconds <= 60


def test_the_solve_joining_the_turns_plans_may_use_all_the_repairs_time(
    small_crowd: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the orders take budget.search_share of the time; when every part has a plan, the
    # solve that joins them is the likeliest plan, and 2 s short of 3 s lost crowd-64's
    deadlines: dict[str, float] = {}
    order, held = prioritized.plan_in_order, prioritized.held_plan

    def orders(turns: Any, order_: Any, budget: Budget, *args: Any) -> Any:
        deadlines["orders"] = budget.deadline
        return order(turns, order_, budget, *args)

    def joined(merged: Any, turns: Any, config: Any, budget: Budget) -> Any:
        deadlines["held"] = budget.deadline
        return held(merged, turns, config, budget)

    monkeypatch.setattr(prioritized, "plan_in_order", orders)
    monkeypatch.setattr(prioritized, "held_plan", joined)
    overrides = Overrides(
        time_limit=120,
        threads=1,
        first_plan=True,
        config={"repair.crowd_agents": 2, "repair.crowd_team": None},
    )
    _, result = plan(small_crowd, overrides)
    assert result.status.has_plan and result.report is not None and result.report.satisfied
    assert deadlines["held"] > deadlines["orders"] + 1.0


def test_a_team_merged_into_one_part_needs_no_assembly(
    small_crowd: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the merged part's model is a model of the whole problem: its plan is the run's (the
    # assembly solve took 8 s of crowd-64's 60)
    from stlplan.planner.core import components

    assembled: list[Any] = []
    monkeypatch.setattr(components, "assembled_objective", lambda *args: assembled.append(args))
    overrides = Overrides(
        time_limit=120,
        threads=1,
        first_plan=True,
        config={"repair.crowd_agents": 2, "repair.crowd_team": None},
    )
    _, result = plan(small_crowd, overrides)
    assert assembled == []
    assert result.status.has_plan and result.report is not None and result.report.satisfied
    assert result.objective is not None and result.bound is not None


def test_a_part_without_a_plan_around_no_other_part_ends_the_orders(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # no order can plan a part that finds none first in an order: the orders stop there and
    # name it (the repair by elements then starts its synchronous run later)
    from types import SimpleNamespace

    from stlplan.planner.run.reached import Reached

    turns = [_Turn("a", 0.0), _Turn("b", 1.0, fails=99), _Turn("c", 2.0)]
    for turn in turns:
        turn.guided, turn.agents, turn.blockers = False, {turn.name}, set()  # type: ignore[attr-defined]
        turn.clear, turn.pm = (lambda: None), SimpleNamespace(model=None)  # type: ignore[attr-defined]
    made = iter(turns)
    monkeypatch.setattr(prioritized, "Turn", lambda *_: next(made))
    monkeypatch.setattr(prioritized, "requirements_naming", lambda _: {})
    monkeypatch.setattr(prioritized, "model_values", lambda _: {})
    monkeypatch.setattr(prioritized, "load_values", lambda *_: None)
    merged = SimpleNamespace(pm=None, clock=SimpleNamespace(reached=Reached()))
    alone: list[int] = []
    parts = [SimpleNamespace(pm=None, lent=lambda gap: contextlib.nullcontext())] * 3
    budget = Budget.of_seconds(10)
    found = prioritized.prioritized(merged, parts, PlannerConfig(), budget, budget, alone)  # type: ignore[arg-type]
    assert found is None
    assert alone == [1]
    # b failed after a in the first order, then first in the second: no third order
    assert [len(t.seen) for t in turns] == [1, 2, 0]
    assert turns[1].seen == [["a"], []]
