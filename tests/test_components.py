"""Solving independent parts of the team apart: parts, merging on collisions, the gap, the result."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import pytest

from stlplan.formula.boundary import EPSILON
from stlplan.planner.backend.session import HighsSession
from stlplan.planner.backend.values import plan_of
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.components import crossing_requirements, waiting
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.parts import Part
from stlplan.planner.core.repairs import Broken, HeldRepair
from stlplan.planner.core.side_by_side import in_shares
from stlplan.planner.core.team_split import agent_parts, sub_problem
from stlplan.planner.encoding.deferred import requirement_key
from stlplan.planner.encoding.model import build_model
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.missions import detour_for_free, mission, swap_problem
from tests.helpers.paths import MISSIONS
from tests.helpers.solving import accepted, by_parts, up_front_optimum


def two_teams(separation: float | None = 0.05) -> Any:
    # a and b share a task; c and d share another; e has none: three parts
    agents = [
        {"name": n, "dynamics": "si", "capabilities": [cap], "initial_state": [x, 0]}
        for n, cap, x in [("a", "X", 0), ("b", "X", 1), ("c", "Y", 2), ("d", "Y", 3), ("e", "Z", 4)]
    ]
    return mission(
        horizon=3,
        agents=agents,
        regions={"R": {"box": [[0, 1], [2, 3]]}, "S": {"box": [[2, 3], [-3, -2]]}},
        tasks={
            "north": {"formula": "F[2,3] in(p, R)", "roles": {"p": "X"}},
            "south": {"formula": "F[2,3] in(p, S)", "roles": {"p": "Y"}},
        },
        separation=separation,
        objective={"beta": 1.0, "effort": "l1"},
    )


def test_parts_follow_tasks_and_constraints() -> None:
    assert agent_parts(two_teams()) == [("a", "b"), ("c", "d"), ("e",)]
    assert agent_parts(swap_problem(0.5)) == [("a",), ("b",)]
    linked = mission(
        horizon=2,
        agents=[{"name": n, "dynamics": "si", "initial_state": [i, 0]} for i, n in enumerate("ab")],
        constraints={"near": {"formula": "G[0,2] dist(p, q) <= 3", "roles": {"p": "a", "q": "b"}}},
    )  # fmt: skip
    assert agent_parts(linked) == [("a", "b")]


def test_a_maximized_margin_keeps_one_part() -> None:
    problem = mission(
        horizon=2,
        agents=[{"name": n, "dynamics": "si", "initial_state": [i, 0]} for i, n in enumerate("ab")],
        objective={"margin": {"maximize": True}},
    )
    assert agent_parts(problem) == [("a", "b")]


def test_sub_problem_keeps_only_its_agents() -> None:
    problem = two_teams()
    sub = sub_problem(problem, ["c", "d"])
    assert [a.name for a in sub.agents] == ["c", "d"]
    assert [t.name for t in sub.tasks] == ["south"]
    assert sub.agent("c") is problem.agent("c")


def test_parts_give_the_up_front_optimum() -> None:
    # proven to a gap of 1e-6 (4e-6 at this objective of about -4), so that two optima must
    # agree within the tolerance 1e-5
    problem = two_teams()
    options = PlannerConfig().with_overrides({"solver.time_limit": 60.0, "solver.gap": 1e-6})
    found = by_parts(problem, options)
    whole = up_front_optimum(problem)
    parted = plan(problem, options)
    assert found[1].status is PlanStatus.OPTIMAL
    assert found[1].objective == pytest.approx(whole.objective, abs=1e-5)
    assert parted.objective == pytest.approx(whole.objective, abs=1e-5)
    assert accepted(problem, parted)


def test_parts_solved_side_by_side_give_the_optimum_of_parts_one_after_another() -> None:
    options = PlannerConfig().with_overrides(
        {"solver.time_limit": 60.0, "solver.gap": 1e-6, "solver.threads": 2}
    )
    problem = two_teams()
    apart = plan(problem, options.with_overrides({"parts.side_by_side": 1}))
    beside = plan(problem, options)  # two threads: both parts at the same time
    assert beside.status is apart.status is PlanStatus.OPTIMAL
    assert beside.objective == pytest.approx(apart.objective, abs=1e-5)
    parts = {r["part"] for r in apart.round_log}
    assert len(parts) == 3 and {r["part"] for r in beside.round_log} == parts
    assert accepted(problem, beside)


def test_a_collision_between_parts_merges_them() -> None:
    # a and b are separate parts whose straight plans collide at step 1
    problem = swap_problem(separation=0.5)
    found = by_parts(problem, PlannerConfig().with_overrides({"solver.time_limit": 60.0}))
    full, step1 = found
    assert step1.status is PlanStatus.OPTIMAL
    # every predicate holds with the margin EPSILON (see tests/test_lazy.py); the merged part
    # holds the whole team, so this is its MILP's incumbent, whose rows hold within HiGHS's
    # primal feasibility tolerance (1e-7), not a held solve's
    assert step1.objective == pytest.approx(-(2 * 1.9 + 2 * 0.4 + 6 * EPSILON), abs=1e-6)
    assert full.deferral is not None
    assert any(full.deferral.lazy[n].source == "separation" for n in full.added)
    result = plan(problem, PlannerConfig().with_overrides({"solver.time_limit": 60.0}))
    assert accepted(problem, result)


def test_a_merged_part_is_repaired_with_only_the_colliding_agents_free(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    repairs: list[tuple[frozenset[str], Plan | None]] = []
    repair = HeldRepair.repair

    def spy(self: HeldRepair, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        repaired = repair(self, broken, config, budget)
        repairs.append((broken.free, repaired))
        return repaired

    monkeypatch.setattr(HeldRepair, "repair", spy)
    problem = detour_for_free()
    assert agent_parts(problem) == [("a", "b"), ("e",)]
    options = PlannerConfig().with_overrides({"solver.time_limit": 60.0, "solver.gap": 1e-6})
    found = by_parts(problem, options)
    _, step1 = found
    whole = up_front_optimum(problem)
    assert [free for free, _ in repairs] == [frozenset({"a", "e"})]  # b was held
    repaired = repairs[0][1]
    assert repaired is not None
    assert step1.status is PlanStatus.OPTIMAL
    assert step1.objective == pytest.approx(whole.objective, abs=1e-5)
    # the repair found the optimum: a took another monotone path at no cost
    assert repaired.objective == pytest.approx(whole.objective, abs=1e-5)
    assert accepted(problem, plan(problem, options))


@pytest.mark.parametrize(
    "first_plan, exact_finds, gaps",
    [(False, True, [1e-6]), (False, False, [1e-6, 0.02]), (True, True, [0.02])],
)
def test_the_held_repair_looks_for_a_plan_to_the_repair_gap_when_the_run_gap_finds_none(
    monkeypatch: pytest.MonkeyPatch, first_plan: bool, exact_finds: bool, gaps: list[float]
) -> None:
    # a repair's bound bounds only the held problem: once a solve to the run's gap (which may
    # prove the merged part) found no plan, or when a plan is all that is asked, the held
    # rounds stop at the repair's gap
    seen: list[tuple[LazySolver, float]] = []
    run = LazySolver.run

    def spy(self: LazySolver, budget: Budget, abs_gap: Any = None, trial: bool = False) -> Any:
        done = run(self, budget, abs_gap, trial)
        if not trial:
            return done
        seen.append((self, self.session.solver.config.rel_gap))
        return done if exact_finds or len(seen) > 1 else dataclasses.replace(done, objective=None)

    monkeypatch.setattr(LazySolver, "run", spy)
    options = PlannerConfig().with_overrides(
        {
            "solver.time_limit": 60.0,
            "solver.gap": 1e-6,
            "repair.gap": 0.02,
            "repair.by_elements": None,
        }  # (its rounds' looser gap: test_plan_first)
    )
    options = options.with_overrides({"solver.first_plan": first_plan})
    found = by_parts(detour_for_free(), options)
    assert found[1].objective is not None
    assert [gap for _, gap in seen] == gaps
    assert seen[0][0].session.solver.config.rel_gap == 1e-6  # the merged part's own rounds'


def test_a_solve_starts_from_a_given_plan() -> None:
    # HiGHS stops at its first improving plan: without a start that is a poor one here
    pm = build_model(
        detour_for_free(),
        paper_model(model__encoding="standard"),
    )
    exact = HighsSession(pm.model, PlannerConfig(), Clock(0.0, None), "step1")
    optimum = exact.solve(Budget.of_seconds(60)).results.incumbent_objective
    best = plan_of(pm.model, pm.model.step1)
    first = PlannerConfig().with_overrides(
        {"solver.highs_options": {"mip_max_improving_sols": 1, "mip_heuristic_effort": 0.0}}
    )
    trajectory = {k: v for k, v in best.values.items() if k[0] in ("x", "u")}
    partial = Plan(float("nan"), trajectory, meets_all=False)  # HiGHS completes the rest
    found = []
    for start in (None, best, partial):
        session = HighsSession(pm.model, first, Clock(0.0, None), "step1")
        if start is not None:
            session.start_from(start)
        found.append(session.solve(Budget.of_seconds(60)).results.incumbent_objective)
    assert found[0] < optimum - 1.0
    assert found[1] == pytest.approx(optimum, abs=1e-9)
    assert found[2] == pytest.approx(optimum, abs=1e-9)


def _place(part: Part, where: dict[str, tuple[float, float]]) -> None:
    """Load a plan standing still at ``where`` into ``part``'s model."""
    for name, (x, y) in where.items():
        for k in range(part.pm.problem.horizon + 1):
            part.pm.model.x[name, k, 0].set_value(x)
            part.pm.model.x[name, k, 1].set_value(y)


