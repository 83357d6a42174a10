"""Step requirements that may be left out of the MILP until a plan violates them (lazy rows).

Obstacle avoidance (``G[0,H] !in(p, Obs)``) and pairwise separation split into one requirement per
step, each a disjunction of half-planes:

    R(k):  OR_i  alpha_i(x(k)) - r >= 0,

with ``alpha_i`` linear in the states of the bound agents and ``r`` the spatial margin. Most of them
never bind: an agent rarely comes near the obstacle or another agent. The lazy loop
(:mod:`stlplan.planner.core.lazy`) solves without them, finds those the plan violates with numpy, adds exactly
those (encoded as if they had been there from the start), and solves again. When a plan violates
none, it satisfies every requirement of the full problem and its objective bound came from a
relaxation of that problem, so it is the full problem's optimum.

A requirement that one of its half-planes meets at every reachable state (the interval bound of
:func:`stlplan.planner.encoding.stl.predicate_range` over the reachable boxes) is dropped: it cannot bind.

With inter-sample safety (DESIGN 2.9, the default) a disjunction required by one constraint and
binding (or one pair's separation) at both ``k`` and ``k+1`` is required on the segment between
them: one requirement spanning the two steps, one half-plane held at both ends
(:mod:`stlplan.planner.encoding.segments`). A disjunction required at an isolated step stays a step
requirement; a single half-plane needs no segment requirement (it holds between two ends that meet
it).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stlplan.formula.boundary import HOLDS_AT, required_margin
from stlplan.formula.tree import Distance, Formula, Or, Predicate, step_parts
from stlplan.mission.problem import Problem
from stlplan.planner.encoding.alphas import Flat, alpha_values, flatten
from stlplan.planner.encoding.ledger import Enforced
from stlplan.planner.encoding.segments import require_on_steps
from stlplan.planner.encoding.stl import (
    Boxes,
    StlContext,
    predicate_range,
    require,
    require_predicate,
)
from stlplan.planner.encoding.tasks import separation_formula

Part = tuple[Formula, int, Mapping[str, str]]
"""A formula at a step under a binding."""

SEPARATION = "separation"
"""Source name of the pairwise separation requirements."""


@dataclass(frozen=True, eq=False)
class Requirement:
    """``OR_i alpha_i(x(k)) - r >= 0`` at step ``k`` under ``binding`` (a single ``alpha`` too);
    with ``span = 1``, on the segment from step ``k`` to ``k + 1`` (one ``alpha_i`` at both ends).

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
    span
        0 for a step, 1 for the segment ``[x(k), x(k+1)]``.
    """

    formula: Formula
    k: int
    binding: Mapping[str, str]
    source: str
    span: int = 0
    tightening: Callable[[Predicate, int], float] = field(
        default=lambda node, k: 0.0, repr=False, compare=False
    )
    """How much a half-plane's margin is raised at a step (:meth:`Problem.tightening`)."""

    @property
    def steps(self) -> range:
        """The steps whose states the requirement reads."""
        return range(self.k, self.k + self.span + 1)

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

    @functools.cached_property
    def flat(self) -> Flat:
        """The requirement as arrays, for evaluating many at once
        (:func:`stlplan.planner.encoding.alphas.alpha_maxima`)."""
        return flatten(self)

    def options(self) -> list[list[Enforced]]:
        """Each half-plane as the predicates ``(alpha_i, t, binding)`` enforcing it, t in steps."""
        return [[(alt, t, self.binding) for t in self.steps] for alt in self.alternatives]

    def encode_side(self, ctx: StlContext, side: int) -> None:
        """Enforce the half-plane ``side`` at every step, without a binary."""
        scope = ctx.bound(self.binding)
        for t in self.steps:
            require_predicate(self.alternatives[side], t, scope)

    def encode(self, ctx: StlContext) -> None:
        """Enforce the requirement in the model of ``ctx`` (as if it had been there from the start)."""
        scope = ctx.bound(self.binding)
        if self.span == 0:
            require(self.formula, self.k, scope)
        else:
            require_on_steps(self.alternatives, self.steps, scope)


