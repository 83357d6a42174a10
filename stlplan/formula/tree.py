"""The formula tree: immutable nodes for the inner logic of tasks.

Surface atoms (``in``, ``dist``, linear inequalities, the team's ``count`` and ``visits``) come
from the parser; ``lower`` in :mod:`stlplan.formula.normal` turns them into :class:`Predicate`
half-spaces (and a count into :class:`AtLeast` over its agents' formulas), the only atoms the
encoder and the monitor see. Negation is written on atoms only; :func:`negate` pushes it there.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

from stlplan.errors import FormulaError

Comparison = Literal["<=", ">="]


@dataclass(frozen=True)
class Interval:
    """Inclusive integer step interval ``[lo, hi]`` with ``0 <= lo <= hi``."""

    lo: int
    hi: int

    def __post_init__(self) -> None:
        if self.lo < 0 or self.hi < self.lo:
            raise FormulaError(f"interval [{self.lo},{self.hi}] must satisfy 0 <= lo <= hi")


@dataclass(frozen=True)
class InRegion:
    """``in(role, region)``: the role's position lies in the named region."""

    role: str
    region: str


@dataclass(frozen=True)
class Distance:
    """``dist(left, right) <= radius`` (or ``>=``), infinity norm on positions."""

    left: str
    right: str
    op: Comparison
    radius: float


@dataclass(frozen=True)
class Term:
    """``coef * role.x[component]``: one term of a linear inequality."""

    coef: float
    role: str
    component: int


@dataclass(frozen=True)
class Linear:
    """``sum(terms) <= bound`` (or ``>=``) over role state components."""

    terms: tuple[Term, ...]
    op: Comparison
    bound: float


@dataclass(frozen=True)
class Who:
    """The agents a count ranges over: those with every capability listed (``camera & aerial``),
    with at least one of them (``ground | aerial``, ``any_of``), or every agent (none listed)."""

    capabilities: tuple[str, ...] = ()
    any_of: bool = False

    def admits(self, capabilities: frozenset[str]) -> bool:
        """Whether an agent with ``capabilities`` is counted."""
        if not self.capabilities:
            return True
        if self.any_of:
            return not capabilities.isdisjoint(self.capabilities)
        return capabilities.issuperset(self.capabilities)

    def text(self) -> str:
        """The selector as written: ``camera``, ``UV & IR``, ``ground | aerial``."""
        return (" | " if self.any_of else " & ").join(self.capabilities)


@dataclass(frozen=True)
class Count:
    """``count(region, who) >= n`` (or ``<=``): how many of the agents ``who`` admits are in
    the region at the step (the team's agents, not a role's)."""

    region: str
    who: Who
    op: Comparison
    n: int


@dataclass(frozen=True)
class Visits:
    """``visits[a,b](region, who) >= n`` (or ``<=``): how many times agents ``who`` admits
    enter the region at steps ``k+a..k+b`` (outside at ``t-1``, inside at ``t``; inside at
    ``k+a`` counts as an entry)."""

    interval: Interval
    region: str
    who: Who
    op: Comparison
    n: int


@dataclass(frozen=True)
class Predicate:
    """Core half-space atom ``sum(coef * x_role[component]) - bound >= 0``.

    Produced by lowering; its value is the predicate function alpha of the paper.
    """

    terms: tuple[Term, ...]
    bound: float


Atom = InRegion | Distance | Linear | Count | Visits | Predicate

TEAM_ROLE = "@"
"""Prefix of the roles a lowered count gives its agents (``@uv1``): no written role starts so."""


def team_role(agent: str) -> str:
    """The role under which a lowered count reads ``agent``'s states."""
    return TEAM_ROLE + agent


def is_team_role(role: str) -> bool:
    """Whether ``role`` is a count's agent (:func:`team_role`), not a written role."""
    return role.startswith(TEAM_ROLE)


@dataclass(frozen=True)
class Not:
    """Negation of an atom (negation is never written above an atom)."""

    atom: Atom


@dataclass(frozen=True)
class And:
    """Conjunction of two or more children."""

    children: tuple[Formula, ...]


@dataclass(frozen=True)
class Or:
    """Disjunction of two or more children."""

    children: tuple[Formula, ...]


@dataclass(frozen=True)
class Always:
    """``G[a,b] child``: child holds at every step of ``[k+a, k+b]``."""

    interval: Interval
    child: Formula


@dataclass(frozen=True)
class Eventually:
    """``F[a,b] child``: child holds at some step of ``[k+a, k+b]``."""

    interval: Interval
    child: Formula


