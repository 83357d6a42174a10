"""The sides of the lazy requirements step 1 never added, held by the continuous stage.

Step 1's plan meets every lazy requirement its rounds left out. The continuous stage keeps, of
each, the half-plane that plan meets best (a row without a binary), so that its own plan meets
them too. A large team's rounds leave tens of thousands of such requirements, nearly all far
from the plan, and their rows would make most of the continuous model. So the model starts with
the sides within ``continuous.near_sides`` of the step-1 plan; after each solve the sides its
plan breaks are added and the model is solved again (warm). A plan optimal over fewer rows that
meets the others is optimal over them all: the result is that of the model with every side.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from stlplan.planner.encoding.alphas import best_sides, half_plane_values
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.encoding.ledger import Enforced
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.tolerances import ROUND_OFF


@dataclass
class KeptSides:
    """The side kept of each lazy requirement not in step 1's model, and which are held.

    Attributes
    ----------
    requirements
        The requirements left out of step 1's model.
    sides
        The index of the half-plane kept of each.
    held
        Whether each kept side is in the continuous model.
    """

    requirements: tuple[Requirement, ...]
    sides: np.ndarray
    held: np.ndarray

    @classmethod
    def of(cls, pm: PlanModel, states: Mapping[str, np.ndarray]) -> KeptSides:
        """The sides step 1's plan (``states``) meets best of the requirements ``pm`` left out,
        none held yet."""
        pending = () if pm.deferral is None else tuple(pm.deferral.lazy[n] for n in pm.pending())
        sides = best_sides(pending, states)
        return cls(pending, sides, np.zeros(len(pending), dtype=bool))

    def _slacks(self, states: Mapping[str, np.ndarray], margin: float) -> np.ndarray:
        """``alpha - r`` of every kept side on a trajectory (agent name to states)."""
        values, firsts = half_plane_values(self.requirements, states)
        return values[firsts + self.sides] - margin

    def _hold(self, chosen: np.ndarray) -> list[Enforced]:
        """Mark the sides ``chosen`` (indices) held; their predicates at their steps."""
        self.held[chosen] = True
        return [
            enforced
            for n in chosen.tolist()
            for enforced in self.requirements[n].options()[int(self.sides[n])]
        ]

    def near(
        self, states: Mapping[str, np.ndarray], margin: float, within: float | None
    ) -> list[Enforced]:
        """Hold the sides with ``alpha - r`` at most ``within`` on ``states`` (step 1's plan);
        every side when ``within`` is None."""
        if not self.requirements:
            return []
        if within is None:
            return self._hold(np.arange(len(self.requirements)))
        return self._hold(np.flatnonzero(self._slacks(states, margin) <= within))

    def broken(self, states: Mapping[str, np.ndarray], margin: float) -> list[Enforced]:
        """Hold the sides not held yet that ``states`` break (``alpha - r < -ROUND_OFF``)."""
        if self.held.all():
            return []
        loose = self._slacks(states, margin) < -ROUND_OFF
        return self._hold(np.flatnonzero(loose & ~self.held))
