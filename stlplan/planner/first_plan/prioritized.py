"""Parts planned one after another, each around the plans of the parts before it.

When the plans of independent parts collide (a crowd of agents each with its own task, crossing
one room), the merged part is one large problem. Prioritized planning finds a plan of it from
small ones: the parts are taken in an order (:func:`first_order`), and each is solved again in
its *own* model with the parts before it as moving obstacles. Its requirements against an
earlier part (separation, or a constraint binding agents of both) are encoded exactly as the
full model encodes them (:meth:`~stlplan.planner.encoding.deferred.Requirement.encode`),
with the earlier agents' states as numbers: the rows read the later agents' variables only.
They are added lazily, as the part's plans violate them, with every step of their family, and so are
the part's own requirements. A part that finds no plan around those before it is moved ahead,
before the last part in its way (the guide names them), at its next failure before the one
before that, then to the front, and the parts are taken again, as revised prioritized planning
raises the priority of a robot that failed; the parts an order starts with as the last one did
keep their plans. The first ``repair.guided_orders`` orders take guided parts on their guide
paths only, the next ``repair.orders`` with their MILPs too. When every part
found one, the union of their plans meets every requirement between them; the merged model is
then solved once with every agent held near its plan (``tolerances.HOLD``), which sets every
indicator, and its plan is returned when it meets every requirement (the watch of the loop
takes it as any other plan of the full problem).

The parts' models are left as they were: each turn's rows go in a block of their own, removed
after the turn's order, and the turns solve in the parts' own HiGHS sessions, lent without their
lazy loops' watches (:meth:`~stlplan.planner.core.lazy.LazySolver.lent`).
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np
from pyomo.contrib.solver.common.results import TerminationCondition
from pyomo.core.base.block import BlockData

from stlplan.planner.backend.session import HighsSession, has_solution
from stlplan.planner.backend.values import load_values, model_values, trajectory_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.in_turn import hold_agents, release
from stlplan.planner.core.repairs import Rounds
from stlplan.planner.core.watch import (
    least_margin,
    loaded_plan,
    pending_violations,
    trajectory_states,
)
from stlplan.planner.encoding.alphas import best_sides, half_plane_values, violated
from stlplan.planner.encoding.deferred import Requirement, families
from stlplan.planner.encoding.model import PlanModel, add_requirements
from stlplan.planner.first_plan.guide import guide_path, single_integrator, task_planes
from stlplan.planner.first_plan.overlay import States, overlay_context
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Plan
from stlplan.planner.tolerances import FEASIBILITY, HOLD, ROOM

_log = logging.getLogger(__name__)


class Turn:
    """One part solved around the plans of the parts before it (module docstring)."""

    def __init__(
        self,
        pm: PlanModel,
        session: HighsSession,
        merged: PlanModel,
        config: PlannerConfig,
        naming: Mapping[str, Sequence[int]],
    ):
        self.pm, self.session, self.merged, self.config = pm, session, merged, config
        self.agents = {a.name for a in pm.problem.agents}
        lazy = self._lazy()
        mine = sorted({n for a in self.agents for n in naming.get(a, ())})
        self.crossing = [n for n in mine if not set(lazy[n].binding.values()) <= self.agents]
        """The merged model's requirements between the part's agents and others, by index."""
        self.block: BlockData | None = None
        self.blockers: set[str] = set()
        """Agents whose plans left the guide no path, in this turn's last solve."""
        self.own = trajectory_states(pm)
        """The part's plan on its own (loaded when the repair starts): the guide's reference."""

    def solve(
        self, fixed: States, budget: Budget, exact: bool = True, start: Plan | None = None
    ) -> States | None:
        """The part's states around ``fixed`` (the earlier agents' plans), or None. Without
        ``exact`` a guided part (:attr:`guided`) tries its guided solves only, not its MILP;
        every solve of the MILP starts from ``start`` (a plan around ``fixed``) when given."""
        lazy, self.blockers = self._lazy(), set()
        mine = self._crossing_with(fixed)
        crossing = [lazy[n] for n in mine]
        for wanted, guide in self._guides(fixed, crossing):
            guided = self.sided(fixed, crossing, wanted, guide, budget)
            if guided is not None:
                return guided
            if budget.expired():
                break
        if self.guided and not exact:
            return None
        ctx, added = self._context(fixed), set[int]()
        while True:
            if start is not None:
                self.session.start_from(start)
            if not self._solved(budget, fallback=start is None):
                return None
            states = {**fixed, **trajectory_states(self.pm)}
            own = pending_violations(self.pm)
            near = -self.config.repair.near  # and those met by less than repair.near
            found = violated([lazy[n] for n in mine], states, least_margin(self.pm), near)
            if not own and not violated(
                [lazy[mine[i]] for i in found], states, least_margin(self.pm), FEASIBILITY
            ):
                return {a: states[a] for a in self.agents}
            new = set(families(lazy, [mine[i] for i in found])) & set(mine) - added
            if not own and not new:
                _log.debug("prioritized: a turn's plan breaks requirements its model holds")
                return None
            add_requirements(self.pm, families(self._own_lazy(), own))
            for n in new:
                lazy[n].encode(ctx.bound(lazy[n].binding))
            added |= new
            if budget.expired():
                return None

    def _guides(
        self, fixed: States, mine: Sequence[Requirement]
    ) -> Iterator[tuple[list[Requirement], States]]:
        """The guide paths of a guided part (:mod:`stlplan.planner.first_plan.guide`), each with
        the requirements it is to keep sides of, until a solve with those sides plans the part:
        around its task's planes, without them, then weighing the distance from the part's own
        plan more the later it is (none for a part of several agents or of other dynamics)."""
        if not self.guided:
            return
        agent = self.pm.problem.agents[0]
        first = _fixed_steps(self.pm, agent.name)
        reference = self.own[agent.name]
        wanted = [r for r in (*mine, *self._own_lazy()) if r.k + r.span > first]
        margin = least_margin(self.pm)
        task = task_planes(self.pm.problem, agent.name, reference, margin)
        for planes, late in ((task, False), ((), False), ((), True)):
            found = guide_path(agent, first, reference, wanted, fixed, margin, late, planes)
            if found.path is None:
                self.blockers |= found.blockers
                continue
            yield wanted, {**fixed, agent.name: found.path}
        _log.debug("prioritized: no guided plan for %s", agent.name)

    def in_the_way(self, found: States, others: States) -> set[str]:
        """The agents of ``others`` whose plans break a requirement with the part's plan
        ``found``."""
        lazy = self._lazy()
        mine = [lazy[n] for n in self._crossing_with(others)]
        broken = violated(mine, {**others, **found}, least_margin(self.pm), FEASIBILITY)
        return {a for i in broken for a in mine[i].binding.values()} - self.agents

    def _crossing_with(self, others: States) -> list[int]:
        """The requirements of :attr:`crossing` between the part's agents and ``others``."""
        lazy, named = self._lazy(), self.agents | set(others)
        return [n for n in self.crossing if set(lazy[n].binding.values()) <= named]

    @property
    def guided(self) -> bool:
        """Whether the part's turns start from a guide path: one single-integrator agent."""
        agents = self.pm.problem.agents
        return len(agents) == 1 and single_integrator(agents[0])

    def sided(
        self,
        fixed: States,
        mine: Sequence[Requirement],
        wanted: Sequence[Requirement],
        guide: States,
        budget: Budget,
    ) -> States | None:
        """The part's states from solves with the requirements of ``wanted`` held on the side
        ``guide`` keeps: first those it meets by less than ``repair.guide_near``, then, solve
        after solve, those the plan breaks; or None."""
        ctx, margin = self._context(fixed), least_margin(self.pm)
        sides = best_sides(wanted, guide).tolist()
        pending = []
        if wanted:
            values, firsts = half_plane_values(wanted, guide)
            spare = values[firsts + np.asarray(sides, dtype=int)] - margin
            pending = np.flatnonzero(spare < self.config.repair.guide_near).tolist()
        held: set[int] = set()
        while True:
            for n in pending:
                wanted[n].encode_side(ctx, sides[n])
            held.update(pending)
            solved = self.session.solve(budget.seconds(self.config.budget.min_solve_seconds))
            if solved.stopped or not has_solution(solved.results):
                _log.debug("prioritized: a guided solve ended %s", self.session.verdict)
                return None
            found = {**fixed, **trajectory_states(self.pm)}
            pending = [n for n in violated(wanted, found, margin, FEASIBILITY) if n not in held]
            if not pending:
                break
        if pending_violations(self.pm) or violated(mine, found, margin, FEASIBILITY):
            _log.debug("prioritized: a guided plan breaks a requirement")
            return None
        return {a: found[a] for a in self.agents}

    def _solved(self, budget: Budget, fallback: bool = True) -> bool:
        """Whether a solve found a plan: within ``budget.min_solve_seconds`` or, with none by
        then and ``fallback``, within the turn's ``budget``."""
        first = budget.seconds(self.config.budget.min_solve_seconds)
        for limit in (first, budget) if fallback else (first,):
            solved = self.session.solve(limit)
            if solved.stopped or has_solution(solved.results):
                return not solved.stopped
            ended = solved.results.termination_condition
            if ended != TerminationCondition.maxTimeLimit:
                _log.debug("prioritized: a turn ended %s", ended.name)
                return False  # infeasible around the parts before it
        return False

    def _lazy(self) -> Sequence[Requirement]:
        assert self.merged.deferral is not None
        return self.merged.deferral.lazy

    def _own_lazy(self) -> Sequence[Requirement]:
        assert self.pm.deferral is not None
        return self.pm.deferral.lazy

    def _context(self, fixed: States) -> Any:
        """The part's encoding context, its rows in a fresh block, earlier agents as numbers."""
        self.clear()
        ctx, self.block = overlay_context(self.pm, fixed, "around_earlier_parts")
        return ctx

    def clear(self) -> None:
        """Remove the rows of the last turn."""
        if self.block is not None:
            self.pm.model.del_component(self.block)
            self.block = None


