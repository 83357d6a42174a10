"""What the proof path sees of other parts' published plans: the requirements with them that a
repair in turn meets (:class:`Around`), and where parts publish their plans (:class:`Publisher`).
The first-plan heuristics implement both (:mod:`stlplan.planner.first_plan.published`)."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from contextlib import AbstractContextManager
from typing import Protocol

import numpy as np

from stlplan.planner.encoding.model import PlanModel

States = Mapping[str, np.ndarray]
"""Agents' states by name, one row a step."""


class Around(Protocol):
    """The requirements between a model's agents and other parts' published plans, which the
    turns of a repair in turn meet too."""

    def named(self, states: States) -> list[str]:
        """The model's agents whose plans in ``states`` break such a requirement."""
        ...

    def broken(self, states: States, agents: Collection[str]) -> list[int]:
        """The requirements naming one of ``agents`` that ``states`` break, by index."""
        ...

    def add(self, found: Sequence[int]) -> None:
        """Encode the requirements ``found`` with every step of their families."""
        ...

    def excuse(self, agents: Collection[str]) -> bool:
        """Leave the requirements with ``agents`` to a merge; whether any was left."""
        ...


class Publisher(Protocol):
    """Where a team's parts publish their first plans, for the others to plan around."""

    def around(self, pm: PlanModel) -> AbstractContextManager[Around | None]:
        """The published plans as requirements of ``pm``'s agents (None: none to meet)."""
        ...

    def publish(self, states: States) -> None:
        """Publish a part's plan."""
        ...
