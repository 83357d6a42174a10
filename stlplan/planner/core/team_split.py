"""Which agents make the independent parts of a team: agents that no task, constraint or
objective term links, and the problem of a part (its agents' tasks, constraint bindings and
separation).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from stlplan.mission.problem import Problem


def agent_parts(problem: Problem) -> list[tuple[str, ...]]:
    """The agents of each independent part, in agent order (one part when none can be split)."""
    names = [a.name for a in problem.agents]
    if problem.mission.objective.margin.maximize:
        return [tuple(names)]
    parent = {n: n for n in names}

    def find(n: str) -> str:
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    def link(group: Iterable[str]) -> None:
        members = list(group)
        for other in members[1:]:
            parent[find(other)] = find(members[0])

    for task in problem.tasks:
        link(task.agents())
    link({agent for t in problem.tasks if t.sync for agent in t.agents()})
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            link(set(binding.values()))
    parts: dict[str, list[str]] = {}
    for n in names:
        parts.setdefault(find(n), []).append(n)
    return [tuple(p) for p in parts.values()]


def sub_problem(problem: Problem, agents: Iterable[str]) -> Problem:
    """``problem`` restricted to ``agents``: their tasks, constraint bindings and separation."""
    keep = set(agents)
    tasks = tuple(t for t in problem.tasks if t.agents() <= keep)
    constraints = []
    for c in problem.constraints:
        bindings = tuple(b for b in c.bindings if set(b.values()) <= keep)
        if bindings:
            constraints.append(dataclasses.replace(c, bindings=bindings))
    return dataclasses.replace(
        problem,
        agents=tuple(a for a in problem.agents if a.name in keep),
        tasks=tasks,
        constraints=tuple(constraints),
        _by_name={},
    )
