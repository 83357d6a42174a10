"""When a plan is repaired agent by agent: one policy for the lazy rounds and the merged parts.

While no plan meets every requirement, a repair in turn (:mod:`stlplan.planner.in_turn`) may
find one where the next solve would not. The policy says when it is worth trying: after a lazy
round that was long (``repair.after_round_seconds``) or whose violations name a crowd
(``repair.crowd_agents``), and on a merge of parts whose collisions name a crowd.
"""

from __future__ import annotations

from dataclasses import dataclass

from stlplan.planner.config import PlannerConfig


@dataclass(frozen=True)
class RepairPolicy:
    """When to repair in turn (None: never on that count)."""

    after_round_seconds: float | None
    crowd_agents: int | None

    @classmethod
    def of(cls, config: PlannerConfig) -> RepairPolicy:
        """The policy of ``config``'s ``repair`` section."""
        return cls(config.repair.after_round_seconds, config.repair.crowd_agents)

    def after_round(self, seconds: float, agents: int) -> bool:
        """Whether a round of ``seconds`` whose violations name ``agents`` agents is repaired."""
        if self.after_round_seconds is not None and seconds >= self.after_round_seconds:
            return True
        return self.on_merge(agents)

    def on_merge(self, agents: int) -> bool:
        """Whether a merged part whose collisions name ``agents`` agents is repaired in turn."""
        return self.crowd_agents is not None and agents >= self.crowd_agents

    def describe(self) -> str:
        """The triggers in words (empty when there are none)."""
        triggers = []
        if self.after_round_seconds is not None:
            triggers.append(f"round >= {self.after_round_seconds:g} s")
        if self.crowd_agents is not None:
            triggers.append(f">= {self.crowd_agents} agents")
        return " or ".join(triggers)
