"""Diagnosing infeasible missions.

Two kinds of evidence:

* **cheap reasons**, found without solving: the conflicts at step 0 of
  :mod:`stlplan.analysis.initial` (an initial state that breaks a requirement, two agents that
  start too close, a margin no region allows), then a region that a task's formula requires a
  role to reach by some step, when too few of the agents that may fill the role can get there in
  time given their dynamics and bounds (interval reachability, an over-approximation, so a claim
  "cannot reach" is sound; a region outside every such agent's state bounds is said to be);
* **a minimal conflict**, found by a deletion filter over the tasks, constraints and separation:
  drop one item at a time and keep it dropped when the rest is still infeasible. What remains
  cannot be met together, and dropping any one of its items makes it feasible (when every
  feasibility solve finished in time).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterator

import numpy as np

from stlplan.analysis.decided import upper_robustness
from stlplan.analysis.initial import TOLERANCE, Reason, initial_reasons
from stlplan.analysis.reach import needs, reachable_boxes
from stlplan.analysis.shared import shared_agent_reasons
from stlplan.formula.boundary import HOLDS_AT
from stlplan.formula.parser import to_text
from stlplan.formula.tree import Always, Formula, InRegion, Not, regions, team_atoms
from stlplan.mission.problem import Problem, TaskModel
from stlplan.result import Diagnosis, PlanStatus

Feasibility = Callable[[Problem], PlanStatus]

STATE_BOUNDS = "state bounds"
"""The item a reason blames when an agent's state cannot keep within its bounds."""


def _meets(problem: Problem, region: str, box_lo: np.ndarray, box_hi: np.ndarray) -> bool:
    """Whether the box ``[box_lo, box_hi]`` of positions meets the region's half-spaces."""
    rows, rhs = problem.regions[region]
    # min over the box of g . z, per row; the region is missed when some row exceeds h
    lowest = [float(np.sum(np.where(np.array(g) > 0, box_lo, box_hi) * np.array(g))) for g in rows]
    return all(m <= h + 1e-9 for m, h in zip(lowest, rhs, strict=False))


def _can_reach(problem: Problem, boxes: dict, agent: str, region: str, deadline: int) -> bool:
    """Whether the agent's reachable box meets the region's half-spaces at some step <= deadline."""
    lo, hi = boxes[agent]
    ix, iy = problem.agent(agent).position
    return any(
        _meets(problem, region, np.array([lo[k, ix], lo[k, iy]]), np.array([hi[k, ix], hi[k, iy]]))
        for k in range(min(deadline, problem.horizon) + 1)
    )


def _outside(problem: Problem, agents: list[str], region: str) -> str | None:
    """``"x in [0, 6], y in [0, 4]"``-style bounds when ``region`` lies outside the position
    bounds of every one of ``agents`` (None when some agent's bounds meet it)."""
    boxes = []
    for name in agents:
        agent = problem.agent(name)
        ix, iy = agent.position
        lo, hi = agent.state_lo[[ix, iy]], agent.state_hi[[ix, iy]]
        if _meets(problem, region, lo, hi):
            return None
        boxes.append(f"{name}: x in [{lo[0]:g}, {hi[0]:g}], y in [{lo[1]:g}, {hi[1]:g}]")
    return "; ".join(dict.fromkeys(boxes))


def _task_reasons(problem: Problem, task: TaskModel, boxes: dict) -> Iterator[Reason]:
    offset = 0 if task.sync is None else task.sync.b
    for role, region, deadline in dict.fromkeys(needs(task.formula, offset)):
        pool = sorted({e[task.roles.index(role)] for e in task.elements})
        able = [a for a in pool if _can_reach(problem, boxes, a, region, deadline)]
        wanted = 1 if task.reuse_agents else task.count
        outside = None if able else _outside(problem, pool, region)
        if outside is not None:
            yield Reason(
                task.name,
                f"task '{task.name}': role '{role}' must reach region '{region}', which lies "
                f"outside the state bounds of every agent that may fill the role ({outside})",
            )
        elif len(able) < wanted:
            which = f"only {', '.join(able)}" if able else "none"
            yield Reason(
                task.name,
                f"task '{task.name}': role '{role}' must reach region '{region}' by step "
                f"{deadline} in {wanted} element(s), but {which} of {', '.join(pool)} can, "
                f"given the dynamics and bounds",
            )


