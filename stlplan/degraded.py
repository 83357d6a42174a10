"""Degraded plans: when a mission cannot be met whole, the most tasks that can (DESIGN 2.15).

Which tasks to drop is a hitting-set search over conflicts. A conflict is a set of tasks (with
constraints and separation, which are never dropped) that cannot be met together: a task that
the cheap reasons of :mod:`stlplan.analysis.diagnose` rule out on its own, or a minimal
conflict found by feasibility solves. Every plan must drop a task of every conflict, so the
cheapest set of tasks that hits every conflict found so far is a lower bound on what must go;
when the mission without it is feasible, it is the answer. Otherwise that mission's own minimal
conflict joins the others and the search goes on.

The cost of dropping a task grows with its ``priority`` so steeply that one task of a higher
priority outweighs every task below it (lexicographic); among equal priorities, it counts
tasks. The search is exact as long as every feasibility solve ends with a verdict.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from stlplan.analysis.diagnose import Feasibility, cheap_reasons, minimal_conflict
from stlplan.mission.problem import Problem
from stlplan.result import Dropped, PlanStatus


@dataclass(frozen=True)
class Conflict:
    """Tasks of which a plan must drop at least one, and why: a cheap reason's text, or the
    items (tasks, constraints, separation) that cannot be met together."""

    tasks: frozenset[str]
    reason: str = ""
    items: tuple[str, ...] = ()
    after: int | None = None
    """A replan's step (the past and the events there are part of the conflict)."""

    def why(self, task: str) -> str:
        """Why ``task`` cannot be met, by this conflict."""
        if self.reason:
            return self.reason
        others = [f"'{n}'" for n in self.items if n != task]
        why = f"cannot be met together with {', '.join(others)}" if others else "cannot be met"
        if self.after is not None:
            why += f" after the executed past and the events at step {self.after}"
        return why


@dataclass(frozen=True)
class Degraded:
    """The mission a degraded plan meets, and the tasks it drops."""

    problem: Problem
    dropped: tuple[Dropped, ...]


@dataclass(frozen=True)
class Undecided:
    """The tasks a degraded plan was to drop when the time ran out before a verdict on the
    mission without them."""

    dropped: tuple[str, ...]


def drop_costs(problem: Problem) -> dict[str, int]:
    """The cost of dropping each task: ``(n + 1) ** rank`` of its priority among the distinct
    priorities (rank 0 the lowest), so one task outweighs every task of lower priorities."""
    priority = {t.name: problem.mission.tasks[t.name].priority for t in problem.tasks}
    ranks = {p: r for r, p in enumerate(sorted(set(priority.values())))}
    base = len(priority) + 1
    return {name: base ** ranks[p] for name, p in priority.items()}


def cheapest_hitting_set(
    conflicts: Sequence[Conflict], costs: Mapping[str, int]
) -> frozenset[str] | None:
    """The cheapest set of tasks meeting every conflict (None when a conflict has no task)."""
    if any(not c.tasks for c in conflicts):
        return None
    candidates = sorted(set().union(*(c.tasks for c in conflicts)))
    best: tuple[int, frozenset[str]] | None = None
    for size in range(len(candidates) + 1):
        for chosen in itertools.combinations(candidates, size):
            hit = frozenset(chosen)
            cost = sum(costs[t] for t in hit)
            if all(c.tasks & hit for c in conflicts) and (best is None or cost < best[0]):
                best = (cost, hit)
    return None if best is None else best[1]


def without(problem: Problem, tasks: frozenset[str]) -> Problem:
    """``problem`` without the tasks ``tasks``."""
    kept = tuple(t for t in problem.tasks if t.name not in tasks)
    return dataclasses.replace(problem, tasks=kept, _by_name={})


def _cheap_conflicts(problem: Problem) -> list[Conflict]:
    tasks = {t.name for t in problem.tasks}
    found = []
    for reason in cheap_reasons(problem):
        blamed = {reason.item, *reason.others} & tasks  # (a pair of tasks, or one)
        found.append(Conflict(frozenset(blamed), reason.text))
    return found


def _solved_conflict(problem: Problem, feasibility: Feasibility, seconds: float) -> Conflict:
    """A minimal conflict of ``problem`` (infeasible), by feasibility solves."""
    names, _ = minimal_conflict(problem, feasibility, seconds)
    tasks = frozenset(n for n in names if any(t.name == n for t in problem.tasks))
    after = None if problem.past is None else problem.past.step
    return Conflict(tasks, items=names, after=after)


def degrade(
    problem: Problem, feasibility: Feasibility, seconds: float
) -> Degraded | Undecided | None:
    """The infeasible ``problem`` with the cheapest set of tasks dropped that makes it feasible,
    within ``seconds``: :class:`Undecided` when the time ran out before a verdict on the set
    tried, None when no set of tasks will do (a conflict of constraints alone, or a
    feasibility solve that failed)."""
    started, costs = time.monotonic(), drop_costs(problem)
    conflicts = _cheap_conflicts(problem)
    while True:
        hit = cheapest_hitting_set(conflicts, costs)
        if hit is None:
            return None
        kept = without(problem, hit)
        left = seconds - (time.monotonic() - started)
        if not hit:  # the whole mission: known to be infeasible
            status = PlanStatus.INFEASIBLE
        else:
            status = feasibility(kept) if left > 0 else PlanStatus.NO_PLAN
        if status.has_plan:
            return Degraded(kept, tuple(_why(task, conflicts) for task in sorted(hit)))
        if status is PlanStatus.NO_PLAN:
            return Undecided(tuple(sorted(hit)))
        if status is not PlanStatus.INFEASIBLE:
            return None
        conflicts.append(_solved_conflict(kept, feasibility, left))


def _why(task: str, conflicts: Sequence[Conflict]) -> Dropped:
    reasons = [c.why(task) for c in conflicts if task in c.tasks]
    return Dropped(task, reasons[0] if reasons else "cannot be met with the tasks kept")
