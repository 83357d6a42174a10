"""A checked mission in the form the encoder and the monitor read.

:func:`build_problem` parses every formula, runs the semantic checks of :mod:`stlplan.mission.checks`, and
enumerates each task's elements (groups only on demand). Agents carry numpy matrices; formulas stay surface
trees and are lowered per role binding with :meth:`Problem.lowered`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from stlplan.errors import MissionError
from stlplan.formula.normal import HalfSpaces, lower
from stlplan.formula.parser import parse
from stlplan.formula.tree import (
    Formula,
    Predicate,
    horizon,
    is_team_role,
    roles,
    team_atoms,
    team_role,
)
from stlplan.mission import checks
from stlplan.mission.groups import Element, RoleRule, elements, iter_groups, pack
from stlplan.mission.schema import Mission, PinnedRole, Region


@dataclass(frozen=True, eq=False)
class AgentModel:
    """An agent with its dynamics as arrays."""

    name: str
    capabilities: frozenset[str]
    A: np.ndarray
    B: np.ndarray
    position: tuple[int, int]
    state_lo: np.ndarray
    state_hi: np.ndarray
    input_lo: np.ndarray
    input_hi: np.ndarray
    initial_state: np.ndarray
    at_rest: bool = False
    """The agent must end at rest: ``(A - I) x(H) = 0``."""

    def rest_rows(self) -> np.ndarray:
        """The rows of ``A - I`` that are not zero: ``rows @ x(H) = 0`` is "at rest"."""
        rows = self.A - np.eye(self.n)
        return rows[np.any(rows != 0, axis=1)]

    @property
    def n(self) -> int:
        """State dimension."""
        return int(self.A.shape[0])

    @property
    def m(self) -> int:
        """Input dimension."""
        return int(self.B.shape[1])


@dataclass(frozen=True)
class SyncWindow:
    """``F[a,b] <G[0,d] phi, ...>``: start window ``[a, b]``, hold ``d``, upper bound gamma."""

    a: int
    b: int
    d: int
    gamma: float


@dataclass(frozen=True, eq=False)
class TaskModel:
    """A task ``<phi, c, Pattern>`` with its elements enumerated; its groups only on demand."""

    name: str
    formula: Formula
    count: int
    roles: tuple[str, ...]
    rules: Mapping[str, RoleRule]
    reuse_agents: bool
    elements: tuple[Element, ...]
    sync: SyncWindow | None = None
    team: tuple[str, ...] = ()
    """The agents the formula's counts read (``count``, ``visits``), beside its roles'."""

    @cached_property
    def groups(self) -> tuple[tuple[int, ...], ...]:
        """Every group, as increasing element indices (the paper's enumeration; it can be huge:
        see :func:`stlplan.mission.groups.count_groups` before asking)."""
        return tuple(iter_groups(self.elements, self.count, self.reuse_agents))

    def binding(self, element: Element) -> dict[str, str]:
        """Role to agent name for one element (and each agent a count reads, under its team
        role)."""
        return dict(zip(self.roles, element, strict=False)) | team_binding(self.team)

    def agents(self) -> set[str]:
        """Every agent some element binds or a count reads."""
        return {a for e in self.elements for a in e} | set(self.team)


@dataclass(frozen=True, eq=False)
class ConstraintModel:
    """Plain STL that must hold at step 0 under each role binding."""

    name: str
    formula: Formula
    bindings: tuple[Mapping[str, str], ...]


@dataclass(frozen=True)
class Recovery:
    """A pair the executed past left closer than the separation at the replan's step
    (:mod:`stlplan.analysis.recovery`)."""

    closest: float
    """Their infinity-norm distance at ``K``: the plan keeps them at least this far apart."""
    restored: int | None
    """The first step from which the full separation holds again (None: none before the
    horizon the dynamics allow)."""


@dataclass(frozen=True)
class Past:
    """The executed past of a replan and its events.

    Attributes
    ----------
    step
        ``K``: the states of steps ``0..K`` are executed; inputs are planned from ``K`` on.
    states
        Agent name to its executed states, shape ``(K+1, n)``.
    lost
        Agents lost at ``K``: no inputs from ``K`` on, the state of ``K`` kept to the end.
    closed
        Regions closed at ``K``: an obstacle for every agent not lost, from ``K`` on.
    recovering
        The pairs ``(p, q)`` (in the agents' order) closer than the separation at ``K`` (a part
        of the team reads those of its own agents).
    """

    step: int
    states: Mapping[str, np.ndarray]
    lost: frozenset[str] = frozenset()
    closed: tuple[str, ...] = ()
    recovering: Mapping[tuple[str, str], Recovery] = field(default_factory=dict)

    def known_through(self, agent: str, horizon: int) -> int:
        """The last step whose state is data: ``K``, or ``H`` for a lost agent."""
        return horizon if agent in self.lost else self.step

    def state(self, agent: str, k: int) -> np.ndarray:
        """The known state of ``agent`` at step ``k`` (a lost agent keeps its state of ``K``)."""
        return self.states[agent][min(k, self.step)]

    def events(self) -> list[str]:
        """The events, in words (``vis1 lost``, ``C closed``)."""
        return [f"{a} lost" for a in sorted(self.lost)] + [f"{r} closed" for r in self.closed]

    def closures(self) -> dict[str, str]:
        """The names of the constraints each closed region becomes (``closed C``, and ``closed C
        (leaving)`` for the agents inside it at ``K``) -> the region."""
        names: dict[str, str] = {}
        for region in self.closed:
            names |= {f"closed {region}": region, f"closed {region} (leaving)": region}
        return names


@dataclass(frozen=True, eq=False)
class Problem:
    """Everything the planner and the monitor need from a mission."""

    mission: Mission
    horizon: int
    agents: tuple[AgentModel, ...]
    regions: Mapping[str, HalfSpaces]
    tasks: tuple[TaskModel, ...]
    constraints: tuple[ConstraintModel, ...]
    separation: float | None
    source: str | None = None
    inter_sample: bool = True
    """Safety requirements hold on the segments between steps (DESIGN 2.9), not only at steps."""
    robust_to: float = 0.0
    """W: the planner keeps every predicate after the first planned step above what one step of
    an additive disturbance bounded by W per state component can use up (the monitor judges the
    predicates as they are)."""
    past: Past | None = None
    """A replan's executed past and events (:mod:`stlplan.mission.past`); None for a plan from
    the initial states."""
    _by_name: dict[str, AgentModel] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._by_name.update({a.name: a for a in self.agents})

    def agent(self, name: str) -> AgentModel:
        """The agent called ``name``."""
        return self._by_name[name]

    def robust(self, disturbance: float) -> Problem:
        """The same problem, planned to withstand ``disturbance`` (:meth:`tightening`)."""
        if disturbance == self.robust_to:
            return self
        robust = replace(self, robust_to=float(disturbance), _by_name={})
        for agent in robust.agents:
            room = robust.input_room(agent, robust.horizon)
            if np.any(2 * room >= agent.input_hi - agent.input_lo):
                raise MissionError(
                    f"a disturbance of {disturbance:g} per state component needs more input than "
                    f"agent '{agent.name}' has to cancel it; expected a smaller --robust-to",
                    where="execution.disturbance",
                )
        return robust

    def with_inter_sample(self, on: bool | None) -> Problem:
        """The same problem with inter-sample safety on or off (None keeps the mission's)."""
        if on is None or on == self.inter_sample:
            return self
        return replace(self, inter_sample=on, _by_name={})

    def in_past(self, part: Formula, k: int) -> bool:
        """Whether ``part`` at step ``k`` reads a replan's executed states before ``K`` only:
        data, not planned (constraints and separation are planned from ``K``, whose part starts
        the segment to ``K+1``)."""
        return self.past is not None and k + horizon(part) < self.past.step

    def separated_from(self, p: str, q: str) -> int:
        """The first step at which ``p`` and ``q`` (in the agents' order) are held to the full
        separation: 0, or for a pair the executed past left too close, the step it is restored
        (``H + 1``: never; :mod:`stlplan.analysis.recovery`)."""
        recovery = None if self.past is None else self.past.recovering.get((p, q))
        if recovery is None:
            return 0
        return self.horizon + 1 if recovery.restored is None else recovery.restored

    def tightening(self, node: Predicate, k: int) -> float:
        """How much the planner raises ``node``'s margin at step ``k``: ``W sum |coef|`` (the
        most one step of the disturbance can move ``alpha``) after the first step it plans
        (step 0, or a replan's ``K``: known states are not disturbed), else 0."""
        first = 0 if self.past is None else self.past.step
        if self.robust_to <= 0 or k <= first:
            return 0.0
        return self.robust_to * sum(abs(t.coef) for t in node.terms)

    def input_room(self, agent: AgentModel, k: int) -> np.ndarray:
        """How much the planner narrows ``agent``'s input box at step ``k`` (per component):
        ``W |B^+| 1`` after the first step it plans, for an agent whose ``B`` can cancel any
        disturbance in one step (full row rank), so that the next replan can; else 0."""
        first = 0 if self.past is None else self.past.step
        room = np.zeros(agent.m)
        if self.robust_to > 0 and k > first and np.linalg.matrix_rank(agent.B) == agent.n:
            room = self.robust_to * np.abs(np.linalg.pinv(agent.B)).sum(axis=1)
        return room

    def known_through(self, agent: str) -> int:
        """The last step whose state of ``agent`` is data: 0 (its initial state), a replan's
        ``K``, or ``H`` for an agent lost."""
        return 0 if self.past is None else self.past.known_through(agent, self.horizon)

    def lowered(self, formula: Formula, binding: Mapping[str, str]) -> Formula:
        """``formula`` with roles bound to agents, as half-space predicates over roles."""
        positions = {role: self.agent(name).position for role, name in binding.items()}
        capabilities = {
            role: self.agent(name).capabilities
            for role, name in binding.items()
            if is_team_role(role)
        }
        return lower(formula, self.regions, positions, capabilities)


def team_binding(agents: tuple[str, ...]) -> dict[str, str]:
    """Each agent a count reads, under its team role."""
    return {team_role(a): a for a in agents}


def counted_agents(mission: Mission, formula: Formula) -> tuple[str, ...]:
    """The agents (in the team's order) that some count of ``formula`` reads."""
    counts = team_atoms(formula)
    return tuple(
        a.name
        for a in mission.agents
        if any(c.who.admits(frozenset(a.capabilities)) for c in counts)
    )


def region_halfspaces(region: Region) -> HalfSpaces:
    """``(G, h)`` with rows scaled to unit Euclidean norm (boxes: 4 axis rows)."""
    if region.box is not None:
        (xl, xh), (yl, yh) = region.box
        return ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)), (xh, -xl, yh, -yl)
    assert region.G is not None and region.h is not None
    rows, rhs = [], []
    for g, h in zip(region.G, region.h, strict=False):
        norm = float(np.hypot(*g)) or 1.0
        rows.append((g[0] / norm, g[1] / norm))
        rhs.append(h / norm)
    return tuple(rows), tuple(rhs)


