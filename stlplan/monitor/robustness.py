"""Quantitative semantics of lowered STL formulas, evaluated with numpy.

The monitor's arithmetic core. It reads a formula after :func:`stlplan.formula.normal.lower`
(only :class:`Predicate`, :class:`And`, :class:`Or`, :class:`Always`, :class:`Eventually`,
:class:`Until`, :class:`AtLeast`) and the states of the agents bound to its roles, and returns the robustness
``rho(k)`` at every step ``k`` where the formula can be decided inside the horizon, i.e.
``k + horizon(formula) <= H``. The formula holds at ``k`` iff ``rho(k) >= HOLDS_AT``
(:func:`stlplan.formula.boundary.holds`: a region's boundary is neither inside nor outside).

Each node type has one small evaluator in :data:`EVALUATORS`; an evaluator returns an array whose
index is ``k`` and whose length is ``H + 1 - horizon(node)``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from stlplan.errors import FormulaError
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
from stlplan.formula.tree import horizon as formula_horizon

Signals = Mapping[str, np.ndarray]
"""Role name to the bound agent's states, shape (H+1, n)."""

Evaluator = Callable[[Formula, Signals, int], np.ndarray]


def robustness(formula: Formula, signals: Signals, horizon: int) -> np.ndarray:
    """Robustness ``rho(k)`` of a lowered formula for ``k = 0 .. H - horizon(formula)``.

    Parameters
    ----------
    formula
        A lowered formula (see :func:`stlplan.formula.normal.lower`).
    signals
        Role name to the states ``x(0..H)`` of the agent bound to that role, shape (H+1, n).
    horizon
        The mission horizon ``H``.

    Returns
    -------
    numpy.ndarray
        Float array of length ``max(0, H + 1 - horizon(formula))``; entry ``k`` is ``rho(k)``.

    Raises
    ------
    FormulaError
        If the formula holds a node that lowering removes (``in``, ``dist``, ``!``, ...).
    """
    if formula_horizon(formula) > horizon:
        return np.empty(0)
    return _evaluate(formula, signals, horizon)


def _evaluate(formula: Formula, signals: Signals, horizon: int) -> np.ndarray:
    evaluator = EVALUATORS.get(type(formula))
    if evaluator is None:
        raise FormulaError(
            f"the monitor evaluates lowered formulas only; found a {type(formula).__name__} node"
        )
    return evaluator(formula, signals, horizon)


def _predicate(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # alpha(k) = sum_i coef_i * x_{role_i}(k)[component_i] - bound
    assert isinstance(node, Predicate)
    value = np.full(horizon + 1, -float(node.bound))
    for term in node.terms:
        value = (
            value
            + term.coef * np.asarray(signals[term.role], dtype=float)[: horizon + 1, term.component]
        )
    return value


def _children(node: And | Or | AtLeast, signals: Signals, horizon: int) -> np.ndarray:
    # children have different horizons: keep the steps where every child is defined
    kids = node.options if isinstance(node, AtLeast) else node.children
    values = [_evaluate(c, signals, horizon) for c in kids]
    length = min(len(v) for v in values)
    return np.stack([v[:length] for v in values])


def _and(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(and_i phi_i, k) = min_i rho(phi_i, k)
    assert isinstance(node, And)
    return np.min(_children(node, signals, horizon), axis=0)


def _or(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(or_i phi_i, k) = max_i rho(phi_i, k)
    assert isinstance(node, Or)
    return np.max(_children(node, signals, horizon), axis=0)


def _at_least(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(at least n of phi_1..phi_m, k) = the n-th largest of rho(phi_i, k)
    assert isinstance(node, AtLeast)
    values = np.sort(_children(node, signals, horizon), axis=0)
    return values[len(node.options) - node.n]


def _windows(child: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Row ``k`` holds ``child[k+lo .. k+hi]`` for every ``k`` with ``k + hi < len(child)``."""
    length = len(child) - hi
    return sliding_window_view(child, hi - lo + 1)[lo : lo + length]


def _always(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(G[a,b] phi, k) = min_{k' in [k+a, k+b]} rho(phi, k')
    assert isinstance(node, Always)
    child = _evaluate(node.child, signals, horizon)
    return np.min(_windows(child, node.interval.lo, node.interval.hi), axis=1)


def _eventually(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(F[a,b] phi, k) = max_{k' in [k+a, k+b]} rho(phi, k')
    assert isinstance(node, Eventually)
    child = _evaluate(node.child, signals, horizon)
    return np.max(_windows(child, node.interval.lo, node.interval.hi), axis=1)


def _until(node: Formula, signals: Signals, horizon: int) -> np.ndarray:
    # rho(l U[a,b] r, k) = max_{k' in [k+a, k+b]} min(rho(r, k'), min_{k'' in [k, k']} rho(l, k''))
    # rho(l U*[a,b] r, k): the same with k'' in [k, k') (an empty min is +inf)
    assert isinstance(node, Until)
    left = _evaluate(node.left, signals, horizon)
    right = _evaluate(node.right, signals, horizon)
    lo, hi = node.interval.lo, node.interval.hi
    length = min(len(left), len(right)) - hi
    prefix_min = np.full(length, np.inf)  # min of left over [k, k + t] (strict: [k, k + t))
    best = np.full(length, -np.inf)
    for t in range(hi + 1):
        if not node.strict:
            prefix_min = np.minimum(prefix_min, left[t : t + length])
        if t >= lo:
            best = np.maximum(best, np.minimum(right[t : t + length], prefix_min))
        if node.strict:
            prefix_min = np.minimum(prefix_min, left[t : t + length])
    return best


EVALUATORS: dict[type, Evaluator] = {
    Predicate: _predicate,
    And: _and,
    Or: _or,
    Always: _always,
    Eventually: _eventually,
    Until: _until,
    AtLeast: _at_least,
}
"""Node type to its evaluator ``(node, signals, H) -> rho`` (the dispatch table)."""
