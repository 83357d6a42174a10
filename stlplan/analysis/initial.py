"""Requirements the initial states already break, and margins no region allows: found at once.

Every agent's state at step 0 is given, so whatever a requirement demands at step 0 is decided
without solving. :func:`step0_part` keeps the part of a formula that must hold at step 0
(through ``&``, ``G[0,b]``, ``F[0,0]`` and the left side of ``U``; through ``|`` only when every
branch has one; a ``count`` is one, a ``visits`` none), and its robustness at the initial states is compared with the required margin
(``objective.margin.minimum``, 0 by default):

* a constraint's step-0 part broken by the agents bound to it (an agent that starts inside a
  region it must always avoid);
* an ordinary task whose step-0 part fewer than ``count`` elements meet;
* two agents that start closer than the separation and the required margin (infinity norm of
  their positions);
* a region a task or constraint must reach (:func:`stlplan.analysis.reach.needs`) in which no
  point lies as far inside as the required margin (the radius of the largest disc inside it).

Each finding is a :class:`Reason` naming the task, constraint or ``separation`` it blames.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any, NamedTuple

import numpy as np

from stlplan.analysis.reach import needs
from stlplan.formula import tree
from stlplan.formula.parser import to_text
from stlplan.formula.tree import Formula
from stlplan.mission.polytope import inscribed_radius
from stlplan.mission.problem import Problem

TOLERANCE = 1e-9
"""A value this far below what is required still counts as met (round-off)."""


class Reason(NamedTuple):
    """Why a mission is infeasible, found without solving."""

    item: str
    """The task, constraint or ``separation`` that cannot be met."""
    text: str
    """The explanation: who, at which step, which requirement, which numbers."""
    others: tuple[str, ...] = ()
    """The constraints (or another task) it cannot be met with (none: it cannot be met on its
    own)."""


def _all_known(parts: list[Formula | None]) -> list[Formula] | None:
    known = [p for p in parts if p is not None]
    return known if len(known) == len(parts) else None


def _conjunction(parts: list[Formula | None]) -> Formula | None:
    known = [p for p in parts if p is not None]
    return None if not known else known[0] if len(known) == 1 else tree.And(tuple(known))


def _disjunction(parts: list[Formula | None]) -> Formula | None:
    known = _all_known(parts)
    return None if known is None else tree.Or(tuple(known))


_STEP0: dict[type, Callable[[Any], Formula | None]] = {
    # what must hold at step 0 for the node to hold at step 0 (None: nothing known)
    **{t: lambda f: f for t in (*tree.ATOM_TYPES, tree.Not)},
    tree.Visits: lambda f: None,
    tree.And: lambda f: _conjunction([step0_part(c) for c in f.children]),
    tree.Or: lambda f: _disjunction([step0_part(c) for c in f.children]),
    tree.Always: lambda f: step0_part(f.child) if f.interval.lo == 0 else None,
    tree.Eventually: lambda f: step0_part(f.child) if f.interval.hi == 0 else None,
    tree.Until: lambda f: step0_part(f.left),
}


def step0_part(formula: Formula) -> Formula | None:
    """The requirement ``formula`` makes at step 0, free of temporal operators (None if none)."""
    return _STEP0[type(formula)](formula)


_VALUE: dict[type, Callable[[Any, Mapping[str, np.ndarray]], float]] = {
    # robustness at step 0 of a lowered formula (predicates, & and |)
    tree.Predicate: lambda f, x: sum(t.coef * x[t.role][t.component] for t in f.terms) - f.bound,
    tree.And: lambda f, x: min(_value(c, x) for c in f.children),
    tree.Or: lambda f, x: max(_value(c, x) for c in f.children),
    tree.AtLeast: lambda f, x: sorted(_value(c, x) for c in f.options)[-f.n],
}


def _value(formula: Formula, states: Mapping[str, np.ndarray]) -> float:
    return float(_VALUE[type(formula)](formula, states))


def initial_value(problem: Problem, part: Formula, binding: Mapping[str, str]) -> float:
    """Robustness of the step-0 requirement ``part`` at the initial states of ``binding``."""
    states = {role: problem.agent(name).initial_state for role, name in binding.items()}
    return _value(problem.lowered(part, binding), states)


def _where(problem: Problem, binding: Mapping[str, str]) -> str:
    """``p = a1 at (0.5, 0.5)``: each role's agent and its initial position."""
    out = []
    for role, name in binding.items():
        agent = problem.agent(name)
        x, y = (float(agent.initial_state[i]) for i in agent.position)
        out.append(f"{role} = {name} at ({x:g}, {y:g})")
    return ", ".join(out)


