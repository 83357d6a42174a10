"""Which repairs run, when, and with what share of the time: one policy for the lazy rounds
and the merged parts.

While no plan meets every requirement, a repair (:mod:`stlplan.planner.core.repairs`) may find one
where the next solve would not. After a lazy round that was long
(``repair.after_round_seconds``) or whose violations name a crowd (``repair.crowd_agents``), or
after any round naming two agents or more of a loop that looks for its first plan only
(measured: docs/measurements.md#first-plans-repaired-at-once), the round's plan is repaired in turn within ``budget.side_share`` of
the loop's time left (``budget.search_share`` in a loop that looks for its first plan only).
A merge of parts whose collisions name a crowd (or two agents, while
looking for a first plan) in a team of ``repair.crowd_team`` agents or more is repaired part by
part, each part in its own model around
those before it (up to ``repair.orders`` orders; none when 0, or when a part has more than
``repair.part_agents`` agents; its orders within ``budget.search_share`` of the time left
and the solve that joins their plans within all of it), then in turn, within
``budget.search_share`` of the time left; then, without a plan, with the other agents held
(within ``budget.side_share``).

In a loop that looks for its first plan only, a round naming two agents or more is repaired by
elements first (:mod:`stlplan.planner.first_plan.by_elements`: its task choices as parts of their own,
planned part by part), within ``repair.by_elements`` of the time left, and so is a merge of parts
too large for the prioritized repair while looking for a first plan.

The prioritized repair and the repair by elements are the first-plan heuristics'
(:class:`FirstPlanRepairs`, :mod:`stlplan.planner.core.hooks`): a policy without them names
neither.

Once a plan meets every requirement, no round's plan is repaired: the rounds prove.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from stlplan.mission.problem import Problem
from stlplan.planner.config import BudgetConfig, PartsConfig, PlannerConfig, RepairConfig
from stlplan.planner.core.repairs import HeldRepair, InTurnRepair, Repair

Planned = tuple[tuple[Repair, float], ...]
"""Repairs to try in order, each with its share of the time left when it starts."""


class FirstPlanRepairs(Protocol):
    """The first-plan heuristics' repairs (:class:`~stlplan.planner.core.hooks.FirstPlanHooks`)."""

    def chooses(self, problem: Problem) -> bool:
        """Whether the repair by elements may run on ``problem`` (a task chooses)."""
        ...

    def by_elements(self) -> Repair:
        """The repair by elements."""
        ...

    def prioritized(self, orders_share: float) -> Repair:
        """The prioritized repair of a merge, its orders within ``orders_share`` of its time."""
        ...


@dataclass(frozen=True)
class RepairPolicy:
    """When to repair, and with what share of the time: the ``repair``, ``parts`` and ``budget`` sections
    of the run's configuration, read as they are (None: never on that count), and the
    first-plan heuristics' repairs (None: none)."""

    repair: RepairConfig
    parts: PartsConfig
    budget: BudgetConfig
    first_plan: FirstPlanRepairs | None = None

    @classmethod
    def of(cls, config: PlannerConfig, first_plan: FirstPlanRepairs | None = None) -> RepairPolicy:
        """The policy of ``config``, with the first-plan heuristics of ``first_plan``."""
        return cls(config.repair, config.parts, config.budget, first_plan)

    def first_gap(self, problem: Problem, gap: float, by_elements_gap: float) -> float:
        """The gap of the rounds of a loop that looks for its first plan: ``gap``, or the looser
        ``by_elements_gap`` where the repair by elements may run (it takes the round's choices,
        not its optimum)."""
        hooks = self.first_plan
        chooses = (
            self.repair.by_elements is not None and hooks is not None and hooks.chooses(problem)
        )
        return max(gap, by_elements_gap if chooses else 0.0)

    def round_repairs(self, seconds: float, agents: int, first: bool = False) -> Planned:
        """The repairs of a lazy round of ``seconds`` whose violations name ``agents``, in a
        loop that looks for its first plan only when ``first`` (then any round that names two
        agents or more, within ``budget.search_share`` of its time
        left). None once a plan meets every requirement: the loop does not ask then."""
        before_plan = first and agents >= 2
        repaired = self.after_round(seconds, agents) or before_plan
        share = self.budget.search_share if first else self.budget.side_share
        if not repaired:
            return ()
        hooks = self.first_plan
        if before_plan and self.repair.by_elements is not None and hooks is not None:
            return (hooks.by_elements(), self.repair.by_elements), (InTurnRepair(), share)
        return ((InTurnRepair(), share),)

    def merge_repairs(
        self, agents: int, largest: int = 1, team: int | None = None, first: bool = False
    ) -> Planned:
        """The repairs of a merged part of a team of ``team`` agents (None: a team large enough)
        whose collisions name ``agents`` agents, from parts of at most ``largest`` agents, while
        looking for a first plan only when ``first``."""
        held: Planned = ((HeldRepair(), self.budget.side_share),)
        if not self.on_merge(agents, team, first):
            return held
        ordered, hooks = self.ordered(largest), self.first_plan
        ahead: Planned = ()
        if hooks is not None and ordered:  # its last solve: any time left
            ahead = ((hooks.prioritized(self.budget.search_share), 1.0),)
        elif hooks is not None and first and self.repair.by_elements is not None:
            ahead = ((hooks.by_elements(), self.repair.by_elements),)
        return (*ahead, (InTurnRepair(), self.budget.search_share), *held)

    def ordered(self, largest: int) -> bool:
        """Whether a merge of parts of at most ``largest`` agents is repaired part by part."""
        return bool(self.repair.orders) and largest <= self.repair.part_agents

    def after_round(self, seconds: float, agents: int) -> bool:
        """Whether a round of ``seconds`` whose violations name ``agents`` agents is repaired."""
        if (
            self.repair.after_round_seconds is not None
            and seconds >= self.repair.after_round_seconds
        ):
            return True
        return self.crowd(agents)

    def crowd(self, agents: int) -> bool:
        """Whether violations naming ``agents`` agents name a crowd."""
        return self.repair.crowd_agents is not None and agents >= self.repair.crowd_agents

    def on_merge(self, agents: int, team: int | None = None, first: bool = False) -> bool:
        """Whether a merged part of a team of ``team`` agents (None: a team large enough)
        whose collisions name ``agents`` agents is repaired in turn."""
        large = self.repair.crowd_team is None or team is None or team >= self.repair.crowd_team
        before_plan = first and agents >= 2
        return large and (self.crowd(agents) or before_plan)

    def describe(self) -> str:
        """The triggers in words (empty when there are none)."""
        triggers = []
        if self.repair.after_round_seconds is not None:
            triggers.append(f"round >= {self.repair.after_round_seconds:g} s")
        if self.repair.crowd_agents is not None:
            triggers.append(f">= {self.repair.crowd_agents} agents")
        triggers.append("before a first plan")
        return " or ".join(triggers)