def test_only_requirements_between_parts_are_crossings() -> None:
    # a part's plan meets its own rows within HiGHS's tolerances (which may exceed the check's);
    # such a requirement is no crossing: merging parts could not change it, and the loop of
    # the parts would merge nothing and check again, forever
    problem = two_teams()
    options, clock = PlannerConfig().with_overrides({"solver.time_limit": 60.0}), Clock(0.0, None)
    lazy = paper_model(lazy__enabled=True, model__encoding=options.model.encoding)
    full = build_model(problem, lazy)
    parts = []
    for names in agent_parts(problem):
        pm = build_model(sub_problem(problem, names), lazy)
        parts.append(Part(names, pm, LazySolver(pm, options, clock)))
    spread = {"a": (0.0, 0.0), "b": (1.0, 0.0), "c": (2.0, 0.0), "d": (3.0, 0.0), "e": (4.0, 0.0)}
    for part in parts:
        _place(part, {n: spread[n] for n in part.agents})
    assert crossing_requirements(full, parts) == []
    owner = {n: part for part in parts for n in part.agents}
    _place(owner["b"], {"b": (0.0, 0.0)})  # a and b (one part) on the same spot
    assert crossing_requirements(full, parts) == []
    _place(owner["c"], {"c": (0.0, 0.0)})  # now c (another part) too
    linked = crossing_requirements(full, parts)
    assert linked and all({"c"} < set(r.binding.values()) for r in linked)


