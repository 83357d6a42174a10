"""The repair by elements: a plan's task choices as tasks of count 1, planned part by part."""

from __future__ import annotations

from typing import Any

import pytest

from stlplan.formula.tree import Always, Interval
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.in_turn import InTurn
from stlplan.planner.core.parts import build_part
from stlplan.planner.core.repairs import Broken
from stlplan.planner.core.team_split import agent_parts
from stlplan.planner.encoding.readout import chosen, chosen_run
from stlplan.planner.first_plan import by_elements
from stlplan.planner.first_plan.by_elements import (
    element_problem,
    element_tasks,
    has_choices,
    run_of,
)
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from tests.helpers.missions import crossing_problem, mission
from tests.helpers.solving import accepted, solve

QUICK = PlannerConfig().with_overrides({"solver.time_limit": 60.0})


def crossing_by_capability() -> Problem:
    """Two P agents cross the square eastwards and two Q agents northwards; each goal takes any
    agent of its capability, and a task takes any pair of a P and a Q agent (they start apart),
    so the four are one part until the choices are made."""
    starts = {"p1": ("P", (0, 0.8)), "p2": ("P", (0, 1.2)),
              "q1": ("Q", (0.8, 0)), "q2": ("Q", (1.2, 0))}  # fmt: skip
    goals = {"E1": ("P", (2, 0.8)), "E2": ("P", (2, 1.2)),
             "N1": ("Q", (0.8, 2)), "N2": ("Q", (1.2, 2))}  # fmt: skip
    return mission(
        safety={"inter_sample": True},
        horizon=5,
        agents=[
            {"name": n, "dynamics": "si", "capabilities": [c], "initial_state": list(s)}
            for n, (c, s) in starts.items()
        ],
        regions={
            g: {"box": [[x - 0.1, x + 0.1], [y - 0.1, y + 0.1]]} for g, (_, (x, y)) in goals.items()
        },
        tasks={
            **{
                f"to_{g}": {"formula": f"F[4,5] in(p, {g})", "roles": {"p": c}}
                for g, (c, _) in goals.items()
            },
            "apart": {"formula": "dist(p, q) >= 0.1", "roles": {"p": "P", "q": "Q"}},
        },
        separation=0.3,
        objective={"beta": 1.0, "effort": "l1"},
    )


def meeting() -> Problem:
    """Two of three V agents must stay in C together (a synchronous task), and one of two W
    agents must reach D."""
    agents = [
        {"name": f"v{i}", "dynamics": "si", "capabilities": ["V"], "initial_state": [i, 0]}
        for i in range(3)
    ] + [
        {"name": f"w{i}", "dynamics": "si", "capabilities": ["W"], "initial_state": [i, 3]}
        for i in range(2)
    ]
    return mission(
        horizon=6,
        agents=agents,
        regions={"C": {"box": [[0.5, 1.5], [1.5, 2.5]]}, "D": {"box": [[2.5, 3.5], [2.5, 3.5]]}},
        tasks={
            "meet": {
                "formula": "in(p, C)",
                "count": 2,
                "roles": {"p": "V"},
                "synchronous": {"within": [1, 3], "hold": 1},
            },
            "reach": {"formula": "F[0,6] in(p, D)", "roles": {"p": "W"}},
        },
        separation=0.2,
        objective={"beta": 1.0, "effort": "l1"},
    )


def solved_part(problem: Problem) -> Any:
    """The lazy solver of the whole of ``problem``, its plan loaded."""
    budget = Budget.of_seconds(60)
    part = build_part(problem, [a.name for a in problem.agents], QUICK, Clock(0.0, None), budget)
    assert part.solver.run(budget).objective is not None
    return part.solver


def test_a_plans_choices_become_tasks_of_count_one() -> None:
    problem = meeting()
    pm = solved_part(problem).pm
    tasks = element_tasks(pm)
    (reach,) = pm.tasks
    (meet,) = pm.synchronous
    members, start, length = chosen_run(meet)
    assert length >= 2  # G[0, 1]
    assert len(tasks) == len(chosen(reach)) + len(members) == 1 + 2
    assert all(t.count == 1 and len(t.elements) == 1 and t.sync is None for t in tasks)
    run = Always(Interval(start, start + length - 1), meet.task.formula)
    assert [t.formula for t in tasks if t.name.startswith("meet")] == [run, run]
    assert {t.elements[0] for t in tasks} == {
        *(reach.task.elements[i] for i in chosen(reach)),
        *(meet.task.elements[i] for i in members),
    }
    names = {"meet"}
    assert [run_of(t.name, names) for t in tasks].count("meet") == 2
    assert run_of("reach_e0", names) is None and run_of("meet_e0", names) is None
    # a run started later, while it stays G[0, d] long
    later = element_tasks(pm, {"meet": length - 2})
    assert {t.formula for t in later if t.name.startswith("meet")} == {
        Always(Interval(start + length - 2, start + length - 1), meet.task.formula)
    }
    with pytest.raises(ValueError):
        element_tasks(pm, {"meet": length - 1})
    assert element_problem(problem, [pm], {"meet": length - 1}) is None