def _agent_model(mission: Mission, index: int) -> AgentModel:
    spec = mission.agents[index]
    dyn = mission.dynamics[spec.dynamics]
    sb, ib = np.array(dyn.state_bounds, dtype=float), np.array(dyn.input_bounds, dtype=float)
    return AgentModel(
        name=spec.name,
        capabilities=frozenset(spec.capabilities),
        A=np.array(dyn.A, dtype=float),
        B=np.array(dyn.B, dtype=float),
        position=dyn.position,
        state_lo=sb[:, 0],
        state_hi=sb[:, 1],
        input_lo=ib[:, 0],
        input_hi=ib[:, 1],
        initial_state=np.array(spec.initial_state, dtype=float),
        at_rest=spec.final == "at_rest",
    )


def _rule(rule: str | list[str] | PinnedRole) -> RoleRule:
    if isinstance(rule, PinnedRole):
        return RoleRule(agent=rule.agent)
    return RoleRule(capabilities=frozenset([rule] if isinstance(rule, str) else rule))


def _task_model(mission: Mission, name: str, source: str | None) -> TaskModel:
    spec = mission.tasks[name]
    formula = parse(spec.formula, source=source, where=f"tasks.{name}.formula")
    checks.check_task(mission, name, formula, source)
    order = roles(formula)
    rules = {r: _rule(spec.roles[r]) for r in order}
    team = {a.name: frozenset(a.capabilities) for a in mission.agents}
    elems = elements(order, rules, team)
    found = pack(elems, range(len(elems)), spec.count, spec.reuse_agents)
    checks.check_groups(mission, name, len(elems), found is not None, source)
    sync = None
    if spec.synchronous is not None:
        s = spec.synchronous
        gamma = mission.objective.gamma if s.gamma is None else s.gamma
        sync = SyncWindow(s.within[0], s.within[1], s.hold, gamma)
    counted = counted_agents(mission, formula)
    return TaskModel(
        name, formula, spec.count, order, rules, spec.reuse_agents, elems, sync, counted
    )


