"""A large team's first plan improved element by element: each element planned again around all
the others.

A first plan of a large team (:mod:`stlplan.planner.plan_first`) most often comes from the
repair by elements (:mod:`stlplan.planner.by_elements`): the tasks' chosen elements planned one
after another, each around those before it. The first ones were planned as if the later ones
were not there, and the later ones go around them, so the plan spends more effort than its
choices need. Before the parts go on towards their proofs, the plan's choices are written as a
problem of their own again (:func:`~stlplan.planner.by_elements.element_problem`), and its parts
(an element's agents, or an agent no element chose) are planned again, each in its own model
with every other part's plan as moving obstacles (a prioritized turn,
:class:`~stlplan.planner.prioritized.Turn`), those with the most effort first. A part keeps
its new plan only when it spends less effort. Sweeps over every part are repeated while one
lowers the team's effort, within ``parts.improve_share`` of the time left. The model of the
whole team is then solved once with every agent held near its plan
(:func:`~stlplan.planner.prioritized.held_plan`), and its plan is taken when its objective is
higher than the first plan's.

The choices stay as they were (the elements each task chose, a synchronous task's run): only
the effort improves, never the synchronous robustness. Every part's new plan meets every
requirement between it and the plans of all the others, so the team's plan stays a plan of the
whole problem after every accepted turn. This is a large neighbourhood search whose
neighbourhoods are the tasks' elements.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Sequence
from typing import Any

from stlplan.mission.problem import Problem
from stlplan.planner.budget import Budget
from stlplan.planner.by_elements import element_groups, element_part, element_problem
from stlplan.planner.clock import Clock
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.lazy import LazySolver
from stlplan.planner.outcome import Outcome, Plan, relative_gap
from stlplan.planner.prioritized import Turn, held_plan, requirements_naming
from stlplan.planner.values import load_values, model_values
from stlplan.planner.watch import load_plan
from stlplan.runtime import signals

Solved = tuple[PlanModel, Outcome]
"""A model of the whole team with its plan loaded, and the outcome of that plan."""


def improved(
    problem: Problem, solved: Solved, config: PlannerConfig, clock: Clock, budget: Budget
) -> Solved:
    """``solved`` (a plan of the whole team of ``problem``, loaded in its model) improved
    element by element within ``budget`` (module docstring), or as it was."""
    full, done = solved
    if done.objective is None or not done.status.has_plan:
        return solved
    elements = element_problem(problem, [full])
    if elements is None:
        return solved
    groups = element_groups(elements, config)
    if groups is None:
        return solved
    saved, before = model_values(full.model), frozenset(full.added)
    plan, taken = None, False
    try:
        with clock.reached.within("improvement by elements"):
            plan = _swept(elements, groups, full, config, clock, budget, saved)
        taken = plan is not None and plan.objective > done.objective
    finally:
        if not taken:  # the first plan again, the requirements added since on its sides
            load_plan(full, saved, before)
    if plan is None or not taken:
        return solved
    clock.plan_found(plan.objective)
    gap = relative_gap(plan.objective, done.bound)
    return full, dataclasses.replace(done, objective=plan.objective, gap=gap)


def _swept(
    elements: Problem,
    groups: Sequence[tuple[str, ...]],
    full: PlanModel,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    saved: dict[Any, float],
) -> Plan | None:
    """The parts of ``groups`` (of the element problem) planned again in sweeps, their plans
    joined in ``full``; None when no sweep lowered the effort or the join found no plan."""
    whole = LazySolver(full, config, clock)
    states = {k: v for k, v in saved.items() if k[0] in ("x", "u")}
    parts = [element_part(elements, g, whole, config, budget, states, {}) for g in groups]
    with contextlib.ExitStack() as lent:
        sessions = [lent.enter_context(part.lent(config.repair.gap)) for part in parts]
        naming = requirements_naming(full)
        turns = [Turn(p.pm, s, full, config, naming) for p, s in zip(parts, sessions, strict=True)]
        if not sweeps(turns, budget.share(SWEEPS_SHARE)) or signals.requested():
            return None
        return held_plan(whole, turns, config, budget)


def sweeps(turns: Sequence[Any], budget: Budget) -> bool:
    """Each turn's part planned again around all the others' plans, the most effort first, a
    new plan kept when it spends less; sweeps while one lowers the effort. Whether any did (the
    turns' models then hold the kept plans)."""
    plans = [dict(turn.own) for turn in turns]
    kept = [model_values(turn.pm.model) for turn in turns]
    spent = [effort(turn.pm) for turn in turns]
    order = sorted(range(len(turns)), key=lambda i: -spent[i])
    lowered = False
    while not (budget.expired() or signals.requested()):
        gained = 0.0
        for i in order:
            if budget.expired() or signals.requested():
                break
            fixed = {a: s for j, plan in enumerate(plans) if j != i for a, s in plan.items()}
            found = turns[i].solve(fixed, budget)
            turns[i].clear()
            now = effort(turns[i].pm) if found is not None else None
            if found is not None and now is not None and now < spent[i] - EFFORT_TOL:
                gained += spent[i] - now
                spent[i], plans[i], kept[i] = now, found, model_values(turns[i].pm.model)
            else:
                load_values(turns[i].pm.model, kept[i])
        lowered = lowered or gained > 0
        if gained <= 0:
            break
    return lowered


SWEEPS_SHARE = 0.75
"""Share of the improvement's time the sweeps may take; the solve that joins their plans may
take the rest."""

EFFORT_TOL = 1e-6
"""A part's new plan is kept when it spends less effort than its plan by more than this."""


def effort(pm: PlanModel) -> float:
    """The L1 effort of the inputs loaded in ``pm`` (the effort step 1 counts)."""
    return sum(abs(v) for k, v in model_values(pm.model).items() if k[0] == "u")
