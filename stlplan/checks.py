"""Semantic checks of a mission the schema accepted: one clear message per mistake.

Each check raises :class:`MissionError` (or :class:`FormulaError`) naming the field path and what
was expected. They run in the order a reader meets the file: dynamics, agents, regions, tasks,
constraints, objective.
"""

from __future__ import annotations

import math
import re
from difflib import get_close_matches
from typing import NoReturn

import numpy as np

from stlplan.errors import FormulaError, MissionError
from stlplan.formula.parser import to_text
from stlplan.formula.tree import (
    Atom,
    Distance,
    Formula,
    Linear,
    Predicate,
    atoms,
    horizon,
    regions,
    roles,
)
from stlplan.mission import Constraint, Dynamics, Mission, PinnedRole, Synchronous, Task

MAX_HORIZON = 100_000
"""Largest horizon H (states are stored for every step)."""
MAX_ELEMENTS = 10_000
"""Elements a task's roles may admit (they are enumerated)."""
MAX_GROUPS = 1_000_000
"""Bound on the groups (and partial groups) enumerated for one task."""
ROLE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _fail(message: str, where: str, source: str | None) -> NoReturn:
    raise MissionError(message, source=source, where=where)


def _did_you_mean(name: str, options: list[str]) -> str:
    close = get_close_matches(name, options, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _undefined(kind: str, name: str, options: list[str]) -> str:
    known = ", ".join(options) if options else "none"
    return f"undefined {kind} '{name}'{_did_you_mean(name, options)}; defined: {known}"


def check_dynamics(mission: Mission, source: str | None) -> None:
    """Matrix shapes, position components and bound intervals of every dynamics model."""
    for name, dyn in mission.dynamics.items():
        where = f"dynamics.{name}"
        n, m = _check_matrices(dyn, where, source)
        for field, bounds, size, kind in (
            ("state_bounds", dyn.state_bounds, n, "state"),
            ("input_bounds", dyn.input_bounds, m, "input"),
        ):
            if len(bounds) != size:
                _fail(
                    f"expected {size} {kind} bounds (one per {kind} component), found "
                    f"{len(bounds)}",
                    f"{where}.{field}",
                    source,
                )
            for i, (lo, hi) in enumerate(bounds):
                if lo > hi:
                    _fail(
                        f"empty interval [{lo}, {hi}]: low must be <= high",
                        f"{where}.{field}[{i}]",
                        source,
                    )
        i, j = dyn.position
        if i == j or not (0 <= i < n and 0 <= j < n):
            _fail(
                f"position must name two distinct state components in 0..{n - 1}, found [{i}, {j}]",
                f"{where}.position",
                source,
            )


def _check_matrices(dyn: Dynamics, where: str, source: str | None) -> tuple[int, int]:
    """``A`` is n x n and ``B`` is n x m with m >= 1; returns ``(n, m)``."""
    n = len(dyn.A)
    if n == 0 or any(len(row) != n for row in dyn.A):
        _fail(
            f"A must be a non-empty square matrix (n x n), found rows of lengths "
            f"{[len(r) for r in dyn.A]}",
            f"{where}.A",
            source,
        )
    if len(dyn.B) != n:
        _fail(f"B must have n = {n} rows (as A), found {len(dyn.B)}", f"{where}.B", source)
    m = len(dyn.B[0])
    if m == 0:
        _fail("B needs at least one column (one per input component)", f"{where}.B", source)
    for k, row in enumerate(dyn.B):
        if len(row) != m:
            _fail(
                f"every row of B must have m = {m} entries (as B[0]), found {len(row)}",
                f"{where}.B[{k}]",
                source,
            )
    return n, m


def check_agents(mission: Mission, source: str | None) -> None:
    """Unique names, defined dynamics, initial state length and bounds."""
    seen: set[str] = set()
    for k, agent in enumerate(mission.agents):
        where = f"agents[{k}]"
        if agent.name in seen:
            _fail(f"duplicate agent name '{agent.name}'", f"{where}.name", source)
        seen.add(agent.name)
        if agent.dynamics not in mission.dynamics:
            _fail(
                _undefined("dynamics", agent.dynamics, list(mission.dynamics)),
                f"{where}.dynamics",
                source,
            )
        dyn = mission.dynamics[agent.dynamics]
        if len(agent.initial_state) != len(dyn.A):
            _fail(
                f"initial_state has {len(agent.initial_state)} values, dynamics "
                f"'{agent.dynamics}' has {len(dyn.A)} state components",
                f"{where}.initial_state",
                source,
            )
        for i, (x, (lo, hi)) in enumerate(zip(agent.initial_state, dyn.state_bounds, strict=True)):
            if not lo <= x <= hi:
                _fail(
                    f"initial state {x} is outside its bounds [{lo}, {hi}]",
                    f"{where}.initial_state[{i}]",
                    source,
                )


def check_regions(mission: Mission, source: str | None) -> None:
    """Non-empty boxes and consistent polytope shapes."""
    for name, region in mission.regions.items():
        where = f"regions.{name}"
        if region.box is not None:
            for axis, (lo, hi) in zip("xy", region.box, strict=True):
                if lo >= hi:
                    _fail(
                        f"empty box: {axis} interval [{lo}, {hi}] needs low < high",
                        f"{where}.box",
                        source,
                    )
        elif region.G is not None and region.h is not None:
            if len(region.G) != len(region.h):
                _fail(
                    f"G has {len(region.G)} rows but h has {len(region.h)} entries",
                    f"{where}.h",
                    source,
                )
            if not region.G:
                _fail("a polytope needs at least one row [g_x, g_y] in G", f"{where}.G", source)
            if any(np.hypot(*g) == 0 for g in region.G):
                _fail("a row of G is zero", f"{where}.G", source)


def _formula_fits(
    mission: Mission,
    formula: Formula,
    where: str,
    role_agents: dict[str, list[str]],
    reach: int,
    source: str | None,
) -> None:
    for region in regions(formula):
        if region not in mission.regions:
            raise FormulaError(
                _undefined("region", region, list(mission.regions)), source=source, where=where
            )
    if reach > mission.horizon:
        raise FormulaError(
            f"the formula needs steps up to {reach}, past the horizon {mission.horizon}",
            source=source,
            where=where,
        )
    dims = {
        a.name: len(mission.dynamics[a.dynamics].A)
        for a in mission.agents
        if a.dynamics in mission.dynamics
    }
    for atom in atoms(formula):
        if not all(math.isfinite(v) for v in _numbers(atom)):
            raise FormulaError(
                f"'{to_text(atom)}' has a number that is not finite (too large)",
                source=source,
                where=where,
            )
        if isinstance(atom, Linear):
            for term in atom.terms:
                for agent in role_agents.get(term.role, []):
                    if term.component >= dims[agent]:
                        raise FormulaError(
                            f"{term.role}.x[{term.component}] is out of range: agent '{agent}' has "
                            f"{dims[agent]} state components",
                            source=source,
                            where=where,
                        )


def _numbers(atom: Atom) -> tuple[float, ...]:
    if isinstance(atom, Distance):
        return (atom.radius,)
    if isinstance(atom, (Linear, Predicate)):
        return (*(t.coef for t in atom.terms), atom.bound)
    return ()


def check_task(mission: Mission, name: str, formula: Formula, source: str | None) -> None:
    """Roles declared and used, capabilities and agents known, formula within the horizon."""
    task = mission.tasks[name]
    where = f"tasks.{name}"
    used, declared = roles(formula), list(task.roles)
    for role in declared:
        _check_role_name(role, f"{where}.roles.{role}", source)
    for role in used:
        if role not in task.roles:
            raise FormulaError(
                f"role '{role}' is used by the formula but not declared in "
                f"'roles'{_did_you_mean(role, declared)}; declared: "
                f"{', '.join(declared) or 'none'}",
                source=source,
                where=f"{where}.formula",
            )
    for role in declared:
        if role not in used:
            _fail(
                f"role '{role}' is not used by the formula (roles used: {', '.join(used)})",
                f"{where}.roles.{role}",
                source,
            )
    role_agents = {
        r: _role_agents(mission, task.roles[r], f"{where}.roles.{r}", source) for r in used
    }
    _check_pattern_size(task, role_agents, where, source)
    _formula_fits(mission, formula, f"{where}.formula", role_agents, horizon(formula), source)
    if task.synchronous is not None:
        check_window(
            task.synchronous,
            mission.horizon,
            horizon(formula),
            f"{where}.synchronous.within",
            source,
        )


def _check_role_name(role: str, where: str, source: str | None) -> None:
    if not ROLE_NAME.fullmatch(role):
        _fail(f"expected a role name (letters, digits, '_'), found '{role}'", where, source)


def _check_pattern_size(
    task: Task, role_agents: dict[str, list[str]], where: str, source: str | None
) -> None:
    """Bound what :mod:`stlplan.groups` enumerates: elements <= product of the role pools,
    (partial) groups <= sum_{k <= count} C(elements, k)."""
    n_elements = math.prod(len(agents) for agents in role_agents.values())
    if n_elements > MAX_ELEMENTS:
        _fail(
            f"the roles admit up to {n_elements} elements; expected at most {MAX_ELEMENTS} "
            "(narrow the roles' capabilities)",
            f"{where}.roles",
            source,
        )
    partial = 0
    for k in range(min(task.count, n_elements) + 1):
        partial += math.comb(n_elements, k)
        if partial > MAX_GROUPS:
            _fail(
                f"count {task.count} over up to {n_elements} elements allows more than "
                f"{MAX_GROUPS} groups; expected fewer (lower count or narrow the roles)",
                f"{where}.count",
                source,
            )


def check_window(
    sync: Synchronous, horizon_steps: int, reach: int, where: str, source: str | None
) -> None:
    """A synchronous window ``F[a,b] G[0,d] phi`` must fit the horizon: ``b + d + h(phi) <= H``.

    ``reach`` is ``h(phi)``, the steps past ``k`` that deciding phi at ``k`` needs.
    """
    (a, b), d = sync.within, sync.hold
    if a < 0 or b < a:
        _fail(f"window [{a}, {b}] must satisfy 0 <= a <= b", where, source)
    if b + d + reach > horizon_steps:
        phi = f" + {reach} (phi)" if reach else ""
        _fail(
            f"the synchronous window F[{a},{b}] G[0,{d}] needs steps up to {b} + {d}{phi} = "
            f"{b + d + reach}, past the horizon {horizon_steps}",
            where,
            source,
        )


def _role_agents(
    mission: Mission, rule: str | list[str] | PinnedRole, where: str, source: str | None
) -> list[str]:
    names = [a.name for a in mission.agents]
    if isinstance(rule, PinnedRole):
        if rule.agent not in names:
            _fail(_undefined("agent", rule.agent, names), f"{where}.agent", source)
        return [rule.agent]
    wanted = [rule] if isinstance(rule, str) else rule
    known = sorted({c for a in mission.agents for c in a.capabilities})
    for cap in wanted:
        if cap not in known:
            _fail(
                f"no agent has capability '{cap}'{_did_you_mean(cap, known)}; capabilities of "
                f"the team: {', '.join(known) or 'none'}",
                where,
                source,
            )
    fit = _fitting(mission, rule)
    if not fit:
        _fail(f"no agent has all of the capabilities {wanted}", where, source)
    return fit


def check_groups(
    mission: Mission, name: str, n_elements: int, n_groups: int, source: str | None
) -> None:
    """A Pattern must admit at least one group of ``count`` elements."""
    task = mission.tasks[name]
    if n_groups > 0:
        return
    c = task.count
    reuse = "" if task.reuse_agents else " that share no agent"
    shortage = (
        f"the Pattern admits only {n_elements} element(s)"
        if n_elements < c
        else f"no {c} of its {n_elements} elements share no agent"
    )
    fits = "; ".join(
        f"{role}: {', '.join(_fitting(mission, rule)) or 'none'}"
        for role, rule in task.roles.items()
    )
    _fail(
        f"count {c} needs {c} elements{reuse}, but {shortage} (agents that fit each role: "
        f"{fits}); add agents or lower count",
        f"tasks.{name}.count",
        source,
    )


def _fitting(mission: Mission, rule: str | list[str] | PinnedRole) -> list[str]:
    """Agents that may fill a role: the pinned one, or those with every capability listed."""
    if isinstance(rule, PinnedRole):
        return [rule.agent]
    wanted = {rule} if isinstance(rule, str) else set(rule)
    return [a.name for a in mission.agents if wanted <= set(a.capabilities)]


def check_constraint(mission: Mission, name: str, formula: Formula, source: str | None) -> None:
    """Roles bound (by for_each or pinned), agents known, formula within the horizon."""
    spec = mission.constraints[name]
    where = f"constraints.{name}"
    names = [a.name for a in mission.agents]
    for role in spec.roles:
        _check_role_name(role, f"{where}.roles.{role}", source)
    if spec.for_each is not None:
        _check_role_name(spec.for_each, f"{where}.for_each", source)
    for role, agent in spec.roles.items():
        if agent not in names:
            _fail(_undefined("agent", agent, names), f"{where}.roles.{role}", source)
    for k, agent in enumerate(spec.agents or []):
        if agent not in names:
            _fail(_undefined("agent", agent, names), f"{where}.agents[{k}]", source)
    if spec.agents is not None and spec.for_each is None:
        _fail(
            "'agents' needs 'for_each' (the role that ranges over them)", f"{where}.agents", source
        )
    _constraint_roles(spec, roles(formula), where, source)
    pool = spec.agents if spec.agents is not None else names
    role_agents = {r: [a] for r, a in spec.roles.items()}
    if spec.for_each is not None:
        role_agents[spec.for_each] = list(pool)
    _formula_fits(mission, formula, f"{where}.formula", role_agents, horizon(formula), source)


def _constraint_roles(
    spec: Constraint, used: tuple[str, ...], where: str, source: str | None
) -> None:
    """Every role of the formula is bound exactly once, and every bound role is used."""
    bound = [*spec.roles, *([spec.for_each] if spec.for_each is not None else [])]
    if spec.for_each is not None and spec.for_each in spec.roles:
        _fail(
            f"role '{spec.for_each}' is both 'for_each' and pinned in 'roles'; use one",
            f"{where}.for_each",
            source,
        )
    for role in used:
        if role not in bound:
            raise FormulaError(
                f"role '{role}' is neither 'for_each' nor in 'roles'{_did_you_mean(role, bound)}"
                f"; bound roles: {', '.join(bound) or 'none'}",
                source=source,
                where=f"{where}.formula",
            )
    for role in bound:
        if role not in used:
            field = "for_each" if role == spec.for_each else f"roles.{role}"
            _fail(
                f"role '{role}' is not used by the formula (roles used: "
                f"{', '.join(used) or 'none'})",
                f"{where}.{field}",
                source,
            )


def check_mission(mission: Mission, source: str | None) -> None:
    """Every whole-mission check that needs no parsed formula."""
    if mission.horizon > MAX_HORIZON:
        _fail(
            f"expected a horizon of at most {MAX_HORIZON} steps, found {mission.horizon}",
            "horizon",
            source,
        )
    check_dynamics(mission, source)
    check_agents(mission, source)
    check_regions(mission, source)
    if mission.sweep is not None and mission.sweep.initial_region not in mission.regions:
        _fail(
            _undefined("region", mission.sweep.initial_region, list(mission.regions)),
            "sweep.initial_region",
            source,
        )
