"""Parts planned together: a neighbourhood of the improvement by elements larger than one part.

A sweep of the improvement (:func:`stlplan.planner.improve.sweeps`) plans one part at a time
around all the others, so two parts that each go around the other stay as they are: neither
can take the path it would take alone while the other's plan is in the way. Here a part whose
plan spends more effort than its plan around no one (its *excess*) is planned together with
the parts whose plans are in that plan's way, every other part's plan held as moving obstacles,
every solve of that turn given their current plans to start from (completed by HiGHS, so a
solve returns a plan no worse than them) and limited to ``parts.together_seconds``, without
the longer solve a prioritized turn falls back on. The new plans are kept when together they
spend less effort than the plans they replace.
Parts with the largest excess go first; the neighbourhood holds at most
``parts.together_agents`` agents.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence
from typing import Any

from stlplan.planner.budget import Budget
from stlplan.planner.by_elements import element_part
from stlplan.planner.outcome import Plan
from stlplan.planner.overlay import States
from stlplan.planner.prioritized import Turn
from stlplan.planner.values import effort, load_values, model_values, trajectory_values
from stlplan.runtime import signals

_log = logging.getLogger(__name__)

EFFORT_TOL = 1e-6
"""Plans planned together are kept when they spend less effort than before by more than this."""


def together(team: Any, turns: Any, budget: Budget) -> bool:
    """Each part with an excess planned together with the parts in its way (module
    docstring), the largest excess first; whether any plans were kept."""
    alone = _alone(team, turns.alone, budget)
    order = sorted(alone, key=lambda i: team.spent[i] - alone[i][1], reverse=True)
    lowered = False
    for i in order:
        if budget.expired() or signals.requested():
            break
        if team.spent[i] - alone[i][1] <= EFFORT_TOL:
            continue  # (a part's effort may have risen in an earlier neighbourhood)
        members = _neighbourhood(team, i, alone, turns.config.parts.together_agents)
        if len(members) > 1 and _planned_together(team, turns, members, budget):
            lowered = True
    return lowered


def _alone(team: Any, made: dict[int, Any], budget: Budget) -> dict[int, tuple[States, float]]:
    """Each part's plan around no one and its effort, by part (parts without one left out),
    solved once per turn (``made``, by the turn's id); every part's model loaded with its plan
    again after."""
    out = {}
    for i, turn in enumerate(team.turns):
        if budget.expired() or signals.requested():
            break
        if id(turn) not in made:
            found = turn.solve({}, budget)
            turn.clear()
            spent = effort(turn.pm.model)
            load_values(turn.pm.model, team.kept[i])
            if found is None and budget.expired():
                break  # (cut off: not known to have no plan alone)
            made[id(turn)] = None if found is None else (found, spent)
        if made[id(turn)] is not None:
            out[i] = made[id(turn)]
    return out


def _neighbourhood(
    team: Any, i: int, alone: dict[int, tuple[States, float]], most: int
) -> list[int]:
    """Part ``i`` and the parts whose current plans are in the way of its plan alone, those
    with the largest excess first, while they hold at most ``most`` agents."""
    owner = {a: j for j, plan in enumerate(team.plans) for a in plan}
    in_way = {owner[a] for a in team.turns[i].in_the_way(alone[i][0], team.around(i))}

    def excess(j: int) -> float:
        return team.spent[j] - alone[j][1] if j in alone else math.inf

    members, size = [i], len(team.plans[i])
    for j in sorted(in_way, key=excess, reverse=True):
        if size + len(team.plans[j]) <= most:
            members.append(j)
            size += len(team.plans[j])
    return members


def _planned_together(team: Any, turns: Any, members: Sequence[int], budget: Budget) -> bool:
    """The parts ``members`` planned in one turn around every other part, from their current
    plans; their new plans taken when they spend less effort. Whether they were."""
    turn = _joint_turn(team, turns, members, budget)
    agents = turn.agents
    start = trajectory_values(team.values(), agents)  # HiGHS completes the rest
    fixed = {a: s for j, plan in enumerate(team.plans) if j not in members for a, s in plan.items()}
    found = turn.solve(fixed, budget, start=Plan(math.nan, start))
    turn.clear()
    was, now = sum(team.spent[m] for m in members), effort(turn.pm.model)
    _log.debug("improvement: %s together, effort %.4f -> %s", sorted(agents), was, found and now)
    if found is None or now >= was - EFFORT_TOL:
        return False
    values = model_values(turn.pm.model)
    for m in members:
        part = team.turns[m]
        load_values(part.pm.model, trajectory_values(values, part.agents))
        team.take(m, part, {a: found[a] for a in part.agents})
    return True


def _joint_turn(team: Any, turns: Any, members: Sequence[int], budget: Budget) -> Turn:
    """The turn of the agents of the parts ``members`` with their tasks (built once for the
    same agents and tasks), its session lent for as long as ``turns`` lends them."""
    parts = [team.turns[m] for m in members]
    agents = tuple(a.name for a in turns.problem.agents if any(a.name in p.agents for p in parts))
    tasks = tuple(t for p in parts for t in p.pm.problem.tasks)
    joint = dataclasses.replace(turns.problem, tasks=tasks, _by_name={})
    states = trajectory_values(team.values(), agents)
    config = turns.config.with_overrides(
        {"repair.solve_seconds": turns.config.parts.together_seconds}
    )
    part = element_part(joint, agents, turns.whole, config, budget, states, turns.built)
    return turns.turn_of(part, config)
