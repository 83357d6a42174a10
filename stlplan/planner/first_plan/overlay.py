"""Rows of a model against other agents' plans, the other agents' states as numbers.

A part planned around agents whose plans are settled (the parts before it in a prioritized
repair, the first plans other parts published) meets its requirements with them as the full
model encodes them (:meth:`~stlplan.planner.encoding.deferred.Requirement.encode`), with those
agents' states as numbers: the rows read the part's own variables only. They go in a block of
their own, removed when the plans they were written against change.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from pyomo.core.base.var import IndexedVar
from pyomo.environ import Block, ConstraintList, VarList

from stlplan.planner.encoding.ledger import Ledger
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.encoding.sos1 import sos1_block

States = dict[str, np.ndarray]
"""Agent name to its states ``x(0..H)``, an (H+1, n) array."""


class _Overlay:
    """``x[agent, k, i]``: the model's variable, or another agent's planned state."""

    def __init__(self, states: IndexedVar, fixed: Mapping[str, np.ndarray]) -> None:
        self.states, self.fixed = states, fixed

    def __getitem__(self, key: tuple[str, int, int]) -> Any:
        agent, k, i = key
        planned = self.fixed.get(agent)
        return self.states[key] if planned is None else float(planned[k, i])


def overlay_context(pm: PlanModel, fixed: States, name: str) -> tuple[Any, Any]:
    """An encoding context of ``pm`` whose rows go in a fresh block ``name`` of its model, the
    agents of ``fixed`` at their planned states; the context and the block (delete it with
    ``pm.model.del_component``)."""
    ctx = pm.context
    assert ctx is not None
    block = Block(concrete=True)
    block.indicators = VarList(bounds=(0, 1))
    block.rows = ConstraintList()
    block.sos = sos1_block()
    pm.model.add_component(name, block)
    points = {a: (s, s) for a, s in fixed.items()}
    context = dataclasses.replace(
        ctx, block=block, sos=block.sos, states=_Overlay(ctx.states, fixed),
        boxes={**ctx.boxes, **points}, memo={}, ledger=Ledger(),
    )  # fmt: skip
    return context, block
