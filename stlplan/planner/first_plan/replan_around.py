"""Parts done early, repaired around the plans the later parts published.

While a large team looks for its first plan, a part whose lazy loop found one publishes it, and
the repairs in turn of the parts still looking for theirs plan around it
(:mod:`stlplan.planner.first_plan.published`). The part done first planned around nothing, and a later
part's agent that found no way around a published plan left its collisions to a merge: the
merged team's model is built and its plan repaired in turn, each turn a solve of the whole
team's model with one agent free.

Before that merge, each part whose plan collides with another's is repaired in turn once more,
in its own model and HiGHS session, around the plans the other parts published: its agents the
collisions name take turns, each solved around the other parts' plans as around agents of its
own repaired before it, until its plan meets every requirement with them. A part whose repair
finds a plan takes it (its objective is that plan's, its bound stays) and publishes it;
whatever collisions are left are merged as before. The parts go in the order they published,
each once, within ``budget.side_share`` of the time left each. A merge the prioritized repair takes
(parts of at most ``repair.part_agents`` agents, a crowd's) is left to it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from stlplan.planner.backend.values import load_values, model_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.collisions import crossing_requirements
from stlplan.planner.core.in_turn import InTurn
from stlplan.planner.core.parts import Part
from stlplan.planner.core.watch import loaded_plan, pending_violations, trajectory_states
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.first_plan.published import Outside, Published
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.runtime import signals


def replanned_around(
    full: PlanModel,
    parts: Sequence[Part],
    crossing: Sequence[Requirement],
    published: Published | None,
    config: PlannerConfig,
    budget: Budget,
) -> bool:
    """Repair the parts whose plans break ``crossing`` (requirements of ``full`` between parts)
    around the plans of the others in ``published`` (module docstring); whether a part took a
    new plan."""
    if published is None or not crossing or not _taken_here(parts, crossing):
        return False
    changed = False
    for part in sorted(parts, key=lambda p: published.rank(p.agents)):
        if budget.expired() or signals.requested():
            break
        if not _named(part, crossing):
            continue
        if _repaired(part, published, config, budget.share(config.budget.side_share)):
            changed = True
            crossing = crossing_requirements(full, parts)
            if not crossing:
                break
    return changed


def _taken_here(parts: Sequence[Part], crossing: Sequence[Requirement]) -> bool:
    """Whether the merge of the parts ``crossing`` names is not the prioritized repair's."""
    named = [p for p in parts if _named(p, crossing)]
    policy = named[0].solver.policy
    return not policy.ordered(max(len(p.agents) for p in named))


def _named(part: Part, crossing: Sequence[Requirement]) -> bool:
    """Whether a requirement of ``crossing`` names an agent of ``part``."""
    mine = set(part.agents)
    return any(mine & set(r.binding.values()) for r in crossing)


def _repaired(part: Part, published: Published, config: PlannerConfig, budget: Budget) -> bool:
    """Repair ``part``'s plan in turn around the other parts' published plans, in its own
    session; whether it found a plan (taken and published; otherwise its plan is loaded
    again)."""
    solver, pm = part.solver, part.pm
    tick, saved = time.perf_counter(), model_values(pm.model)
    reached = solver.clock.reached
    reached.follow(part.agents)
    plan = None
    with published.around(pm) as outside, solver.lent(config.repair.gap):
        if outside is not None:
            stop = _stop_when_met(pm, outside)
            with reached.within("repair around later plans"):
                repair = InTurn(pm, solver.session, config, outside=outside, stop=stop)
                plan = repair.run([], budget)
            if plan is None and not signals.requested() and stop():  # stopped there
                plan = loaded_plan(pm)
    if plan is None:
        load_values(pm.model, saved)
        return False
    part.step1 = _taken(part, plan, time.perf_counter() - tick, config.solver.gap)
    published.publish(trajectory_states(pm))
    return True


def _stop_when_met(pm: PlanModel, outside: Outside) -> Callable[[], bool]:
    """Whether to stop the repair (asked between turns): on a stop request, or once the plan
    loaded in ``pm`` meets every requirement of its part and every one with the published
    plans."""

    def stop() -> bool:
        if signals.requested():
            return True
        states = trajectory_states(pm)
        return not pending_violations(pm) and not outside.broken(states, states)

    return stop


def _taken(part: Part, plan: Plan, seconds: float, gap: float) -> Outcome:
    """``part``'s result with ``plan`` as its plan (kept by its watch); its bound stays, and
    proves the plan optimal when within ``gap`` of it."""
    assert part.solver.watch is not None and part.step1 is not None
    part.solver.watch.best = plan
    return outcome.taken(part.step1, plan.objective, seconds, gap)
