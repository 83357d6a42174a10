"""Element floors: the least effort an element's agents need together.

The per-agent floors (:mod:`stlplan.planner.encoding.floors`) bound each agent apart and skip
predicates on several agents, such as a formation's ``dist(p, q) <= d``: two agents that start
apart must both move to meet, which no per-agent floor sees, so HiGHS branches long over who
pairs with whom. For an element ``e`` of several agents ``P_e`` whose formula's indicator is
``h_e``, the team LP

    E_e(S) = min sum_{p in P_e} e_p  s.t.  each agent's dynamics from x_p^0 and its boxes,
                                          alpha(x(k)) >= r_min  for every (alpha, k) in S

takes predicates on any of the agents. The floor ``J`` of an indicator is

* predicate or conjunction: with ``S`` every predicate reached through conjunctions alone, the
  largest of ``E_e(S)`` and, for each other child ``d``, ``min_i E_e(S + S_i)`` over the
  children ``d_i`` of ``d`` when ``d`` is a disjunction (``S_i`` reached from ``d_i`` likewise),
  else ``J(d)``;
* disjunction: ``min_i J(d_i)``.

The cut ``sum_{p in P_e} e_p >= J(h_e) x_e`` keeps the optimum for the reason the per-agent cuts
do: at a plan whose indicators are 1 exactly where it needs them, ``x_e = 1`` forces ``h_e = 1``,
every conjunction below forces its children and every disjunction one child, so the plan meets
``S`` and some ``S_i``, and its agents' effort is at least the LP's least. A floor infinite
(no trajectory of the agents meets the element) holds ``x_e = 0``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import highspy
import numpy as np
from pyomo.environ import ConcreteModel

from stlplan.formula.tree import Predicate
from stlplan.planner.encoding.effort_lp import (
    FLOOR_TOL,
    INF,
    EffortLp,
    add_dense_rows,
    least_effort,
)
from stlplan.planner.encoding.stl import Ledger, conjunction_leaves

TeamPredicate = tuple[Predicate, int, tuple[tuple[str, str], ...]]
"""A predicate at step ``k`` with its roles bound to agents (sorted ``(role, agent)`` pairs)."""


class TeamEffortLp:
    """``E_e(S)`` for a set of agents: their :class:`EffortLp` columns and rows side by side."""

    def __init__(self, lps: Sequence[tuple[str, EffortLp]]) -> None:
        self.lps = dict(lps)
        self.margin = lps[0][1].margin
        blocks = [lp.base_block() for _, lp in lps]
        widths = [len(block[2]) for block in blocks]
        self.offset = {name: sum(widths[:i]) for i, (name, _) in enumerate(lps)}
        total = sum(widths)
        self.highs = highspy.Highs()
        self.highs.setOptionValue("output_flag", False)
        lower = np.concatenate([b[0] for b in blocks])
        upper = np.concatenate([b[1] for b in blocks])
        self.highs.addVars(total, lower, upper)
        cost = np.concatenate([b[2] for b in blocks])
        self.highs.changeColsCost(total, np.arange(total, dtype=np.int32), cost)
        for (name, _), (_, _, _, matrix, lo, hi) in zip(lps, blocks, strict=True):
            wide = np.zeros((len(matrix), total))
            start = self.offset[name]
            wide[:, start : start + matrix.shape[1]] = matrix
            add_dense_rows(self.highs, wide, lo, hi)
        self.base_rows = self.highs.getNumRow()

    def _row(self, node: Predicate, k: int, binding: Mapping[str, str]) -> tuple[np.ndarray, float]:
        """Coefficients over the inputs and the right side of ``node`` at step ``k``."""
        row = np.zeros(self.highs.getNumCol())
        rhs = node.bound + self.margin
        for term in node.terms:
            agent = binding[term.role]
            lp, start = self.lps[agent], self.offset[agent]
            gains = lp.gains[k][term.component]
            row[start : start + len(gains)] += term.coef * gains
            rhs -= term.coef * float(lp.free[k][term.component])
        return row, rhs

    def floor(self, predicates: Iterable[TeamPredicate]) -> float:
        """Least total L1 effort of the agents meeting every predicate (inf if none can)."""
        rows = [self._row(node, k, dict(pairs)) for node, k, pairs in predicates]
        if not rows:
            return 0.0
        matrix = np.vstack([r for r, _ in rows])
        lo = np.array([rhs for _, rhs in rows])
        return least_effort(self.highs, self.base_rows, matrix, lo)


@dataclass(eq=False)
class TeamFloors:
    """The floors ``J`` of the module docstring over a :class:`Ledger` (memoized LPs)."""

    ledger: Ledger
    lps: Mapping[str, EffortLp]
    deadline: float = math.inf
    """``time.perf_counter()`` time after which no more LPs run (a floor of 0: no cut)."""
    predicates: dict[int, TeamPredicate] = field(default_factory=dict)
    conjunctions: dict[int, list[Any]] = field(default_factory=dict)
    disjunctions: dict[int, list[Any]] = field(default_factory=dict)
    teams: dict[tuple[str, ...], TeamEffortLp] = field(default_factory=dict)
    cache: dict[tuple[tuple[str, ...], frozenset[TeamPredicate]], float] = field(
        default_factory=dict
    )

    def __post_init__(self) -> None:
        for z, (node, k, binding) in self.ledger.guarded:
            roles = {t.role for t in node.terms}
            self.predicates[id(z)] = (node, k, tuple(sorted((r, binding[r]) for r in roles)))
        for z, children in self.ledger.conjunctions:
            self.conjunctions[id(z)] = children
        for owner, children, _ in self.ledger.choices:
            if owner is not None:
                self.disjunctions[id(owner)] = children

    def closure(self, z: Any) -> tuple[frozenset[TeamPredicate], list[Any]]:
        """Predicates reached from ``z`` through conjunctions, and the other leaves."""
        reached, others = conjunction_leaves(z, self.conjunctions, self.predicates)
        return frozenset(self.predicates[id(node)] for node in reached), others

    def effort(self, team: tuple[str, ...], predicates: frozenset[TeamPredicate]) -> float:
        """``E_e`` over the predicates on the team's agents alone (the others are dropped)."""
        mine = frozenset(p for p in predicates if all(a in team for _, a in p[2]))
        key = (team, mine)
        if key not in self.cache:
            if time.perf_counter() > self.deadline:
                return 0.0
            if team not in self.teams:
                self.teams[team] = TeamEffortLp([(a, self.lps[a]) for a in team])
            self.cache[key] = self.teams[team].floor(sorted(mine, key=repr))
        return self.cache[key]

    def floor(self, team: tuple[str, ...], z: Any) -> float:
        """``J(z)``: a lower bound of the team's total effort when ``z = 1``."""
        if id(z) in self.disjunctions:
            return min(self.floor(team, c) for c in self.disjunctions[id(z)])
        if id(z) not in self.conjunctions and id(z) not in self.predicates:
            return 0.0
        held, others = self.closure(z)
        best = self.effort(team, held)
        for other in others:
            if id(other) in self.disjunctions:
                options = [held | self.closure(c)[0] for c in self.disjunctions[id(other)]]
                best = max(best, min(self.effort(team, s) for s in options))
            else:
                best = max(best, self.floor(team, other))
        return best


def add_team_floors(
    model: ConcreteModel,
    ledger: Ledger,
    lps: Mapping[str, EffortLp],
    apart: Mapping[int, float],
    deadline: float = math.inf,
) -> int:
    """Add ``sum_{p in P_e} e_p >= J(h_e) x_e`` for every element of several agents whose floor
    exceeds ``apart[id(h_e)]`` (its agents' own floors added up); returns the count."""
    floors = TeamFloors(ledger, lps, deadline)
    count = 0
    for x, h_e, agents in ledger.elements:
        if len(agents) < 2:
            continue
        joint = floors.floor(tuple(sorted(agents)), h_e)
        if joint == INF:
            model.effort_floors.add(x <= 0)
        elif joint > apart.get(id(h_e), 0.0) + FLOOR_TOL:
            model.effort_floors.add(sum(model.e[p] for p in agents) >= joint * x)
        else:
            continue
        count += 1
    return count
