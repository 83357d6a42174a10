"""MILP encoding of lowered STL (Kurtz & Lin, the paper's reference on fewer binaries).

Every subformula ``phi`` at step ``k`` under a role binding gets a continuous indicator
``z in [0, 1]`` whose value 1 *enforces* ``(S, k) |= phi`` (a value below 1 enforces nothing):

* predicate ``alpha(x) - r >= -M (1 - z)``, with ``r`` the spatial margin and ``M`` from interval
  arithmetic on the box of states each agent can reach at ``k`` (no binaries);
* conjunction ``z <= z_i`` for every child (no binaries);
* disjunction: fresh ``w_i in [0, 1]`` with ``w_i <= z_i`` and ``{1 - z, w_1..w_n}`` SOS1
  (logarithmic: ``ceil(log2(n + 1))`` binaries). The fresh ``w_i`` keep the encoding sound when a
  child's indicator is shared with other parents (memoized subformulas);
* ``G``, ``F`` and ``U`` are conjunctions and disjunctions over time offsets;
* at least ``n`` of ``m`` options (a count): a disjunction when ``n = 1``, a conjunction when
  ``n = m``, else one binary ``b_i <= z_i`` per option and ``sum b_i >= n z``.

:func:`require` enforces a formula outright (constraints, single-group tasks): conjunctions become
separate requirements, a disjunction needs no "off" slot, and a predicate needs no big-M.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from pyomo.environ import Block

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
    atoms,
    roles,
)
from stlplan.planner.config import Encoding
from stlplan.planner.encoding.ledger import Ledger
from stlplan.planner.encoding.sos1 import sos1
from stlplan.planner.tolerances import ROUND_OFF

Boxes = Mapping[str, tuple[np.ndarray, np.ndarray]]
"""Agent name to ``(lo, hi)`` state bounds per step, each of shape (H+1, n)."""


@dataclass(frozen=True, eq=False)
class StlContext:
    """Where and how formulas are encoded.

    Parameters
    ----------
    block
        Holds ``indicators`` (VarList in [0, 1]) and ``rows`` (ConstraintList).
    sos
        The SOS1 block (:func:`stlplan.planner.encoding.sos1.sos1_block`).
    states
        Indexed variable ``x[agent, k, i]``.
    boxes
        Agent name to ``(lo, hi)``, arrays of shape (H+1, n): the states reachable at each step
        (see :func:`stlplan.analysis.reach.reachable_boxes`).
    horizon
        ``H``: states exist for ``k = 0..H``.
    margin
        ``r``: a number, or a variable when the margin is maximized.
    margin_ceiling
        Upper bound of ``r`` (equal to ``r`` when it is a number).
    encoding
        ``"log"`` or ``"standard"`` SOS1.
    binding
        Role to agent name for the formulas being encoded.
    memo
        ``(node, k, binding)`` to indicator, shared by every binding.
    by_roles_read
        Key the memo on the agents of the roles a subformula reads, not on the whole binding
        (``model.shared_subformulas``).
    ledger
        Every predicate placed (shared by every binding).
    tightening
        How much a predicate's margin is raised at a step (:meth:`Problem.tightening`).
    """

    block: Block
    sos: Block
    states: Any
    boxes: Boxes
    horizon: int
    margin: Any
    margin_ceiling: float
    encoding: Encoding = "standard"
    binding: Mapping[str, str] = field(default_factory=dict)
    memo: dict[tuple[Any, ...], Any] = field(default_factory=dict)
    ledger: Ledger = field(default_factory=Ledger)
    tightening: Callable[[Predicate, int], float] = field(default=lambda node, k: 0.0)
    by_roles_read: bool = True

    def bound(self, binding: Mapping[str, str]) -> StlContext:
        """The same context with roles bound to agents by ``binding`` (memo shared)."""
        return replace(self, binding=dict(binding))


def indicator(ctx: StlContext) -> Any:
    """A new continuous indicator ``z in [0, 1]``."""
    return ctx.block.indicators.add()


def conjunction(ctx: StlContext, children: Sequence[Any]) -> Any:
    """``z <= z_i`` for every child: ``z = 1`` enforces every child (a single child is returned)."""
    if len(children) == 1:
        return children[0]
    z = indicator(ctx)
    for child in children:
        ctx.block.rows.add(z <= child)
    ctx.ledger.conjunctions.append((z, list(children)))
    return z


def choice(ctx: StlContext, children: Sequence[Any], owner: Any = None) -> list[Any]:
    """SOS1 ``{1 - owner, w_1..w_n}`` with fresh ``w_i <= z_i``; returns the ``w_i``.

    Without ``owner`` the vector is ``{w_1..w_n}``: exactly one child is enforced.
    """
    chosen = [indicator(ctx) for _ in children]
    for w, child in zip(chosen, children, strict=True):
        ctx.block.rows.add(w <= child)
    sos1(ctx.sos, chosen if owner is None else [1 - owner, *chosen], ctx.encoding)
    ctx.ledger.choices.append((owner, list(children), chosen))
    return chosen


def disjunction(ctx: StlContext, children: Sequence[Any]) -> Any:
    """``{1 - z, w_1..w_n}`` SOS1 with ``w_i <= z_i``: ``z = 1`` enforces one child."""
    if len(children) == 1:
        return children[0]
    z = indicator(ctx)
    choice(ctx, children, owner=z)
    return z


def predicate_range(
    node: Predicate, k: int, binding: Mapping[str, str], boxes: Boxes
) -> tuple[float, float]:
    """Interval ``[alpha_lo, alpha_hi]`` of ``alpha = sum(c x(k)) - b`` over the boxes at ``k``.

    ``alpha_lo = sum_i min(c_i lo_i, c_i hi_i) - b`` and ``alpha_hi`` likewise with max.
    """
    lo = hi = -node.bound
    for term in node.terms:
        box_lo, box_hi = boxes[binding[term.role]]
        x_lo, x_hi = float(box_lo[k, term.component]), float(box_hi[k, term.component])
        ends = (term.coef * x_lo, term.coef * x_hi)
        lo, hi = lo + min(ends), hi + max(ends)
    return lo, hi


def alpha(node: Predicate, k: int, binding: Mapping[str, str], states: Any) -> Any:
    """``alpha(x(k)) = sum(coef * x_role[k, component]) - bound`` over ``states[agent, k, i]``."""
    return sum(t.coef * states[binding[t.role], k, t.component] for t in node.terms) - node.bound


def predicate_value(node: Predicate, k: int, ctx: StlContext) -> Any:
    """``alpha(x(k))`` of ``node`` under the context's binding, as a Pyomo expression."""
    if k > ctx.horizon:
        raise FormulaError(f"a predicate is needed at step {k}, past the horizon {ctx.horizon}")
    return alpha(node, k, ctx.binding, ctx.states) - ctx.tightening(node, k)


