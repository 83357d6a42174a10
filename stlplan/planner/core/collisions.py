"""Collisions between parts: the requirements between them that their plans violate together,
and the groups of parts those requirements link (merged into one part each)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, TypeVar

from stlplan.planner.core.watch import least_margin, trajectory_states
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.tolerances import FEASIBILITY


class Part(Protocol):
    """A part of the team: its agents, and its model with its plan loaded."""

    @property
    def agents(self) -> tuple[str, ...]: ...

    @property
    def pm(self) -> PlanModel: ...


P = TypeVar("P", bound=Part)


def crossing_requirements(full: PlanModel, parts: Sequence[Part]) -> list[Requirement]:
    """Requirements of the full problem linking agents of different parts that the combined
    plan violates.

    A requirement within one part is that part's own: its plan meets it as HiGHS meets any row,
    within the solver's tolerances, which may exceed :data:`FEASIBILITY`; merging could not
    change that, so such a requirement is not a crossing.

    Parameters
    ----------
    full
        The lazy model of the full problem: its lazy requirements and its margin.
    parts
        The parts, each with its plan loaded in its own model.

    Returns
    -------
    list[Requirement]
        The lazy requirements of ``full`` that the parts' plans together violate by more than
        :data:`FEASIBILITY` and that name agents of at least two parts.
    """
    assert full.deferral is not None
    states, owner = {}, {a: i for i, part in enumerate(parts) for a in part.agents}
    for part in parts:
        states.update(trajectory_states(part.pm))
    found = violated(full.deferral.lazy, states, least_margin(full), FEASIBILITY)
    bad = [full.deferral.lazy[n] for n in found]
    return [r for r in bad if len({owner[a] for a in r.binding.values()}) > 1]


def merge_groups(parts: list[P], linked: list[set[str]]) -> list[list[P]]:
    """Groups of parts to merge, one per connected set of ``linked`` agents."""
    owner = {a: i for i, part in enumerate(parts) for a in part.agents}
    groups: list[set[int]] = []
    for agents in linked:
        touched = {owner[a] for a in agents}
        for g in [g for g in groups if g & touched]:
            touched |= g
            groups.remove(g)
        groups.append(touched)
    return [[parts[i] for i in sorted(g)] for g in groups if len(g) > 1]