def requirements_naming(merged: PlanModel) -> dict[str, list[int]]:
    """The requirements of ``merged`` naming each agent, by index."""
    assert merged.deferral is not None
    out: dict[str, list[int]] = {}
    for n, requirement in enumerate(merged.deferral.lazy):
        for agent in set(requirement.binding.values()):
            out.setdefault(agent, []).append(n)
    return out


def _fixed_steps(pm: PlanModel, agent: str) -> int:
    """The last step whose states are fixed (the initial one, or a replan's past)."""
    k = 0
    while k < pm.problem.horizon and pm.model.x[agent, k + 1, 0].fixed:
        k += 1
    return k


Planned = list[tuple[int, States]]
"""The parts planned in an order, in turn, with their states."""


def plan_in_order(
    turns: Sequence[Turn],
    order: Sequence[int],
    budget: Budget,
    exact: bool = True,
    before: Sequence[tuple[int, States]] = (),
) -> tuple[Planned, int | None]:
    """Each part of ``order`` around the plans of those before it (guided parts without their
    MILPs, without ``exact``); the parts planned, and the first part that found none (None
    when every part found a plan). The parts the order shares with the start of ``before``
    (the last order's) keep their plans: a turn's plan depends on those before it only."""
    fixed: States = {}
    planned: Planned = []
    for place, i in enumerate(order):
        if place < len(before) and before[place][0] == i and len(planned) == place:
            found: States | None = before[place][1]
        else:
            tick = time.perf_counter()
            found = turns[i].solve(fixed, budget, exact)
            _log.debug("prioritized: part %d, %.2f s", i, time.perf_counter() - tick)
        if found is None:
            _log.debug("prioritized: part %d found no plan after %d parts", i, place)
            return planned, i
        planned.append((i, found))
        fixed.update(found)
    return planned, None