def big_m_of(node: Predicate, k: int, ctx: StlContext) -> float:
    """``M = r_max - alpha_lo`` of ``node`` at ``k`` (its value tightened as it is enforced);
    0 when it is round-off (a state fixed by the executed past, on the predicate's boundary):
    HiGHS drops such a coefficient anyway, and says so."""
    lo, _ = predicate_range(node, k, ctx.binding, ctx.boxes)
    big_m = ctx.margin_ceiling - lo + ctx.tightening(node, k)
    return big_m if big_m > ROUND_OFF else 0.0


def encode_predicate(node: Predicate, k: int, ctx: StlContext) -> Any:
    # alpha(x(k)) - r >= -M (1 - z),  M = r_max - alpha_lo
    z = indicator(ctx)
    big_m = big_m_of(node, k, ctx)
    ctx.block.rows.add(predicate_value(node, k, ctx) - ctx.margin >= -big_m * (1 - z))
    ctx.ledger.guarded.append((z, (node, k, ctx.binding)))
    return z


def encode_and(node: And, k: int, ctx: StlContext) -> Any:
    # z <= z_i for every child
    return conjunction(ctx, [encode(c, k, ctx) for c in node.children])


def encode_or(node: Or, k: int, ctx: StlContext) -> Any:
    # {1 - z, w_1..w_n} in SOS1, w_i <= z_i
    return disjunction(ctx, [encode(c, k, ctx) for c in node.children])


