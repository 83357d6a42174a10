"""Semantic checks of a mission the schema accepted: one clear message per mistake.

Each check raises :class:`MissionError` (or :class:`FormulaError`) naming the field path and what
was expected. They run in the order a reader meets the file: dynamics, agents, regions, tasks,
constraints, objective.
"""

from __future__ import annotations

from difflib import get_close_matches
from typing import NoReturn

import numpy as np

from stlplan.errors import FormulaError, MissionError
from stlplan.formula.tree import Formula, Linear, atoms, horizon, regions, roles
from stlplan.mission import Mission, PinnedRole


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
        n = len(dyn.A)
        if n == 0 or any(len(row) != n for row in dyn.A):
            _fail(f"A must be square (n x n), found rows of lengths {[len(r) for r in dyn.A]}",
                  f"{where}.A", source)
        if len(dyn.B) != n:
            _fail(f"B must have n = {n} rows (as A), found {len(dyn.B)}", f"{where}.B", source)
        m = len(dyn.B[0])
        if m == 0 or any(len(row) != m for row in dyn.B):
            _fail("B rows must all have the same non-zero length m", f"{where}.B", source)
        if len(dyn.state_bounds) != n:
            _fail(f"expected {n} state bounds (one per state component), found "
                  f"{len(dyn.state_bounds)}", f"{where}.state_bounds", source)
        if len(dyn.input_bounds) != m:
            _fail(f"expected {m} input bounds (one per input component), found "
                  f"{len(dyn.input_bounds)}", f"{where}.input_bounds", source)
        for field, bounds in (("state_bounds", dyn.state_bounds), ("input_bounds", dyn.input_bounds)):
            for i, (lo, hi) in enumerate(bounds):
                if lo > hi:
                    _fail(f"empty interval [{lo}, {hi}]: low must be <= high",
                          f"{where}.{field}[{i}]", source)
        i, j = dyn.position
        if i == j or not (0 <= i < n and 0 <= j < n):
            _fail(f"position must name two distinct state components in 0..{n - 1}, found "
                  f"[{i}, {j}]", f"{where}.position", source)


def check_agents(mission: Mission, source: str | None) -> None:
    """Unique names, defined dynamics, initial state length and bounds."""
    seen: set[str] = set()
    for k, agent in enumerate(mission.agents):
        where = f"agents[{k}]"
        if agent.name in seen:
            _fail(f"duplicate agent name '{agent.name}'", f"{where}.name", source)
        seen.add(agent.name)
        if agent.dynamics not in mission.dynamics:
            _fail(_undefined("dynamics", agent.dynamics, list(mission.dynamics)),
                  f"{where}.dynamics", source)
        dyn = mission.dynamics[agent.dynamics]
        if len(agent.initial_state) != len(dyn.A):
            _fail(f"initial_state has {len(agent.initial_state)} values, dynamics "
                  f"'{agent.dynamics}' has {len(dyn.A)} state components",
                  f"{where}.initial_state", source)
        for i, (x, (lo, hi)) in enumerate(zip(agent.initial_state, dyn.state_bounds)):
            if not lo <= x <= hi:
                _fail(f"initial state {x} is outside its bounds [{lo}, {hi}]",
                      f"{where}.initial_state[{i}]", source)


def check_regions(mission: Mission, source: str | None) -> None:
    """Non-empty boxes and consistent polytope shapes."""
    for name, region in mission.regions.items():
        where = f"regions.{name}"
        if region.box is not None:
            for axis, (lo, hi) in zip("xy", region.box):
                if lo >= hi:
                    _fail(f"empty box: {axis} interval [{lo}, {hi}] needs low < high",
                          f"{where}.box", source)
        elif region.G is not None and region.h is not None:
            if len(region.G) != len(region.h):
                _fail(f"G has {len(region.G)} rows but h has {len(region.h)} entries",
                      f"{where}.h", source)
            if any(np.hypot(*g) == 0 for g in region.G):
                _fail("a row of G is zero", f"{where}.G", source)