def _constraint_reasons(problem: Problem, boxes: dict) -> Iterator[Reason]:
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            for role, region, deadline in dict.fromkeys(needs(constraint.formula)):
                agent = binding[role]
                if _can_reach(problem, boxes, agent, region, deadline):
                    continue
                outside = _outside(problem, [agent], region)
                why = (
                    f"which lies outside its state bounds ({outside})"
                    if outside is not None
                    else "given its dynamics and bounds"
                )
                yield Reason(
                    constraint.name,
                    f"constraint '{constraint.name}': agent '{agent}' cannot reach region "
                    f"'{region}' by step {deadline}, {why}",
                )


def _decided_reasons(problem: Problem, boxes: dict, named: set[str]) -> Iterator[Reason]:
    """Ordinary tasks (not named yet) that fewer elements than their count can still satisfy,
    whatever the plan (:mod:`stlplan.analysis.decided`), the constraints that keep agents out of
    regions (obstacles, a replan's closed regions) met; a replan's past decides most."""
    after = (
        "" if problem.past is None else f" after the executed past (steps 0..{problem.past.step})"
    )
    for task in problem.tasks:
        if task.sync is not None or task.name in named:
            continue
        able, barring = 0, set()
        read = set(regions(task.formula))
        for binding in map(task.binding, task.elements):
            lowered, roles = problem.lowered(task.formula, binding), _role_boxes(boxes, binding)
            barred, names = _barred(problem, binding, read)
            if upper_robustness(lowered, roles, problem.horizon, barred)[0] >= HOLDS_AT:
                able += 1
            elif upper_robustness(lowered, roles, problem.horizon)[0] >= HOLDS_AT:
                barring |= names
        wanted = 1 if task.reuse_agents else task.count
        if able < wanted:
            kept_out = f" and {_listed(sorted(barring))}" if barring else ""
            yield Reason(
                task.name,
                f"task '{task.name}' can no longer be met{after}{kept_out}: "
                + _shortfall(task, able, wanted),
                tuple(sorted(barring)),
            )


def _shortfall(task: TaskModel, able: int, wanted: int) -> str:
    """How far a decided task falls short: its elements, or for a task that only counts, the
    counts no plan the dynamics and bounds allow can reach."""
    if task.roles:
        return (
            f"{able} of its {len(task.elements)} element(s) can still satisfy it, {wanted} needed"
        )
    counts = ", ".join(f"'{to_text(a)}'" for a in team_atoms(task.formula))
    return f"no plan the dynamics and bounds allow brings enough agents for {counts}"


def _barred(
    problem: Problem, binding: dict[str, str], regions: set[str]
) -> tuple[dict[Formula, np.ndarray], set[str]]:
    """For the roles of ``binding``: each of ``regions`` a constraint ``G[a,b] !in(p, R)``
    keeps its agent out of (as the role's lowered ``in(role, R)``), with the steps ``a..b``;
    and the names of those constraints."""
    barred: dict[Formula, np.ndarray] = {}
    names: set[str] = set()
    for constraint in problem.constraints:
        keeps = constraint.formula
        if not isinstance(keeps, Always) or not isinstance(keeps.child, Not):
            continue
        atom = keeps.child.atom
        if not isinstance(atom, InRegion) or atom.region not in regions:
            continue
        agents = {b[atom.role] for b in constraint.bindings}
        for role, agent in binding.items():
            if agent in agents:
                key = problem.lowered(InRegion(role, atom.region), {role: agent})
                steps = barred.setdefault(key, np.zeros(problem.horizon + 1, dtype=bool))
                steps[keeps.interval.lo : keeps.interval.hi + 1] = True
                names.add(constraint.name)
    return barred, names


def _listed(names: list[str]) -> str:
    """``constraint 'a'``, ``constraints 'a', 'b'``."""
    quoted = ", ".join(f"'{n}'" for n in names)
    return f"constraint{'s' if len(names) > 1 else ''} {quoted}"


