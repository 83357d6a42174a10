"""One requirement's half-planes in one agent's position, term by term (the plain form of
:func:`stlplan.planner.first_plan.guide.readable_planes`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.first_plan.guide_stops import HalfPlanes
from stlplan.planner.tolerances import ROOM


def half_planes(
    req: Requirement, agent: str, fixed: Mapping[str, np.ndarray], margin: float
) -> HalfPlanes | None:
    """``req`` with the states of ``fixed`` as numbers (None when it reads another agent)."""
    alts = req.alternatives
    a, c = np.zeros((len(alts), 2)), np.zeros((len(alts), req.span + 1))
    reads = frozenset(req.binding.values()) - {agent}
    for i, alt in enumerate(alts):
        for s, t in enumerate(req.steps):
            c[i, s] = alt.bound + req.tightening(alt, t) + margin + ROOM
        for term in alt.terms:
            who = req.binding[term.role]
            if who == agent:
                a[i, term.component] += term.coef
            elif who in fixed:
                c[i] -= term.coef * fixed[who][list(req.steps), term.component]
            else:
                return None
    return HalfPlanes(a, c, req.k, req.span, reads)
