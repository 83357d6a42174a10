"""A mission's single-agent tasks and constraints as RTAMT specifications, to cross-check.

Each task or constraint whose formula has one role becomes the text of an RTAMT discrete-time
specification over float variables ``x0 .. x{n-1}``, the state components of the agent bound to
the role. The formula is written after lowering, so regions and distances appear as the linear
inequalities the planner and the monitor read (``in(p, R)`` is one inequality per face of ``R``,
with unit-norm rows), and RTAMT's robustness of ``lhs >= rhs`` is ``lhs - rhs``, stlplan's
predicate value. RTAMT's ``until`` is the strict one (``U*``); the paper's ``l U[a,b] r`` is written
``l until[a:b] (l and r)``, which has the same robustness.

Synchronous tasks (their synchronous robustness is not STL robustness), tasks over several
roles and formulas that count agents (``count``, ``visits``: RTAMT's STL has no operator for the
``n``-th best of several agents' robustness) are listed as comments only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from stlplan.formula.tree import (
    Always,
    And,
    Eventually,
    Formula,
    Or,
    Predicate,
    Until,
    roles,
    team_atoms,
)
from stlplan.mission.problem import Problem


@dataclass(frozen=True)
class RtamtSpec:
    """One RTAMT specification: a task or constraint of one role under the agents listed."""

    name: str
    """The task or constraint."""
    kind: str
    """``task`` or ``constraint``."""
    role: str
    """The formula's role."""
    agents: tuple[str, ...]
    """Agents the role may be bound to whose lowered formula is this text."""
    variables: tuple[str, ...]
    """``x0 .. x{n-1}``: the bound agent's state components, to declare as floats."""
    text: str
    """The specification in RTAMT's STL syntax."""


def _number(value: float) -> str:
    return np.format_float_positional(float(value), unique=True, trim="-")


def _predicate(node: Predicate) -> str:
    # sum(coef * x_i) - bound >= 0  ->  (c0*x0 + c1*x1 >= bound)
    terms = " + ".join(f"{_number(t.coef)}*x{t.component}" for t in node.terms) or "0"
    return f"({terms} >= {_number(node.bound)})"


def _join(word: str) -> Callable[[Any], str]:
    return lambda node: "(" + f" {word} ".join(rtamt_text(c) for c in node.children) + ")"


def _temporal(word: str) -> Callable[[Any], str]:
    return lambda node: f"{word}[{node.interval.lo}:{node.interval.hi}]({rtamt_text(node.child)})"


def _until(node: Until) -> str:
    # RTAMT's until is strict: l U[a,b] r  =  l until[a:b] (l and r)
    left, right = rtamt_text(node.left), rtamt_text(node.right)
    goal = right if node.strict else f"({left} and {right})"
    return f"({left} until[{node.interval.lo}:{node.interval.hi}] {goal})"


WRITERS: dict[type, Callable[[Any], str]] = {
    Predicate: _predicate,
    And: _join("and"),
    Or: _join("or"),
    Always: _temporal("always"),
    Eventually: _temporal("eventually"),
    Until: _until,
}
"""Node type of a lowered formula to its RTAMT text."""


def rtamt_text(formula: Formula) -> str:
    """A lowered formula (:func:`stlplan.formula.normal.lower`) in RTAMT's STL syntax."""
    return WRITERS[type(formula)](formula)


def _pools(problem: Problem) -> Iterator[tuple[str, str, Formula, list[str]]]:
    """``(name, kind, formula, agents)`` of every single-role, non-synchronous requirement."""
    for task in problem.tasks:
        if task.sync is None and len(task.roles) == 1 and not team_atoms(task.formula):
            yield task.name, "task", task.formula, sorted({e[0] for e in task.elements})
    for constraint in problem.constraints:
        (role,) = roles(constraint.formula) or ("",)
        if role and all(len(b) == 1 for b in constraint.bindings):
            pool = sorted({b[role] for b in constraint.bindings})
            yield constraint.name, "constraint", constraint.formula, pool


def rtamt_specs(problem: Problem) -> list[RtamtSpec]:
    """The RTAMT specification of each single-agent task and constraint of ``problem``; one per
    distinct text when the agents a role may take lower the formula differently."""
    out = []
    for name, kind, formula, pool in _pools(problem):
        (role,) = roles(formula)
        texts: dict[str, list[str]] = {}
        for agent in pool:
            texts.setdefault(rtamt_text(problem.lowered(formula, {role: agent})), []).append(agent)
        for text, agents in texts.items():
            n = problem.agent(agents[0]).n
            variables = tuple(f"x{i}" for i in range(n))
            out.append(RtamtSpec(name, kind, role, tuple(agents), variables, text))
    return out


def skipped(problem: Problem) -> list[str]:
    """Tasks and constraints left out of the export, each with why."""
    kept = {name for name, _, _, _ in _pools(problem)}
    out = []
    for task in problem.tasks:
        if task.name not in kept:
            why = "synchronous" if task.sync is not None else _why(task.formula)
            out.append(f"{task.name} ({why})")
    out += [f"{c.name} ({_why(c.formula)})" for c in problem.constraints if c.name not in kept]
    return out


def _why(formula: Formula) -> str:
    if team_atoms(formula):
        return "counts agents, which RTAMT cannot express"
    return "several roles"


def rtamt_document(problem: Problem, source: str, specs: list[RtamtSpec]) -> str:
    """The text ``stlplan export-rtamt`` writes: a header, then per specification a comment line
    and the specification on one line."""
    lines = [
        f"# RTAMT specifications of {source} (stlplan export-rtamt).",
        "# Discrete time, one sample per step k = 0..H; evaluate at k = 0. Declare the variables",
        "# as floats (spec.declare_var('x0', 'float'), ...): xi is state component i of the",
        "# agent bound to the role. RTAMT's until is stlplan's strict U*.",
    ]
    for name in skipped(problem):
        lines.append(f"# not exported: {name}")
    for spec in specs:
        lines += [
            "",
            f"# {spec.kind} {spec.name}, role {spec.role} = {', '.join(spec.agents)}; "
            f"variables {', '.join(spec.variables)}",
            spec.text,
        ]
    return "\n".join(lines) + "\n"


def spec_signals(states: np.ndarray) -> Mapping[str, list[float]]:
    """An agent's states ``(H+1, n)`` as RTAMT's offline dataset: ``time`` and ``x0 .. x{n-1}``."""
    data: dict[str, list[float]] = {"time": [float(k) for k in range(len(states))]}
    for i in range(states.shape[1]):
        data[f"x{i}"] = [float(v) for v in states[:, i]]
    return data
