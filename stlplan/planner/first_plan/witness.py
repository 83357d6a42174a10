"""The predicates, and their steps, by which a plan meets its tasks: what a path must keep.

A lowered formula has no negation: it is monotone in its predicates. So when a plan meets a
formula, some set of (predicate, step) pairs it keeps suffices: any other trajectory keeping
every one of them meets the formula too. Such a set is a *witness*. Taken from an agent's plan
on its own, it tells the guide of a prioritized turn (:mod:`stlplan.planner.first_plan.guide`) where the
agent must be and when, so that its path around the earlier agents still meets its task.

The witness is chosen to leave a path the most room: an ``F`` or an until is witnessed at its
latest step that holds (a late arrival is still in time), an ``Or`` by the child the plan
meets with the most to spare.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from stlplan.formula.tree import Always, And, Eventually, Formula, Or, Predicate, Until
from stlplan.planner.tolerances import MONITOR


@dataclass(frozen=True)
class Kept:
    """``predicate`` kept at ``step``."""

    predicate: Predicate
    step: int


class _Witness:
    """The witness search over one plan: ``signals`` is role to the bound agent's states."""

    def __init__(self, signals: Mapping[str, np.ndarray]) -> None:
        self.signals = signals
        self.horizon = min(len(s) for s in signals.values()) - 1
        self.memo: dict[tuple[int, int], tuple[Kept, ...] | None] = {}

    def value(self, p: Predicate, k: int) -> float:
        return sum(t.coef * float(self.signals[t.role][k, t.component]) for t in p.terms) - p.bound

    def of(self, node: Formula, k: int) -> tuple[Kept, ...] | None:
        """A witness of ``node`` at step ``k``, or None when the plan does not meet it there."""
        key = (id(node), k)
        if key not in self.memo:
            self.memo[key] = None if k > self.horizon else self._find(node, k)
        return self.memo[key]

    def _find(self, node: Formula, k: int) -> tuple[Kept, ...] | None:
        if isinstance(node, Predicate):
            return (Kept(node, k),) if self.value(node, k) >= -MONITOR else None
        if isinstance(node, And):
            return self._all([(c, k) for c in node.children])
        if isinstance(node, Always):
            return self._all([(node.child, t) for t in _steps(node, k)])
        if isinstance(node, Or):
            found = [w for w in (self.of(c, k) for c in node.children) if w is not None]
            return max(found, key=self._room, default=None)
        if isinstance(node, Eventually):
            options = (self.of(node.child, t) for t in reversed(_steps(node, k)))
            return next((w for w in options if w is not None), None)
        if isinstance(node, Until):
            options = (
                self._all([(node.right, t)] + [(node.left, s) for s in node.left_steps(k, t)])
                for t in reversed(_steps(node, k))
            )
            return next((w for w in options if w is not None), None)
        return None

    def _all(self, pairs: list[tuple[Formula, int]]) -> tuple[Kept, ...] | None:
        out: list[Kept] = []
        for node, t in pairs:
            found = self.of(node, t)
            if found is None:
                return None
            out.extend(found)
        return tuple(out)

    def _room(self, kept: tuple[Kept, ...]) -> float:
        return min((self.value(w.predicate, w.step) for w in kept), default=np.inf)


def _steps(node: Always | Eventually | Until, k: int) -> range:
    return range(k + node.interval.lo, k + node.interval.hi + 1)


def witness(formula: Formula, signals: Mapping[str, np.ndarray]) -> tuple[Kept, ...] | None:
    """A witness (module docstring) that the plan ``signals`` meets the lowered ``formula`` at
    step 0, or None when it does not."""
    return _Witness(signals).of(formula, 0)