def first_order(turns: Sequence[Turn]) -> list[int]:
    """The first order of the parts: when every part is one guided agent, by the direction its
    own plan travels (the angle of its last position from its first), so that agents going the
    same way are planned one after another and each finds the plans before it going its way,
    whatever the order the mission lists them in; else the parts' own order."""
    if not all(turn.guided for turn in turns):
        return list(range(len(turns)))
    angles = []
    for turn in turns:
        (states,) = turn.own.values()
        dx, dy = states[-1, :2] - states[0, :2]
        angles.append(float(np.arctan2(dy, dx)))
    return sorted(range(len(turns)), key=lambda i: (angles[i], i))


def raised(
    order: Sequence[int], failed: int, ahead: Sequence[int] = (), tries: int = 1
) -> list[int]:
    """``order`` with the part ``failed`` moved before a part in its way: of those of ``ahead``
    in ``order``, the last at its first failure (``tries``), the one before at its second, and
    so on; to the front when none is left (or none is known)."""
    rest = [i for i in order if i != failed]
    places = [n for n, i in enumerate(rest) if i in ahead]
    place = places[-tries] if 0 < tries <= len(places) else 0
    return rest[:place] + [failed] + rest[place:]


def prioritized(
    merged: Rounds,
    parts: Sequence[Rounds],
    config: PlannerConfig,
    budget: Budget,
    last: Budget | None = None,
    alone: list[int] | None = None,
) -> Plan | None:
    """A plan of the merged part of ``merged`` (its lazy solver) from its ``parts`` (their
    lazy solvers, whose sessions the turns borrow) planned in turn (module docstring), the
    orders within ``budget``, their plans joined within ``last`` (the same budget when None);
    or None. A part whose MILP finds no plan first in an order, around no other part, ends the
    orders (no order plans it): its index goes in ``alone``."""
    alone = [] if alone is None else alone
    with contextlib.ExitStack() as lent:
        turns = _turns(merged, parts, config, lent)
        order, tried, fails = first_order(turns), 0, dict[int, int]()
        planned: Planned = []
        saved = [model_values(turn.pm.model) for turn in turns]
        guided = any(turn.guided for turn in turns)
        passes = ((False, config.repair.guided_orders),) if guided else ()
        try:  # guided parts on their guide paths only, then with their MILPs
            for exact, orders in (*passes, (True, max(1, config.repair.orders))):
                for _ in range(orders):
                    planned, failed = plan_in_order(turns, order, budget, exact, planned)
                    tried += 1
                    merged.clock.reached.ordered(len(planned), len(turns), tried)
                    if failed is None:
                        return held_plan(merged, turns, config, last or budget)
                    if exact and not planned:  # no plan around no other part
                        alone.append(failed)
                    if budget.expired() or alone:
                        return None
                    fails[failed] = fails.get(failed, 0) + 1
                    ahead = [i for i in order if turns[i].agents & turns[failed].blockers]
                    order = raised(order, failed, ahead, fails[failed])
            return None
        finally:
            for turn, values in zip(turns, saved, strict=True):
                turn.clear()
                load_values(turn.pm.model, values)