def encode_always(node: Always, k: int, ctx: StlContext) -> Any:
    # G[a,b] phi at k  =  AND_{t in [k+a, k+b]} phi at t
    lo, hi = node.interval.lo, node.interval.hi
    return conjunction(ctx, [encode(node.child, t, ctx) for t in range(k + lo, k + hi + 1)])


def encode_eventually(node: Eventually, k: int, ctx: StlContext) -> Any:
    # F[a,b] phi at k  =  OR_{t in [k+a, k+b]} phi at t
    lo, hi = node.interval.lo, node.interval.hi
    return disjunction(ctx, [encode(node.child, t, ctx) for t in range(k + lo, k + hi + 1)])


def until_terms(node: Until, k: int, ctx: StlContext) -> list[Any]:
    """For each ``k'`` in ``[k+a, k+b]``: the indicator of ``right(k') and left(k..k')``
    (``left(k..k'-1)`` for the strict ``U*``)."""
    terms = []
    for t in range(k + node.interval.lo, k + node.interval.hi + 1):
        lefts = [encode(node.left, s, ctx) for s in node.left_steps(k, t)]
        terms.append(conjunction(ctx, [encode(node.right, t, ctx), *lefts]))
    return terms


def encode_until(node: Until, k: int, ctx: StlContext) -> Any:
    # l U[a,b] r at k  =  OR_{k' in [k+a, k+b]} (r at k' AND_{k'' in [k, k']} l at k'')
    # l U*[a,b] r at k =  OR_{k' in [k+a, k+b]} (r at k' AND_{k'' in [k, k')} l at k'')
    return disjunction(ctx, until_terms(node, k, ctx))


def at_least(ctx: StlContext, n: int, children: Sequence[Any], owner: Any = None) -> None:
    """``sum b_i >= n owner`` with binaries ``b_i <= z_i``: ``owner = 1`` (or no owner)
    enforces ``n`` of ``children``."""
    chosen = [ctx.sos.binaries.add() for _ in children]
    for b, child in zip(chosen, children, strict=True):
        ctx.block.rows.add(b <= child)
    ctx.block.rows.add(sum(chosen) >= (n if owner is None else n * owner))


def encode_at_least(node: AtLeast, k: int, ctx: StlContext) -> Any:
    # n = 1: a disjunction; n = m: a conjunction; else sum b_i >= n z, b_i <= z_i
    children = [encode(o, k, ctx) for o in node.options]
    if node.n <= 1:
        return disjunction(ctx, children)
    if node.n >= len(children):
        return conjunction(ctx, children)
    z = indicator(ctx)
    at_least(ctx, node.n, children, owner=z)
    return z


ENCODERS: dict[type, Callable[[Any, int, StlContext], Any]] = {
    Predicate: encode_predicate,
    And: encode_and,
    Or: encode_or,
    Always: encode_always,
    Eventually: encode_eventually,
    Until: encode_until,
    AtLeast: encode_at_least,
}


@functools.lru_cache(maxsize=4096)
def _roles_read(node: Formula) -> frozenset[str]:
    return frozenset(roles(node))


def encode(node: Formula, k: int, ctx: StlContext) -> Any:
    """Indicator ``z`` of the lowered ``node`` at step ``k``: ``z = 1`` enforces ``(S, k) |= node``.

    Memoized on ``(node, k)`` and the agents bound to the roles ``node`` reads, so a subformula
    shared by several parents, by several groups holding the same element, or by several
    elements that give its roles the same agents (``in(p, B)`` in every element with ``p = uv1``)
    is encoded once. Without ``ctx.by_roles_read``, on the whole binding: elements never share.
    """
    used = _roles_read(node) if ctx.by_roles_read else ctx.binding.keys()
    key = (node, k, tuple(sorted((r, a) for r, a in ctx.binding.items() if r in used)))
    found = ctx.memo.get(key)
    if found is not None:
        return found
    encoder = ENCODERS.get(type(node))
    if encoder is None:
        raise FormulaError(f"cannot encode {type(node).__name__}: lower the formula first")
    z = encoder(node, k, ctx)
    ctx.memo[key] = z
    return z


