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

Serving two tasks. An agent that serves two tasks (on the farm one UV agent often serves crops A1
and A2) gets from the cuts above only the larger of the two floors, although it must reach both
regions, one after the other. For an agent ``p`` and two tasks ``T1``, ``T2`` that do not reuse
agents, let ``a_T = sum_{e in T, p in e} x_e`` (1 when ``p`` serves ``T``, else 0), and for an
element indicator ``h`` its *options*: the predicate sets on ``p`` reached through conjunctions
alone, from ``h`` itself, or from each child of ``h`` when ``h`` is a disjunction (``F[a,b]``: one
set per step). Then

    J_p(T1, T2) = min over elements e1 of T1 and e2 of T2 with p,
                  and over options O1 of h_e1 and O2 of h_e2, of E_p(O1 + O2)

bounds ``p``'s effort whenever it serves both: both element indicators are 1, each enforces one of
its options, and ``p`` meets their union. With ``f_e`` the floor of element ``e`` and
``F_T = max_e f_e``, the cut

    e_p >= sum_{e in T1} f_e x_e + sum_{e in T2} min(f_e, J_p - F_T1) x_e

holds at every plan: serving one task it is a cut above; serving both, its right side is at most
``F_T1 + J_p - F_T1``. Unlike the cuts above it adds the floors of two tasks up, so it binds when
the agent's shares of the tasks are fractional too, whenever the way between the tasks costs at
least the smaller floor. The same with ``T1`` and ``T2`` swapped, and ``e_p >= J_p (a_T1 + a_T2 -
1)``, which is tight when both shares are 1; ``a_T1 + a_T2 <= 1`` when no union can be met. Pairs with more than ``model.max_combinations`` unions get no cut.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import highspy
from pyomo.environ import ConcreteModel, ConstraintList, Var

from stlplan.mission.problem import Problem
from stlplan.planner.config import ModelConfig
from stlplan.planner.encoding.effort_lp import INF, AgentPredicate, EffortLp
from stlplan.planner.encoding.ledger import Ledger, conjunction_leaves
from stlplan.planner.encoding.team_floors import add_team_floors
from stlplan.planner.tolerances import FEASIBILITY

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
    max_options: int = ModelConfig().max_combinations
    """Most option unions (LPs) one agent and pair of tasks may take (``model.max_combinations``)."""

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
        reached, others = conjunction_leaves(z, self.conjunctions, self.predicates)
        sets: dict[str, set[AgentPredicate]] = {}
        for node in reached:
            found = self.predicates[id(node)]
            if found is not None:
                sets.setdefault(found[0], set()).add(found[1])
        return sets, others

    def floor(self, z: Any) -> Floor:
        """Per-agent effort floor of indicator ``z`` (empty for constants and unknown nodes)."""
        key = id(z)
        if key in self.floors:
            return self.floors[key]
        if key in self.disjunctions:
            parts = [self.floor(c) for c in self.disjunctions[key]]
            agents = sorted(set(itertools.chain.from_iterable(parts)))
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
    settings: ModelConfig | None = None,
    deadline: float = math.inf,
) -> int:
    """Add ``e_p = sum s_p`` and the floor cuts of every conjunction and choice; returns the count.

    ``model.s[p, k, j]`` are the absolute inputs; ``margin`` is the smallest admissible ``r``.
    After ``deadline`` (``time.perf_counter()`` time) no more floor LPs run and the remaining
    indicators get no cut (the floors are valid inequalities: fewer of them keep the optimum).
    ``settings`` bound the work (``model.max_combinations``).
    """
    settings = settings or ModelConfig()
    names = [a.name for a in problem.agents]
    lps = {a.name: EffortLp(a, problem.horizon, margin) for a in problem.agents}
    graph = FloorGraph(ledger, lps, deadline=deadline, max_options=settings.max_combinations)
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
            elif e > FEASIBILITY:
                model.effort_floors.add(model.e[p] >= e * z)
                count += 1
    for _, children, chosen in ledger.choices:
        parts = [graph.floor(c) for c in children]
        for child, part in zip(children, parts, strict=True):
            if INF in part.values():
                impossible[id(child)] = child
        for p in sorted(set(itertools.chain.from_iterable(parts))):
            terms = [(part.get(p, 0.0), w) for part, w in zip(parts, chosen, strict=True)]
            terms = [(e, w) for e, w in terms if FEASIBILITY < e < INF]
            if terms:
                model.effort_floors.add(model.e[p] >= sum(e * w for e, w in terms))
                count += 1
    for z in impossible.values():
        model.effort_floors.add(z <= 0)
    added, exclusive = service_floors(model, graph, ledger.services)
    own = {id(h): graph.floor(h) for _, h, _ in ledger.elements}
    solo = {
        (task, agent): list(zip(_weights(graph, agent, h), x, strict=True))
        for task, agent, h, x in ledger.services
    }
    count += added + add_team_floors(
        model, ledger, lps, own, solo, exclusive, deadline, settings.max_combinations
    )
    # the LPs sized HiGHS's process-wide thread pool; let the MILP size it afresh
    highspy.Highs.resetGlobalScheduler(True)
    return count + len(impossible)