def _turns(
    merged: Rounds, parts: Sequence[Rounds], config: PlannerConfig, lent: contextlib.ExitStack
) -> list[Turn]:
    """A turn of each part in its lent session (returned when ``lent`` closes)."""
    sessions = [lent.enter_context(part.lent(config.repair.gap)) for part in parts]
    naming = requirements_naming(merged.pm)
    return [
        Turn(part.pm, session, merged.pm, config, naming)
        for part, session in zip(parts, sessions, strict=True)
    ]


def held_plan(
    merged: Rounds, turns: Sequence[Turn], config: PlannerConfig, budget: Budget
) -> Plan | None:
    """The merged model solved once with every agent held near the turns' plans."""
    pm, planned = merged.pm, dict[Any, float]()
    for turn in turns:
        planned.update(trajectory_values(model_values(turn.pm.model)))
    load_values(pm.model, planned)
    # a requirement the turns' plans meet with less to spare than the holds allow to move
    # (both agents of a pair) would be broken by the held solve: it goes in with them
    assert pm.deferral is not None
    close = -ROOM
    add_requirements(pm, violated(pm.deferral.lazy, trajectory_states(pm), least_margin(pm), close))
    held = hold_agents(pm, [a.name for a in pm.problem.agents], HOLD)
    try:
        found = merged.run(budget, trial=True)
    finally:
        release(held)
    return None if found.objective is None else loaded_plan(pm)