def require_predicate(node: Predicate, k: int, ctx: StlContext) -> None:
    # alpha(x(k)) - r >= 0: no indicator, no big-M
    ctx.block.rows.add(predicate_value(node, k, ctx) - ctx.margin >= 0)
    ctx.ledger.required.append((node, k, ctx.binding))


def require_and(node: And, k: int, ctx: StlContext) -> None:
    # every child required
    for child in node.children:
        require(child, k, ctx)


def require_always(node: Always, k: int, ctx: StlContext) -> None:
    # child required at every t in [k+a, k+b]
    for t in range(k + node.interval.lo, k + node.interval.hi + 1):
        require(node.child, t, ctx)


def require_or(node: Or, k: int, ctx: StlContext) -> None:
    # {w_1..w_n} in SOS1, w_i <= z_i: exactly one child enforced
    require_one(ctx, [encode(c, k, ctx) for c in node.children])


def require_eventually(node: Eventually, k: int, ctx: StlContext) -> None:
    # {w_a..w_b} in SOS1, w_t <= z(child, t): the child enforced at one t in [k+a, k+b]
    span = range(k + node.interval.lo, k + node.interval.hi + 1)
    require_one(ctx, [encode(node.child, t, ctx) for t in span])


def require_until(node: Until, k: int, ctx: StlContext) -> None:
    # one k' in [k+a, k+b] with right(k') and left(k..k') enforced
    require_one(ctx, until_terms(node, k, ctx))


def require_at_least(node: AtLeast, k: int, ctx: StlContext) -> None:
    # n of the options enforced: one of them (SOS1), all of them, or sum b_i >= n
    if node.n >= len(node.options):
        for option in node.options:
            require(option, k, ctx)
        return
    children = [encode(o, k, ctx) for o in node.options]
    if node.n <= 1:
        require_one(ctx, children)
    else:
        at_least(ctx, node.n, children)


def require_one(ctx: StlContext, children: Sequence[Any]) -> None:
    """Exactly one of ``children`` enforced: ``z_1 >= 1`` alone, else SOS1 ``{w_1..w_n}``."""
    if len(children) == 1:
        ctx.block.rows.add(children[0] >= 1)
    else:
        choice(ctx, children)


REQUIREMENTS: dict[type, Callable[[Any, int, StlContext], None]] = {
    Predicate: require_predicate,
    And: require_and,
    Or: require_or,
    Always: require_always,
    Eventually: require_eventually,
    Until: require_until,
    AtLeast: require_at_least,
}


def require(node: Formula, k: int, ctx: StlContext) -> None:
    """Enforce ``(S, k) |= node`` outright: the indicator fixed at 1, simplified.

    Conjunctions (``And``, ``G``) split into requirements, a predicate is ``alpha - r >= 0`` with no
    big-M, and a disjunction (``Or``, ``F``, ``U``) is an SOS1 ``{w_1..w_n}`` with no "off" slot.
    """
    requirement = REQUIREMENTS.get(type(node))
    if requirement is None:
        raise FormulaError(f"cannot encode {type(node).__name__}: lower the formula first")
    requirement(node, k, ctx)


def margin_ceiling(
    formulas: Sequence[tuple[Formula, Mapping[str, str]]], boxes: Boxes, horizon: int
) -> float:
    """Largest value any predicate of ``formulas`` can take at any step (at least 0).

    No enforced predicate holds with a margin above it, so it bounds a maximized margin ``r``.
    """
    best = 0.0
    for formula, binding in formulas:
        for atom in atoms(formula):
            if isinstance(atom, Predicate):
                highs = (predicate_range(atom, k, binding, boxes)[1] for k in range(horizon + 1))
                best = max(best, *highs)
    return best
