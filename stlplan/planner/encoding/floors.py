"""Effort floors: valid inequalities bounding each agent's effort by what its indicators enforce.

With big-M rows a fractional indicator enforces almost nothing, so the LP relaxation of problem
(step1) barely moves the agents and bounds the effort term ``beta * sum s`` poorly; HiGHS then
branches long to prove an optimum. For an agent ``p`` let ``e_p = sum_{k,j} s_{p,k,j}`` (its L1
effort, ``s >= |u|``) and, for a set ``S`` of predicates on ``p`` alone,

    E_p(S) = min e_p  s.t.  dynamics from x_p^0, state and input boxes,
                            alpha(x_p(k)) >= r_min  for every (alpha, k) in S,

an LP (``+inf`` when infeasible), with ``r_min`` the smallest admissible margin. The floor of an
indicator ``z`` is, per agent,

* predicate: ``E_p({alpha at k})`` when ``alpha`` involves ``p`` only, else 0;
* conjunction: ``max(E_p(S), floor_p(c) for each child c that is no conjunction or predicate)``,
  with ``S`` every single-agent predicate reached through conjunctions alone;
* disjunction: ``min_i floor_p(z_i)``.

The cuts are ``e_p >= floor_p(z) z`` for every conjunction and ``e_p >= sum_i floor_p(z_i) w_i``
for every choice ``sum w_i = z, w_i <= z_i``; ``z = 0`` when the floor is infinite.

They keep the optimum: every feasible point has one with the same ``x``, ``u``, binaries that
matter and objective whose indicators are 1 exactly on the subformulas the plan needs (the least
indicators; unneeded disjunctions take their "off" slot, which costs nothing). There every
indicator at 1 has all its predicates met by ``x``, so ``e_p`` is at least its floor.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import highspy
import numpy as np
from pyomo.environ import ConcreteModel, ConstraintList, Var

from stlplan.formula.tree import Predicate
from stlplan.mission.problem import AgentModel, Problem
from stlplan.planner.encoding.stl import Ledger

INF = float("inf")
FLOOR_TOL = 1e-7
"""Floors below this are treated as 0 (no cut), and every floor is lowered by it (round-off)."""

AgentPredicate = tuple[Predicate, int]
"""A predicate on one agent's state at step ``k``, its role bound to that agent."""