@dataclass(frozen=True)
class Until:
    """``left U[a,b] right``: some ``k'`` in ``[k+a, k+b]`` has right, and left on ``[k, k']``.

    The paper's until holds ``left`` up to and including ``k'``; the strict until ``U*`` (stlpy's
    and RTAMT's) holds it on ``[k, k')`` only, so ``right`` at ``k`` alone satisfies it when
    ``a = 0``.
    """

    interval: Interval
    left: Formula
    right: Formula
    strict: bool = False
    """``left`` on ``[k, k')`` (``U*``) instead of ``[k, k']`` (``U``)."""

    def left_steps(self, k: int, t: int) -> range:
        """The steps at which ``left`` must hold when ``right`` holds at ``t`` (from ``k``)."""
        return range(k, t if self.strict else t + 1)


@dataclass(frozen=True)
class AtLeast:
    """At least ``n`` of ``options`` hold (a lowered count: one option per agent, or per agent
    and entry step). Its robustness is the ``n``-th largest of the options'."""

    n: int
    options: tuple[Formula, ...]


Formula = (
    InRegion
    | Distance
    | Linear
    | Count
    | Visits
    | Predicate
    | Not
    | And
    | Or
    | Always
    | Eventually
    | Until
    | AtLeast
)
ATOM_TYPES = (InRegion, Distance, Linear, Count, Visits, Predicate)
TEAM_ATOMS = (Count, Visits)


def negate(formula: Formula) -> Formula:
    """Return the negation of ``formula`` with ``!`` pushed down to the atoms."""
    if isinstance(formula, ATOM_TYPES):
        return Not(formula)
    if isinstance(formula, Not):
        return formula.atom
    if isinstance(formula, And):
        return Or(tuple(negate(c) for c in formula.children))
    if isinstance(formula, Or):
        return And(tuple(negate(c) for c in formula.children))
    if isinstance(formula, Always):
        return Eventually(formula.interval, negate(formula.child))
    if isinstance(formula, Eventually):
        return Always(formula.interval, negate(formula.child))
    raise FormulaError("negation of an until formula is not supported; rewrite it without '!'")


def children(formula: Formula) -> tuple[Formula, ...]:
    """The direct subformulas of ``formula`` (empty for atoms)."""
    if isinstance(formula, (And, Or)):
        return formula.children
    if isinstance(formula, (Always, Eventually)):
        return (formula.child,)
    if isinstance(formula, Until):
        return (formula.left, formula.right)
    if isinstance(formula, AtLeast):
        return formula.options
    if isinstance(formula, Not):
        return (formula.atom,)
    return ()


def atoms(formula: Formula) -> tuple[Atom, ...]:
    """Every atom of ``formula``, left to right."""
    if isinstance(formula, ATOM_TYPES):
        return (formula,)
    return tuple(a for c in children(formula) for a in atoms(c))


def atom_roles(atom: Atom) -> tuple[str, ...]:
    """The roles an atom mentions, in order of appearance."""
    if isinstance(atom, InRegion):
        return (atom.role,)
    if isinstance(atom, Distance):
        return (atom.left, atom.right)
    if isinstance(atom, TEAM_ATOMS):
        return ()
    return tuple(t.role for t in atom.terms)


def roles(formula: Formula) -> tuple[str, ...]:
    """The roles of ``formula`` in order of first appearance, without repeats."""
    seen: dict[str, None] = {}
    for atom in atoms(formula):
        for role in atom_roles(atom):
            seen.setdefault(role, None)
    return tuple(seen)


def regions(formula: Formula) -> tuple[str, ...]:
    """The region names ``formula`` refers to, without repeats."""
    kinds = (InRegion, *TEAM_ATOMS)
    return tuple(dict.fromkeys(a.region for a in atoms(formula) if isinstance(a, kinds)))


def team_atoms(formula: Formula) -> tuple[Count | Visits, ...]:
    """The ``count`` and ``visits`` atoms of ``formula``, left to right."""
    return tuple(a for a in atoms(formula) if isinstance(a, TEAM_ATOMS))


def horizon(formula: Formula) -> int:
    """Steps past ``k`` that deciding ``formula`` at ``k`` needs (0 for an atom)."""
    if isinstance(formula, (Always, Eventually)):
        return formula.interval.hi + horizon(formula.child)
    if isinstance(formula, Until):
        return formula.interval.hi + max(horizon(formula.left), horizon(formula.right))
    if isinstance(formula, Visits):
        return formula.interval.hi
    return max((horizon(c) for c in children(formula)), default=0)


def step_parts(formula: Formula, k: int = 0) -> Iterator[tuple[Formula, int]]:
    """``formula`` at step ``k`` as the conjunction of its parts: ``G`` and ``and`` unrolled.

    ``G[a,b] phi`` at ``k`` yields ``phi`` at ``k+a..k+b``; ``and`` yields each child; any other
    node is yielded whole with its step.
    """
    if isinstance(formula, And):
        for child in formula.children:
            yield from step_parts(child, k)
    elif isinstance(formula, Always):
        for t in range(k + formula.interval.lo, k + formula.interval.hi + 1):
            yield from step_parts(formula.child, t)
    else:
        yield formula, k
