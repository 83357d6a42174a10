"""Tasks that need the same agents at once, found without solving.

A task whose formula is a conjunction with a conjunct ``G[a,b] (... & in(p, R) & ...)`` keeps the
agent of role ``p`` in region ``R`` at every step ``a..b``, in each of the ``c`` elements of its
group, and a group's elements have distinct agents. Such an agent is then out of every region
disjoint from ``R`` at those steps, as if a constraint kept it out (the ``barred`` steps of
:mod:`stlplan.analysis.decided`). A task of one role whose elements this leaves unable (the
upper bound of their robustness below ``HOLDS_AT``) cannot be served by that agent while the
first task is met. When the agents that can serve it, less those the first task must take from
them, are fewer than its count, the two tasks cannot be met together. The claim is sound, as
every cheap reason: reachability over-approximates, and a task's element that may still be met
is counted as such (the constraints are left out of it, so the two tasks conflict on their own).

This decides, for instance, Case I with ``uv1`` lost: ``crop_B`` keeps both UV agents left in
``B`` at steps 2..7, and ``crop_A1`` (and ``crop_A2``) needs a UV agent in its plot for three
steps starting by step 7: a conflict of two tasks each, so the degraded plan drops ``crop_B``
without a probe to find out.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache

import numpy as np

from stlplan.analysis.decided import upper_robustness
from stlplan.analysis.initial import Reason
from stlplan.formula.boundary import HOLDS_AT
from stlplan.formula.tree import Always, And, Formula, InRegion, regions
from stlplan.mission.polytope import inscribed_radius
from stlplan.mission.problem import Problem, TaskModel


@dataclass(frozen=True)
class Pin:
    """A role a task keeps in a region at every step of ``lo..hi``."""

    role: str
    region: str
    lo: int
    hi: int


def pins(formula: Formula) -> Iterator[Pin]:
    """The pins of a task's formula: ``in(role, R)`` conjuncts of ``G[a,b]`` conjuncts."""
    if isinstance(formula, And):
        for child in formula.children:
            yield from pins(child)
    elif isinstance(formula, Always):
        inner = formula.child.children if isinstance(formula.child, And) else (formula.child,)
        for atom in inner:
            if isinstance(atom, InRegion):
                yield Pin(atom.role, atom.region, formula.interval.lo, formula.interval.hi)


def able(
    problem: Problem,
    task: TaskModel,
    boxes: dict,
    binding: dict[str, str],
    pinned: tuple[Pin, str] | None = None,
) -> bool:
    """Whether the element ``binding`` of ``task`` may still satisfy it: the upper bound of its
    robustness over the reachable ``boxes`` reaches ``HOLDS_AT`` (with ``pinned = (pin,
    agent)``: while the agent is kept in the pin's region, so out of every region disjoint
    from it, at the pin's steps)."""
    barred: dict[Formula, np.ndarray] = {}
    if pinned is not None:
        pin, agent = pinned
        for role in (r for r, a in binding.items() if a == agent):
            for region in set(regions(task.formula)):
                if _disjoint(problem, region, pin.region):
                    key = problem.lowered(InRegion(role, region), {role: agent})
                    steps = barred.setdefault(key, np.zeros(problem.horizon + 1, dtype=bool))
                    steps[pin.lo : pin.hi + 1] = True
    lowered = problem.lowered(task.formula, binding)
    roles = {role: boxes[agent] for role, agent in binding.items()}
    return bool(upper_robustness(lowered, roles, problem.horizon, barred)[0] >= HOLDS_AT)


def _disjoint(problem: Problem, one: str, other: str) -> bool:
    """Whether two regions have no point in common (their half-planes together admit none)."""
    rows: list[tuple[float, ...]] = []
    rhs: list[float] = []
    for name in sorted((one, other)):
        g, h = problem.regions[name]
        rows += [tuple(float(v) for v in row) for row in g]
        rhs += [float(v) for v in h]
    return _empty(tuple(rows), tuple(rhs))


@cache
def _empty(rows: tuple[tuple[float, ...], ...], rhs: tuple[float, ...]) -> bool:
    return bool(inscribed_radius(rows, rhs) < 0)  # (a negative radius: no point in both)


def shared_agent_reasons(problem: Problem, boxes: dict, named: set[str]) -> Iterator[Reason]:
    """Pairs of tasks (neither named yet) that need more of the same agents at once than there
    are (module docstring): a reason that names the second task, with the first among its
    others."""
    candidates = [t for t in problem.tasks if _counted(t) and t.name not in named]
    elements = {
        t.name: [b for b in map(t.binding, t.elements) if able(problem, t, boxes, b)]
        for t in candidates
    }
    for first in candidates:
        for pin in pins(first.formula):
            if pin.role not in first.roles:
                continue
            taken = {b[pin.role] for b in elements[first.name]}
            for second in candidates:
                if second is first or len(second.roles) != 1:
                    continue
                reason = _conflict(problem, boxes, (first, pin, taken), second, elements)
                if reason is not None:
                    yield reason
                    named.add(second.name)


def _counted(task: TaskModel) -> bool:
    """A task of roles whose group's elements have distinct agents (and no synchronous run)."""
    return task.sync is None and bool(task.roles) and not task.reuse_agents


def _conflict(
    problem: Problem,
    boxes: dict,
    pinned: tuple[TaskModel, Pin, set[str]],
    second: TaskModel,
    elements: dict[str, list[dict[str, str]]],
) -> Reason | None:
    """The reason ``second`` cannot be met with the first task of ``pinned`` (None when it can,
    as far as this analysis tells)."""
    first, pin, taken = pinned
    role = second.roles[0]
    serving = {b[role] for b in elements[second.name]}
    lost = {
        agent
        for agent in serving & taken
        if not able(problem, second, boxes, second.binding((agent,)), (pin, agent))
    }
    if not lost:  # the pin takes none of the second's agents: no conflict of the two
        return None
    # the first task takes its agents from those the second can keep first
    from_lost = max(0, first.count - len(taken - lost))
    left = len(serving) - from_lost
    if left >= second.count:
        return None
    text = (
        f"tasks '{first.name}' and '{second.name}' cannot be met together: '{first.name}' keeps "
        f"{first.count} agent(s) of role '{pin.role}' in '{pin.region}' at steps "
        f"{pin.lo}..{pin.hi}; kept there, {_listed(sorted(lost))} cannot serve '{second.name}', "
        f"so {left} agent(s) are left for it, {second.count} needed"
    )
    return Reason(second.name, text, (first.name,))


def _listed(agents: list[str]) -> str:
    """``uv2``, ``uv2 and uv3``, ``uv1, uv2 and uv3``."""
    return agents[0] if len(agents) == 1 else ", ".join(agents[:-1]) + f" and {agents[-1]}"
