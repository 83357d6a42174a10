"""The first-plan heuristics as the proof path's hooks (:class:`FirstPlan`, built by
:mod:`stlplan.planner.strategy` only).

A large team's first plan before its parts' proofs.

Parts are proven before they are merged: a merged part is proven by its parts' bounds, and the
union of the parts' plans is a plan of the whole only once no requirement between them is left.
With parts of ten agents or more a proof takes minutes, and the team's first plan waits for it
(``farm-x2`` from the bench's state 0: 275 s of a 300 s run). When the largest part has at least
``parts.plan_first_agents`` agents, :func:`~stlplan.planner.core.components.solve_parts` therefore
looks for a plan first, within ``budget.search_share`` of the time:

1. each part's lazy loop stops at its first plan that meets every requirement (as with
   ``solver.first_plan``); parts whose plans collide are merged and repaired as for a first plan,
   and the plans are assembled in a model of the whole team of its own;
2. the parts then go on from where they stopped, with the requirements they added and their
   plans as incumbents, towards their proofs, merged and assembled as usual.

The merges of the first step are dropped: a merged part's plan answers the collisions of first
plans, not of optimal ones. Step 1's plan is the better of the two, with the tighter bound, so a
run that ends (the time limit, a stop request) before the second step has a better plan returns
the first.

While the parts look for that first plan, they publish their plans and their repairs plan around
the others' (:mod:`stlplan.planner.first_plan.published`), colliding parts are repaired around
each other's plans before a merge (:mod:`stlplan.planner.first_plan.replan_around`), a merge of
small parts is repaired part by part (:class:`PrioritizedRepair`), a round's or a merge's task
choices by elements (:mod:`stlplan.planner.first_plan.by_elements`); the first plan is then
improved element by element (:mod:`stlplan.planner.first_plan.improve`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.hooks import Publisher, Solved
from stlplan.planner.core.parts import Part
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.repairs import Broken, Repair
from stlplan.planner.core.team_split import agent_parts
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.first_plan.by_elements import ElementsRepair, has_choices
from stlplan.planner.first_plan.improve import improved
from stlplan.planner.first_plan.prioritized import prioritized
from stlplan.planner.first_plan.published import Published, published_for
from stlplan.planner.first_plan.replan_around import replanned_around
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Plan


@dataclass(frozen=True)
class FirstPlan:
    """The heuristics that look for a large team's first plan
    (:class:`~stlplan.planner.core.hooks.FirstPlanHooks`), the first plan improved element by
    element within ``improve_share`` of the time left."""

    improve_share: float

    @classmethod
    def of(cls, config: PlannerConfig) -> FirstPlan:
        """The heuristics as ``config`` sets them (``budget.side_share``)."""
        return cls(config.budget.side_share)

    def chooses(self, problem: Problem) -> bool:
        return has_choices(problem)

    def by_elements(self) -> Repair:
        return ElementsRepair()

    def prioritized(self, orders_share: float) -> Repair:
        return PrioritizedRepair(orders_share)

    def publisher(self, full: PlanModel, config: PlannerConfig) -> Publisher | None:
        return published_for(full, config)

    def before_merge(
        self,
        full: PlanModel,
        parts: Sequence[Part],
        crossing: Sequence[Requirement],
        published: Publisher | None,
        config: PlannerConfig,
        budget: Budget,
    ) -> bool:
        if not isinstance(published, Published):
            return False
        return replanned_around(full, parts, crossing, published, config, budget)

    def plans_first(self, problem: Problem, config: PlannerConfig, least: int) -> bool:
        """Whether ``problem`` is solved for a plan first (module docstring): it has several
        parts, the largest with ``least`` agents or more, and the run asks for more than a first
        plan."""
        if config.solver.first_plan:
            return False
        names = agent_parts(problem)
        return len(names) > 1 and max(len(n) for n in names) >= least

    def improved(
        self,
        problem: Problem,
        early: Solved,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        policy: RepairPolicy,
    ) -> Solved:
        return improved(problem, early, config, clock, budget.share(self.improve_share), policy)

    def describe(self) -> str:
        return "improved by elements"


@dataclass(frozen=True)
class PrioritizedRepair:
    """Part by part, each in its own model around the parts before it (prioritized planning):
    the orders within ``orders_share`` of the repair's time, the solve that turns the parts'
    plans into the merged part's within all of it."""

    orders_share: float = 1.0

    def repair(self, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        if len(broken.parts) < 2:
            return None
        reached = broken.solver.clock.reached
        orders = budget.share(self.orders_share)
        with reached.within("prioritized repair"):
            plan = prioritized(broken.solver, broken.solvers, config, orders, budget)
            if plan is None:
                reached.failed("prioritized repair")
        return plan

    def describe(self) -> str:
        return "prioritized"
