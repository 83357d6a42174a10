"""A large team's first plan improved element by element: each element planned again around the
others, a new plan kept only when it spends less."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from pyomo.environ import Var, value

from stlplan.formula.tree import Interval
from stlplan.monitor.verdicts import check
from stlplan.planner.backend.values import model_values
from stlplan.planner.core.in_turn import hold_agents, release
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.watch import least_margin, trajectory_states
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import best_side
from stlplan.planner.encoding.model import add_requirements
from stlplan.planner.encoding.readout import chosen, chosen_run, trajectory
from stlplan.planner.first_plan import improve
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.planner.tolerances import FEASIBILITY, HOLD
from stlplan.result import PlanStatus
from tests.test_by_elements import QUICK, meeting, solved_part


class _Model:
    def __init__(self, spent: float) -> None:
        self.values = {"spent": spent}


class _Turn:
    """A part whose solves spend ``efforts`` in turn (None: no plan)."""

    def __init__(self, name: str, spent: float, efforts: list[float | None]) -> None:
        self.name, self.efforts, self.fixed = name, list(efforts), list[dict[str, Any]]()
        self.own = {name: f"{name} as planned"}
        self.pm = type("PM", (), {"model": _Model(spent)})()
        self.cleared = 0

    def solve(self, fixed: dict[str, Any], budget: Budget) -> dict[str, Any] | None:
        self.fixed.append(dict(fixed))
        spent = self.efforts.pop(0) if self.efforts else self.pm.model.values["spent"]
        self.pm.model.values = {"spent": 99.0 if spent is None else spent}
        return None if spent is None else {self.name: f"{self.name} at {spent}"}

    def clear(self) -> None:
        self.cleared += 1


@pytest.fixture()
def fake_models(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(improve, "model_values", lambda model: dict(model.values))
    monkeypatch.setattr(improve, "load_values", lambda model, v: setattr(model, "values", dict(v)))
    monkeypatch.setattr(improve, "effort", lambda model: model.values["spent"])


@pytest.mark.usefixtures("fake_models")
def test_a_part_keeps_a_new_plan_only_when_it_spends_less() -> None:
    a = _Turn("a", 1.0, [0.5, 0.5])  # better, then the same: kept once
    b = _Turn("b", 3.0, [4.0, None])  # worse, then no plan: never kept
    c = _Turn("c", 2.0, [1.0, 1.0])
    assert improve.sweeps(improve.Team.of([a, b, c]), Budget.of_seconds(30))
    # the most effort first; each around every other part's plan, its own left out
    assert [t.fixed[0].keys() for t in (b, c, a)] == [{"a", "c"}, {"a", "b"}, {"b", "c"}]
    assert b.fixed[0] == {"a": "a as planned", "c": "c as planned"}
    assert a.fixed[0]["c"] == "c at 1.0"  # a kept plan is an obstacle at once
    # b's worse plan and its failed solve leave it as it was
    assert b.pm.model.values == {"spent": 3.0}
    assert a.pm.model.values == {"spent": 0.5} and c.pm.model.values == {"spent": 1.0}
    assert a.fixed[1]["b"] == "b as planned"
    # a second sweep lowered nothing: no third
    assert [len(t.fixed) for t in (a, b, c)] == [2, 2, 2]
    assert a.cleared == b.cleared == 2


@pytest.mark.usefixtures("fake_models")
def test_sweeps_that_lower_nothing_say_so() -> None:
    turns = [_Turn("a", 1.0, [1.0]), _Turn("b", 1.0, [None])]
    assert not improve.sweeps(improve.Team.of(turns), Budget.of_seconds(30))
    assert [t.pm.model.values for t in turns] == [{"spent": 1.0}, {"spent": 1.0}]


class _Part:
    """A part that finds a plan unless an agent of ``blocked_by`` is among those it goes around;
    the plan breaks requirements with the agents of ``in_way`` it did not go around."""

    def __init__(self, name: str, blocked_by: tuple[str, ...] = (), in_way: tuple[str, ...] = ()):
        self.name, self.agents = name, {name}
        self.blocked_by, self.in_way = set(blocked_by), set(in_way)
        self.own = {name: f"{name} as planned"}
        self.pm = type("PM", (), {"model": _Model(1.0)})()
        self.fixed = list[dict[str, Any]]()

    def solve(self, fixed: dict[str, Any], budget: Budget) -> dict[str, Any] | None:
        self.fixed.append(dict(fixed))
        self.pm.model.values = {"spent": 2.0}  # a solve's values, kept or not
        if self.blocked_by & set(fixed):
            return None
        return {self.name: f"{self.name} around {','.join(sorted(fixed))}"}

    def clear(self) -> None:
        pass

    def in_the_way(self, found: dict[str, Any], others: dict[str, Any]) -> set[str]:
        around = found[self.name].split(" around ")[1].split(",")
        return (self.in_way & set(others)) - set(around)


@pytest.mark.usefixtures("fake_models")
def test_the_parts_in_a_moved_parts_way_are_planned_again_after_it() -> None:
    a, b, c, d = _Part("a"), _Part("b"), _Part("c"), _Part("d")
    team = improve.Team.of([a, b, c, d])
    # a's part with its run earlier: no plan around b; alone, in the way of b and c
    moved = _Part("a", blocked_by=("b",), in_way=("b", "c"))
    assert improve.chain_moved(team, [moved, b, c, d], Budget.of_seconds(30))
    assert team.turns == [moved, b, c, d]
    assert team.plans[0] == {"a": "a around c"}  # c taken back: only b is in its way
    assert team.plans[1] == {"b": "b around a,c,d"}  # after it, around its plan
    assert team.plans[2:] == [{"c": "c as planned"}, {"d": "d as planned"}]
    plans = {"b": "b as planned", "c": "c as planned", "d": "d as planned"}
    assert moved.fixed == [plans, {}, {"b": plans["b"]}, {"c": plans["c"]}]
    assert c.fixed == d.fixed == []


@pytest.mark.usefixtures("fake_models")
def test_a_move_whose_chain_breaks_leaves_the_team_as_it_was() -> None:
    a, b, c = _Part("a"), _Part("b"), _Part("c", blocked_by=("a",))
    team = improve.Team.of([a, b, c])
    moved = _Part("a", blocked_by=("b", "c"), in_way=("b", "c"))
    assert not improve.chain_moved(team, [moved, b, c], Budget.of_seconds(30))
    assert b.fixed and c.fixed  # both planned again after it, c found none
    assert team.turns == [a, b, c]
    assert team.plans == [{"a": "a as planned"}, {"b": "b as planned"}, {"c": "c as planned"}]
    assert [t.pm.model.values for t in (a, b, c)] == [{"spent": 1.0}] * 3


@pytest.mark.usefixtures("fake_models")
def test_the_better_of_the_joined_plans_is_kept_loaded(monkeypatch: pytest.MonkeyPatch) -> None:
    moved, swept = improve.Team.of([_Part("a")]), improve.Team.of([_Part("a")])
    joined: list[Any] = []
    objectives = {id(moved.turns[0]): 1.0, id(swept.turns[0]): 2.0}

    def held(solver: Any, turns: list[Any], *_: Any) -> Plan:
        joined.append(solver)
        return Plan(objectives[id(turns[0])], {("n",): float(len(joined))})

    loaded: list[Any] = []
    monkeypatch.setattr(improve, "held_plan", held)
    monkeypatch.setattr(improve, "LazySolver", lambda *_: "a fresh solver")
    monkeypatch.setattr(improve, "load_plan", lambda pm, values, added: loaded.append(values))
    whole = type("Whole", (), {"pm": "the team's model", "clock": None, "policy": None})()
    best = improve.joined(whole, [moved, swept], QUICK, Budget.of_seconds(30))
    assert best is not None and best.objective == 2.0
    assert joined == [whole, "a fresh solver"]  # a joined plan is the watch's best: fresh
    assert loaded == []  # the last joined is the one loaded
    objectives[id(swept.turns[0])] = 0.5
    joined.clear()
    best = improve.joined(whole, [moved, swept], QUICK, Budget.of_seconds(30))
    assert best is not None and best.objective == 1.0 and loaded == [{("n",): 1.0}]


def _idle(solver: Any) -> str:
    """An agent that no element of the loaded plan's choices names."""
    pm = solver.pm
    (reach,) = pm.tasks
    (meet,) = pm.synchronous
    members, _, _ = chosen_run(meet)
    named = {a for i in chosen(reach) for a in reach.task.elements[i]}
    named |= {a for i in members for a in meet.task.elements[i]}
    return next(a.name for a in pm.problem.agents if a.name not in named)


