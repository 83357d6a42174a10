"""A lazy loop's last round completed when the time runs out before any plan meets every
requirement.

The last round's plan (:mod:`stlplan.planner.core.lazy`) may violate requirements left out of the
model. Its binaries are fixed, every remaining requirement added, and HiGHS looks for a plan
with those decisions (a small MILP) in the grace a finishing solve has past the run's deadline
(:meth:`stlplan.planner.run.budget.Budget.finishing`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import replace

from pyomo.environ import Var

from stlplan.planner.backend.session import HighsSession, Solved, has_solution
from stlplan.planner.backend.values import model_values, var_key
from stlplan.planner.core.in_turn import Held, hold_near, release
from stlplan.planner.encoding.model import PlanModel, add_requirements
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Outcome, VarKey
from stlplan.result import PlanStatus
from stlplan.runtime import signals


def fix_and_solve(
    pm: PlanModel, session: HighsSession, decisions: Mapping[VarKey, float], budget: Budget
) -> Solved | None:
    """Fix the binaries with a value in ``decisions``, add every requirement, solve (a
    finishing solve whose infeasible verdict says only that those decisions admit no plan, so
    it is neither confirmed nor reported as the mission's); None when adding the requirements
    outlasts ``budget``.

    A decision is fixed by its bounds: a fixed Pyomo variable would make the persistent
    interface remove and add again every row it appears in."""
    held = hold_decisions(pm, decisions)
    trial, session.trial = session.trial, True  # fixed decisions: the verdict is not the mission's
    try:
        if not added_in_time(pm, session, budget):
            return None
        return session.solve(budget)
    finally:
        session.trial = trial
        release(held)


def hold_decisions(
    pm: PlanModel, decisions: Mapping[VarKey, float], free: frozenset[int] = frozenset()
) -> Held:
    """Hold every binary of ``pm`` with a value in ``decisions`` at it (by its bounds), but
    those in ``free`` (by ``id``); returns what :func:`release` restores."""
    held: Held = []
    for v in pm.model.component_data_objects(Var):
        decided = decisions.get(var_key(v)) if v.is_binary() and not v.fixed else None
        if decided is not None and id(v) not in free:
            hold_near(v, float(round(decided)), held, 0.0)
    return held


ADD_BATCH = 500
"""Requirements a completion adds between two looks at the clock."""


def added_in_time(pm: PlanModel, session: HighsSession, budget: Budget) -> bool:
    """Add every pending requirement to ``pm`` and ``session``'s HiGHS model, in batches while
    ``budget`` lasts; whether all were added. A large team has tens of thousands: encoding them
    and loading them into HiGHS (about 1 ms each at 16 agents) is not bounded by HiGHS's time
    limit, so each batch is loaded before the clock is read again."""
    pending = pm.pending()
    for start in range(0, len(pending), ADD_BATCH):
        if budget.expired():
            return False
        add_requirements(pm, pending[start : start + ADD_BATCH])
        session.load_changes()
        session.clock.reached.completing(min(start + ADD_BATCH, len(pending)), len(pending))
    return True


def complete(
    pm: PlanModel,
    session: HighsSession,
    last: Solved,
    tick: float,
    rounds: int,
    budget: Budget,
) -> Outcome:
    """Out of time with no plan feasible for the full problem: complete the last round's plan
    (within ``budget``, a finishing one).

    The bound stays the last round's (it bounds the full problem); the gap is recomputed.
    """
    bound, before = last.results.objective_bound, len(pm.added)
    solved = fix_and_solve(pm, session, model_values(pm.model), budget)
    seconds = time.perf_counter() - tick
    stop = last.results.termination_condition.name
    base = Outcome(PlanStatus.NO_PLAN, None, bound, None, seconds, rounds, before, stop,
                   completed=True, completion_added=len(pm.added) - before)  # fmt: skip
    if solved is None:  # out of time while adding the requirements: no plan
        return outcome.completed(None, bound, signals.requested(), replace(base, completed=False))
    # (an interrupt by the watch still leaves a plan)
    found = has_solution(solved.results)
    objective = float(solved.results.incumbent_objective) if found else None
    return outcome.completed(objective, bound, solved.stopped, base)