def _is_step_disjunction(formula: Formula) -> bool:
    if isinstance(formula, Predicate):
        return True
    return isinstance(formula, Or) and all(isinstance(c, Predicate) for c in formula.children)


def kind(requirement: Requirement) -> str:
    """``separation`` or ``constraint``, then ``step`` or ``segment``: e.g. "separation segment"."""
    source = "separation" if requirement.source == SEPARATION else "constraint"
    return f"{source} {'segment' if requirement.span else 'step'}"


def always_met(requirement: Requirement, boxes: Boxes, margin_ceiling: float) -> bool:
    """Whether some ``alpha_i`` exceeds every admissible margin on the whole reachable box."""
    return any(
        all(
            predicate_range(alt, t, requirement.binding, boxes)[0] - requirement.tightening(alt, t)
            >= margin_ceiling
            for t in requirement.steps
        )
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
    eager: tuple[Part, ...]
    dropped: int


def _all_parts(problem: Problem) -> Iterator[tuple[Formula, int, Mapping[str, str], str]]:
    """Every constraint (at step 0) and separation (at every step), split into step parts (a
    replan's parts in its executed past left out: data, not planned)."""
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            lowered = problem.lowered(constraint.formula, binding)
            for part, k in step_parts(lowered, 0):
                if not problem.in_past(part, k):
                    yield part, k, binding, constraint.name
    if problem.separation is not None:  # (a pair the past left too close: from its restoring)
        for p, q in itertools.combinations([a.name for a in problem.agents], 2):
            formula = separation_formula(problem, p, q)
            for k in range(problem.separated_from(p, q), problem.horizon + 1):
                if not problem.in_past(formula, k):
                    yield formula, k, {"p": p, "q": q}, SEPARATION


def on_segments(requirements: Sequence[Requirement], first: int = 0) -> list[Requirement]:
    """Step requirements with their disjunctions at consecutive steps joined into segments.

    A disjunction of one family required at ``k`` and ``k+1`` (``k >= first``) becomes a
    requirement on the segment ``[k, k+1]``; a step that no such segment covers stays a step
    requirement; a single half-plane stays as it is (it holds on a segment whose ends meet it).
    Segments before ``first`` (a replan's executed past) are not planned.
    """
    steps: dict[tuple[object, ...], set[int]] = {}
    for req in requirements:
        steps.setdefault((*req.family, req.formula), set()).add(req.k)
    out: list[Requirement] = []
    for req in requirements:
        if isinstance(req.formula, Predicate):
            out.append(req)
            continue
        held = steps[(*req.family, req.formula)]
        if req.k < first:
            out.append(req)
        elif req.k + 1 in held:
            out.append(dataclasses.replace(req, span=1))
        elif req.k - 1 not in held or req.k - 1 < first:
            out.append(req)
    return out


def step_requirements(
    problem: Problem, floors: bool = True
) -> tuple[list[Requirement], list[Part]]:
    """The problem's constraints and separation as step requirements (segments with
    inter-sample safety; with ``floors``, a replan's :func:`floor_requirements` too), and the
    parts with temporal structure below a disjunction."""
    found: list[Requirement] = []
    eager: list[Part] = []
    for part, k, binding, source in _all_parts(problem):
        if _is_step_disjunction(part):
            found.append(Requirement(part, k, binding, source, tightening=problem.tightening))
        else:
            eager.append((part, k, binding))
    if problem.past is None:
        return (on_segments(found) if problem.inter_sample else found), eager
    K = problem.past.step
    now = [r for r in found if r.k == K]  # data: each becomes, at most, its segment's end
    later = [r for r in found if r.k != K]
    ends = [e for e in (segment_end(problem, r) for r in now) if e is not None]
    kept = (on_segments(later, K + 1) + ends) if problem.inter_sample else later
    return kept + (floor_requirements(problem) if floors else []), eager


def segment_end(
    problem: Problem, requirement: Requirement, least: float = HOLDS_AT
) -> Requirement | None:
    """A requirement at a replan's step ``K`` (executed data) as what the segment from ``K``
    to ``K+1`` asks of the plan: ``x(K+1)`` in one of the half-planes ``x(K)`` is in, at
    ``least`` (the segment then stays in it). None when ``x(K)`` is in none: the past broke it."""
    past = problem.past
    assert past is not None and requirement.k == past.step
    if requirement.k + 1 > problem.horizon:
        return None
    states = {name: past.states[name] for name in requirement.binding.values()}
    alpha = alpha_values(requirement, states)
    held = [p for p, a in zip(requirement.alternatives, alpha, strict=True) if a >= least]
    if not held:
        return None
    formula: Formula = held[0] if len(held) == 1 else Or(tuple(held))
    return dataclasses.replace(requirement, formula=formula, k=requirement.k + 1)


def floor_requirements(problem: Problem) -> list[Requirement]:
    """The floors of the pairs a replan's executed past left closer than the separation.

    Such a pair (``c`` apart at ``K``) is held to the full separation from the step it is
    restored, ``R`` (:mod:`stlplan.analysis.recovery`), and before that to a floor at ``c`` on
    every step and segment from ``K`` to ``R``: the separation's four half-planes with
    ``c - r_min`` in place of ``d``, so that the margin ``r >= r_min`` (and a robust
    tightening) lands on ``c``. With inter-sample safety: ``x(K+1)`` on a side ``x(K)`` holds
    at ``c`` (:func:`segment_end`: the segment from the executed state stays on it), then one
    half-plane at both ends of each segment up to ``[R-1, R]``; else the steps ``K+1 .. R-1``.
    """
    past = problem.past
    if past is None or not past.recovering:
        return []
    margin = required_margin(problem.mission.objective.margin.minimum)
    found: list[Requirement] = []
    for p, q in itertools.combinations([a.name for a in problem.agents], 2):
        recovery = past.recovering.get((p, q))
        if recovery is None:
            continue
        binding = {"p": p, "q": q}
        floor = problem.lowered(Distance("p", "q", ">=", recovery.closest - margin), binding)
        steps = range(past.step + 1, problem.separated_from(p, q))
        if not problem.inter_sample:
            found += [
                Requirement(floor, k, binding, SEPARATION, 0, problem.tightening) for k in steps
            ]
            continue
        found += [
            Requirement(floor, k, binding, SEPARATION, 1, problem.tightening)
            for k in steps
            if k + 1 <= problem.horizon
        ]
        at = Requirement(floor, past.step, binding, SEPARATION, 0, problem.tightening)
        end = segment_end(problem, at, margin - HOLDS_AT)  # x(K) holds its closest side at c
        found += [end] if end is not None else []
    return found


def segment_requirements(problem: Problem) -> list[Requirement]:
    """The requirements on segments alone (added to a model that encodes every step), and a
    replan's segment ends (:func:`segment_end`) and floors (:func:`floor_requirements`)."""
    floors = floor_requirements(problem)
    if not problem.inter_sample:
        return floors
    K = None if problem.past is None else problem.past.step + 1
    found = step_requirements(problem, floors=False)[0]
    return [req for req in found if req.span > 0 or req.k == K] + floors


def defer(problem: Problem, boxes: Boxes, margin_ceiling: float) -> Deferral:
    """Split the problem's constraints and separation into lazy step requirements and the rest."""
    lazy: list[Requirement] = []
    dropped = 0
    found, eager = step_requirements(problem)
    for requirement in found:
        if always_met(requirement, boxes, margin_ceiling):
            dropped += 1
        else:
            lazy.append(requirement)
    return Deferral(tuple(lazy), tuple(eager), dropped)


def requirement_key(req: Requirement) -> tuple[Any, ...]:
    """What identifies a requirement across models of the same mission."""
    return req.source, tuple(sorted(req.binding.items())), req.k, req.span, req.formula


def best_side(requirement: Requirement, states: Mapping[str, np.ndarray]) -> int:
    """Index of the half-plane with the largest ``alpha_i`` on a trajectory."""
    return int(np.argmax(alpha_values(requirement, states)))


def families(requirements: Sequence[Requirement], chosen: Sequence[int]) -> list[int]:
    """``chosen`` with every requirement of their families (every step of the pair, or of the
    agent and constraint)."""
    wanted = {requirements[n].family for n in chosen}
    return sorted({*chosen, *(n for n, r in enumerate(requirements) if r.family in wanted)})
