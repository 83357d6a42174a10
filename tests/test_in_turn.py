"""Repairing a lazy round's plan agent by agent: a plan of the full problem, the same optimum."""

from __future__ import annotations

import logging
import time
from functools import partial
from typing import Any

import pytest
from pyomo.environ import value

from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.planner.backend.session import HighsSession
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.in_turn import (
    InTurn,
    agents_of,
    hold_agents,
    in_formations,
    in_the_way,
    release,
    solve_free,
)
from stlplan.planner.core.repairs import Broken, HeldRepair, InTurnRepair
from stlplan.planner.core.watch import pending_violations
from stlplan.planner.encoding.model import build_model
from stlplan.planner.encoding.readout import assignments, partners
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Plan
from stlplan.planner.solve import plan
from stlplan.planner.tolerances import HOLD
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.missions import crossing_problem, detour_for_free
from tests.helpers.paths import FARM
from tests.helpers.solving import accepted, by_parts, solve, up_front_optimum


def _first_round(problem: Problem) -> tuple[Any, HighsSession]:
    options = PlannerConfig().with_overrides({"solver.time_limit": 60.0})
    pm = build_model(
        problem,
        paper_model(lazy__enabled=True, model__encoding=options.model.encoding),
    )
    session = HighsSession(pm.model, options, Clock(0.0, None), "step1")
    assert session.solve(Budget.of_seconds(30)).results.incumbent_objective is not None
    return pm, session


def test_a_round_repaired_in_turn_meets_every_requirement() -> None:
    problem = crossing_problem()
    pm, session = _first_round(problem)
    bad = pending_violations(pm)
    assert bad and agents_of(pm, bad) >= {"a", "b"}  # the relaxed plan drives through others
    bounds = {id(v): v.bounds for v in pm.model.x.values()}
    freed: list[set[str]] = []
    turn = partial(solve_free, pm, session, PlannerConfig().repair)

    def spy(free: set[str], done: set[str], budget: Budget) -> list[str]:
        freed.append(set(free))
        return turn(free, done, budget)

    repaired = InTurn(pm, session, PlannerConfig(), solve=spy).run(bad, Budget.of_seconds(30.0))
    assert repaired is not None  # the repair returns its plan: the loaded one, as a value
    assert repaired.objective == pytest.approx(float(value(pm.model.step1)), abs=1e-6)
    assert repaired.added == frozenset(pm.added)
    assert {"a"} in freed  # the first agent is solved alone
    assert pending_violations(pm) == []  # a plan of the full problem
    # the trial settings and the held bounds are given back
    assert not session.trial and session.solver.config.rel_gap == PlannerConfig().solver.gap
    assert {id(v): v.bounds for v in pm.model.x.values()} == bounds


def test_held_agents_keep_their_plan_and_are_released() -> None:
    pm, _ = _first_round(crossing_problem())
    before = {key: v.bounds for key, v in pm.model.x.items()}
    held = hold_agents(pm, ["a"], HOLD)
    for (name, _, _), v in pm.model.x.items():
        if name == "a" and not v.fixed:
            lo, hi = v.bounds
            assert lo is not None and hi is not None and hi - lo <= 2.1e-4
            assert lo <= v.value <= hi
    release(held)
    assert {key: v.bounds for key, v in pm.model.x.items()} == before


@pytest.mark.parametrize("inter_sample", [True, False])
def test_repairing_in_turn_keeps_the_optimum(inter_sample: bool) -> None:
    problem = crossing_problem(inter_sample)
    with_turns, rounds = solve(problem, {"repair.after_round_seconds": 0.0})
    without, _ = solve(problem, {"repair.after_round_seconds": None, "repair.crowd_agents": None})
    up_front, _ = solve(problem, {"lazy.enabled": False, "model.floors": False})
    assert rounds >= 2
    assert with_turns.status is without.status is up_front.status is PlanStatus.OPTIMAL
    assert with_turns.objective is not None and up_front.objective is not None
    assert with_turns.objective == pytest.approx(up_front.objective, rel=2e-4)
    assert without.objective == pytest.approx(up_front.objective, rel=2e-4)
    assert accepted(problem, with_turns) and accepted(problem, without)


