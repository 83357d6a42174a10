"""Parts whose plans collide, merged into one part and repaired.

:mod:`stlplan.planner.core.components` merges parts whose plans break a requirement between them
(its docstring says when and why): the merged part's model is built, seeded with what its parts
had added, and the parts' plans are repaired together by the repairs the policy names for the
merge (:mod:`stlplan.planner.core.repairs`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.assembly import added_keys, plan_values
from stlplan.planner.core.collisions import merge_groups
from stlplan.planner.core.parts import Part, build_part, followed, tighten
from stlplan.planner.core.policy import Planned
from stlplan.planner.core.repairs import Broken
from stlplan.planner.core.watch import least_margin, trajectory_states
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import Deferral, Requirement, requirement_key
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.planner.tolerances import FEASIBILITY


def merged_parts(
    problem: Problem,
    parts: list[Part],
    crossing: Sequence[Requirement],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    whole: Deferral | None = None,
) -> list[Part]:
    """``parts`` with those linked by ``crossing`` merged (seeded with what they had added),
    each recording the whole's bound (:func:`~stlplan.planner.core.parts.followed`); a merge of
    every agent reuses ``whole``, the split of the whole team's requirements."""
    out, first = list(parts), config.solver.first_plan
    for group in merge_groups(parts, [set(r.binding.values()) for r in crossing]):
        agents = {a for p in group for a in p.agents}
        free = frozenset(a for r in crossing for a in r.binding.values()) & agents
        seed = set().union(*(added_keys(p.pm) for p in group))
        # (a repair in turn adds them as its plans cross)
        if not group[0].solver.policy.on_merge(len(free), len(problem.agents), first):
            seed |= {requirement_key(r) for r in crossing if set(r.binding.values()) <= agents}
        order = [a.name for a in problem.agents if a.name in agents]
        out = [p for p in out if p not in group]
        reused = whole if len(order) == len(problem.agents) else None
        merged = build_part(problem, order, config, clock, budget, seed, group[0].inner, reused)
        clock.reached.merges += 1
        merged.merged_from = tuple(group)
        merged.free, merged.team = free, len(problem.agents)
        out.append(merged)
    return followed(out, clock)


def merge_repairs(part: Part, config: PlannerConfig) -> tuple[Broken, Planned]:
    """What the repairs of a merged part start from (its parts' plans loaded, with the
    requirements they break together), and the repairs the policy names for the merge, each
    with its share of the time (module docstring)."""
    largest = max(len(p.pm.problem.agents) for p in part.merged_from)
    first = config.solver.first_plan
    repairs = part.solver.policy.merge_repairs(len(part.free), largest, part.team, first)
    return _broken(part), repairs


def merge_repaired(
    part: Part, plan: Plan, config: PlannerConfig, budget: Budget, tick: float
) -> Outcome:
    """A merged part's result from a repair's ``plan`` (the repair began at ``tick``), the
    bounds of the parts it comes from tightened towards it."""
    repaired = part.solver.repaired(plan, time.perf_counter() - tick)
    tighten(part.merged_from, config, budget, plan=repaired.objective)
    return repaired


def _broken(part: Part) -> Broken:
    """The plans of the parts a merged part comes from, loaded into its model, with the
    requirements they break together."""
    pm = part.pm
    assert pm.deferral is not None
    models = [p.pm for p in part.merged_from]
    for var, planned in plan_values(pm, models):
        var.set_value(planned, skip_validation=True)
    bad = violated(pm.deferral.lazy, trajectory_states(pm), least_margin(pm), FEASIBILITY)
    return Broken(part.solver, bad, models, part.free, [p.solver for p in part.merged_from])
