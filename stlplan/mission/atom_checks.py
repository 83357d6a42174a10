"""Checks of a formula's atoms against the mission: regions defined, steps within the horizon,
numbers finite and of sane magnitude, state components its agents have, and ``in`` with its
arguments in order. Each raises :class:`FormulaError` naming the field path."""

from __future__ import annotations

import math

from stlplan.errors import FormulaError, undefined
from stlplan.formula.parser import to_text
from stlplan.formula.tree import (
    Atom,
    Distance,
    Formula,
    InRegion,
    Linear,
    Predicate,
    atoms,
    regions,
)
from stlplan.mission.count_checks import check_counts
from stlplan.mission.schema import MAGNITUDE_TEXT, MAX_MAGNITUDE, Mission


def formula_fits(
    mission: Mission,
    formula: Formula,
    where: str,
    role_agents: dict[str, list[str]],
    reach: int,
    source: str | None,
) -> None:
    """Regions defined, steps within the horizon, numbers finite, state components in range."""
    for region in regions(formula):
        if region not in mission.regions:
            raise FormulaError(
                undefined("region", region, list(mission.regions)), source=source, where=where
            )
    if reach > mission.horizon:
        raise FormulaError(
            f"the formula needs steps up to {reach}, past the horizon {mission.horizon}",
            source=source,
            where=where,
        )
    _atoms_fit(mission, formula, where, role_agents, source)
    check_counts(mission, formula, where, source)


def _atoms_fit(
    mission: Mission,
    formula: Formula,
    where: str,
    role_agents: dict[str, list[str]],
    source: str | None,
) -> None:
    """Every atom has finite numbers and names state components its agents have."""
    dims = {
        a.name: len(mission.dynamics[a.dynamics].A)
        for a in mission.agents
        if a.dynamics in mission.dynamics
    }
    for atom in atoms(formula):
        _atom_is_sane(atom, where, source)
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


def _atom_is_sane(atom: Atom, where: str, source: str | None) -> None:
    """Finite numbers of magnitude at most ``MAX_MAGNITUDE``; ``dist`` between two roles."""
    numbers = _numbers(atom)
    if not all(math.isfinite(v) for v in numbers):
        raise FormulaError(
            f"'{to_text(atom)}' has a number that is not finite (too large)",
            source=source,
            where=where,
        )
    if any(abs(v) > MAX_MAGNITUDE for v in numbers):
        raise FormulaError(
            f"'{to_text(atom)}' has a number of magnitude above {MAGNITUDE_TEXT}; expected "
            f"numbers between -{MAGNITUDE_TEXT} and {MAGNITUDE_TEXT} (rescale the units)",
            source=source,
            where=where,
        )
    if isinstance(atom, Distance) and atom.left == atom.right:
        raise FormulaError(
            f"'{to_text(atom)}' measures role '{atom.left}' against itself (always 0); expected "
            "two different roles, such as dist(p, q)",
            source=source,
            where=where,
        )


def _numbers(atom: Atom) -> tuple[float, ...]:
    """The numbers written in ``atom`` (coefficients, bound, radius)."""
    if isinstance(atom, Distance):
        return (atom.radius,)
    if isinstance(atom, (Linear, Predicate)):
        return (*(t.coef for t in atom.terms), atom.bound)
    return ()


def check_argument_order(
    mission: Mission, formula: Formula, declared: list[str], where: str, source: str | None
) -> None:
    """``in(Goal, p)`` names a region where the role goes: say the arguments are swapped."""
    for atom in atoms(formula):
        if (
            isinstance(atom, InRegion)
            and atom.role not in declared
            and atom.role in mission.regions
            and atom.region not in mission.regions
        ):
            raise FormulaError(
                f"in({atom.role}, {atom.region}) has its arguments swapped: '{atom.role}' is a "
                f"region and '{atom.region}' is not; expected in(ROLE, REGION), here "
                f"in({atom.region}, {atom.role})",
                source=source,
                where=where,
            )
