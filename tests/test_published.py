"""Parts planned around the first plans other parts published."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from pyomo.environ import Block, ConstraintList, VarList

from stlplan.mission.problem import Problem
from stlplan.planner.backend.session import HighsSession
from stlplan.planner.backend.values import ColumnKeys
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.components import Parts
from stlplan.planner.core.in_turn import InTurn, agents_of, broken_requirements
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.team_split import sub_problem
from stlplan.planner.core.watch import pending_violations, trajectory_states
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.model import build_model
from stlplan.planner.first_plan.hooks import FirstPlan
from stlplan.planner.first_plan.published import Published
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.solve import plan
from stlplan.planner.strategy import LazyRounds
from tests.helpers.configs import paper_model
from tests.helpers.missions import crossing_problem
from tests.helpers.solving import accepted


def pairs_problem() -> Problem:
    """The crossing problem's four agents in two parts, a with b and c with d: every straight
    plan meets near (1, 1) at step 2."""
    return crossing_problem(paired=True)


def _relaxed(problem: Problem) -> tuple[Any, HighsSession]:
    """The lazy model of ``problem`` with its first round's plan (no separation) loaded."""
    options = PlannerConfig().with_overrides({"solver.time_limit": 60.0})
    pm = build_model(problem, paper_model(lazy__enabled=True))
    session = HighsSession(pm.model, options, Clock(0.0, None), "step1")
    assert session.solve(Budget.of_seconds(30)).results.incumbent_objective is not None
    return pm, session


def _published(problem: Problem, agents: list[str]) -> Published:
    """Where the plans of the part of ``agents`` are published: its first round's, repaired in
    turn."""
    pm, session = _relaxed(sub_problem(problem, agents))
    InTurn(pm, session, PlannerConfig()).run(pending_violations(pm), Budget.of_seconds(30))
    assert pending_violations(pm) == []
    published = Published(build_model(problem, paper_model(lazy__enabled=True)))
    published.publish(trajectory_states(pm))
    return published


def test_only_requirements_with_published_agents_are_outside() -> None:
    problem = pairs_problem()
    pm, _ = _relaxed(sub_problem(problem, ["c", "d"]))
    published = Published(build_model(problem, paper_model(lazy__enabled=True)))
    with published.around(pm) as outside:
        assert outside is None  # nothing published yet
    published = _published(problem, ["a", "b"])
    published.plans.pop("b")
    components = set(pm.model.component_map())
    with published.around(pm) as outside:
        assert outside is not None
        named = [set(r.binding.values()) for r in outside.requirements]
        assert named and all(agents in ({"a", "c"}, {"a", "d"}) for agents in named)
        outside.add(outside.naming(["c"]))  # c's rows in a block of its own
        assert len(set(pm.model.component_map()) - components) == 1
        assert outside.excuse(["c"]) and not outside.excuse(["c"])  # removed, once
        assert outside.naming(["c"]) == [] and outside.naming(["d"])
        assert not outside.excuse(["d"]) and outside.naming(["d"])  # no rows: not excused
        outside.add(outside.naming(["d"]))
    assert set(pm.model.component_map()) == components  # every block removed


def test_a_repair_in_turn_plans_around_the_published_plans() -> None:
    problem = pairs_problem()
    published = _published(problem, ["a", "b"])
    pm, session = _relaxed(sub_problem(problem, ["c", "d"]))
    bad = pending_violations(pm)
    assert agents_of(pm, bad) == {"c", "d"}  # c and d cross each other
    fixed = published.plans
    with published.around(pm) as outside:
        assert outside is not None
        assert outside.named(trajectory_states(pm))  # and the plans of a and b
        repaired = InTurn(pm, session, PlannerConfig(), outside=outside).run(
            bad, Budget.of_seconds(30)
        )
        assert not outside.excused
    assert repaired is not None and pending_violations(pm) == []
    full = build_model(problem, paper_model(lazy__enabled=True))
    assert full.deferral is not None
    states = {**fixed, **trajectory_states(pm)}
    assert violated(full.deferral.lazy, states, 0.0, 1e-6) == []  # with a and b's plans too