def _wasteful(solver: Any) -> tuple[str, float]:
    """The loaded plan with an idle agent stepping out and back (its inputs ``d`` then ``-d``,
    its states following its dynamics); the effort added."""
    pm, name = solver.pm, _idle(solver)
    agent = pm.problem.agent(name)
    step = np.zeros(agent.B.shape[1])
    step[0] = 0.05
    x = np.array(agent.initial_state, dtype=float)
    for k in range(pm.problem.horizon):
        u = step if k == 0 else -step if k == 1 else 0 * step
        for j, uj in enumerate(u):
            pm.model.u[name, k, j].set_value(float(uj))
        x = agent.A @ x + agent.B @ u
        for i, xi in enumerate(x):
            pm.model.x[name, k + 1, i].set_value(float(xi))
    return name, 2 * float(np.abs(step).sum())


def test_a_wasteful_first_plan_is_improved() -> None:
    problem = meeting()
    solver = solved_part(problem)
    pm, beta = solver.pm, problem.mission.objective.beta
    optimum = float(value(pm.model.step1))
    name, added = _wasteful(solver)
    states = trajectory_states(pm)
    assert not violated(pm.deferral.lazy, states, least_margin(pm), FEASIBILITY)
    assert check(problem, trajectory(pm)).satisfied
    first = optimum - beta * added
    done = Outcome(PlanStatus.FEASIBLE, first, optimum + 1.0, None, 0.0, 1, len(pm.added), "test")
    clock = Clock(0.0, None)
    full, better = improve.improved(problem, (pm, done), QUICK, clock, Budget.of_seconds(30))
    assert full is pm and better.objective is not None
    assert better.objective > first + 0.5 * beta * added
    assert better.objective == pytest.approx(float(value(pm.model.step1)))
    assert better.gap == pytest.approx((optimum + 1.0 - better.objective) / abs(better.objective))
    assert check(problem, trajectory(pm)).satisfied
    assert np.allclose(trajectory_states(pm)[name][1:3], trajectory_states(pm)[name][0], atol=1e-3)
    assert clock.convergence.incumbent == better.objective
    assert [r["stage"] for r in clock.round_log][-1:] == ["improvement by elements"]


