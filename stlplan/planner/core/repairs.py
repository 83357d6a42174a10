"""Repairs: ways to turn a plan that breaks requirements into one that meets them all.

A repair is a plug-in: the lazy loop and the parts call the repairs the
:class:`~stlplan.planner.core.policy.RepairPolicy` names, each within its share of the time
left, and take the plan it returns (a :class:`~stlplan.planner.run.outcome.Plan` that meets every
requirement, or None). Two repairs here, and two of the first-plan heuristics
(:mod:`stlplan.planner.core.hooks`: the prioritized repair and the repair by elements):

* :class:`InTurnRepair`: the agents the broken requirements name are solved again one at a
  time around the others, as prioritized planners do (:mod:`stlplan.planner.core.in_turn`);
* :class:`HeldRepair`: the model of a merged part solved with every agent but those the
  collisions name held near the parts' plans (``tolerances.HOLD``), a small problem: to the run's
  gap first, then, without a plan, to the repair's gap (``repair.gap``: its bound bounds only
  the held problem).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Protocol

from stlplan.planner.backend.session import HighsSession
from stlplan.planner.backend.values import load_values, model_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.around import Publisher
from stlplan.planner.core.assembly import hold_plans
from stlplan.planner.core.in_turn import InTurn, release
from stlplan.planner.core.watch import Watch, loaded_plan
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.planner.tolerances import HOLD


class Rounds(Protocol):
    """The lazy loop a repair works on (:class:`~stlplan.planner.core.lazy.LazySolver`): its
    model, session, clock and watch, its rounds, and its session lent to other solves."""

    pm: PlanModel
    session: HighsSession
    clock: Clock
    config: PlannerConfig
    watch: Watch | None
    published: Publisher | None
    trial: bool

    def run(self, budget: Budget, abs_gap: float | None = None, trial: bool = False) -> Outcome:
        """Rounds within ``budget`` until a plan meets every requirement or time is up."""
        ...

    def lent(self, gap: float) -> AbstractContextManager[HighsSession]:
        """The session for other solves within the block, at the relative gap ``gap``."""
        ...

    def sibling(self, pm: PlanModel) -> Rounds:
        """A lazy loop of another model with this loop's configuration, clock and policy."""
        ...


@dataclass(frozen=True, eq=False)
class Broken:
    """What a repair starts from.

    Attributes
    ----------
    solver
        The lazy solver of the model, with a plan loaded that violates ``bad`` (its ``pm``,
        ``session`` and ``run``).
    bad
        The lazy requirements the loaded plan violates.
    parts
        For a merged part: the models of the parts it comes from, with their plans.
    free
        For a merged part: the agents the collisions name.
    solvers
        For a merged part: the lazy solvers of the parts it comes from (of ``parts``).
    """

    solver: Rounds
    bad: Sequence[int]
    parts: Sequence[PlanModel] = ()
    free: frozenset[str] = field(default_factory=frozenset)
    solvers: Sequence[Rounds] = ()


class Repair(Protocol):
    """A way to repair a broken plan."""

    def repair(self, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        """A plan that meets every requirement, found within ``budget`` (None: none)."""
        ...

    def describe(self) -> str:
        """The repair in words."""
        ...


@dataclass(frozen=True)
class InTurnRepair:
    """Agent by agent, each around the agents already repaired (prioritized planning)."""

    def repair(self, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        solver = broken.solver
        reached = solver.clock.reached
        stop = solver.watch.done if solver.watch is not None else lambda: False
        with reached.within("repair in turn"):
            plan = _around_published(broken, config, budget, stop)
            if plan is None and not (budget.expired() or stop()):
                plan = InTurn(solver.pm, solver.session, config, stop=stop).run(broken.bad, budget)
            if plan is None and solver.watch is not None and stop():
                return solver.watch.best  # the loop's watch took a plan on the way
            if plan is None:
                reached.failed("repair in turn")
        return plan

    def describe(self) -> str:
        return "in turn"


def _around_published(
    broken: Broken, config: PlannerConfig, budget: Budget, stop: Callable[[], bool]
) -> Plan | None:
    """The repair in turn around the first plans other parts published (its agents that break
    requirements with them take turns too); None without such plans or without a plan (the
    broken plan then loaded again, for the repair that follows)."""
    solver = broken.solver
    if solver.published is None or solver.watch is None:
        return None
    with solver.published.around(solver.pm) as outside:
        if outside is None:
            return None
        watch, saved = solver.watch, model_values(solver.pm.model)
        watch.also = lambda states: not outside.broken(states, states)  # its plans meet them
        try:
            repair = InTurn(solver.pm, solver.session, config, outside=outside, stop=stop)
            plan = repair.run(broken.bad, budget)
        finally:
            watch.also = None
        if plan is None:
            load_values(solver.pm.model, saved)
        return plan


@dataclass(frozen=True)
class HeldRepair:
    """With every agent the collisions do not name held near its part's plan: solved to the
    run's gap within ``repair.held_exact_share`` of the time, then (without a plan, or with
    ``solver.first_plan`` at once) to the repair's gap."""

    def repair(self, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        solver = broken.solver
        reached = solver.clock.reached
        held = hold_plans(solver.pm, broken.parts, HOLD, broken.free)
        with reached.within("held repair"):
            try:
                found = _held_runs(solver, config, budget)
            finally:
                release(held)
            plan = None if found.objective is None else loaded_plan(solver.pm)
            if plan is None:
                reached.failed("held repair")
        return plan

    def describe(self) -> str:
        return "held"


def _held_runs(solver: Rounds, config: PlannerConfig, budget: Budget) -> Outcome:
    """The held model's lazy runs (:class:`HeldRepair`); the last one's outcome. A repair's
    bound bounds only the held problem: the second run looks for a plan, not for a proof."""
    exact = config.repair.held_exact_share
    if exact > 0 and not config.solver.first_plan:
        found = solver.run(budget.share(exact), trial=True)
        if found.objective is not None or budget.expired():
            return found
    with solver.session.looking_for_a_plan(config.repair.gap):
        return solver.run(budget, trial=True)