def _constraint_model(mission: Mission, name: str, source: str | None) -> ConstraintModel:
    spec = mission.constraints[name]
    formula = parse(spec.formula, source=source, where=f"constraints.{name}.formula")
    checks.check_constraint(mission, name, formula, source)
    team = team_binding(counted_agents(mission, formula))
    if spec.for_each is None:
        return ConstraintModel(name, formula, (dict(spec.roles) | team,))
    pool = spec.agents if spec.agents is not None else [a.name for a in mission.agents]
    pinned = set(spec.roles.values())
    bindings = tuple({**spec.roles, spec.for_each: a, **team} for a in pool if a not in pinned)
    return ConstraintModel(name, formula, bindings)


def build_problem(mission: Mission, source: str | None = None) -> Problem:
    """Check ``mission`` and build its :class:`Problem`.

    Raises
    ------
    MissionError, FormulaError
        On the first inconsistency, naming the field path.
    """
    checks.check_mission(mission, source)
    return Problem(
        mission=mission,
        horizon=mission.horizon,
        agents=tuple(_agent_model(mission, i) for i in range(len(mission.agents))),
        regions={n: region_halfspaces(r) for n, r in mission.regions.items()},
        tasks=tuple(_task_model(mission, n, source) for n in mission.tasks),
        constraints=tuple(_constraint_model(mission, n, source) for n in mission.constraints),
        separation=mission.separation,
        source=source,
        inter_sample=mission.safety.inter_sample,
    )
