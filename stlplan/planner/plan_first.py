"""A large team's first plan before its parts' proofs.

Parts are proven before they are merged: a merged part is proven by its parts' bounds, and the
union of the parts' plans is a plan of the whole only once no requirement between them is left.
With parts of ten agents or more a proof takes minutes, and the team's first plan waits for it
(``farm-x2`` from the bench's state 0: 275 s of a 300 s run). When the largest part has at least
``parts.plan_first_agents`` agents, :func:`~stlplan.planner.components.solve_parts` therefore
looks for a plan first, within ``parts.plan_first_share`` of the time:

1. each part's lazy loop stops at its first plan that meets every requirement (as with
   ``solver.first_plan``); parts whose plans collide are merged and repaired as for a first plan,
   and the plans are assembled in a model of the whole team of its own;
2. the parts then go on from where they stopped, with the requirements they added and their
   plans as incumbents, towards their proofs, merged and assembled as usual.

The merges of the first step are dropped: a merged part's plan answers the collisions of first
plans, not of optimal ones. Step 1's plan is the better of the two, with the tighter bound, so a
run that ends (the time limit, a stop request) before the second step has a better plan returns
the first.
"""

from __future__ import annotations

import dataclasses

from stlplan.mission.problem import Problem
from stlplan.planner import outcome
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.outcome import Outcome
from stlplan.planner.team_split import agent_parts
from stlplan.result import PlanStatus
from stlplan.runtime import signals

Solved = tuple[PlanModel, Outcome]
"""A model of the whole team with its plan loaded, and how its solve ended."""


def plans_first(problem: Problem, config: PlannerConfig, least: int) -> bool:
    """Whether ``problem`` is solved for a plan first (module docstring): it has several parts,
    the largest with ``least`` agents or more, and the run asks for more than a first plan."""
    if config.solver.first_plan:
        return False
    names = agent_parts(problem)
    return len(names) > 1 and max(len(n) for n in names) >= least


def better(first_solve: Solved | None, second_solve: Solved, gap: float) -> Solved:
    """The second solve when its plan is at least as good as the first's (or there is no
    first), else the first; either with the tighter bound of the two."""
    if first_solve is None:
        return second_solve
    (pm, first), (pm2, best) = first_solve, second_solve
    bound = outcome.lowest(best.bound, first.bound)
    kept = best.status.has_plan and best.objective is not None
    if kept and first.objective is not None and best.objective < first.objective:  # type: ignore[operator]
        kept = False
    model, chosen = (pm2, best) if kept else (pm, first)
    found = outcome.relative_gap(chosen.objective, bound)
    status = chosen.status
    if found is not None and found <= gap * outcome.SLACK:
        status = PlanStatus.OPTIMAL
    elif not kept:
        status = outcome.kept_status(signals.requested())
    return model, dataclasses.replace(chosen, status=status, bound=bound, gap=found)
