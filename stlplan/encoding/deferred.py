"""Step requirements that may be left out of the MILP until a plan violates them (lazy rows).

Obstacle avoidance (``G[0,H] !in(p, Obs)``) and pairwise separation split into one requirement per
step, each a disjunction of half-planes:

    R(k):  OR_i  alpha_i(x(k)) - r >= 0,

with ``alpha_i`` linear in the states of the bound agents and ``r`` the spatial margin. Most of them
never bind: an agent rarely comes near the obstacle or another agent. The lazy loop
(:mod:`stlplan.lazy`) solves without them, finds those the plan violates with numpy, adds exactly
those (encoded as if they had been there from the start), and solves again. When a plan violates
none, it satisfies every requirement of the full problem and its objective bound came from a
relaxation of that problem, so it is the full problem's optimum.

A requirement that one of its half-planes meets at every reachable state (the interval bound of
:func:`stlplan.encoding.stl.predicate_range` over the reachable boxes) is dropped: it cannot bind.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from stlplan.encoding.stl import Boxes, Enforced, predicate_range
from stlplan.encoding.tasks import separation_formula
from stlplan.formula.tree import Always, And, Formula, Or, Predicate
from stlplan.problem import Problem

SEPARATION = "separation"
"""Source name of the pairwise separation requirements."""


@dataclass(frozen=True, eq=False)
class Requirement:
    """``OR_i alpha_i(x(k)) - r >= 0`` at step ``k`` under ``binding`` (a single ``alpha`` too).

    Attributes
    ----------
    formula
        A lowered :class:`Predicate` or an :class:`Or` of predicates.
    k
        The step.
    binding
        Role to agent name.
    source
        Name of the constraint it comes from, or :data:`SEPARATION`.
    """

    formula: Formula
    k: int
    binding: Mapping[str, str]
    source: str

    @property
    def alternatives(self) -> tuple[Predicate, ...]:
        """The half-planes ``alpha_i`` of the disjunction."""
        if isinstance(self.formula, Predicate):
            return (self.formula,)
        assert isinstance(self.formula, Or)
        return tuple(c for c in self.formula.children if isinstance(c, Predicate))

    @property
    def family(self) -> tuple[str, tuple[tuple[str, str], ...]]:
        """``(source, binding)``: requirements of one agent (or pair) at different steps."""
        return self.source, tuple(sorted(self.binding.items()))

    def options(self) -> list[Enforced]:
        """Each half-plane as an enforceable predicate ``(alpha_i, k, binding)``."""
        return [(alt, self.k, self.binding) for alt in self.alternatives]


def _is_step_disjunction(formula: Formula) -> bool:
    if isinstance(formula, Predicate):
        return True
    return isinstance(formula, Or) and all(isinstance(c, Predicate) for c in formula.children)


def split_steps(formula: Formula, k: int) -> Iterator[tuple[Formula, int]]:
    """``formula`` at ``k`` as the conjunction of its parts: ``G`` and ``and`` are unrolled.

    ``G[a,b] phi`` at ``k`` yields ``phi`` at ``k+a..k+b``; ``and`` yields each child; any other
    node is yielded whole.
    """
    if isinstance(formula, And):
        for child in formula.children:
            yield from split_steps(child, k)
    elif isinstance(formula, Always):
        for t in range(k + formula.interval.lo, k + formula.interval.hi + 1):
            yield from split_steps(formula.child, t)
    else:
        yield formula, k


def always_met(requirement: Requirement, boxes: Boxes, margin_ceiling: float) -> bool:
    """Whether some ``alpha_i`` exceeds every admissible margin on the whole reachable box."""
    return any(
        predicate_range(alt, requirement.k, requirement.binding, boxes)[0] >= margin_ceiling
        for alt in requirement.alternatives
    )


@dataclass(frozen=True, eq=False)
class Deferral:
    """The constraints and separation of a problem, split into lazy and eager parts.

    Attributes
    ----------
    lazy
        Step requirements the lazy loop may add later.
    eager
        ``(formula, k, binding)`` parts with temporal structure below a disjunction, encoded at
        once.
    dropped
        How many step requirements reachability proves (never encoded).
    """

    lazy: tuple[Requirement, ...]
    eager: tuple[tuple[Formula, int, Mapping[str, str]], ...]
    dropped: int


def _all_parts(problem: Problem) -> Iterator[tuple[Formula, int, Mapping[str, str], str]]:
    """Every constraint (at step 0) and separation (at every step), split into step parts."""
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            lowered = problem.lowered(constraint.formula, binding)
            for part, k in split_steps(lowered, 0):
                yield part, k, binding, constraint.name
    if problem.separation is not None:
        for p, q in itertools.combinations([a.name for a in problem.agents], 2):
            formula = separation_formula(problem, p, q)
            for k in range(problem.horizon + 1):
                yield formula, k, {"p": p, "q": q}, SEPARATION


def defer(problem: Problem, boxes: Boxes, margin_ceiling: float) -> Deferral:
    """Split the problem's constraints and separation into lazy step requirements and the rest."""
    lazy: list[Requirement] = []
    eager: list[tuple[Formula, int, Mapping[str, str]]] = []
    dropped = 0
    for part, k, binding, source in _all_parts(problem):
        if not _is_step_disjunction(part):
            eager.append((part, k, binding))
            continue
        requirement = Requirement(part, k, binding, source)
        if always_met(requirement, boxes, margin_ceiling):
            dropped += 1
        else:
            lazy.append(requirement)
    return Deferral(tuple(lazy), tuple(eager), dropped)


def alpha_values(requirement: Requirement, states: Mapping[str, np.ndarray]) -> np.ndarray:
    """``alpha_i(x(k))`` of every half-plane on a trajectory (agent name to (H+1, n) states)."""
    out = np.empty(len(requirement.alternatives))
    for i, alt in enumerate(requirement.alternatives):
        total = -alt.bound
        for term in alt.terms:
            total += (
                term.coef * states[requirement.binding[term.role]][requirement.k, term.component]
            )
        out[i] = total
    return out


def violated(
    requirements: Sequence[Requirement],
    states: Mapping[str, np.ndarray],
    margin: float,
    tolerance: float,
) -> list[int]:
    """Indices of the requirements with ``max_i alpha_i(x(k)) - r < -tolerance``."""
    return [
        n
        for n, req in enumerate(requirements)
        if float(alpha_values(req, states).max()) - margin < -tolerance
    ]


def best_side(requirement: Requirement, states: Mapping[str, np.ndarray]) -> int:
    """Index of the half-plane with the largest ``alpha_i`` on a trajectory."""
    return int(np.argmax(alpha_values(requirement, states)))


def best_option(requirement: Requirement, states: Mapping[str, np.ndarray]) -> Enforced:
    """The half-plane with the largest ``alpha_i`` on a trajectory (the side a plan keeps)."""
    return requirement.options()[best_side(requirement, states)]


def neighbours(
    requirements: Sequence[Requirement], chosen: Sequence[int], window: int | None
) -> list[int]:
    """``chosen`` with every requirement of the same family within ``window`` steps.

    ``window = 0`` keeps ``chosen``; None takes the whole family (every step of the pair or agent).
    """
    if window == 0:
        return sorted(set(chosen))
    wanted: dict[tuple[object, ...], list[int]] = {}
    for n in chosen:
        wanted.setdefault(requirements[n].family, []).append(requirements[n].k)
    picked = set(chosen)
    for n, req in enumerate(requirements):
        steps = wanted.get(req.family)
        if steps and (window is None or any(abs(req.k - k) <= window for k in steps)):
            picked.add(n)
    return sorted(picked)