@pytest.mark.parametrize(("crowd", "repairs"), [(4, True), (5, False)])
def test_a_crowded_round_is_repaired_however_short(
    crowd: int, repairs: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the four agents' relaxed plans all meet in the middle: a crowd of four, in a short round
    problem = crossing_problem()
    runs: list[set[str]] = []
    run = InTurn.run

    def spy(self: InTurn, bad: Any, budget: Budget) -> bool:
        runs.append(agents_of(self.pm, bad))
        return run(self, bad, budget)

    monkeypatch.setattr(InTurn, "run", spy)
    # without the prioritized repair, which plans these four one-agent parts before any turn
    config = {"repair.after_round_seconds": 1e6, "repair.crowd_agents": crowd, "repair.orders": 0}
    result, _ = solve(problem, config)
    assert result.status is PlanStatus.OPTIMAL and accepted(problem, result)
    assert bool(runs) is repairs
    assert all(len(agents) >= crowd for agents in runs)


@pytest.mark.parametrize("first_plan", [True, False])
def test_a_loop_looking_for_its_first_plan_repairs_every_round(
    first_plan: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a short round whose violations name no crowd: repaired only on the way to a first plan
    problem = crossing_problem()
    runs: list[set[str]] = []
    run = InTurn.run

    def spy(self: InTurn, bad: Any, budget: Budget) -> Plan | None:
        runs.append(agents_of(self.pm, bad))
        return run(self, bad, budget)

    monkeypatch.setattr(InTurn, "run", spy)
    config = {
        "solver.first_plan": first_plan,
        "repair.after_round_seconds": 1e6,
        "repair.crowd_agents": None,
        "repair.orders": 0,
        "repair.by_elements": None,  # (each agent its own element: no repair in turn)
    }
    result, _ = solve(problem, config)
    assert result.objective is not None and accepted(problem, result)
    assert bool(runs) is first_plan


def between(pm: Any, agents: set[str]) -> list[int]:
    """The lazy requirements that name exactly ``agents``."""
    return [n for n, r in enumerate(pm.deferral.lazy) if set(r.binding.values()) == agents]


def test_a_turn_that_fails_frees_the_agents_it_could_not_avoid() -> None:
    # the turns' solves stubbed: b alone cannot avoid a (names a); b with a finds a plan
    pm, session = _first_round(crossing_problem())
    calls: list[tuple[set[str], set[str]]] = []

    def stub(free: set[str], done: set[str], budget: Budget) -> set[str]:
        calls.append((set(free), set(done)))
        return {"a", "b"} if free == {"b"} else set()

    bad = between(pm, {"a", "b"})  # turns of a then b; c and d held throughout
    InTurn(pm, session, PlannerConfig(), solve=stub).run(bad, Budget.of_seconds(60))
    assert calls == [
        ({"a"}, {"c", "d"}),
        ({"b"}, {"a", "c", "d"}),
        ({"a", "b"}, {"a", "c", "d"}),  # b's turn again, a freed with it: a plan
        ({"a"}, {"b", "c", "d"}),  # the second turns: the repair went on
        ({"b"}, {"a", "c", "d"}),  # (b alone fails again: the second turns stop)
    ]
    # no agent to free with it: no plan, and no turn after it
    calls.clear()

    def alone(free: set[str], done: set[str], budget: Budget) -> set[str]:
        calls.append((set(free), set(done)))
        return set(free)

    assert InTurn(pm, session, PlannerConfig(), solve=alone).run(bad, Budget.of_seconds(60)) is None
    assert calls == [({"a"}, {"c", "d"})]


def test_the_agents_in_a_turns_way_are_freed_one_at_a_time() -> None:
    # b alone cannot avoid c and a (c named last); with c it still cannot avoid a; with both, a plan
    pm, session = _first_round(crossing_problem())
    calls: list[set[str]] = []

    def stub(free: set[str], done: set[str], budget: Budget) -> list[str]:
        calls.append(set(free))
        return {"b": ["b", "c", "a"], "bc": ["b", "c", "a"]}.get("".join(sorted(free)), [])

    bad = between(pm, {"a", "b"}) + between(pm, {"b", "c"})
    InTurn(pm, session, PlannerConfig(), solve=stub).run(bad, Budget.of_seconds(60))
    grown = [{"b"}, {"b", "c"}, {"a", "b", "c"}]
    assert calls[: 1 + len(grown)] == [{"a"}, *grown]  # a's turn, then b's (c freed with it)
    assert calls[1 + len(grown)] == {"a"}  # the second turns: the repair went on


@pytest.mark.heavy
def test_a_turn_out_of_time_frees_no_more_agents() -> None:
    # b's solve spends its share and still runs into c and a: more agents free would be slower
    pm, session = _first_round(crossing_problem())
    calls: list[set[str]] = []

    def stub(free: set[str], done: set[str], budget: Budget) -> list[str]:
        calls.append(set(free))
        if free == {"a"}:
            return []
        time.sleep(max(0.0, budget.remaining()))
        return ["b", "c", "a"]

    bad = between(pm, {"a", "b"}) + between(pm, {"b", "c"})
    assert InTurn(pm, session, PlannerConfig(), solve=stub).run(bad, Budget.of_seconds(6)) is None
    assert calls == [{"a"}, {"b"}]


def test_the_agents_named_by_a_later_solve_come_first() -> None:
    pm, _ = _first_round(crossing_problem())
    ab, bc, bd = (between(pm, {"b", x})[0] for x in "acd")
    # a named twice, then c, then d and a once more: d and a last named, a more often
    assert in_the_way(pm, {"b"}, [[ab], [ab, bc], [bd, ab]]) == ["b", "a", "d", "c"]
    assert in_the_way(pm, {"b"}, [[bd], [bc]]) == ["b", "c", "d"]
    assert in_the_way(pm, {"b", "c"}, [[bc]]) == ["b", "c"]


@pytest.mark.heavy
def test_a_formation_takes_its_turns_together() -> None:
    # Case I: each UV agent's turn is followed by that of the IR agent its crop_B element pairs
    # it with in the round's plan (the UV agents come first in the team's order)
    problem = load_problem(FARM)
    pm, _ = _first_round(problem)
    names = [a.name for a in problem.agents]
    (crop_b,) = (a for a in assignments(pm)[0] if a.task == "crop_B")
    order = in_formations(pm, names)
    assert sorted(order) == sorted(names) and order != names
    for uv, ir in crop_b.group:
        assert partners(pm, ir) == [uv] and partners(pm, uv) == [ir]
        assert order.index(ir) == order.index(uv) + 1
    assert in_formations(pm, ["vis1", "ir1", "vis2"]) == ["vis1", "ir1", "vis2"]


def test_a_choice_without_values_names_no_partners(caplog: pytest.LogCaptureFixture) -> None:
    # a merge's model before its first solve: the parts' plans give states, not choices
    pm = build_model(load_problem(FARM), paper_model(lazy__enabled=True))
    with caplog.at_level(logging.DEBUG):
        assert partners(pm, "ir1") == []
        assert in_formations(pm, ["uv1", "vis1", "ir1"]) == ["uv1", "vis1", "ir1"]
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_the_second_turns_never_make_the_repaired_plan_worse() -> None:
    problem = crossing_problem()
    pm, session = _first_round(problem)
    bad = pending_violations(pm)
    involved, repaired = agents_of(pm, bad), set[str]()
    turn = partial(solve_free, pm, session, PlannerConfig().repair)
    first: list[float] = []  # the plan's objective once every first turn has found a plan
    second: list[set[str]] = []  # the agents of the turns after that

    def spy(free: set[str], done: set[str], budget: Budget) -> list[str]:
        if repaired >= involved:
            second.append(set(free))
        partners = turn(free, done, budget)
        if not partners and not repaired >= involved:
            repaired.update(free)
            if repaired >= involved:
                first.append(float(value(pm.model.step1)))
        return partners

    assert InTurn(pm, session, PlannerConfig(), solve=spy).run(bad, Budget.of_seconds(30))
    assert pending_violations(pm) == []
    assert second and all(len(free) == 1 for free in second)
    (repaired_objective,) = first
    assert value(pm.model.step1) >= repaired_objective - 1e-7


def test_a_turn_adds_every_step_of_a_pair_it_crosses() -> None:
    problem = crossing_problem()
    pm, session = _first_round(problem)
    assert pm.deferral is not None
    InTurn(pm, session, PlannerConfig()).run(pending_violations(pm), Budget.of_seconds(30.0))
    lazy = pm.deferral.lazy
    families = {lazy[n].family for n in pm.added}
    assert families  # the turns crossed held agents and added what they crossed
    assert all(n in pm.added for n, r in enumerate(lazy) if r.family in families)


@pytest.mark.parametrize(
    "crowd, team, in_turn", [(2, None, True), (2, 3, True), (3, None, False), (2, 4, False)]
)
def test_a_merged_part_colliding_in_a_crowd_is_repaired_in_turn(
    crowd: int, team: int | None, in_turn: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a's plan crosses the idle e (another part): a crowd of two merges them, in a team of three
    problem = detour_for_free()
    turns: list[set[str]] = []
    repairs: list[tuple[str, Plan | None]] = []
    run = InTurn.run
    plug_ins = {kind: kind.repair for kind in (InTurnRepair, HeldRepair)}

    def spy_run(self: InTurn, bad: Any, budget: Budget) -> Plan | None:
        turns.append(agents_of(self.pm, bad))
        return run(self, bad, budget)

    def spy(kind: type) -> Any:
        def repair(self: Any, broken: Broken, config: PlannerConfig, budget: Budget) -> Any:
            pm = broken.solver.pm
            seeded = {pm.deferral.lazy[n].source for n in pm.added}
            assert ("separation" in seeded) is not in_turn  # the crossing is left to the turns
            repairs.append((self.describe(), plug_ins[kind](self, broken, config, budget)))
            return repairs[-1][1]

        return repair

    monkeypatch.setattr(InTurn, "run", spy_run)
    for kind in plug_ins:
        monkeypatch.setattr(kind, "repair", spy(kind))
    options = PlannerConfig().with_overrides(
        {
            "solver.time_limit": 60.0,
            "solver.gap": 1e-6,
            "repair.crowd_agents": crowd,
            "repair.crowd_team": team,
            "repair.orders": 0,
        }  # the repair in turn alone (prioritized: test_prioritized.py)
    )
    found = by_parts(problem, options)
    assert found[1].status is PlanStatus.OPTIMAL
    assert turns == ([{"a", "e"}] if in_turn else [])
    name, repaired = repairs[0]
    assert name == ("in turn" if in_turn else "held") and repaired is not None
    whole = up_front_optimum(problem)
    assert found[1].objective == pytest.approx(whole.objective, abs=1e-5)
    assert accepted(problem, plan(problem, options))


def test_a_repair_stops_once_the_loop_has_the_plan_it_asked_for() -> None:
    # the loop's watch took a plan during a's turn (a first plan): no turn or solve after it
    pm, session = _first_round(crossing_problem())
    calls: list[set[str]] = []

    def stub(free: set[str], done: set[str], budget: Budget) -> list[str]:
        calls.append(set(free))
        return []

    bad = between(pm, {"a", "b"})
    repair = InTurn(pm, session, PlannerConfig(), solve=stub, stop=lambda: bool(calls))
    assert repair.run(bad, Budget.of_seconds(60)) is None
    assert calls == [{"a"}]
    calls.clear()
    InTurn(pm, session, PlannerConfig(), solve=stub).run(bad, Budget.of_seconds(60))
    assert len(calls) > 2  # without a stop: b's turn, and the second turns
