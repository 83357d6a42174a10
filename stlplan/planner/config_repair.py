"""The repairs' knobs: a section of :class:`stlplan.planner.config.PlannerConfig`
(``repair.*``), and the base of every section. No Pyomo, no HiGHS here."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class Section(BaseModel):
    """A section of the planner's knobs: unknown keys and wrong types refused."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, strict=True, use_attribute_docstrings=True
    )


class RepairConfig(Section):
    """Repairing a plan agent by agent (prioritized planning) while no plan meets every
    requirement."""

    after_round_seconds: float | None = Field(default=8.0, ge=0)
    """A lazy round that took at least this long has its plan repaired before the next round
    (None: never by duration). Measured: docs/dropped.md#the-repair-in-turn."""
    crowd_agents: int | None = Field(default=7, ge=1)
    """A lazy round, or a merge of parts, whose violated requirements name at least this many
    agents is repaired in turn (None: never by crowd). Measured:
    docs/measurements.md#the-16-agent-farm-with-doubled-counts."""
    crowd_team: int | None = Field(default=10, ge=1)
    """A merge's crowd is repaired in turn only in a team of this many agents or more (None: any).
    Measured: docs/performance.md#crowded-merges-in-cases-i-iii."""
    by_elements: float | None = Field(default=0.5, gt=0, le=1)
    """Before a first plan, in a loop that looks for one, a round's plan is first repaired by
    elements (its task choices as parts of their own, planned in turn) within this share of the
    loop's time left, and so is a merge of parts too large for the prioritized repair (None:
    never). Measured: docs/measurements.md#the-repair-by-elements."""
    by_elements_gap: float = Field(default=0.1, ge=0)
    """Relative gap of the rounds of a loop that looks for its first plan, where its tasks
    choose, while the repair by elements is on: the repair takes a round's choices, not its
    optimum. Measured:
    docs/measurements.md#the-repair-by-elements."""
    solves_per_turn: int = Field(default=10, ge=1)
    """Solves of one agent's turn at most (each after adding what the last plan violated)."""
    gap: float = Field(default=0.01, ge=0)
    """Relative gap of a repair's solves (a turn's, the held repair's rounds): the repair looks
    for a plan, the rounds prove. Measured: docs/measurements.md#where-farm-x2s-first-plan-comes-from."""
    held_exact_share: float = Field(default=0.5, ge=0, le=1)
    """Share of its time the held repair of a merged part spends solving to the run's gap (its
    plan may then prove the merged part); the rest, when that found no plan, goes to solving
    to ``repair.gap``. Measured: docs/measurements.md#where-farm-x2s-first-plan-comes-from."""
    near: float = Field(default=0.3, ge=0)
    """A prioritized turn adds, with the requirements against earlier parts its plan violates,
    those it meets by less than this (fewer solves per turn). Measured:
    docs/measurements.md#the-prioritized-repair."""
    orders: int = Field(default=3, ge=0)
    """Orders of the parts a prioritized repair of a merged crowd tries with the turns' MILPs, a
    failed part moved before the parts in its way (0: no prioritized repair). Measured:
    docs/measurements.md#the-prioritized-repair."""
    guided_orders: int = Field(default=40, ge=0)
    """Orders a prioritized repair first tries with guided parts on their guide paths only,
    before its ``repair.orders`` orders with the turns' MILPs. Measured:
    docs/measurements.md#the-first-order-by-the-direction-of-travel."""
    guide_near: float = Field(default=0.5, ge=0)
    """A guided turn first holds the sides of the requirements its guide path meets by less
    than this; the others when its plan breaks them. Measured: docs/measurements.md#guided-turns."""
    part_agents: int = Field(default=4, ge=1)
    """A prioritized repair runs only when the parts of the merge have at most this many agents
    each: a larger part's turn is a MILP of its own that does not finish. Measured:
    docs/measurements.md#guided-turns."""
