"""Semantic checks of tasks and constraints: roles, Patterns and formulas against the mission.

A task's roles must be declared, used and fillable by some agent; its Pattern must admit at
least one group without enumerating too many, and a synchronous window must fit the horizon. A
constraint binds each role of its formula once (``for_each`` or pinned). Every formula may name
only defined regions, steps within the horizon and state components its agents have
(:mod:`stlplan.mission.atom_checks`). Each check raises :class:`MissionError` or
:class:`FormulaError` naming the field path; the whole-mission checks that run before these are
in :mod:`stlplan.mission.checks`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

from stlplan.errors import FormulaError, did_you_mean, fail, undefined
from stlplan.formula.tree import (
    Formula,
    horizon,
    roles,
)
from stlplan.mission.atom_checks import check_argument_order, formula_fits
from stlplan.mission.groups import Element, count_groups
from stlplan.mission.schema import (
    Constraint,
    Mission,
    PinnedRole,
    Synchronous,
    Task,
)

MAX_ELEMENTS = 10_000
"""Elements a task's roles may admit (they are enumerated)."""
MAX_GROUPS = 1_000_000
"""Bound on the groups (and partial groups) enumerated for one task."""
ROLE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def check_task(mission: Mission, name: str, formula: Formula, source: str | None) -> None:
    """Roles declared and used, capabilities and agents known, formula within the horizon."""
    task = mission.tasks[name]
    where = f"tasks.{name}"
    used, declared = roles(formula), list(task.roles)
    check_argument_order(mission, formula, declared, f"{where}.formula", source)
    _check_pins(task, where, source)
    for role in declared:
        _check_role_name(role, f"{where}.roles.{role}", source)
    for role in used:
        if role not in task.roles:
            raise FormulaError(
                f"role '{role}' is used by the formula but not declared in "
                f"'roles'{did_you_mean(role, declared)}; declared: "
                f"{', '.join(declared) or 'none'}",
                source=source,
                where=f"{where}.formula",
            )
    for role in declared:
        if role not in used:
            fail(
                f"role '{role}' is not used by the formula (roles used: {', '.join(used)})",
                f"{where}.roles.{role}",
                source,
            )
    _check_roleless(task, used, where, source)
    role_agents = {
        r: _role_agents(mission, r, task.roles[r], f"{where}.roles.{r}", source) for r in used
    }
    _check_pattern_size(task, role_agents, where, source)
    formula_fits(mission, formula, f"{where}.formula", role_agents, horizon(formula), source)
    if task.synchronous is not None:
        check_window(
            task.synchronous,
            mission.horizon,
            horizon(formula),
            f"{where}.synchronous.within",
            source,
        )


def _check_roleless(task: Task, used: tuple[str, ...], where: str, source: str | None) -> None:
    """A task whose formula names no role (it only counts) has one element: count 1."""
    if not used and task.count != 1:
        fail(
            f"a task whose formula names no role (only counts) is met once; found count "
            f"{task.count}, expected 1 (or count inside the formula)",
            f"{where}.count",
            source,
        )


def _check_pins(task: Task, where: str, source: str | None) -> None:
    """Two roles pinned to one agent admit no element: distinct roles are distinct agents."""
    pinned: dict[str, str] = {}
    for role, rule in task.roles.items():
        if isinstance(rule, PinnedRole):
            if rule.agent in pinned:
                fail(
                    f"roles '{pinned[rule.agent]}' and '{role}' are both pinned to agent "
                    f"'{rule.agent}', but within an element distinct roles are distinct agents; "
                    "expected one role per pinned agent",
                    f"{where}.roles.{role}",
                    source,
                )
            pinned[rule.agent] = role


def _check_role_name(role: str, where: str, source: str | None) -> None:
    """``role`` is an identifier: letters, digits and '_', not starting with a digit."""
    if not ROLE_NAME.fullmatch(role):
        fail(f"expected a role name (letters, digits, '_'), found '{role}'", where, source)


