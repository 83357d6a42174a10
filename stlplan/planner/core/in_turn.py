"""A lazy round's plan repaired agent by agent, for a plan that meets every requirement.

A lazy round (:mod:`stlplan.planner.core.lazy`) solves a relaxation: its plan may drive agents
through each other or a segment through an obstacle. On a large team packed in a small start
area, the next round (the whole search again, with the violated requirements added) may find no
plan meeting them in the time left. Repairing in turn finds one the way prioritized planners do:
the agents the violated requirements name are freed one at a time, every other agent held at its
plan, and the free agent's plan is solved again with the requirements it violates together with
the agents already repaired (or never involved). Each of those solves is small: one agent's
trajectory and choices. The agent is then held at its new plan. The turns go in the team's order, but an agent's formation partners (the other roles of the elements it
fills) take theirs right after it, while few agents are yet held around the path it chose
(measured: docs/measurements.md#formations-in-turn). A requirement between two repaired agents is met by the later
one, which avoided the earlier one's final plan, so when every turn succeeds the last plan meets
every requirement. An agent that finds no plan around the agents already repaired is solved
again together with the ones it could not avoid, added one at a time:
first the one its violations named last and most often, so that a pair's solve, small, comes
before the joint solve of all of them, a MILP of several agents that may not finish. Agents are
freed only while the turn fails within its time (an infeasible solve: the free agents cannot get
past those held); a turn out of time fails, as more agents free would be slower still. The
repaired agents then have one more turn each, alone, every other agent at its repaired plan:
detours made around agents repaired later are undone where no longer needed.

Nothing found here is trusted beyond what it is: the watch of the loop keeps a plan only when
it violates no requirement left out of the model (a plan of the full problem, so its objective
bounds the optimum from below). The solves are trials with a loose gap; their bounds bound
nothing but a held problem and are never recorded. Requirements added on the way stay in the
model: the full problem has them.

The knobs are the ``repair`` section of :class:`stlplan.planner.config.PlannerConfig`: a turn
solves one agent's plan around held ones (``tolerances.HOLD`` of room each), again after adding
every step of the families of the requirements its plan violates, while its time lasts, to the
loose ``repair.gap``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection, Iterable, Sequence
from functools import partial
from typing import Any

from pyomo.core.base.var import VarData

from stlplan.planner.backend.session import HighsSession, Solved, has_solution
from stlplan.planner.backend.values import plan_of
from stlplan.planner.config import PlannerConfig, RepairConfig
from stlplan.planner.core.around import Around
from stlplan.planner.core.watch import (
    loaded_plan,
    pending_violations,
    trajectory_states,
)
from stlplan.planner.encoding.deferred import families
from stlplan.planner.encoding.model import PlanModel, add_requirements
from stlplan.planner.encoding.readout import partners
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Plan
from stlplan.planner.tolerances import HOLD

_log = logging.getLogger(__name__)

Held = list[tuple[Any, Any, Any]]
"""``(variable, lower, upper)`` to restore."""

FreeSolve = Callable[[set[str], set[str], Budget], Collection[str]]
"""One solve of a turn, ``(free, done, budget) -> agents``: the agents ``free`` solved again,
every other agent held, around the agents ``done``; no agents when that found a plan, otherwise
``free`` and the agents in their way, in the order they are to be freed (:func:`solve_free`)."""


def hold_near(var: VarData, value: float, held: Held, width: float) -> None:
    """Bound ``var`` to within ``width`` of ``value`` (inside its own bounds); record the old
    bounds in ``held``.

    HiGHS accepts binaries within 1e-6 of 0 or 1, so a plan may miss an enforced predicate by
    ``big-M * 1e-6``; a solve that holds it (an assembly, whose indicators are exact, or a turn)
    needs room to repair that (``tolerances.HOLD``)."""
    lo, hi = var.bounds
    held.append((var, lo, hi))
    low = value - width if lo is None else max(lo, value - width)
    high = value + width if hi is None else min(hi, value + width)
    var.setlb(low if hi is None else min(low, hi))
    var.setub(high if lo is None else max(high, lo))


def release(held: Held) -> None:
    """Restore the bounds :func:`hold_near` changed."""
    for var, lo, hi in held:
        var.setlb(lo)
        var.setub(hi)


def hold_agents(pm: PlanModel, names: Iterable[str], width: float) -> Held:
    """Hold the states and inputs of the agents ``names`` within ``width`` of their loaded
    values."""
    names = set(names)
    held: Held = []
    for component in (pm.model.x, pm.model.u):
        for key, var in component.items():
            if key[0] in names and not var.fixed and var.value is not None:
                hold_near(var, float(var.value), held, width)
    return held


def agents_of(pm: PlanModel, indices: Iterable[int]) -> set[str]:
    """Agents the lazy requirements ``indices`` name."""
    assert pm.deferral is not None
    return {name for n in indices for name in pm.deferral.lazy[n].binding.values()}


def in_formations(pm: PlanModel, turns: Sequence[str]) -> list[str]:
    """``turns`` with each agent's partners among them (:func:`partners`) right after it."""
    order: list[str] = []
    for name in turns:
        if name not in order:
            order.append(name)
            order += [a for a in partners(pm, name) if a in turns and a not in order]
    return order


