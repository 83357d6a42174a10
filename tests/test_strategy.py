"""Step 1's composed strategies (stlplan.planner.strategy): composed from the configuration,
and every one reaches the up-front optimum, accepted by the monitor."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import pytest

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.first_plan.hooks import FirstPlan
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.solve import STAGES, plan
from stlplan.planner.strategy import Direct, LazyRounds, Parts, build_strategy, describe, policy_of
from stlplan.result import PlanStatus
from tests.helpers.missions import detour_for_free, swap_problem
from tests.helpers.solving import accepted, up_front_optimum

EXACT = PlannerConfig().with_overrides({"solver.time_limit": 60.0, "solver.gap": 1e-6})
POLICY = policy_of(EXACT)


def test_the_configuration_composes_the_strategy() -> None:
    assert build_strategy(EXACT) == Parts(LazyRounds(POLICY), 10, FirstPlan.of(EXACT))
    alone = EXACT.with_overrides({"parts.enabled": False})
    assert build_strategy(alone) == LazyRounds(policy_of(alone))
    assert build_strategy(EXACT.with_overrides({"lazy.enabled": False})) == Direct()
    line = describe(EXACT)
    assert build_strategy(EXACT).describe() in line and line.startswith("model(standard")


@dataclass(frozen=True)
class _CountedRounds(LazyRounds):
    """Lazy rounds that record the agents of every loop they make."""

    made: list[tuple[str, ...]] = field(default_factory=list)

    def rounds(
        self, pm: PlanModel, config: PlannerConfig, clock: Clock, whole: bool = False
    ) -> LazySolver:
        self.made.append(tuple(a.name for a in pm.problem.agents))
        return super().rounds(pm, config, clock, whole)


@dataclass(frozen=True)
class _CountedHooks(FirstPlan):
    """The first-plan hooks, recording each time the parts ask whether to plan first."""

    asked: list[int] = field(default_factory=list)

    def plans_first(self, problem: Problem, config: PlannerConfig, agents: int) -> bool:
        self.asked.append(agents)
        return super().plans_first(problem, config, agents)


def test_the_printed_pieces_are_the_ones_that_run() -> None:
    # the strategy the configuration composes, its inner rounds and hooks counted: every part's
    # loop is made by the inner strategy, repairing by the policy it prints
    composed = build_strategy(EXACT)
    assert isinstance(composed, Parts)
    assert isinstance(composed.hooks, FirstPlan)
    inner = _CountedRounds(composed.inner.policy)
    hooks = _CountedHooks(composed.hooks.improve_share)
    strategy = dataclasses.replace(composed, inner=inner, hooks=hooks)
    assert strategy.describe() == composed.describe()
    problem = detour_for_free()
    _, outcome = strategy.solve(problem, EXACT, Clock.started(None), Budget.for_run(EXACT))
    assert outcome.status is PlanStatus.OPTIMAL
    assert sorted(inner.made[:2]) == [("a", "b"), ("e",)]  # the two parts, each by the inner
    assert hooks.asked == [10]  # asked once, with the configured size, before the proofs
    # without parts the inner strategy's own loop solves the whole team
    alone = _CountedRounds(composed.inner.policy)
    alone.solve(problem, EXACT, Clock.started(None), Budget.for_run(EXACT))
    assert alone.made == [("a", "b", "e")]


def test_the_stages_run_in_order() -> None:
    assert [name for name, _ in STAGES] == ["step 1", "continuous", "strict retry"]


def _policy(**repair: Any) -> RepairPolicy:
    """The policy of the defaults with ``repair`` knobs set."""
    return RepairPolicy.of(EXACT.with_overrides({f"repair.{k}": v for k, v in repair.items()}))


def test_the_repair_policy_decides_both_triggers() -> None:
    policy = _policy(after_round_seconds=8.0, crowd_agents=7, crowd_team=None)
    assert policy.after_round(8.0, 1) and policy.after_round(0.1, 7)
    assert not policy.after_round(7.9, 6)
    assert policy.on_merge(7) and not policy.on_merge(6)
    teams = _policy(after_round_seconds=8.0, crowd_agents=7, crowd_team=10)
    assert teams.on_merge(7, 10) and not teams.on_merge(7, 9) and not teams.on_merge(6, 64)
    assert teams.after_round(0.1, 7)  # a round's crowd is one in any team
    # before a first plan a merge of a large team is repaired in turn from two agents named
    first = _policy(crowd_agents=7, crowd_team=10)
    assert first.on_merge(2, 24, first=True) and not first.on_merge(2, 24)
    assert not first.on_merge(1, 24, first=True) and not first.on_merge(2, 9, first=True)
    never = _policy(after_round_seconds=None, crowd_agents=None)
    assert not never.after_round(1e6, 100) and not never.on_merge(100)
    assert never.describe() == "before a first plan"  # (the only trigger left)


PROBLEMS: dict[str, Callable[[], Problem]] = {
    "swap": lambda: swap_problem(separation=0.5),
    "detour_for_free": detour_for_free,
}


@pytest.mark.parametrize("name", sorted(PROBLEMS))
@pytest.mark.parametrize(
    "strategy",
    [Direct(), LazyRounds(POLICY), Parts(LazyRounds(POLICY)), Parts(LazyRounds(POLICY), 1)],
)
def test_every_strategy_reaches_the_up_front_optimum(name: str, strategy: object) -> None:
    problem = PROBLEMS[name]()
    reference = up_front_optimum(problem)
    assert reference.status is PlanStatus.OPTIMAL and reference.objective is not None
    pm, outcome = strategy.solve(problem, EXACT, Clock.started(None), Budget.for_run(EXACT))  # type: ignore[attr-defined]
    assert outcome.status is PlanStatus.OPTIMAL, outcome
    assert outcome.objective == pytest.approx(reference.objective, abs=1e-5)
    assert pm.problem is problem


@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_a_planned_run_is_accepted_by_the_monitor(name: str) -> None:
    problem = PROBLEMS[name]()
    result = plan(problem, EXACT)
    assert result.status is PlanStatus.OPTIMAL and accepted(problem, result)
    assert result.objective == pytest.approx(up_front_optimum(problem).objective, abs=1e-5)


@pytest.mark.parametrize("strictly", [PlanStatus.NO_PLAN, PlanStatus.INFEASIBLE])
def test_a_strict_retry_out_of_time_keeps_the_first_plan(
    strictly: PlanStatus, monkeypatch: pytest.MonkeyPatch
) -> None:
    import dataclasses

    import stlplan.planner.solve as solve_module
    from stlplan.planner.core.finish import Finish

    problem = swap_problem(separation=0.5)
    real = build_strategy(EXACT)
    calls: list[int] = []

    class Once:
        """The real strategy the first time; no plan when step 1 is solved again strictly."""

        def solve(self, *args: object) -> object:
            pm, found = real.solve(*args)  # type: ignore[arg-type]
            calls.append(1)
            if len(calls) > 1:
                found = dataclasses.replace(found, status=strictly, objective=None)
            return pm, found

    monkeypatch.setattr(solve_module, "build_strategy", lambda config: Once())
    infeasible = Finish("the continuous solve ended provenInfeasible", infeasible=True)
    monkeypatch.setattr(solve_module, "finish", lambda *args: infeasible)
    result = plan(problem, EXACT)
    assert len(calls) == 2  # the retry ran, and found nothing
    if strictly is PlanStatus.INFEASIBLE:  # a strict verdict stands
        assert result.status is PlanStatus.INFEASIBLE and result.trajectory is None
        return
    assert result.status.has_plan and result.trajectory is not None
    assert result.fallback is not None and "step-1 plan" in result.fallback.kept
    assert accepted(problem, result)


def test_the_policy_names_the_repairs_and_their_shares() -> None:
    from stlplan.planner.core.repairs import HeldRepair, InTurnRepair
    from stlplan.planner.first_plan.by_elements import ElementsRepair
    from stlplan.planner.first_plan.hooks import PrioritizedRepair

    policy = policy_of(EXACT)
    assert policy.round_repairs(10.0, 1) == ((InTurnRepair(), EXACT.budget.side_share),)
    assert policy.round_repairs(1.0, 1) == ()
    # a loop that looks for its first plan only repairs every round naming two agents or more,
    # within a share of its own
    share = EXACT.budget.search_share
    assert share != EXACT.budget.side_share
    # ... the round's choices planned element by element first, within a share of their own
    elements = EXACT.repair.by_elements
    assert elements is not None
    by_elements = ((ElementsRepair(), elements), (InTurnRepair(), share))
    assert policy.round_repairs(1.0, 2, first=True) == by_elements
    alone = policy_of(EXACT.with_overrides({"repair.by_elements": None}))
    assert alone.round_repairs(1.0, 2, first=True) == ((InTurnRepair(), share),)
    assert policy.round_repairs(10.0, 1, first=True) == ((InTurnRepair(), share),)
    assert policy.round_repairs(1.0, 1, first=True) == ()  # (one agent: the next round)
    crowd = EXACT.repair.crowd_agents
    assert crowd is not None
    assert [r.describe() for r, _ in policy.merge_repairs(crowd)] == [
        "prioritized",
        "in turn",
        "held",
    ]
    # the prioritized repair's orders take the crowd's share; the solve joining their plans
    # may take all the time left
    assert [share for _, share in policy.merge_repairs(crowd)] == [
        1.0,
        EXACT.budget.search_share,
        EXACT.budget.side_share,
    ]
    first = policy.merge_repairs(crowd)[0][0]
    assert first == PrioritizedRepair(EXACT.budget.search_share)
    assert policy.merge_repairs(crowd - 1) == ((HeldRepair(), EXACT.budget.side_share),)
    # a merge of large parts while looking for a first plan: their choices planned element by
    # element first (the prioritized repair takes a crowd's small parts as they are)
    elements = EXACT.repair.by_elements
    assert [r.describe() for r, _ in policy.merge_repairs(2, largest=9, first=True)] == [
        "by elements",
        "in turn",
        "held",
    ]
    assert policy.merge_repairs(2, largest=9, first=True)[0][1] == elements
    assert policy.merge_repairs(crowd, first=True)[0][0] == first  # parts of one agent
    assert [r.describe() for r, _ in policy.merge_repairs(crowd, largest=9)] == ["in turn", "held"]