def test_a_turn_without_a_plan_around_them_leaves_them_to_a_merge() -> None:
    # a published plan on d's own path, from d's start: no turn of d can keep away from it
    problem = pairs_problem()
    pm, session = _relaxed(sub_problem(problem, ["c", "d"]))
    published = Published(build_model(problem, paper_model(lazy__enabled=True)))
    published.publish({"a": trajectory_states(pm)["d"].copy()})
    bad = pending_violations(pm)
    with published.around(pm) as outside:
        assert outside is not None
        repaired = InTurn(pm, session, PlannerConfig(), outside=outside).run(
            bad, Budget.of_seconds(30)
        )
        assert "d" in outside.excused and outside.naming(["d"]) == []
    assert repaired is not None and pending_violations(pm) == []


@pytest.mark.parametrize("around", [True, False])
def test_while_looking_for_a_first_plan_a_part_plans_around_those_done(around: bool) -> None:
    problem = pairs_problem()
    options = PlannerConfig().with_overrides({
        "solver.time_limit": 60.0, "solver.first_plan": True, "solver.threads": 1,
        "repair.orders": 0,
    })  # fmt: skip
    clock = Clock(0.0, None)
    hooks = FirstPlan.of(options)  # (without the first-plan hooks nothing is published)
    inner = LazyRounds(RepairPolicy.of(options, hooks))
    parts = Parts(inner, hooks=hooks if around else None)
    found = parts.solve(problem, options, clock, Budget.of_seconds(60))
    assert found[1].status.has_plan
    assert (clock.reached.merges == 0) is around  # the second part's plan meets the first's
    result = plan(problem, options)
    assert result.objective is not None and accepted(problem, result)


def test_blocks_keep_their_names_apart_when_an_earlier_one_is_removed() -> None:
    # a part of three agents around a published plan: b's rows, c's, b excused, then d's
    problem = crossing_problem()
    pm, _ = _relaxed(sub_problem(problem, ["b", "c", "d"]))
    published = Published(build_model(problem, paper_model(lazy__enabled=True)))
    published.publish({"a": np.ones((5, 2))})  # in the middle of the square
    with published.around(pm) as outside:
        assert outside is not None
        for agent in "bc":
            outside.add(outside.naming([agent]))
        assert outside.excuse(["b"])
        outside.add(outside.naming(["d"]))  # a name of its own, not c's
        assert sorted(outside.blocks) == ["c", "d"]


def test_column_keys_follow_a_block_removed_and_another_of_its_size_added() -> None:
    pm, session = _relaxed(crossing_problem())
    columns = ColumnKeys(pm.model, session.columns)
    for name in ("first", "second"):  # the second block's columns take the first's places
        block = Block(concrete=True)
        block.v = VarList(bounds=(0, 1))
        block.rows = ConstraintList()
        for _ in range(3):
            block.rows.add(block.v.add() <= 1)
        pm.model.add_component(name, block)
        assert session.solve(Budget.of_seconds(30)).results.incumbent_objective is not None
        keys = columns.keys()
        blocks = {key[0] for key in keys if key is not None and key[0].endswith(".v")}
        assert blocks == {f"{name}.v"}
        pm.model.del_component(block)


def test_a_held_agent_breaking_a_requirement_with_a_published_plan_is_caught() -> None:
    # d's own plan published as a's: every step of d breaks its separation from a
    problem = pairs_problem()
    pm, _ = _relaxed(sub_problem(problem, ["c", "d"]))
    published = Published(build_model(problem, paper_model(lazy__enabled=True)))
    published.publish({"a": trajectory_states(pm)["d"].copy()})
    with published.around(pm) as outside:
        assert outside is not None
        _, theirs = broken_requirements(pm, outside, free={"c"}, done={"d"})  # d held, c free
        assert any("d" in outside.requirements[n].binding.values() for n in theirs)
