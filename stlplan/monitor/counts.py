"""What a formula's team counts saw on a trajectory: who is inside a counted region when, and
each visit (an entry) a ``visits`` atom counts.

``count(R, who) >= n`` counts, at each step, the agents ``who`` admits that are inside region
``R``; ``visits[lo,hi](R, who) >= n`` counts their entries into ``R`` at steps ``k+lo..k+hi``: an
agent enters at ``t`` when it is outside at ``t-1`` and inside at ``t``, and being inside at the
window's first step counts as an entry. "Inside" is the monitor's: the robustness of the lowered
``in(@a, R)`` is at least :data:`~stlplan.formula.boundary.HOLDS_AT` (a region's boundary is
neither inside nor outside), so the figures show the entries the verdicts count.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from stlplan.formula.boundary import holds
from stlplan.formula.tree import (
    And,
    Count,
    Formula,
    InRegion,
    Not,
    Or,
    Visits,
    children,
    team_role,
)
from stlplan.mission.problem import Problem
from stlplan.monitor.robustness import robustness
from stlplan.result import Trajectory


@dataclass(frozen=True)
class CountPresence:
    """A ``count`` atom and, for each agent it counts, the steps at which the agent is inside."""

    atom: Count
    inside: Mapping[str, tuple[int, ...]]
    """Each agent ``atom.who`` admits (in the team's order) -> the steps of ``0..H`` at which it
    is inside ``atom.region`` (empty when it never is)."""


@dataclass(frozen=True)
class VisitEntries:
    """A ``visits`` atom and the entries it counts within its window."""

    atom: Visits
    window: tuple[int, int]
    """The first and last step whose entries count (see :func:`team_events`)."""
    entries: tuple[tuple[str, int], ...]
    """Each visit as ``(agent, step of its entry)``, by step, then in the team's order."""


TeamEvent = CountPresence | VisitEntries


def inside_steps(problem: Problem, trajectory: Trajectory, agent: str, region: str) -> np.ndarray:
    """Whether ``agent`` is inside ``region`` at each step ``0..H`` (boolean, shape ``(H+1,)``):
    the robustness of the lowered ``in(@agent, region)`` holds."""
    role = team_role(agent)
    lowered = problem.lowered(InRegion(role, region), {role: agent})
    rho = robustness(lowered, {role: trajectory.states[agent]}, trajectory.horizon)
    return np.asarray(holds(rho), dtype=bool)


def entry_steps(inside: np.ndarray, first: int, last: int) -> list[int]:
    """The steps ``t`` of ``[first, last]`` at which an agent enters: inside at ``t`` and outside
    at ``t-1``, or inside at ``t = first`` (the window's first step)."""
    steps = np.arange(first, min(last, len(inside) - 1) + 1)
    before = np.concatenate([[False], inside[:-1]])
    entered = inside[steps] & ((steps == first) | ~before[steps])
    return [int(t) for t in steps[entered]]


def placed_atoms(formula: Formula, nested: bool = False) -> Iterator[tuple[Count | Visits, bool]]:
    """Each ``count`` and ``visits`` atom of ``formula``, left to right, with whether it sits
    under a temporal operator (``G``, ``F``, ``U``: decided at other steps than 0)."""
    if isinstance(formula, (Count, Visits)):
        yield formula, nested
        return
    deeper = nested or not isinstance(formula, (And, Or, Not))
    for child in children(formula):
        yield from placed_atoms(child, deeper)


def team_events(problem: Problem, trajectory: Trajectory, formula: Formula) -> list[TeamEvent]:
    """What each ``count`` and ``visits`` atom of a task's or constraint's ``formula`` saw.

    A ``count`` gives, for each agent it counts, every step of ``0..H`` at which the agent is
    inside its region (which of those steps the formula reads depends on its operators). A
    ``visits`` gives its entries within its window at ``k = 0``: ``[lo, hi]`` when the atom is
    decided at step 0 only (under ``and``, ``or``, ``!`` at most); under a temporal operator it
    is decided at several steps, so the window is the whole horizon ``0..H``. Agents are those the
    atom's selector admits, in the team's order.
    """
    horizon = trajectory.horizon
    seen: dict[tuple[str, str], np.ndarray] = {}
    team = {a.name: a.capabilities for a in problem.agents}

    def inside(agent: str, region: str) -> np.ndarray:
        if (agent, region) not in seen:
            seen[agent, region] = inside_steps(problem, trajectory, agent, region)
        return seen[agent, region]

    events: list[TeamEvent] = []
    for atom, nested in placed_atoms(formula):
        agents = [a for a, caps in team.items() if atom.who.admits(caps)]
        if isinstance(atom, Count):
            steps = {a: tuple(np.flatnonzero(inside(a, atom.region)).tolist()) for a in agents}
            events.append(CountPresence(atom, steps))
            continue
        lo, hi = (0, horizon) if nested else (atom.interval.lo, min(atom.interval.hi, horizon))
        found = [
            (t, i, a)
            for i, a in enumerate(agents)
            for t in entry_steps(inside(a, atom.region), lo, hi)
        ]
        entries = tuple((a, t) for t, _, a in sorted(found))
        events.append(VisitEntries(atom, (lo, hi), entries))
    return events
