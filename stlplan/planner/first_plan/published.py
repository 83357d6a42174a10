"""First plans of a team's parts, published for the parts still looking for theirs.

While a large team looks for its first plan (:mod:`stlplan.planner.first_plan.plan_first`, or
``--first-plan``), its parts are planned apart, and parts whose plans collide are merged: a
model of the merged team is built and its plan repaired, a MILP as large as the parts together.
Most often one part's plan is done while another's is still being repaired in turn. That repair
can plan around it: a part whose lazy loop found its first
plan publishes it, and the turns of a later repair in turn (:mod:`stlplan.planner.core.in_turn`) meet
the requirements between their free agent and the published agents as well, the published
agents' states as numbers (:mod:`stlplan.planner.first_plan.overlay`), added as the turn's plans break
them. Its agents whose plans break such a requirement take turns too, first, and the loop's
watch takes no plan that breaks one (a first plan ends the loop). A turn that finds no plan
around them is solved again without its rows: those requirements are left to a merge. The plan
found is a plan of the part (the requirements against others' plans only narrow its choices),
and its collisions with the published plans, when none are left, need no merge. A published
plan is a first plan: a merge that replans its part publishes the new one; nothing here is
used after the first plans.
"""

from __future__ import annotations

import threading
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
from pyomo.common.modeling import unique_component_name

from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.watch import least_margin
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import Requirement, families
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.first_plan.overlay import States, overlay_context
from stlplan.planner.tolerances import FEASIBILITY


class Outside:
    """The requirements between a model's agents and agents held at their published plans,
    encoded in the model, each agent's in a block of its own.

    Parameters
    ----------
    pm
        The model (a part's) whose agents are planned.
    fixed
        The published plans of the other agents.
    requirements
        The requirements binding agents of ``pm`` with agents of ``fixed`` (and no others).
    """

    def __init__(self, pm: PlanModel, fixed: States, requirements: Sequence[Requirement]) -> None:
        self.pm, self.fixed, self.requirements = pm, fixed, list(requirements)
        self.blocks: dict[str, tuple[Any, Any]] = {}
        self.encoded: set[int] = set()
        self.excused: set[str] = set()
        """Agents that found no plan around the published plans: their requirements with them
        are left to a merge."""

    def naming(self, agents: Collection[str]) -> list[int]:
        """The requirements naming one of ``agents`` and no excused agent, by index."""
        named = (set(r.binding.values()) for r in self.requirements)
        return [
            n for n, names in enumerate(named) if names & set(agents) and not names & self.excused
        ]

    def broken(self, states: Mapping[str, np.ndarray], agents: Collection[str]) -> list[int]:
        """The requirements naming one of ``agents`` that the plan ``states`` (of the model's
        agents) breaks, by index."""
        mine = self.naming(agents)
        plans = {**self.fixed, **states}
        found = violated([self.requirements[n] for n in mine], plans, least_margin(self.pm),
                         FEASIBILITY)  # fmt: skip
        return [mine[i] for i in found]

    def named(self, states: Mapping[str, np.ndarray]) -> list[str]:
        """The model's agents named by a requirement the plan ``states`` breaks."""
        return sorted({
            a for n in self.broken(states, states) for a in self.requirements[n].binding.values()
            if a not in self.fixed
        })  # fmt: skip

    def add(self, indices: Sequence[int]) -> None:
        """Encode the requirements ``indices`` with every step of their families
        (:func:`families`)."""
        for n in families(self.requirements, indices):
            if n not in self.encoded:
                self.requirements[n].encode(self._context(self._owner(n)))
                self.encoded.add(n)

    def excuse(self, agents: Collection[str]) -> bool:
        """Remove the rows of those of ``agents`` that have some and leave their requirements to
        a merge (an agent without rows is not kept from a plan by them); whether any had."""
        removed = [a for a in agents if a in self.blocks]
        for agent in removed:
            self.pm.model.del_component(self.blocks.pop(agent)[1])
        self.excused |= set(removed)
        self.encoded = {n for n in self.encoded if self._owner(n) not in self.excused}
        return bool(removed)

    def clear(self) -> None:
        """Remove the rows from the model."""
        self.excuse(list(self.blocks))

    def _owner(self, n: int) -> str:
        """The agent of the model whose block holds the requirement ``n``."""
        return min(a for a in self.requirements[n].binding.values() if a not in self.fixed)

    def _context(self, agent: str) -> Any:
        if agent not in self.blocks:
            name = unique_component_name(self.pm.model, "around_published_plans")
            self.blocks[agent] = overlay_context(self.pm, self.fixed, name)
        return self.blocks[agent][0]


class Published:
    """The first plans published so far, by agent (module docstring).

    Parameters
    ----------
    full
        A lazy model of the whole team: its requirements between agents of different parts.
    """

    def __init__(self, full: PlanModel) -> None:
        assert full.deferral is not None
        self.lazy = full.deferral.lazy
        self.plans: States = {}
        self._lock = threading.Lock()

    def publish(self, states: Mapping[str, np.ndarray]) -> None:
        """Publish the plans ``states`` (they replace the agents' earlier ones)."""
        with self._lock:
            self.plans.update(states)

    def rank(self, agents: Collection[str]) -> int:
        """When the first of ``agents`` was published, among the agents published so far
        (after them all when none was)."""
        with self._lock:
            order = {a: i for i, a in enumerate(self.plans)}
        return min((order[a] for a in agents if a in order), default=len(order))

    @contextmanager
    def around(self, pm: PlanModel) -> Iterator[Outside | None]:
        """The published plans of the agents not in ``pm`` as an :class:`Outside` of ``pm``,
        its rows removed afterwards (None: no requirement binds ``pm``'s agents with them)."""
        mine = {a.name for a in pm.problem.agents}
        with self._lock:
            fixed = {a: s for a, s in self.plans.items() if a not in mine}
        requirements = [r for r in self.lazy if _between(r, mine, fixed)]
        if not requirements:
            yield None
            return
        outside = Outside(pm, fixed, requirements)
        try:
            yield outside
        finally:
            outside.clear()


def published_for(full: PlanModel, config: PlannerConfig) -> Published | None:
    """Where a team's parts publish their first plans, while looking for a first plan (None
    otherwise)."""
    return Published(full) if config.solver.first_plan else None


def _between(requirement: Requirement, mine: set[str], fixed: Mapping[str, Any]) -> bool:
    """Whether ``requirement`` binds agents of ``mine`` with agents of ``fixed`` only."""
    agents = set(requirement.binding.values())
    return bool(agents & mine) and bool(agents - mine) and agents - mine <= fixed.keys()
