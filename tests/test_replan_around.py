"""Parts done early, repaired around the plans the later parts published, before a merge."""

from __future__ import annotations

import numpy as np

from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.collisions import crossing_requirements
from stlplan.planner.core.parts import Part, build_part
from stlplan.planner.core.watch import pending_violations, trajectory_states
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.first_plan.published import Published
from stlplan.planner.first_plan.replan_around import replanned_around
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from tests.helpers.missions import crossing_problem


def _apart(orders: int) -> tuple[PlanModel, list[Part], Published, PlannerConfig]:
    """The crossing problem's pairs a, b and c, d, each planned on its own (their straight
    plans meet near (1, 1)), both plans published, the first pair's first."""
    problem = crossing_problem(paired=True)
    config = PlannerConfig().with_overrides({
        "solver.time_limit": 60.0, "solver.first_plan": True, "solver.threads": 1,
        "repair.orders": orders,
    })  # fmt: skip
    clock, budget = Clock(0.0, None), Budget.of_seconds(60)
    full = build_model(problem, config.with_overrides({"model.floors": False}))
    published = Published(full)
    parts = [build_part(problem, pair, config, clock, budget) for pair in (("a", "b"), ("c", "d"))]
    for part in parts:
        part.step1 = part.solver.run(budget)
        assert part.step1.status.has_plan
        published.publish(trajectory_states(part.pm))
    return full, parts, published, config


def test_the_part_done_first_is_repaired_around_the_later_ones_plan() -> None:
    full, parts, published, config = _apart(orders=0)
    crossing = crossing_requirements(full, parts)
    assert crossing
    later = {a: s.copy() for a, s in trajectory_states(parts[1].pm).items()}
    assert replanned_around(full, parts, crossing, published, config, Budget.of_seconds(60))
    assert crossing_requirements(full, parts) == []  # no merge needed
    for agent, states in trajectory_states(parts[1].pm).items():  # the later part kept its plan
        np.testing.assert_array_equal(states, later[agent])
    first = parts[0]
    assert pending_violations(first.pm) == []  # a plan of its own part
    assert first.solver.watch is not None and first.solver.watch.best is not None
    assert first.step1 is not None and first.step1.objective == first.solver.watch.best.objective
    for agent, states in trajectory_states(first.pm).items():  # published again
        np.testing.assert_array_equal(published.plans[agent], states)


def test_a_merge_the_prioritized_repair_takes_is_left_to_it() -> None:
    full, parts, published, config = _apart(orders=3)  # pairs: parts of at most 4 agents
    crossing = crossing_requirements(full, parts)
    before = [trajectory_states(p.pm) for p in parts]
    assert crossing
    assert not replanned_around(full, parts, crossing, published, config, Budget.of_seconds(60))
    for part, states in zip(parts, before, strict=True):
        for agent, planned in trajectory_states(part.pm).items():
            np.testing.assert_array_equal(planned, states[agent])


def test_publication_order_ranks_the_parts() -> None:
    _, parts, published, _ = _apart(orders=0)
    assert published.rank(parts[0].agents) < published.rank(parts[1].agents)
    assert published.rank(("e",)) == len(published.plans)  # never published: last