class InTurn:
    """One repair of the loaded plan (module docstring).

    Parameters
    ----------
    pm, session, config
        The lazy model, its HiGHS session and the run's configuration.
    solve
        One solve of a turn (default: :func:`solve_free` on ``pm`` and ``session`` with the
        ``repair`` section of ``config`` and ``outside``).
    outside
        Agents of other parts held at their published plans, whose requirements with the agents
        of ``pm`` the turns meet too (:mod:`stlplan.planner.first_plan.published`; None: no such agents).
    stop
        Whether to stop at once (the loop's watch has the plan it asked for).
    """

    def __init__(
        self,
        pm: PlanModel,
        session: HighsSession,
        config: PlannerConfig,
        solve: FreeSolve | None = None,
        outside: Around | None = None,
        stop: Callable[[], bool] = lambda: False,
    ) -> None:
        self.pm, self.session, self.repair, self.outside = pm, session, config.repair, outside
        self.stop = stop
        self.solve = solve or partial(solve_free, pm, session, config.repair, outside=outside)

    def run(self, bad: Sequence[int], budget: Budget) -> Plan | None:
        """Repair the agents ``bad`` names within ``budget``; the repaired plan, when every turn
        found one and it meets every requirement (None otherwise)."""
        names = [a.name for a in self.pm.problem.agents]
        involved = agents_of(self.pm, bad)
        around = self.outside.named(trajectory_states(self.pm)) if self.outside else []
        turns = [n for n in names if n in around and n not in involved]  # their turns first
        involved |= set(around)
        turns += [n for n in names if n in involved and n not in turns]
        turns = in_formations(self.pm, turns)
        done = set(names) - involved
        self.session.clock.reached.turns(0, len(turns))
        with self.session.looking_for_a_plan(self.repair.gap):
            if not self._repair(turns, done, budget):
                return None
            self._improve(turns, set(names), budget)
            return loaded_plan(self.pm)

    def _repair(self, turns: list[str], done: set[str], budget: Budget) -> bool:
        """The turns of the agents ``turns``, in order; whether each found a plan."""
        for name in turns:
            if name in done:  # freed together with an earlier agent
                continue
            if self.stop():
                return False
            left = [n for n in turns if n not in done]
            free = self._turn({name}, done, budget, len(left))
            if free is None:
                return False
            done |= free
            self.session.clock.reached.turns(len(done & set(turns)), len(turns))
        return True

    def _improve(self, turns: list[str], everyone: set[str], budget: Budget) -> None:
        """Each repaired agent once more, alone, every other agent at its repaired plan: the
        detours it made around agents repaired after it are undone where no longer needed.
        Stops at the first solve without a plan (the watch keeps the best plan so far)."""
        for name, share in zip(turns, budget.split(len(turns)), strict=True):
            if share.expired() or self.stop():
                return
            self.session.start_from(plan_of(self.pm.model, self.pm.model.step1))  # no worse
            if self.solve({name}, everyone - {name}, share):
                return

    def _turn(self, free: set[str], done: set[str], budget: Budget, left: int) -> set[str] | None:
        """Agents ``free`` solved again (every other agent held); when that fails, again with
        the repaired agents they could not avoid (:meth:`_to_free`). Returns the agents
        freed, or None without a plan."""
        waiting: list[str] | None = None  # the agents the first solve could not avoid
        while True:
            share = budget.share(1 / (left + bool(waiting)))  # as much for those waiting
            if share.expired() or self.stop():
                return None
            partners = self.solve(free, done, share)
            if not partners:
                return free
            if waiting is None:
                waiting = [a for a in partners if a not in free]
            if not waiting or share.expired():
                return None  # (out of time: more agents free would be slower still)
            taken = self._to_free(waiting, partners)
            free = free | taken
            waiting = [a for a in waiting if a not in taken]

    def _to_free(self, waiting: list[str], partners: Collection[str]) -> set[str]:
        """The agent to free next of ``waiting``: the first the last solve named (``partners``,
        most in the way first), else the first."""
        named = [a for a in partners if a in waiting]
        return {(named or waiting)[0]}


