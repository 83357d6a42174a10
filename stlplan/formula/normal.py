"""Lowering surface atoms to half-space predicates: the core tree the encoder and monitor read.

After :func:`lower`, a formula holds only :class:`Predicate`, :class:`And`, :class:`Or`,
:class:`Always`, :class:`Eventually` and :class:`Until` (no ``Not``: a negated half-space is the
opposite half-space, boundary included, so that robustness ``>= 0`` means satisfied both ways).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from stlplan.formula.tree import (
    Always,
    And,
    Atom,
    Distance,
    Eventually,
    Formula,
    InRegion,
    Linear,
    Not,
    Or,
    Predicate,
    Term,
    Until,
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


def _lower_atom(
    atom: Atom,
    regions: Mapping[str, HalfSpaces],
    positions: Mapping[str, tuple[int, int]],
) -> Formula:
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
    assert isinstance(formula, Or)
    return And(tuple(_negate_lowered(c) for c in formula.children))


def lower(
    formula: Formula,
    regions: Mapping[str, HalfSpaces],
    positions: Mapping[str, tuple[int, int]],
) -> Formula:
    """Rewrite every atom of ``formula`` as half-space predicates.

    Parameters
    ----------
    regions
        Region name to ``(G, h)`` with unit-norm rows.
    positions
        Role name to the two state components that are that role's planar position.
    """
    if isinstance(formula, (InRegion, Distance, Linear, Predicate)):
        return _lower_atom(formula, regions, positions)
    if isinstance(formula, Not):
        return _negate_lowered(_lower_atom(formula.atom, regions, positions))
    if isinstance(formula, And):
        return And(tuple(lower(c, regions, positions) for c in formula.children))
    if isinstance(formula, Or):
        return Or(tuple(lower(c, regions, positions) for c in formula.children))
    if isinstance(formula, Always):
        return Always(formula.interval, lower(formula.child, regions, positions))
    if isinstance(formula, Eventually):
        return Eventually(formula.interval, lower(formula.child, regions, positions))
    left = lower(formula.left, regions, positions)
    right = lower(formula.right, regions, positions)
    return Until(formula.interval, left, right, formula.strict)