def _bounds_reasons(problem: Problem, boxes: dict) -> Iterator[Reason]:
    """Agents whose state no input keeps within its bounds at some step: the first such step,
    after an executed past (a disturbance) that left them too far out or too fast."""
    after = (
        "" if problem.past is None else f" after the executed past (steps 0..{problem.past.step})"
    )
    for agent in problem.agents:
        lo, hi = boxes[agent.name]
        empty = np.argwhere(lo > hi + TOLERANCE)
        if empty.size == 0:
            continue
        k, i = (int(v) for v in empty[0])
        if lo[k, i] > agent.state_hi[i]:
            reach = f"at least {lo[k, i]:.4g}, above its bound {agent.state_hi[i]:.4g}"
        else:
            reach = f"at most {hi[k, i]:.4g}, below its bound {agent.state_lo[i]:.4g}"
        yield Reason(
            STATE_BOUNDS,
            f"agent '{agent.name}' cannot keep its state bounds at step {k}{after}: whatever "
            f"its inputs, component {i} of its state is {reach}",
        )


def _role_boxes(boxes: dict, binding: dict[str, str]) -> dict:
    return {role: boxes[agent] for role, agent in binding.items()}


def cheap_reasons(problem: Problem) -> tuple[Reason, ...]:
    """Reasons the mission is infeasible that need no solve (empty when none is found): the
    conflicts at step 0 first, then the regions no capable agent reaches in time, then the
    tasks no plan can satisfy any more, then pairs of tasks that need more of the same agents at
    once than there are (:mod:`stlplan.analysis.shared`)."""

    found = list(initial_reasons(problem))
    boxes = reachable_boxes(problem)
    found += list(_bounds_reasons(problem, boxes))
    found += [r for task in problem.tasks for r in _task_reasons(problem, task, boxes)]
    found += list(_constraint_reasons(problem, boxes))
    found += list(_decided_reasons(problem, boxes, {r.item for r in found}))
    found += list(shared_agent_reasons(problem, boxes, {r.item for r in found}))
    return tuple(found)


def kind_of(problem: Problem, name: str) -> str:
    """``task``, ``constraint``, ``separation`` or ``state bounds``: what ``name`` is in
    ``problem``."""
    if name == STATE_BOUNDS:
        return STATE_BOUNDS
    if any(t.name == name for t in problem.tasks):
        return "task"
    return "constraint" if any(c.name == name for c in problem.constraints) else "separation"


def cheap_diagnosis(problem: Problem, reasons: tuple[Reason, ...]) -> Diagnosis:
    """The diagnosis the cheap reasons make: their texts, and the items they blame."""
    conflict = tuple(dict.fromkeys(n for r in reasons for n in (r.item, *r.others)))
    return Diagnosis(
        reasons=tuple(r.text for r in reasons),
        conflict=conflict,
        complete=True,
        kinds=tuple(kind_of(problem, name) for name in conflict),
    )


def _subset(problem: Problem, items: list[str]) -> Problem:
    keep = set(items)
    return dataclasses.replace(
        problem,
        tasks=tuple(t for t in problem.tasks if t.name in keep),
        constraints=tuple(c for c in problem.constraints if c.name in keep),
        separation=problem.separation if "separation" in keep else None,
    )


def minimal_conflict(
    problem: Problem, feasibility: Feasibility, budget: float
) -> tuple[tuple[str, ...], bool]:
    """Deletion filter: a minimal infeasible set of task, constraint and separation names.

    Returns the set and whether every feasibility solve decided (else it may not be minimal).
    """
    kept = [t.name for t in problem.tasks] + [c.name for c in problem.constraints]
    if problem.separation is not None:
        kept.append("separation")
    complete, started = True, time.monotonic()
    for item in list(kept):
        if time.monotonic() - started >= budget:
            return tuple(kept), False
        trial = [i for i in kept if i != item]
        status = feasibility(_subset(problem, trial))
        if status is PlanStatus.INFEASIBLE:
            kept = trial
        elif not status.has_plan:
            complete = False
    return tuple(kept), complete


def diagnose(problem: Problem, feasibility: Feasibility, budget: float) -> Diagnosis:
    """A minimal conflict by feasibility solves within ``budget`` seconds (the cheap reasons,
    :func:`cheap_reasons`, are looked for before solving)."""
    conflict, complete = minimal_conflict(problem, feasibility, budget)
    kinds = tuple(kind_of(problem, name) for name in conflict)
    return Diagnosis(conflict=conflict, complete=complete, kinds=kinds)
