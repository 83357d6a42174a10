"""Lowering surface atoms to half-space predicates: the core tree the encoder and monitor read.

After :func:`lower`, a formula holds only :class:`Predicate`, :class:`And`, :class:`Or`,
:class:`Always`, :class:`Eventually`, :class:`Until` and :class:`AtLeast` (no ``Not``: a negated
half-space is the opposite half-space, boundary included, so that robustness ``>= 0`` means
satisfied both ways).

A count reads the team: ``count(R, who) >= n`` is ``AtLeast(n, in(@a, R) for each agent a who
admits)``, under the roles :func:`stlplan.formula.tree.team_role` gives those agents; ``<= n`` is
its negation, at least ``m - n`` of them outside ``R``. ``visits[lo,hi](R, who) >= n`` is
``AtLeast(n, ...)`` over one entry per agent and step ``t`` of the window: ``!in(@a, R)`` at
``t - 1`` and ``in(@a, R)`` at ``t`` (at ``t = lo`` inside alone).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from stlplan.formula.tree import (
    Always,
    And,
    AtLeast,
    Atom,
    Count,
    Distance,
    Eventually,
    Formula,
    InRegion,
    Interval,
    Linear,
    Not,
    Or,
    Predicate,
    Term,
    Until,
    Visits,
    Who,
    is_team_role,
)

HalfSpaces = tuple[Sequence[Sequence[float]], Sequence[float]]
"""A convex region ``{z : G z <= h}`` as ``(G, h)`` with unit-norm rows."""


def _flip(p: Predicate) -> Predicate:
    # not(a.x - b >= 0)  ->  -a.x + b >= 0
    return Predicate(tuple(Term(-t.coef, t.role, t.component) for t in p.terms), -p.bound)


def _inside(role: str, region: HalfSpaces, position: tuple[int, int]) -> And:
    # z in {G z <= h}  <=>  for every row i: -G_i z + h_i >= 0
    rows, rhs = region
    preds = []
    for g, h in zip(rows, rhs, strict=False):
        terms = tuple(
            Term(-float(c), role, comp) for c, comp in zip(g, position, strict=False) if c != 0
        )
        preds.append(Predicate(terms, -float(h)))
    return And(tuple(preds))


def _near(atom: Distance, positions: Mapping[str, tuple[int, int]]) -> And:
    # ||z_l - z_r||_inf <= r  <=>  for each axis, r - (z_l - z_r) >= 0 and r + (z_l - z_r) >= 0
    preds = []
    for left, right in zip(positions[atom.left], positions[atom.right], strict=False):
        diff = (Term(1.0, atom.left, left), Term(-1.0, atom.right, right))
        preds.append(_flip(Predicate(diff, atom.radius)))
        preds.append(Predicate(diff, -atom.radius))
    return And(tuple(preds))


def _counted(
    who: Who,
    positions: Mapping[str, tuple[int, int]],
    capabilities: Mapping[str, frozenset[str]],
) -> list[str]:
    """The team roles of the bound agents ``who`` admits, in the binding's order."""
    return [r for r in positions if is_team_role(r) and who.admits(capabilities[r])]


def _at(step: int, formula: Formula) -> Formula:
    # phi at k + step: F[step, step] phi (phi itself at step 0)
    return formula if step == 0 else Eventually(Interval(step, step), formula)


def _entries(atom: Visits, insides: Sequence[Formula]) -> list[Formula]:
    lo, hi = atom.interval.lo, atom.interval.hi
    options = []
    for inside in insides:
        options.append(_at(lo, inside))
        outside = _negate_lowered(inside)
        options += [And((_at(t - 1, outside), _at(t, inside))) for t in range(lo + 1, hi + 1)]
    return options


def _lower_count(
    atom: Count | Visits,
    regions: Mapping[str, HalfSpaces],
    positions: Mapping[str, tuple[int, int]],
    capabilities: Mapping[str, frozenset[str]],
) -> AtLeast:
    agents = _counted(atom.who, positions, capabilities)
    insides: list[Formula] = [_inside(r, regions[atom.region], positions[r]) for r in agents]
    options = _entries(atom, insides) if isinstance(atom, Visits) else insides
    if atom.op == ">=":
        return AtLeast(atom.n, tuple(options))
    # at most n of them: at least (m - n) of their negations
    return AtLeast(len(options) - atom.n, tuple(_negate_lowered(o) for o in options))


def _lower_atom(
    atom: Atom,
    regions: Mapping[str, HalfSpaces],
    positions: Mapping[str, tuple[int, int]],
    capabilities: Mapping[str, frozenset[str]],
) -> Formula:
    if isinstance(atom, (Count, Visits)):
        return _lower_count(atom, regions, positions, capabilities)
    if isinstance(atom, InRegion):
        return _inside(atom.role, regions[atom.region], positions[atom.role])
    if isinstance(atom, Distance):
        near = _near(atom, positions)
        if atom.op == "<=":
            return near
        return Or(tuple(_flip(p) for p in near.children if isinstance(p, Predicate)))
    if isinstance(atom, Linear):
        if atom.op == ">=":
            return Predicate(atom.terms, atom.bound)
        return _flip(Predicate(atom.terms, atom.bound))
    return atom


def _negate_lowered(formula: Formula) -> Formula:
    if isinstance(formula, Predicate):
        return _flip(formula)
    if isinstance(formula, And):
        return Or(tuple(_negate_lowered(c) for c in formula.children))
    if isinstance(formula, Or):
        return And(tuple(_negate_lowered(c) for c in formula.children))
    if isinstance(formula, Always):
        return Eventually(formula.interval, _negate_lowered(formula.child))
    if isinstance(formula, Eventually):
        return Always(formula.interval, _negate_lowered(formula.child))
    # fewer than n of m hold  <=>  at least m - n + 1 of their negations hold
    assert isinstance(formula, AtLeast)
    negated = tuple(_negate_lowered(o) for o in formula.options)
    return AtLeast(len(negated) - formula.n + 1, negated)


def lower(
    formula: Formula,
    regions: Mapping[str, HalfSpaces],
    positions: Mapping[str, tuple[int, int]],
    capabilities: Mapping[str, frozenset[str]] | None = None,
) -> Formula:
    """Rewrite every atom of ``formula`` as half-space predicates.

    Parameters
    ----------
    regions
        Region name to ``(G, h)`` with unit-norm rows.
    positions
        Role name to the two state components that are that role's planar position (the team
        roles a count reads included).
    capabilities
        Team role to its agent's capabilities (needed when ``formula`` counts).
    """
    caps = capabilities or {}

    def down(node: Formula) -> Formula:
        return lower(node, regions, positions, caps)

    if isinstance(formula, (InRegion, Distance, Linear, Count, Visits, Predicate)):
        return _lower_atom(formula, regions, positions, caps)
    if isinstance(formula, Not):
        return _negate_lowered(_lower_atom(formula.atom, regions, positions, caps))
    if isinstance(formula, And):
        return And(tuple(down(c) for c in formula.children))
    if isinstance(formula, Or):
        return Or(tuple(down(c) for c in formula.children))
    if isinstance(formula, Always):
        return Always(formula.interval, down(formula.child))
    if isinstance(formula, Eventually):
        return Eventually(formula.interval, down(formula.child))
    if isinstance(formula, AtLeast):
        return AtLeast(formula.n, tuple(down(o) for o in formula.options))
    assert isinstance(formula, Until)
    return Until(formula.interval, down(formula.left), down(formula.right), formula.strict)
