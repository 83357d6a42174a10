"""Checks of the team's counts in a formula (``count``, ``visits``) against the mission.

Every capability a count names exists, and its bound is one some plan can meet and some plan can
break: at most the agents counted (for ``visits``, their entries, at most one every other step of
the window), at least 1 for ``>=``, below that most for ``<=``. Each check raises
:class:`FormulaError` naming the formula's field path.
"""

from __future__ import annotations

from stlplan.errors import FormulaError, did_you_mean
from stlplan.formula.parser import to_text
from stlplan.formula.tree import Count, Formula, Visits, team_atoms
from stlplan.mission.schema import Mission


def check_counts(mission: Mission, formula: Formula, where: str, source: str | None) -> None:
    """Every ``count`` and ``visits`` of ``formula`` fits the team (module docstring)."""
    for atom in team_atoms(formula):
        _count_fits(mission, atom, where, source)


def _count_fits(mission: Mission, atom: Count | Visits, where: str, source: str | None) -> None:
    """Capabilities known, and a bound that some plan can meet and some plan can break."""
    known = sorted({c for a in mission.agents for c in a.capabilities})
    for cap in atom.who.capabilities:
        if cap not in known:
            raise FormulaError(
                f"'{to_text(atom)}' counts agents with capability '{cap}'"
                f"{did_you_mean(cap, known)}, but no agent has it; capabilities of the team: "
                f"{', '.join(known) or 'none'}",
                source=source,
                where=where,
            )
    counted = sum(atom.who.admits(frozenset(a.capabilities)) for a in mission.agents)
    who = f" with {atom.who.text()}" if atom.who.capabilities else ""
    most, why = counted, f"the team has {counted} agent(s){who}"
    if isinstance(atom, Visits):
        span = atom.interval.hi - atom.interval.lo + 1
        most = counted * ((span + 1) // 2)
        why += f", who enter at most {most} times in its {span} steps (each every other step)"
    if atom.op == ">=" and not 1 <= atom.n <= most:
        never = "fail" if atom.n < 1 else "hold"
        raise FormulaError(
            f"'{to_text(atom)}' can never {never}: {why}; expected a bound from 1 to {most}",
            source=source,
            where=where,
        )
    if atom.op == "<=" and atom.n >= most:
        raise FormulaError(
            f"'{to_text(atom)}' always holds: {why}; expected a bound below {most}",
            source=source,
            where=where,
        )