def _margin(problem: Problem) -> float:
    return float(problem.mission.objective.margin.minimum)


def _shortfall(problem: Problem, part: Formula, binding: Mapping[str, str]) -> float | None:
    """The value of ``part`` at the initial states when it is below the required margin."""
    value = initial_value(problem, part, binding)
    return value if value < _margin(problem) - TOLERANCE else None


def _step0_parts(items: Iterable[Any]) -> Iterator[tuple[Any, Formula]]:
    """Each task or constraint with its step-0 part (synchronous tasks start later)."""
    for item in items:
        part = step0_part(item.formula) if getattr(item, "sync", None) is None else None
        if part is not None:
            yield item, part


def _constraint_reasons(problem: Problem) -> Iterator[Reason]:
    for constraint, part in _step0_parts(problem.constraints):
        for binding in constraint.bindings:
            value = _shortfall(problem, part, binding)
            if value is not None:
                yield Reason(
                    constraint.name,
                    f"constraint '{constraint.name}' requires '{to_text(part)}' at step 0, but "
                    f"the initial state breaks it ({_where(problem, binding)}: value {value:.4g}, "
                    f"needed >= {_margin(problem):g})",
                )


def _task_reasons(problem: Problem) -> Iterator[Reason]:
    for task, part in _step0_parts(problem.tasks):
        meeting = [e for e in task.elements if _shortfall(problem, part, task.binding(e)) is None]
        if len(meeting) >= task.count:
            continue
        shortage = f"only {len(meeting)} of its {len(task.elements)} element(s) meet it"
        needed = f"{task.count} element(s), needed >= {_margin(problem):g}"
        text = f"requires '{to_text(part)}' at step 0 ({needed}), but {shortage} there"
        yield Reason(task.name, f"task '{task.name}' {text}")


def _separation_reasons(problem: Problem) -> Iterator[Reason]:
    if problem.separation is None or problem.past is not None:
        return  # (a replan's pair its past left too close recovers: stlplan.analysis.recovery)
    agents, margin = problem.agents, _margin(problem)
    needed = (
        f" with the required margin {margin:g} (objective.margin.minimum)" if margin > 0 else ""
    )
    for i, first in enumerate(agents):
        for second in agents[i + 1 :]:
            z1 = first.initial_state[list(first.position)]
            z2 = second.initial_state[list(second.position)]
            gap = float(np.max(np.abs(z1 - z2)))
            if gap < problem.separation + margin - TOLERANCE:
                yield Reason(
                    "separation",
                    f"agents '{first.name}' and '{second.name}' start {gap:g} apart at step 0 "
                    f"(infinity norm of their initial positions), closer than the separation "
                    f"{problem.separation:g}{needed}",
                )


def _margin_reasons(problem: Problem) -> Iterator[Reason]:

    needed = _margin(problem)
    if needed <= 0:
        return
    radius: dict[str, float] = {}
    items = [("task", t.name, t.formula) for t in problem.tasks]
    items += [("constraint", c.name, c.formula) for c in problem.constraints]
    for kind, name, formula in items:
        for role, region, step in dict.fromkeys(needs(formula)):
            if region not in radius:
                radius[region] = inscribed_radius(*problem.regions[region])
            if radius[region] < needed - TOLERANCE:
                yield Reason(
                    name,
                    f"{kind} '{name}' needs role '{role}' in region '{region}' (by step {step}) "
                    f"with the required margin {needed:g} (objective.margin.minimum), but no "
                    f"point of '{region}' lies more than {max(radius[region], 0.0):g} inside it",
                )


def initial_reasons(problem: Problem) -> tuple[Reason, ...]:
    """Every step-0 conflict and impossible margin of ``problem`` (empty when there is none)."""
    return (
        *_constraint_reasons(problem),
        *_task_reasons(problem),
        *_separation_reasons(problem),
        *_margin_reasons(problem),
    )