def solve_free(
    pm: PlanModel,
    session: HighsSession,
    repair: RepairConfig,
    free: set[str],
    done: set[str],
    budget: Budget,
    outside: Around | None = None,
) -> list[str]:
    """One solve of a turn: the agents ``free`` solved again, every other agent held near its
    loaded plan, again while ``budget`` lasts, each time adding the requirements the plan
    violates among ``free`` and ``done`` (every step of their families), and those it violates
    with the agents ``outside``.

    Parameters
    ----------
    pm, session, repair
        The lazy model with the plan to repair loaded, its HiGHS session, and the ``repair``
        section of the run's configuration.
    free, done
        The agents solved again, and the agents already repaired (or never involved).
    budget
        The turn's time.
    outside
        Agents held at plans of their own outside ``pm`` (None: none).

    Returns
    -------
    list[str]
        No agents when a solve ends with a plan that meets every requirement among ``free`` and
        ``done``; otherwise ``free`` and then the agents of the requirements added, the most in
        the way first (:func:`in_the_way`).
    """
    assert pm.deferral is not None
    lazy, named = pm.deferral.lazy, list[list[int]]()
    others = (a.name for a in pm.problem.agents if a.name not in free)
    held = hold_agents(pm, others, HOLD)
    try:
        while True:
            solved = session.solve(budget)
            if solved.stopped or not has_solution(solved.results):
                _log.debug("turn of %s: %.1f s, %s", sorted(free), solved.seconds, session.verdict)
                if _excused(outside, free, solved, budget):
                    continue  # again, its requirements with the agents outside left to a merge
                break
            mine, theirs = broken_requirements(pm, outside, free, done)
            _log.debug("turn of %s: %.1f s, %d violated, %d outside", sorted(free),
                       solved.seconds, len(mine), len(theirs))  # fmt: skip
            if not mine and not theirs:
                return []
            named.append(mine)
            if budget.expired():
                break
            add_requirements(pm, families(lazy, mine))
            if outside is not None:
                outside.add(theirs)
        return in_the_way(pm, free, named)
    finally:
        release(held)


def broken_requirements(
    pm: PlanModel, outside: Around | None, free: set[str], done: set[str]
) -> tuple[list[int], list[int]]:
    """The requirements the loaded plan breaks among the agents ``free`` and ``done`` (lazy
    indices of ``pm``), and those between the agents ``outside`` and ``free`` or ``done`` (its
    indices): a held agent moves within ``tolerances.HOLD``, enough to break a requirement its
    plan met exactly, and a row keeps it from that."""
    mine = [n for n in pending_violations(pm) if agents_of(pm, [n]) <= done | free]
    theirs = outside.broken(trajectory_states(pm), free | done) if outside else []
    return mine, theirs


def _excused(outside: Around | None, free: set[str], solved: Solved, budget: Budget) -> bool:
    """Whether a turn without a plan had rows against the agents ``outside`` (now removed) and
    time left to solve again without them."""
    if outside is None or solved.stopped or budget.expired():
        return False
    return outside.excuse(free)


def in_the_way(pm: PlanModel, free: set[str], named: Sequence[Sequence[int]]) -> list[str]:
    """``free``, then the other agents of the requirements ``named`` (those each solve of a
    turn violated, in order): those a later solve named first, then those named more often."""
    last: dict[str, int] = {}
    count: dict[str, int] = {}
    for solve, indices in enumerate(named):
        for n in indices:
            for agent in agents_of(pm, [n]) - free:
                last[agent] = solve
                count[agent] = count.get(agent, 0) + 1
    ranked = sorted(last, key=lambda a: (-last[a], -count[a], a))
    return sorted(free) + ranked
