"""What an encoding placed: every predicate, and how the indicators above them are linked.

Step 2 (:mod:`stlplan.planner.core.finish`) and the effort floors
(:mod:`stlplan.planner.encoding.floors`, :mod:`stlplan.planner.encoding.team_floors`) read it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from stlplan.formula.tree import Predicate

Enforced = tuple[Predicate, int, Mapping[str, str]]
"""A predicate at a step under a binding: ``alpha(x(k)) - r >= 0`` when enforced."""


@dataclass(eq=False)
class Ledger:
    """Every predicate the encoding placed, and how the indicators above them are linked.

    Step 2 rebuilds a small continuous model from it: the predicates whose indicators the fixed
    decisions force to 1, plus the unconditional ones. The effort floors
    (:mod:`stlplan.planner.encoding.floors`) read the links: conjunctions and choices.
    """

    guarded: list[tuple[Any, Enforced]] = field(default_factory=list)
    """``(z, (node, k, binding))``: ``z = 1`` enforces the predicate."""
    required: list[Enforced] = field(default_factory=list)
    """Predicates enforced outright."""
    conjunctions: list[tuple[Any, list[Any]]] = field(default_factory=list)
    """``(z, [z_1..z_n])`` with ``z <= z_i``: ``z = 1`` enforces every child."""
    choices: list[tuple[Any, list[Any], list[Any]]] = field(default_factory=list)
    """``(z, [z_1..z_n], [w_1..w_n])`` with ``w_i <= z_i`` and ``sum w = z`` (``z`` None: 1)."""
    elements: list[tuple[Any, Any, tuple[str, ...]]] = field(default_factory=list)
    """``(x_e, h_e, agents)``: a task's element ``e`` is chosen (``x_e <= h_e``)."""
    services: list[tuple[str, str, list[Any], list[Any]]] = field(default_factory=list)
    """``(task, agent, [h_e], [x_e])``: the elements of a task that reuses no agent and that
    contain the agent (at most one of them chosen), with their indicators."""


def conjunction_leaves(
    z: Any, conjunctions: Mapping[int, Sequence[Any]], predicates: Mapping[int, Any]
) -> tuple[list[Any], list[Any]]:
    """The predicate indicators reached from ``z`` through conjunctions alone (keys of
    ``predicates`` and ``conjunctions`` are indicator ids), and the other leaves reached."""
    reached: list[Any] = []
    others: list[Any] = []
    stack = [z]
    while stack:
        node = stack.pop()
        if id(node) in conjunctions:
            stack.extend(conjunctions[id(node)])
        elif id(node) in predicates:
            reached.append(node)
        else:
            others.append(node)
    return reached, others