def _check_pattern_size(
    task: Task, role_agents: dict[str, list[str]], where: str, source: str | None
) -> None:
    """Bound the elements a Pattern admits (at most the product of the role pools); groups are
    bounded only where they are enumerated (:func:`check_group_count`)."""
    n_elements = math.prod(len(agents) for agents in role_agents.values())
    if n_elements > MAX_ELEMENTS:
        fail(
            f"the roles admit up to {n_elements} elements; expected at most {MAX_ELEMENTS} "
            "(narrow the roles' capabilities)",
            f"{where}.roles",
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
        fail(f"window [{a}, {b}] must satisfy 0 <= a <= b", where, source)
    if b + d + reach > horizon_steps:
        phi = f" + {reach} (phi)" if reach else ""
        fail(
            f"the synchronous window F[{a},{b}] G[0,{d}] needs steps up to {b} + {d}{phi} = "
            f"{b + d + reach}, past the horizon {horizon_steps}",
            where,
            source,
        )


def _role_agents(
    mission: Mission,
    role: str,
    rule: str | list[str] | PinnedRole,
    where: str,
    source: str | None,
) -> list[str]:
    """The agents that may fill ``role``, after checking its agent or capabilities exist (an
    agent's name where a capability is expected is told how to bind that agent)."""
    names = [a.name for a in mission.agents]
    if isinstance(rule, PinnedRole):
        if rule.agent not in names:
            fail(undefined("agent", rule.agent, names), f"{where}.agent", source)
        return [rule.agent]
    wanted = [rule] if isinstance(rule, str) else rule
    known = sorted({c for a in mission.agents for c in a.capabilities})
    for cap in wanted:
        if cap not in known and cap in names:
            fail(
                f"role '{role}' names agent '{cap}', but a role rule lists capabilities; to bind "
                f"an agent write {{agent: {cap}}}",
                where,
                source,
            )
        if cap not in known:
            fail(
                f"no agent has capability '{cap}'{did_you_mean(cap, known)}; capabilities of "
                f"the team: {', '.join(known) or 'none'}",
                where,
                source,
            )
    fit = _fitting(mission, rule)
    if not fit:
        fail(f"no agent has all of the capabilities {wanted}", where, source)
    return fit


def check_group_count(
    mission: Mission, name: str, elems: Sequence[Element], source: str | None
) -> None:
    """The paper's group enumeration of task ``name`` must stay below :data:`MAX_GROUPS`."""
    task = mission.tasks[name]
    n_groups = count_groups(elems, task.count, task.reuse_agents, limit=MAX_GROUPS + 1)
    if n_groups > MAX_GROUPS:
        fail(
            f"count {task.count} over {len(elems)} elements allows more than {MAX_GROUPS} "
            "groups to enumerate; expected fewer (use the selection encoding, "
            "`--tasks selection`, which enumerates no group, or lower count)",
            f"tasks.{name}.count",
            source,
        )


def check_groups(
    mission: Mission, name: str, n_elements: int, has_group: bool, source: str | None
) -> None:
    """A Pattern must admit at least one group of ``count`` elements."""
    task = mission.tasks[name]
    if has_group:
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
    fail(
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
            fail(undefined("agent", agent, names), f"{where}.roles.{role}", source)
    for k, agent in enumerate(spec.agents or []):
        if agent not in names:
            fail(undefined("agent", agent, names), f"{where}.agents[{k}]", source)
    if spec.agents is not None and spec.for_each is None:
        fail(
            "'agents' needs 'for_each' (the role that ranges over them)", f"{where}.agents", source
        )
    bound = [*spec.roles, *([spec.for_each] if spec.for_each is not None else [])]
    check_argument_order(mission, formula, bound, f"{where}.formula", source)
    _constraint_roles(spec, roles(formula), where, source)
    pool = spec.agents if spec.agents is not None else names
    role_agents = {r: [a] for r, a in spec.roles.items()}
    if spec.for_each is not None:
        role_agents[spec.for_each] = list(pool)
    formula_fits(mission, formula, f"{where}.formula", role_agents, horizon(formula), source)


def _constraint_roles(
    spec: Constraint, used: tuple[str, ...], where: str, source: str | None
) -> None:
    """Every role of the formula is bound exactly once, and every bound role is used."""
    bound = [*spec.roles, *([spec.for_each] if spec.for_each is not None else [])]
    if spec.for_each is not None and spec.for_each in spec.roles:
        fail(
            f"role '{spec.for_each}' is both 'for_each' and pinned in 'roles'; use one",
            f"{where}.for_each",
            source,
        )
    for role in used:
        if role not in bound:
            raise FormulaError(
                f"role '{role}' is neither 'for_each' nor in 'roles'{did_you_mean(role, bound)}"
                f"; bound roles: {', '.join(bound) or 'none'}",
                source=source,
                where=f"{where}.formula",
            )
    for role in bound:
        if role not in used:
            field = "for_each" if role == spec.for_each else f"roles.{role}"
            fail(
                f"role '{role}' is not used by the formula (roles used: "
                f"{', '.join(used) or 'none'})",
                f"{where}.{field}",
                source,
            )