def test_a_plan_no_sweep_improves_is_left_as_it_was() -> None:
    problem = meeting()
    solver = solved_part(problem)
    pm = solver.pm
    objective = float(value(pm.model.step1))
    saved = model_values(pm.model)
    done = Outcome(PlanStatus.FEASIBLE, objective, objective, 0.0, 0.0, 1, len(pm.added), "test")
    solved = (pm, done)
    again = improve.improved(problem, solved, QUICK, Clock(0.0, None), Budget.of_seconds(30))
    assert again is solved
    assert model_values(pm.model) == saved
    # nothing to improve without choices of elements (a margin maximized: no element problem)
    margin = problem.mission.objective.margin.model_copy(update={"maximize": True})
    objective_ = problem.mission.objective.model_copy(update={"margin": margin})
    widened = dataclasses.replace(
        problem, mission=problem.mission.model_copy(update={"objective": objective_}), _by_name={}
    )
    assert (
        improve.improved(widened, solved, QUICK, Clock(0.0, None), Budget.of_seconds(30)) is solved
    )


def test_a_joined_plan_not_taken_leaves_every_decision_as_the_first_plan_has_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    problem = meeting()
    solver = solved_part(problem)
    pm, beta = solver.pm, problem.mission.objective.beta
    optimum = float(value(pm.model.step1))
    _, added = _wasteful(solver)
    first_values = model_values(pm.model)
    lazy = pm.deferral.lazy
    fresh = next(n for n in range(len(lazy)) if n not in pm.added)

    def joined_then_lost(merged: Any, *_: Any) -> None:
        add_requirements(merged.pm, [fresh])  # as the joining solve's rounds would
        for v in merged.pm.model.component_data_objects(Var):
            if v.is_binary() and not v.fixed:
                v.set_value(None, skip_validation=True)
        return None

    monkeypatch.setattr(improve, "held_plan", joined_then_lost)
    done = Outcome(PlanStatus.FEASIBLE, optimum - beta * added, optimum, None, 0.0, 1,
                   len(pm.added), "test")  # fmt: skip
    solved = (pm, done)
    assert (
        improve.improved(problem, solved, QUICK, Clock(0.0, None), Budget.of_seconds(30)) is solved
    )
    now = model_values(pm.model)
    assert all(now.get(k) == v for k, v in first_values.items())
    states = trajectory_states(pm)
    assert fresh in pm.added
    side = best_side(lazy[fresh], states)
    assert all(v.value is not None for v in pm.model.component_data_objects(Var) if v.is_binary())
    assert side is not None