def test_a_plan_of_the_choices_meets_the_mission() -> None:
    problem = meeting()
    pm = solved_part(problem).pm
    choices = element_problem(problem, [pm])
    assert choices is not None
    # one part per chosen element, one per agent no element chose
    assert sorted(map(len, agent_parts(choices))) == [1] * len(problem.agents)
    result, _ = solve(choices)
    assert result.trajectory is not None
    assert accepted(problem, result)
    # the synchronous task keeps the run it was given: its synchronous robustness at least
    (meet,) = pm.synchronous
    _, _, length = chosen_run(meet)
    report = check(problem, result.trajectory)
    assert report.rho_s is not None and report.rho_s >= length - 1 - 1


def test_a_margin_maximized_or_a_replan_is_left_to_the_other_repairs() -> None:
    problem = meeting()
    pm = solved_part(problem).pm
    margin = problem.mission.objective.margin.model_copy(update={"maximize": True})
    objective = problem.mission.objective.model_copy(update={"margin": margin})
    widened = problem.mission.model_copy(update={"objective": objective})
    assert element_problem(_with(problem, mission=widened), [pm]) is None
    assert element_problem(_with(problem, past=object()), [pm]) is None


def _with(problem: Problem, **fields: Any) -> Problem:
    import dataclasses

    return dataclasses.replace(problem, _by_name={}, **fields)


@pytest.mark.parametrize("on", [True, False])
def test_a_first_plan_comes_from_the_choices_planned_in_turn(
    on: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    problem = crossing_by_capability()
    assert len(agent_parts(problem)) == 1
    in_turn: list[Any] = []
    run = InTurn.run
    monkeypatch.setattr(InTurn, "run", lambda self, *a: in_turn.append(a) or run(self, *a))
    config = {"solver.first_plan": True, "repair.by_elements": 0.5 if on else None}
    result, _ = solve(problem, config)
    assert result.objective is not None and accepted(problem, result)
    # the first round's plan crosses; its choices planned in turn (their joining solve in the
    # round log) give the plan at once, with no repair in turn
    stages = [row["stage"] for row in result.round_log]
    assert stages == ["lazy rounds", "repair by elements"] if on else ["lazy rounds"]
    assert bool(in_turn) is not on


def test_a_run_no_part_can_reach_alone_starts_later(monkeypatch: pytest.MonkeyPatch) -> None:
    problem = meeting()
    solver = solved_part(problem)
    (meet,) = solver.pm.synchronous
    members, start, length = chosen_run(meet)
    runs: list[set[Any]] = []

    def orders(merged: Any, parts: Any, config: Any, budget: Any, last: Any, alone: Any) -> Any:
        formulas = {
            t.formula for p in parts for t in p.pm.problem.tasks if t.name.startswith("meet")
        }
        runs.append({f.interval for f in formulas})
        if len(runs) == 1:  # the first part holding the run finds no plan alone
            alone.append(next(i for i, p in enumerate(parts) if p.pm.problem.tasks and
                              p.pm.problem.tasks[0].name.startswith("meet")))  # fmt: skip
        return None

    monkeypatch.setattr(by_elements, "prioritized", orders)
    assert length >= 3 or pytest.fail(f"run of {length} steps: nothing to start later")
    repair = by_elements.ElementsRepair()
    assert repair.repair(Broken(solver, []), QUICK, Budget.of_seconds(30)) is None
    last = start + length - 1
    assert runs[:2] == [{Interval(start, last)}, {Interval(start + 1, last)}]


def test_tasks_that_choose_nothing_are_left_as_they_are() -> None:
    # each agent its own task (a crowd's): the choices are the problem itself, so no repair by
    # elements, and the loop looking for its first plan keeps the run's gap
    problem = crossing_problem()
    assert not has_choices(problem) and has_choices(meeting())
    assert has_choices(crossing_by_capability())
    budget = Budget.of_seconds(60)
    quick = QUICK.with_overrides({"solver.first_plan": True})
    names = [a.name for a in problem.agents]
    part = build_part(problem, names, quick, Clock(0.0, None), budget)
    assert part.solver.run(budget).objective is not None
    assert element_problem(problem, [part.pm]) is None
    assert part.solver.session.solver.config.rel_gap == quick.solver.gap
    part.solver.stop_at_first_plan(True)
    assert part.solver.session.solver.config.rel_gap == quick.repair.gap
