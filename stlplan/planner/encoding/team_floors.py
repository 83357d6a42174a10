"""Element floors: the least effort an element's agents need together.

The per-agent floors (:mod:`stlplan.planner.encoding.floors`) bound each agent apart and skip
predicates on several agents, such as a formation's ``dist(p, q) <= d``: two agents that start
apart must both move to meet, which no per-agent floor sees, so HiGHS branches long over who
pairs with whom. For an element ``e`` of several agents ``P_e`` whose formula's indicator is
``h_e``, the team LP

    E_e(S) = min sum_{p in P_e} e_p  s.t.  each agent's dynamics from x_p^0 and its boxes,
                                          alpha(x(k)) >= r_min  for every (alpha, k) in S

takes predicates on any of the agents. The floor ``J`` of an indicator is

* predicate or conjunction: with ``S`` every predicate reached through conjunctions alone and
  ``d^1..d^m`` the disjunctions reached, ``min E_e(S + S^1_i + ... + S^m_j)`` over one child of
  each (``S^l_i`` reached from child ``i`` of ``d^l`` likewise) while there are at most
  ``model.max_combinations`` combinations, else the largest of ``E_e(S)`` and each
  ``min_i E_e(S + S^l_i)``; any other child ``d`` gives ``J(d)`` too (the largest counts);
* disjunction: ``min_i J(d_i)``.

Both keep the optimum for the reason the per-agent cuts do: at a plan whose indicators are 1
exactly where it needs them, ``x_e = 1`` forces ``h_e = 1``, every conjunction below forces its
children and every disjunction one child, so the plan meets ``S`` and one child of each, and its
agents' effort is at least the LP's least. A floor infinite (no trajectory of the agents meets
the element) holds ``x_e = 0``.

*Shares.* The row ``sum_{p in P_e} e_p >= J(h_e) x_e`` is weak where the choice is fractional:
with ``x_e = 1/4`` on four elements holding ``p``, each row asks a quarter and one effort
``e_p`` pays all four. In a task that reuses no agent at most one element holding ``p`` is
chosen, so the element gets shares ``s_pe >= 0`` (``s_pe = e_p x_e`` in a plan) with

    sum_{p in P_e} s_pe >= J(h_e) x_e,    s_pe >= J_p(h_e) x_e,    e_p >= sum_{e holding p} s_pe,

``J_p`` the agent's own floor: the LP pays the elements' floors in proportion to their choice,
and summing the rows bounds the task's effort by the least fractional choice of ``c`` elements.
When an agent can serve at most one of several tasks (their options together admit no
trajectory of it), its shares of them add up too: ``e_p >= sum_T a_pT``, with ``a_pT`` its
shares of ``T`` or ``sum_e J_p(h_e) x_e``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import highspy
import numpy as np
from pyomo.environ import ConcreteModel, VarList

from stlplan.formula.tree import Predicate
from stlplan.planner.config import ModelConfig
from stlplan.planner.encoding.effort_lp import (
    INF,
    EffortLp,
    add_dense_rows,
    least_effort,
)
from stlplan.planner.encoding.ledger import Ledger, conjunction_leaves
from stlplan.planner.tolerances import FEASIBILITY

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
    max_combinations: int = ModelConfig().max_combinations
    """Most combinations of one child per disjunction that :meth:`floor` solves together
    (beyond it, each disjunction is bounded apart; ``model.max_combinations``)."""
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
        choices = list({id(o): o for o in others if id(o) in self.disjunctions}.values())
        for other in others:
            if id(other) not in self.disjunctions:
                best = max(best, self.floor(team, other))
        if math.prod(len(self.disjunctions[id(d)]) for d in choices) <= self.max_combinations:
            return max(best, self._combined(team, held, choices))
        for other in choices:
            options = [held | self.closure(c)[0] for c in self.disjunctions[id(other)]]
            best = max(best, min(self.effort(team, s) for s in options))
        return best

    def _combined(
        self, team: tuple[str, ...], held: frozenset[TeamPredicate], choices: Sequence[Any]
    ) -> float:
        """``min E_e(S + S_i + S_j + ...)`` over one child of each disjunction in ``choices``."""
        unions = [held]
        for choice in choices:
            children = [self.closure(c)[0] for c in self.disjunctions[id(choice)]]
            unions = [u | c for u in unions for c in children]
        return min(self.effort(team, u) for u in unions)


def add_team_floors(
    model: ConcreteModel,
    ledger: Ledger,
    lps: Mapping[str, EffortLp],
    own: Mapping[int, Mapping[str, float]],
    solo: Mapping[tuple[str, str], Sequence[tuple[float, Any]]],
    exclusive: set[tuple[str, frozenset[str]]],
    deadline: float = math.inf,
    max_combinations: int = ModelConfig().max_combinations,
) -> int:
    """Add the team floor of every element of several agents whose floor exceeds its agents'
    own floors (``own[id(h_e)]``) added up: by shares in a task that reuses no agent, else
    ``sum_{p in P_e} e_p >= J(h_e) x_e`` (module docstring). ``solo`` holds each agent's own
    floors per task, ``(J_p(h_e), x_e)``, and ``exclusive`` the ``(agent, {task, task})`` it
    cannot serve both of. Returns the count."""
    floors = TeamFloors(ledger, lps, deadline, max_combinations=max_combinations)
    task_of = shared_tasks(ledger)
    model.team_shares = VarList(bounds=(0.0, None))
    shares: dict[tuple[str, str], list[Any]] = {}
    count = 0
    for x, h_e, agents in ledger.elements:
        if len(agents) < 2:
            continue
        joint = floors.floor(tuple(sorted(agents)), h_e)
        alone = own.get(id(h_e), {})
        if joint == INF:
            model.effort_floors.add(x <= 0)
        elif joint <= sum(alone.values()) + FEASIBILITY:
            continue
        elif id(x) in task_of:
            for p, share in _element_shares(model, x, joint, agents, alone).items():
                shares.setdefault((task_of[id(x)], p), []).append(share)
        else:
            model.effort_floors.add(sum(model.e[p] for p in agents) >= joint * x)
        count += 1
    for (_, p), mine in shares.items():
        model.effort_floors.add(model.e[p] >= sum(mine))
    return count + _across_tasks(model, shares, solo, exclusive)


def shared_tasks(ledger: Ledger) -> dict[int, str]:
    """``id(x_e)`` to the task of every element whose task reuses no agent (its floor is paid
    by shares)."""
    return {id(x): task for task, _, _, xs in ledger.services for x in xs}


def _element_shares(
    model: ConcreteModel, x: Any, joint: float, agents: Sequence[str], alone: Mapping[str, float]
) -> dict[str, Any]:
    """Shares ``s_pe`` with ``sum_p s_pe >= J x_e`` and ``s_pe >= J_p x_e``, by agent."""
    mine = {p: model.team_shares.add() for p in agents}
    model.effort_floors.add(sum(mine.values()) >= joint * x)
    for p, share in mine.items():
        if FEASIBILITY < alone.get(p, 0.0) < INF:
            model.effort_floors.add(share >= alone[p] * x)
    return mine


def _across_tasks(
    model: ConcreteModel,
    shares: Mapping[tuple[str, str], list[Any]],
    solo: Mapping[tuple[str, str], Sequence[tuple[float, Any]]],
    exclusive: set[tuple[str, frozenset[str]]],
) -> int:
    """``e_p >= sum_T a_pT`` over tasks ``T`` that agent ``p`` can serve at most one of, with
    ``a_pT`` its shares of ``T`` (or, without shares, ``sum_e J_p(h_e) x_e``); returns the
    count. At most one ``a_pT`` is nonzero in a plan, so the row holds; one row per task with
    shares, over a greedy set of tasks pairwise exclusive with it."""
    count = 0
    for task, p in shares:
        others = [t for t, q in solo if q == p and (p, frozenset((task, t))) in exclusive]
        chosen = [task]
        for other in others:
            if all((p, frozenset((other, t))) in exclusive for t in chosen):
                chosen.append(other)
        if len(chosen) < 2:
            continue
        terms = [v for t in chosen for v in shares.get((t, p), [])]
        terms += [w * x for t in chosen if (t, p) not in shares for w, x in solo[(t, p)]]
        model.effort_floors.add(model.e[p] >= sum(terms))
        count += 1
    return count
