"""Where the large-team first-plan heuristics plug into the proof path.

The proof path (this package) is complete on its own: with no hooks, a run proves its optimum
by lazy rounds, parts, merges and the repairs in turn and held. The
heuristics that only look for a large team's first plan (:mod:`stlplan.planner.first_plan`)
come in through one :class:`FirstPlanHooks` object, which only :mod:`stlplan.planner.strategy`
builds: it hands it to the :class:`~stlplan.planner.core.policy.RepairPolicy` (their repairs)
and to the parts' solve (:func:`~stlplan.planner.core.components.solve_parts`). This package
never imports them; the protocols are what it sees of them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.around import Publisher
from stlplan.planner.core.parts import Part
from stlplan.planner.core.policy import FirstPlanRepairs, RepairPolicy
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome

Solved = tuple[PlanModel, Outcome]
"""A model of the whole team with its plan loaded, and how its solve ended."""


class FirstPlanHooks(FirstPlanRepairs, Protocol):
    """The heuristics that look for a large team's first plan: their repairs (which the policy
    names) and what they add to the parts' solve."""

    def publisher(self, full: PlanModel, config: PlannerConfig) -> Publisher | None:
        """Where the parts of ``full``'s team publish their first plans (None: nowhere)."""
        ...

    def before_merge(
        self,
        full: PlanModel,
        parts: Sequence[Part],
        crossing: Sequence[Requirement],
        published: Publisher | None,
        config: PlannerConfig,
        budget: Budget,
    ) -> bool:
        """Repair colliding parts around each other's plans before they merge; whether a plan
        changed."""
        ...

    def plans_first(self, problem: Problem, config: PlannerConfig, least: int) -> bool:
        """Whether a first plan of the whole team comes before the parts' proofs."""
        ...

    def improved(
        self,
        problem: Problem,
        early: Solved,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        policy: RepairPolicy,
    ) -> Solved:
        """The first plan ``early`` improved element by element within a share of ``budget``,
        its loops repairing by ``policy`` (or as it was)."""
        ...

    def describe(self) -> str:
        """What the heuristics do after the first plan, in words (empty: nothing)."""
        ...
