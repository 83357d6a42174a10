"""Classes of interchangeable agents, and one chain of ordering rows per class.

Two agents are *interchangeable* when they have the same capabilities, the same dynamics (``A``,
``B``, position components, state and input bounds, final condition) and the same initial state,
and the mission names neither of them: no task Pattern pins a role to it, and no constraint lists
it in ``agents`` or pins a role to it. Effort has one weight, ``beta``, for every agent.

*Swapping is a symmetry.* Let ``pi`` exchange two interchangeable agents ``p`` and ``q``. A role
with a capability rule admits ``p`` exactly when it admits ``q``, and no role is pinned to
either, so ``pi`` maps the elements of every task (all assignments of distinct admitted agents
to the roles) onto elements of the same task, and every constraint binding onto a binding
(``for_each`` over the whole team). Given a plan, give ``p`` the trajectory of ``q`` and ``q``
that of ``p``, and choose element ``pi(e)`` wherever ``e`` was chosen: ``h_pi(e)`` under the new
trajectories is ``h_e`` under the old (same dynamics and initial state, same formula), each agent
is still in at most one chosen element, the window of a synchronous task is unchanged,
separation and constraints hold for every pair and agent alike, and the effort is the same sum.
So the image is a plan of the same objective; composing swaps, so is the image under any
permutation of a class, and permutations of two classes act on disjoint agents.

*The chain.* For a class ``p1 < ... < pm`` (mission order) and one task ``T`` with
``s_T(p) = sum of x_e over T's elements containing p``, the rows

    s_T(p1) >= s_T(p2) >= ... >= s_T(pm)

keep an optimal plan: permute the class so that ``s_T`` decreases along it (the permutation
moves ``s_T(p)`` to the new holder of ``p``'s trajectory). One class's permutation leaves
``s_T'(q)`` of every agent ``q`` outside it unchanged, so one chain per class, all at once, is
valid; two chains for one class (on two tasks) are not in general. ``T`` is the first task, in
mission order, that the class can serve and whose elements are chosen by binaries (a task whose
every element is required gives every class member the same ``s_T``, by the symmetry above).

The rows are written on element selections (:mod:`stlplan.planner.encoding.selection`); the
group encoding gets none. A part of the team (:mod:`stlplan.planner.core.parts`) holds whole classes
(a class serves the same tasks), so a part's chains are the full problem's. A solve that holds
some agents at their plans (a repair) keeps the rows: what it finds is a plan of the full problem,
though the rows may leave it fewer plans than it would have without them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from stlplan.mission.problem import AgentModel, Problem, TaskModel
from stlplan.mission.schema import PinnedRole
from stlplan.planner.encoding.selection import Selection
from stlplan.planner.encoding.stl import StlContext

_ARRAYS = ("A", "B", "state_lo", "state_hi", "input_lo", "input_hi", "initial_state")
"""The numpy fields of :class:`AgentModel` two interchangeable agents share exactly."""


def named_agents(problem: Problem) -> set[str]:
    """Agents the mission names: pinned task roles, constraint ``agents`` lists and roles."""
    named = {
        rule.agent
        for spec in problem.mission.tasks.values()
        for rule in spec.roles.values()
        if isinstance(rule, PinnedRole)
    }
    for spec in problem.mission.constraints.values():
        named |= set(spec.agents or ()) | set(spec.roles.values())
    return named


def same_agent(a: AgentModel, b: AgentModel) -> bool:
    """Same capabilities, dynamics, bounds, final condition and initial state (exactly)."""
    if (a.capabilities, a.position, a.at_rest) != (b.capabilities, b.position, b.at_rest):
        return False
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in _ARRAYS)


def agent_classes(problem: Problem) -> list[tuple[str, ...]]:
    """Classes of at least two interchangeable agents, each in mission order."""
    named = named_agents(problem)
    classes: list[list[AgentModel]] = []
    for agent in problem.agents:
        if agent.name in named:
            continue
        home = next((c for c in classes if same_agent(c[0], agent)), None)
        if home is None:
            classes.append([agent])
        else:
            home.append(agent)
    return [tuple(a.name for a in c) for c in classes if len(c) >= 2]


def serves(task: TaskModel, agent: str) -> bool:
    """Whether some element of ``task`` holds ``agent``."""
    return any(agent in element for element in task.elements)


def chain_task(
    problem: Problem, members: Sequence[str], selections: Mapping[str, Selection]
) -> Selection | None:
    """The selection of the first task (mission order) the class serves with a choice."""
    for task in problem.tasks:
        chosen = selections[task.name]
        if serves(task, members[0]) and not all(isinstance(x, float) for x in chosen.chosen):
            return chosen
    return None


def share(selection: Selection, agent: str) -> Any:
    """``s_T(p)``: the sum of ``x_e`` over the task's elements holding ``p``."""
    elements = selection.task.elements
    return sum(x for x, e in zip(selection.chosen, elements, strict=True) if agent in e)


def order_classes(ctx: StlContext, problem: Problem, selections: Sequence[Selection]) -> None:
    """``s_T(p_i) >= s_T(p_i+1)`` for each class (module docstring)."""
    by_name = {s.task.name: s for s in selections}
    for members in agent_classes(problem):
        selection = chain_task(problem, members, by_name)
        if selection is None:
            continue
        for first, second in zip(members, members[1:], strict=False):
            ctx.block.rows.add(share(selection, first) >= share(selection, second))