def _later(solver: Any) -> None:
    """The loaded plan a step later: every agent waits at its initial state for one step, then
    follows its plan (single integrators: the input shifted a step)."""
    pm = solver.pm
    horizon, m = pm.problem.horizon, pm.model
    for a in pm.problem.agents:
        for j in range(a.B.shape[1]):
            inputs = [float(m.u[a.name, k, j].value) for k in range(horizon)]
            for k, v in enumerate([0.0, *inputs[:-1]]):
                m.u[a.name, k, j].set_value(v)
        for i in range(a.A.shape[0]):
            states = [float(m.x[a.name, k, i].value) for k in range(horizon + 1)]
            for k, v in enumerate([states[0], *states[:-1]]):
                if k > 0:
                    m.x[a.name, k, i].set_value(v)


def test_a_late_synchronous_run_is_started_earlier() -> None:
    problem = meeting()
    solver = solved_part(problem)
    pm = solver.pm
    (meet,) = pm.synchronous
    _, start, _ = chosen_run(meet)
    _later(solver)
    late = check(problem, trajectory(pm))
    assert late.satisfied and late.rho_s is not None
    held = hold_agents(pm, [a.name for a in problem.agents], HOLD)
    try:
        done = LazySolver(pm, QUICK, Clock(0.0, None)).run(Budget.of_seconds(60))
    finally:
        release(held)
    assert done.objective is not None and chosen_run(meet)[1] == start + 1
    clock = Clock(0.0, None)
    full, better = improve.improved(problem, (pm, done), QUICK, clock, Budget.of_seconds(30))
    assert full is pm and better.objective is not None
    assert chosen_run(meet)[1] == start  # one step more synchronous robustness
    assert better.objective > done.objective + 0.5
    report = check(problem, trajectory(pm))
    assert report.satisfied and report.rho_s == pytest.approx(late.rho_s + 1)
    assert clock.convergence.incumbent == better.objective


def test_a_run_is_started_earlier_within_its_window_and_what_its_robustness_counts() -> None:
    problem = meeting()
    pm = solved_part(problem).pm
    (meet,) = pm.synchronous
    members, start, length = chosen_run(meet)
    window = meet.task.sync
    assert window is not None and start - 1 >= window.a  # the plan's run from 2, the window's 1
    sooner = improve.earlier(problem, pm, "meet", 1, {})
    assert sooner is not None
    runs = {t.formula.interval for t in sooner.tasks if t.name.startswith("meet")}
    assert runs == {Interval(start - 1, start + length - 1)}
    assert improve.earlier(problem, pm, "meet", start - window.a + 1, {}) is None
    # a run longer than gamma counts no more: not started earlier
    object.__setattr__(meet.task, "sync", dataclasses.replace(window, gamma=length - 1 - window.d))
    assert improve.earlier(problem, pm, "meet", 1, {}) is None