def _options(graph: FloorGraph, agent: str, z: Any) -> list[frozenset[AgentPredicate]]:
    """The option sets of indicator ``z`` for ``agent`` (module docstring)."""
    tops = graph.disjunctions.get(id(z), [z])
    return [frozenset(graph.closure(top)[0].get(agent, ())) for top in tops]


def _joint_floor(
    graph: FloorGraph, agent: str, first: Sequence[Any], second: Sequence[Any]
) -> float:
    """``J_p``: least effort of ``agent`` meeting an option of each of two element indicators
    (0 when there are too many options to try)."""
    left = _distinct(o for h in first for o in _options(graph, agent, h))
    right = _distinct(o for h in second for o in _options(graph, agent, h))
    if len(left) * len(right) > graph.max_options:
        return 0.0
    return min(graph.effort_floor(agent, a | b) for a, b in itertools.product(left, right))


def _distinct(options: Iterable[frozenset[AgentPredicate]]) -> list[frozenset[AgentPredicate]]:
    """Each option once, in a fixed order: the LPs are warm-started from the last one solved,
    so their order must not follow the process's string hashing."""
    return sorted(set(options), key=lambda o: sorted(map(repr, o)))


def service_floors(
    model: ConcreteModel,
    graph: FloorGraph,
    services: Sequence[tuple[str, str, list[Any], list[Any]]],
) -> tuple[int, set[tuple[str, frozenset[str]]]]:
    """Add the cuts of two tasks served by one agent (module docstring); returns the count and
    the ``(agent, {task, task})`` that the agent cannot serve both of."""
    exclusive: set[tuple[str, frozenset[str]]] = set()
    by_agent: dict[str, list[tuple[str, str, list[Any], list[Any]]]] = {}
    for service in services:
        by_agent.setdefault(service[1], []).append(service)
    count = 0
    for agent, mine in by_agent.items():
        for (t1, _, h1, x1), (t2, _, h2, x2) in itertools.combinations(mine, 2):
            joint = _joint_floor(graph, agent, h1, h2)
            if joint <= FEASIBILITY:
                continue
            both = sum(x1) + sum(x2)
            if joint == INF:
                model.effort_floors.add(both <= 1)
                exclusive.add((agent, frozenset((t1, t2))))
            else:
                model.effort_floors.add(model.e[agent] >= joint * (both - 1))
            count += 1
            f1, f2 = _weights(graph, agent, h1), _weights(graph, agent, h2)
            cuts = {
                (tuple(f1), tuple(_capped(f2, joint - max(f1)))),
                (tuple(_capped(f1, joint - max(f2))), tuple(f2)),
            }
            for w1, w2 in cuts:
                terms = [w * x for w, x in zip(w1 + w2, x1 + x2, strict=True) if w > FEASIBILITY]
                if terms:
                    model.effort_floors.add(model.e[agent] >= sum(terms))
                    count += 1
    return count, exclusive


def _weights(graph: FloorGraph, agent: str, indicators: Sequence[Any]) -> list[float]:
    """The agent's floor of each element indicator (0 for an impossible one: it is held at 0)."""
    floors = (graph.floor(h).get(agent, 0.0) for h in indicators)
    return [f if f < INF else 0.0 for f in floors]


def _capped(weights: Sequence[float], cap: float) -> list[float]:
    return [max(0.0, min(w, cap)) for w in weights]
