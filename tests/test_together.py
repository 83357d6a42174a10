"""Parts planned together: a part whose plan spends more than its plan around no one, planned
in one turn with the parts in that plan's way."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from stlplan.planner import improve, together
from stlplan.planner.budget import Budget
from stlplan.planner.config import PlannerConfig


def _u(agent: str, value: float) -> dict[Any, float]:
    return {("u", (agent, 0, 0)): value}


class _Model:
    def __init__(self, values: dict[Any, float]) -> None:
        self.values = dict(values)


class _Part:
    """A part of ``agents`` spending ``spent`` (its first agent's input); alone it spends
    ``alone``, and its plan alone is in the way of the agents ``in_way``."""

    def __init__(self, agents: str, spent: float, alone: float, in_way: str = "") -> None:
        self.agents, self.alone, self.in_way = set(agents), alone, set(in_way)
        self.first = min(agents)
        self.own = {a: f"{a} as planned" for a in agents}
        self.pm = SimpleNamespace(model=_Model(_u(self.first, spent)))
        self.fixed = list[dict[str, Any]]()

    def solve(self, fixed: dict[str, Any], budget: Budget, **_: Any) -> dict[str, Any]:
        self.fixed.append(dict(fixed))
        self.pm.model.values.update(_u(self.first, self.alone))
        return {a: f"{a} alone" for a in self.agents}

    def clear(self) -> None:
        pass

    def in_the_way(self, found: dict[str, Any], others: dict[str, Any]) -> set[str]:
        return self.in_way & set(others)


class _Joint:
    """The turn of parts planned together: its plan spends ``spent`` per agent."""

    def __init__(self, agents: set[str], spent: float | None) -> None:
        self.agents, self.spent = agents, spent
        self.pm = SimpleNamespace(model=_Model({}))
        self.calls = list[tuple[dict[str, Any], Any]]()

    def solve(
        self, fixed: dict[str, Any], budget: Budget, start: Any = None
    ) -> dict[str, Any] | None:
        self.calls.append((dict(fixed), start))
        if self.spent is None:
            return None
        for a in self.agents:
            self.pm.model.values.update(_u(a, self.spent))
        return {a: f"{a} together" for a in self.agents}

    def clear(self) -> None:
        pass


@pytest.fixture()
def fakes(monkeypatch: pytest.MonkeyPatch) -> list[_Joint]:
    def values(model: _Model) -> dict[Any, float]:
        return dict(model.values)

    def load(model: _Model, v: dict[Any, float]) -> None:
        model.values.update(v)

    def spent(model: _Model) -> float:
        return sum(abs(v) for k, v in model.values.items() if k[0] == "u")

    made: list[_Joint] = []

    def joint(team: Any, turns: Any, members: list[int], budget: Budget) -> _Joint:
        agents = {a for m in members for a in team.turns[m].agents}
        made.append(_Joint(agents, turns.spent))
        return made[-1]

    for module in (improve, together):
        monkeypatch.setattr(module, "model_values", values)
        monkeypatch.setattr(module, "load_values", load)
        monkeypatch.setattr(module, "effort", spent)
    monkeypatch.setattr(together, "_joint_turn", joint)
    return made


def _turns(spent: float | None, agents: int = 8) -> Any:
    config = PlannerConfig().with_overrides({"parts.together_agents": agents})
    return SimpleNamespace(config=config, spent=spent, alone={})


def test_a_part_and_the_parts_in_its_way_are_planned_together(fakes: list[_Joint]) -> None:
    a, b, c = _Part("a", 4.0, 1.0, in_way="b"), _Part("b", 1.0, 1.0), _Part("c", 2.0, 2.0)
    team = improve.Team.of([a, b, c])
    assert together.together(team, _turns(spent=1.5), Budget.of_seconds(30))
    (joint,) = fakes  # a alone is in b's way; b and c spend what they would alone
    assert joint.agents == {"a", "b"}
    fixed, start = joint.calls[0]
    assert fixed == {"c": "c as planned"}  # around every other part's plan
    assert start is not None and start.values == {**_u("a", 4.0), **_u("b", 1.0)}
    assert team.plans[:2] == [{"a": "a together"}, {"b": "b together"}]
    assert team.spent == [1.5, 1.5, 2.0]  # 3.0 together against 5.0
    assert team.plans[2] == {"c": "c as planned"}
    # every part was planned alone once, its plan loaded again after
    assert [len(p.fixed) for p in (a, b, c)] == [1, 1, 1] and c.pm.model.values == _u("c", 2.0)


def test_plans_together_that_spend_no_less_are_left(fakes: list[_Joint]) -> None:
    a, b = _Part("a", 4.0, 1.0, in_way="b"), _Part("b", 1.0, 1.0)
    team = improve.Team.of([a, b])
    turns = _turns(spent=2.5)
    assert not together.together(team, turns, Budget.of_seconds(30))
    assert len(fakes) == 1 and team.spent == [4.0, 1.0]
    assert not together.together(team, turns, Budget.of_seconds(30))
    assert len(a.fixed) == len(b.fixed) == 1  # each part planned alone once
    assert team.plans == [{"a": "a as planned"}, {"b": "b as planned"}]
    assert a.pm.model.values == _u("a", 4.0)


def test_the_neighbourhood_holds_at_most_its_agents(fakes: list[_Joint]) -> None:
    # b has the larger excess but two agents: with a, three, more than two
    a = _Part("a", 4.0, 1.0, in_way="bxc")
    b, c = _Part("bx", 3.0, 1.0), _Part("c", 1.5, 1.0)
    team = improve.Team.of([a, b, c])
    together.together(team, _turns(spent=0.1, agents=2), Budget.of_seconds(30))
    assert fakes[0].agents == {"a", "c"}


def test_no_part_spends_more_than_alone_nothing_is_planned(fakes: list[_Joint]) -> None:
    team = improve.Team.of([_Part("a", 1.0, 1.0, in_way="b"), _Part("b", 2.0, 2.0)])
    assert not together.together(team, _turns(spent=0.1), Budget.of_seconds(30))
    assert fakes == []


def test_parts_together_without_a_plan_are_left(fakes: list[_Joint]) -> None:
    a, b = _Part("a", 4.0, 1.0, in_way="b"), _Part("b", 1.0, 1.0)
    team = improve.Team.of([a, b])
    assert not together.together(team, _turns(spent=None), Budget.of_seconds(30))
    assert len(fakes) == 1 and team.spent == [4.0, 1.0]
    assert team.plans == [{"a": "a as planned"}, {"b": "b as planned"}]
    assert a.pm.model.values == _u("a", 4.0) and b.pm.model.values == _u("b", 1.0)


@pytest.mark.parametrize("on", [False, True])
def test_the_improvement_plans_parts_together_only_when_asked(
    fakes: list[_Joint], on: bool
) -> None:
    # a's sweep turn finds nothing better (its plan alone breaks b's), together they do
    a, b = _Part("a", 4.0, 1.0, in_way="b"), _Part("b", 1.0, 1.0)
    a.solve = _alone_then_kept(a)  # type: ignore[method-assign]
    turns = _turns(spent=1.5)
    turns.config = turns.config.with_overrides({"parts.together": on})
    team = improve.Team.of([a, b])
    changed = improve._swept_together(team, turns, Budget.of_seconds(30))
    assert changed is on
    assert len(fakes) == (2 if on else 0)  # a second pass lowers nothing: the loop ends
    assert team.spent == ([1.5, 1.0] if on else [4.0, 1.0])  # b lowered again by a sweep after


def _alone_then_kept(part: _Part) -> Any:
    """``part``'s solves: around no one its plan alone, around others its plan as it is."""
    spent = part.pm.model.values[("u", (part.first, 0, 0))]

    def solve(fixed: dict[str, Any], budget: Budget, **_: Any) -> dict[str, Any]:
        part.fixed.append(dict(fixed))
        value = part.alone if not fixed else spent
        part.pm.model.values.update(_u(part.first, value))
        return {a: f"{a} {'alone' if not fixed else 'as planned'}" for a in part.agents}

    return solve
