"""Formulas that no plan can satisfy any more, found without solving.

Robustness is built from predicate values by ``min``, ``max`` and the ``n``-th largest (a
count) alone, so it grows with every
predicate's value. Its value with every predicate at the largest it takes over the agents'
reachable boxes (:func:`stlplan.analysis.reach.reachable_boxes`) bounds it from above for every
trajectory the dynamics allow. When that bound is below ``HOLDS_AT``, the formula is decided
false. A replan's executed past makes its boxes points, so a ``G`` the past broke, or an ``F``
whose window closed unmet, is found here at once.

A constraint ``G[a,b] !in(p, R)`` (an obstacle, a region a replan closed) keeps ``in(p, R)``
false at steps ``a..b`` for any plan that meets it: given as ``barred``, the region's lowered
conjunction is bounded by ``-HOLDS_AT`` there, so a task that needs an agent in a closed region
is decided false too.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from stlplan.formula.boundary import HOLDS_AT
from stlplan.formula.tree import (
    Always,
    And,
    AtLeast,
    Eventually,
    Formula,
    Or,
    Predicate,
    Until,
)

Boxes = Mapping[str, tuple[np.ndarray, np.ndarray]]
"""Role name to the (H+1, n) lower and upper bounds of its agent's states."""

Barred = Mapping[Formula, np.ndarray]
"""A lowered ``in(role, region)`` to the steps (a boolean per step ``0..H``) at which a
constraint keeps it false."""

_NONE: Barred = MappingProxyType({})


def upper_robustness(
    formula: Formula, boxes: Boxes, horizon: int, barred: Barred = _NONE
) -> np.ndarray:
    """An upper bound of ``rho(formula, k)`` over every trajectory within ``boxes`` that meets
    the constraints behind ``barred``, for ``k = 0 .. H - horizon(formula)`` (a lowered formula,
    as the monitor evaluates)."""
    values = _EVALUATORS[type(formula)](formula, boxes, horizon, barred)
    steps = barred.get(formula)
    if steps is not None:
        values = np.where(steps[: len(values)], np.minimum(values, -HOLDS_AT), values)
    return values


def _predicate(node: Formula, boxes: Boxes, horizon: int, barred: Barred) -> np.ndarray:
    # max over the box of sum_i coef_i x_i - bound: each term at its larger end
    assert isinstance(node, Predicate)
    value = np.full(horizon + 1, -float(node.bound))
    for term in node.terms:
        lo, hi = boxes[term.role]
        ends = term.coef * np.stack([lo[:, term.component], hi[:, term.component]])
        value = value + ends.max(axis=0)[: horizon + 1]
    return value


def _children(node: Formula, boxes: Boxes, horizon: int, barred: Barred) -> np.ndarray:
    assert isinstance(node, And | Or)
    values = [upper_robustness(c, boxes, horizon, barred) for c in node.children]
    length = min(len(v) for v in values)
    stacked = np.stack([v[:length] for v in values])
    return stacked.min(axis=0) if isinstance(node, And) else stacked.max(axis=0)


def _at_least(node: Formula, boxes: Boxes, horizon: int, barred: Barred) -> np.ndarray:
    # the n-th largest of the options' bounds
    assert isinstance(node, AtLeast)
    values = [upper_robustness(o, boxes, horizon, barred) for o in node.options]
    length = min(len(v) for v in values)
    stacked = np.sort(np.stack([v[:length] for v in values]), axis=0)
    return stacked[len(values) - node.n]


def _windows(child: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Row ``k``: ``child[k+lo .. k+hi]``, for every ``k`` with ``k + hi < len(child)``."""
    if len(child) <= hi:
        return np.empty((0, hi - lo + 1))
    return sliding_window_view(child, hi - lo + 1)[lo : lo + len(child) - hi]


def _temporal(node: Formula, boxes: Boxes, horizon: int, barred: Barred) -> np.ndarray:
    assert isinstance(node, Always | Eventually)
    child = upper_robustness(node.child, boxes, horizon, barred)
    windows = _windows(child, node.interval.lo, node.interval.hi)
    return windows.min(axis=1) if isinstance(node, Always) else windows.max(axis=1)


def _until(node: Formula, boxes: Boxes, horizon: int, barred: Barred) -> np.ndarray:
    # max_{t in [a,b]} min(right(k+t), min of left over [k, k+t] (strict: [k, k+t)))
    assert isinstance(node, Until)
    left = upper_robustness(node.left, boxes, horizon, barred)
    right = upper_robustness(node.right, boxes, horizon, barred)
    lo, hi = node.interval.lo, node.interval.hi
    length = max(0, min(len(left), len(right)) - hi)
    prefix, best = np.full(length, np.inf), np.full(length, -np.inf)
    for t in range(hi + 1):
        if not node.strict:
            prefix = np.minimum(prefix, left[t : t + length])
        if t >= lo:
            best = np.maximum(best, np.minimum(right[t : t + length], prefix))
        if node.strict:
            prefix = np.minimum(prefix, left[t : t + length])
    return best


_EVALUATORS: dict[type, Callable[[Formula, Boxes, int, Barred], np.ndarray]] = {
    Predicate: _predicate,
    And: _children,
    Or: _children,
    Always: _temporal,
    Eventually: _temporal,
    Until: _until,
    AtLeast: _at_least,
}