def _formula_fits(
    mission: Mission, formula: Formula, where: str, role_agents: dict[str, list[str]],
    reach: int, source: str | None,
) -> None:
    for region in regions(formula):
        if region not in mission.regions:
            raise FormulaError(_undefined("region", region, list(mission.regions)),
                               source=source, where=where)
    if reach > mission.horizon:
        raise FormulaError(f"the formula needs steps up to {reach}, past the horizon "
                           f"{mission.horizon}", source=source, where=where)
    dims = {a.name: len(mission.dynamics[a.dynamics].A) for a in mission.agents
            if a.dynamics in mission.dynamics}
    for atom in atoms(formula):
        if isinstance(atom, Linear):
            for term in atom.terms:
                for agent in role_agents.get(term.role, []):
                    if term.component >= dims[agent]:
                        raise FormulaError(
                            f"{term.role}.x[{term.component}] is out of range: agent '{agent}' has "
                            f"{dims[agent]} state components", source=source, where=where)


def check_task(mission: Mission, name: str, formula: Formula, source: str | None) -> None:
    """Roles declared and used, capabilities and agents known, formula within the horizon."""
    task = mission.tasks[name]
    where = f"tasks.{name}"
    used, declared = roles(formula), list(task.roles)
    for role in used:
        if role not in task.roles:
            raise FormulaError(_undefined("role", role, declared) + " in 'roles'",
                               source=source, where=f"{where}.formula")
    for role in declared:
        if role not in used:
            _fail(f"role '{role}' is not used by the formula (roles used: {', '.join(used)})",
                  f"{where}.roles.{role}", source)
    role_agents = {r: _role_agents(mission, task.roles[r], f"{where}.roles.{r}", source)
                   for r in used}
    reach = horizon(formula)
    if task.synchronous is not None:
        a, b = task.synchronous.within
        if a < 0 or b < a:
            _fail(f"window [{a}, {b}] must satisfy 0 <= a <= b", f"{where}.synchronous.within",
                  source)
        reach += b + task.synchronous.hold
    _formula_fits(mission, formula, f"{where}.formula", role_agents, reach, source)


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
            _fail(f"no agent has capability '{cap}'{_did_you_mean(cap, known)}; capabilities of "
                  f"the team: {', '.join(known) or 'none'}", where, source)
    fit = [a.name for a in mission.agents if set(wanted) <= set(a.capabilities)]
    if not fit:
        _fail(f"no agent has all of the capabilities {wanted}", where, source)
    return fit


def check_groups(
    mission: Mission, name: str, n_elements: int, n_groups: int, source: str | None
) -> None:
    """A Pattern must admit at least one group."""
    task = mission.tasks[name]
    if n_groups == 0:
        reuse = "" if task.reuse_agents else " without reusing an agent"
        _fail(f"the Pattern admits {n_elements} element(s) but no group of {task.count}"
              f"{reuse}: the team has too few agents for this task", f"tasks.{name}.count",
              source)


def check_constraint(mission: Mission, name: str, formula: Formula, source: str | None) -> None:
    """Roles bound (by for_each or pinned), agents known, formula within the horizon."""
    spec = mission.constraints[name]
    where = f"constraints.{name}"
    names = [a.name for a in mission.agents]
    bound = dict.fromkeys(spec.roles)
    if spec.for_each is not None:
        bound[spec.for_each] = None
    for role in roles(formula):
        if role not in bound:
            raise FormulaError(f"role '{role}' is neither 'for_each' nor in 'roles'",
                               source=source, where=f"{where}.formula")
    for role, agent in spec.roles.items():
        if agent not in names:
            _fail(_undefined("agent", agent, names), f"{where}.roles.{role}", source)
    for k, agent in enumerate(spec.agents or []):
        if agent not in names:
            _fail(_undefined("agent", agent, names), f"{where}.agents[{k}]", source)
    if spec.agents is not None and spec.for_each is None:
        _fail("'agents' needs 'for_each' (the role that ranges over them)", f"{where}.agents",
              source)
    pool = spec.agents if spec.agents is not None else names
    role_agents = {r: [a] for r, a in spec.roles.items()}
    if spec.for_each is not None:
        role_agents[spec.for_each] = list(pool)
    _formula_fits(mission, formula, f"{where}.formula", role_agents, horizon(formula), source)


def check_mission(mission: Mission, source: str | None) -> None:
    """Every whole-mission check that needs no parsed formula."""
    check_dynamics(mission, source)
    check_agents(mission, source)
    check_regions(mission, source)
    if mission.sweep is not None and mission.sweep.initial_region not in mission.regions:
        _fail(_undefined("region", mission.sweep.initial_region, list(mission.regions)),
              "sweep.initial_region", source)