class EffortLp:
    """``E_p(S)`` for one agent, as a warm-started HiGHS LP over its inputs.

    Variables ``u`` (H*m) and ``s`` (H*m); rows ``s - u >= 0``, ``s + u >= 0`` and the state box
    ``x_lo <= f_k + G_k u <= x_hi`` for ``k = 1..H``, with ``x(k) = f_k + G_k u`` condensed
    (``f_k = A^k x^0``, ``G_k`` the stacked ``A^(k-1-i) B``). A query adds the predicate rows
    ``c . G_k u >= b + r_min - c . f_k``, solves and deletes them.
    """

    def __init__(self, agent: AgentModel, horizon: int, margin: float) -> None:
        self.margin = margin
        n, m = agent.n, agent.m
        self.free = np.empty((horizon + 1, n))
        self.gains = np.zeros((horizon + 1, n, horizon * m))
        self.free[0] = agent.initial_state
        for k in range(horizon):
            self.free[k + 1] = agent.A @ self.free[k]
            self.gains[k + 1] = agent.A @ self.gains[k]
            self.gains[k + 1][:, k * m : (k + 1) * m] = agent.B
        self.highs = highspy.Highs()
        self.highs.setOptionValue("output_flag", False)
        self._base(agent, horizon)

    def _base(self, agent: AgentModel, horizon: int) -> None:
        width = horizon * agent.m
        u_lo = np.tile(agent.input_lo, horizon)
        u_hi = np.tile(agent.input_hi, horizon)
        cost = np.concatenate([np.zeros(width), np.ones(width)])
        lower = np.concatenate([u_lo, np.zeros(width)])
        upper = np.concatenate([u_hi, np.maximum(np.abs(u_lo), np.abs(u_hi))])
        self.highs.addVars(2 * width, lower, upper)
        self.highs.changeColsCost(2 * width, np.arange(2 * width, dtype=np.int32), cost)
        eye = np.eye(width)
        rows = [np.hstack([-eye, eye]), np.hstack([eye, eye])]
        lo = [np.zeros(width), np.zeros(width)]
        hi = [np.full(width, INF), np.full(width, INF)]
        for k in range(1, horizon + 1):
            rows.append(np.hstack([self.gains[k], np.zeros((agent.n, width))]))
            lo.append(agent.state_lo - self.free[k])
            hi.append(agent.state_hi - self.free[k])
        self._add_rows(np.vstack(rows), np.concatenate(lo), np.concatenate(hi))
        self.base_rows = self.highs.getNumRow()

    def _add_rows(self, matrix: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        starts: list[int] = []
        index: list[int] = []
        values: list[float] = []
        for row in matrix:
            starts.append(len(index))
            nonzero = np.flatnonzero(np.abs(row) > 1e-12)
            index.extend(nonzero.tolist())
            values.extend(row[nonzero].tolist())
        self.highs.addRows(
            len(matrix), lo, hi, len(index),
            np.array(starts, dtype=np.int32), np.array(index, dtype=np.int32),
            np.array(values, dtype=float),
        )  # fmt: skip

    def floor(self, predicates: Iterable[AgentPredicate]) -> float:
        """``E_p(S)``: least L1 effort meeting every predicate of ``S`` (inf if none can)."""
        width = self.gains.shape[2]
        matrix, lo = [], []
        for node, k in predicates:
            c = np.zeros(self.free.shape[1])
            for term in node.terms:
                c[term.component] += term.coef
            matrix.append(np.concatenate([c @ self.gains[k], np.zeros(width)]))
            lo.append(node.bound + self.margin - float(c @ self.free[k]))
        if not matrix:
            return 0.0
        self._add_rows(np.vstack(matrix), np.array(lo), np.full(len(lo), INF))
        self.highs.run()
        status = self.highs.getModelStatus()
        value = self.highs.getInfo().objective_function_value
        extra = np.arange(self.base_rows, self.highs.getNumRow(), dtype=np.int32)
        self.highs.deleteRows(len(extra), extra)
        if status == highspy.HighsModelStatus.kInfeasible:
            return INF
        if status != highspy.HighsModelStatus.kOptimal:
            return 0.0  # unknown: no cut
        return max(0.0, float(value) - FLOOR_TOL)


Floor = dict[str, float]
"""Agent name to a lower bound of its effort."""


@dataclass(eq=False)
class FloorGraph:
    """The indicator links of a :class:`Ledger`, and each indicator's floor (memoized by id)."""

    ledger: Ledger
    lps: Mapping[str, EffortLp]
    predicates: dict[int, tuple[str, AgentPredicate] | None] = field(default_factory=dict)
    conjunctions: dict[int, list[Any]] = field(default_factory=dict)
    disjunctions: dict[int, list[Any]] = field(default_factory=dict)
    floors: dict[int, Floor] = field(default_factory=dict)
    cache: dict[tuple[str, frozenset[AgentPredicate]], float] = field(default_factory=dict)
    deadline: float = math.inf
    """``time.perf_counter()`` time after which no more LPs run: a floor of 0 (no cut) is valid."""

    def __post_init__(self) -> None:
        for z, (node, k, binding) in self.ledger.guarded:
            agents = {binding[t.role] for t in node.terms}
            self.predicates[id(z)] = (agents.pop(), (node, k)) if len(agents) == 1 else None
        for z, children in self.ledger.conjunctions:
            self.conjunctions[id(z)] = children
        for owner, children, _ in self.ledger.choices:
            if owner is not None:
                self.disjunctions[id(owner)] = children

    def effort_floor(self, agent: str, predicates: frozenset[AgentPredicate]) -> float:
        key = (agent, predicates)
        if key not in self.cache:
            if time.perf_counter() > self.deadline:
                return 0.0
            self.cache[key] = self.lps[agent].floor(sorted(predicates, key=repr))
        return self.cache[key]

    def closure(self, z: Any) -> tuple[dict[str, set[AgentPredicate]], list[Any]]:
        """Single-agent predicates reached from ``z`` through conjunctions, and the other leaves."""
        sets: dict[str, set[AgentPredicate]] = {}
        others: list[Any] = []
        stack = [z]
        while stack:
            node = stack.pop()
            if id(node) in self.conjunctions:
                stack.extend(self.conjunctions[id(node)])
            elif id(node) in self.predicates:
                found = self.predicates[id(node)]
                if found is not None:
                    sets.setdefault(found[0], set()).add(found[1])
            else:
                others.append(node)
        return sets, others

    def floor(self, z: Any) -> Floor:
        """Per-agent effort floor of indicator ``z`` (empty for constants and unknown nodes)."""
        key = id(z)
        if key in self.floors:
            return self.floors[key]
        if key in self.disjunctions:
            parts = [self.floor(c) for c in self.disjunctions[key]]
            agents = set(itertools.chain.from_iterable(parts))
            out = {p: min(part.get(p, 0.0) for part in parts) for p in agents}
        elif key in self.conjunctions or key in self.predicates:
            sets, others = self.closure(z)
            out = {p: self.effort_floor(p, frozenset(s)) for p, s in sets.items()}
            for part in map(self.floor, others):
                for p, e in part.items():
                    out[p] = max(out.get(p, 0.0), e)
        else:
            out = {}
        self.floors[key] = out
        return out


def add_effort_floors(
    model: ConcreteModel,
    problem: Problem,
    ledger: Ledger,
    margin: float,
    deadline: float = math.inf,
) -> int:
    """Add ``e_p = sum s_p`` and the floor cuts of every conjunction and choice; returns the count.

    ``model.s[p, k, j]`` are the absolute inputs; ``margin`` is the smallest admissible ``r``.
    After ``deadline`` (``time.perf_counter()`` time) no more floor LPs run and the remaining
    indicators get no cut (the floors are valid inequalities: fewer of them keep the optimum).
    """
    names = [a.name for a in problem.agents]
    lps = {a.name: EffortLp(a, problem.horizon, margin) for a in problem.agents}
    graph = FloorGraph(ledger, lps, deadline=deadline)
    model.e = Var(names, bounds=(0.0, None))
    model.effort_floors = ConstraintList()
    for p in names:
        terms = [v for (q, _, _), v in model.s.items() if q == p]
        model.effort_floors.add(model.e[p] == sum(terms))
    impossible: dict[int, Any] = {}
    count = 0
    for z, _ in ledger.conjunctions:
        for p, e in graph.floor(z).items():
            if e == INF:
                impossible[id(z)] = z
            elif e > FLOOR_TOL:
                model.effort_floors.add(model.e[p] >= e * z)
                count += 1
    for _, children, chosen in ledger.choices:
        parts = [graph.floor(c) for c in children]
        for child, part in zip(children, parts, strict=True):
            if INF in part.values():
                impossible[id(child)] = child
        for p in set(itertools.chain.from_iterable(parts)):
            terms = [(part.get(p, 0.0), w) for part, w in zip(parts, chosen, strict=True)]
            terms = [(e, w) for e, w in terms if FLOOR_TOL < e < INF]
            if terms:
                model.effort_floors.add(model.e[p] >= sum(e * w for e, w in terms))
                count += 1
    for z in impossible.values():
        model.effort_floors.add(z <= 0)
    # the LPs sized HiGHS's process-wide thread pool; let the MILP size it afresh
    highspy.Highs.resetGlobalScheduler(True)
    return count + len(impossible)