def test_parts_are_solved_smallest_first_in_shares_with_a_reserve(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # each stub part uses its whole share; the first solves leave parts.merge_reserve of the time
    asked: list[tuple[tuple[str, ...], float]] = []
    start = time.perf_counter()

    def solve_part(part: Part, share: Budget) -> Outcome:
        asked.append((part.agents, share.remaining()))
        monkeypatch.setattr(time, "perf_counter", lambda: share.deadline)  # the share is spent
        return Outcome(PlanStatus.OPTIMAL, 1.0, 1.0, None, 0.0, 1, 0, "optimal")

    parts = [Part(agents, None, None) for agents in (("a", "b", "c"), ("d",), ("e", "f"))]  # type: ignore[arg-type]
    monkeypatch.setattr(time, "perf_counter", lambda: start)
    budget = Budget(start + 100.0, start + 100.0)
    reserve = PlannerConfig().parts.merge_reserve
    first = waiting(parts)
    solved = in_shares(first, solve_part, budget, reserve)
    assert [agents for agents, _ in asked] == [("d",), ("e", "f"), ("a", "b", "c")]
    assert [p.agents for p in first] == [agents for agents, _ in asked]
    usable = 100.0 * (1 - reserve)
    assert [share for _, share in asked] == pytest.approx([usable / 3] * 3)
    assert all(done is not None and done.status is PlanStatus.OPTIMAL for done in solved)


def test_every_solve_of_a_merged_part_is_a_round_of_its_own() -> None:
    # a and b apart, then merged: the held repair's solve, then the merged part's own round;
    # the two used to share one round number, so `rounds` was one less than the records
    result = plan(swap_problem(0.5, horizon=3, inter_sample=True))
    assert result.status is PlanStatus.OPTIMAL
    log = result.round_log
    assert result.rounds == len(log) == 4
    assert [r["round"] for r in log] == [1, 2, 3, 4]
    assert [(r["part"], r["stage"]) for r in log] == [
        ("a", "lazy rounds"),
        ("b", "lazy rounds"),
        ("a, b", "held repair"),
        ("a, b", "lazy rounds"),
    ]
    assert result.requirements_added == sum(log[-1]["held"].values()) > 0
    assert result.requirements_completed == 0
    nodes = [r["nodes"] for r in log]  # the parts alone have no integers; the merge has
    assert nodes[:2] == [None, None] and all(isinstance(n, int) and n >= 1 for n in nodes[2:])


def test_a_merge_of_the_whole_team_reuses_the_whole_teams_requirements() -> None:
    from stlplan.planner.core.merges import merged_parts
    from stlplan.planner.core.parts import build_part

    config, clock, budget = PlannerConfig(), Clock(0.0, None), Budget.of_seconds(60)
    problem = two_teams(separation=0.5)
    full = build_model(problem, config)
    assert full.deferral is not None
    names = agent_parts(problem)
    parts = [build_part(problem, agents, config, clock, budget) for agents in names]

    def merged(pairs: list[tuple[str, str]]) -> Any:
        # the requirements of these pairs at step 1 are the crossings
        lazy = full.deferral.lazy
        crossing = [r for r in lazy if tuple(sorted(r.binding.values())) in pairs and r.k == 1]
        assert len(crossing) >= len(pairs)
        out = merged_parts(problem, parts, crossing, config, clock, budget, full.deferral)
        return next(p for p in out if p.merged_from)

    some = merged([("b", "c")])
    assert set(some.agents) == {"a", "b", "c", "d"}
    assert some.pm.deferral is not full.deferral  # a part of the team: its own
    every = merged([("b", "c"), ("d", "e")])
    assert set(every.agents) == {a.name for a in problem.agents}
    assert every.pm.deferral is full.deferral
    own = build_model(problem, config).deferral  # what it would have split itself
    assert own is not None
    keys = [requirement_key(r) for r in own.lazy]
    assert keys == [requirement_key(r) for r in full.deferral.lazy]


def test_a_tightened_part_whose_plan_collides_with_another_parts_gets_its_plan_back() -> None:
    # warehouse: the forklift's plan to a 30% gap keeps clear of the drone's, its optimum does
    # not; tightening used to keep the optimum after the crossing check, and the assembled
    # plan broke the separation (the monitor rejected it when the continuous stage ran out)
    from stlplan import api
    from stlplan.planner.core.parts import build_part, tighten
    from stlplan.planner.core.watch import trajectory_states

    problem = api.validate(MISSIONS / "warehouse.yaml")
    quick = {"solver.gap": 0.3, "solver.deterministic": True, "solver.threads": 1}
    loose = PlannerConfig.from_mission(problem.mission, quick)
    exact = loose.with_overrides({"solver.gap": 1e-4})
    clock, budget = Clock(0.0, None), Budget.of_seconds(60)
    full = build_model(problem, exact.with_overrides({"model.floors": False}))

    def solved() -> list[Part]:
        parts = [build_part(problem, names, loose, clock, budget) for names in agent_parts(problem)]
        for part in parts:
            part.step1 = part.solver.run(budget)
        assert crossing_requirements(full, parts) == []
        return parts

    alone = solved()
    tighten(alone, exact, budget)
    assert crossing_requirements(full, alone)  # the optimum of one part collides
    parts = solved()
    forklift = next(p for p in parts if p.agents == ("forklift",))
    assert forklift.step1 is not None and forklift.step1.bound is not None
    before, states = forklift.step1, trajectory_states(forklift.pm)["forklift"].copy()
    tighten(parts, exact, budget, together=lambda: not crossing_requirements(full, parts))
    assert crossing_requirements(full, parts) == []
    assert (trajectory_states(forklift.pm)["forklift"] == states).all()
    assert forklift.step1.objective == before.objective
    assert forklift.step1.bound is not None and forklift.step1.bound < before.bound - 1e-3
