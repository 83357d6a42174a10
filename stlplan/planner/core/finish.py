"""The continuous stage after step 1: step 2 (or the one-step polish) with the decisions fixed.

Step 1's binaries are fixed at their rounded values; one LP over the step-1 model finds the
predicates they enforce; the small continuous model of :mod:`stlplan.planner.encoding.continuous`
minimizes the effort (or polishes the step-1 objective) over exactly those and the sides step
1's plan keeps of the lazy requirements it left out (:mod:`stlplan.planner.core.kept_sides`). Its plan
meets every enforced predicate with the margin ``r >= EPSILON`` to HiGHS's LP tolerance (DESIGN
2.10), which step 1's plan, held only to the MIP tolerances, need not.

When the continuous solve stops short of optimality without an infeasible verdict, its point is
landed: the nearest plan meeting every enforced predicate, found by an LP
(:func:`stlplan.planner.encoding.continuous.landing_model`). HiGHS's active-set QP solver does
this routinely on step 2's ``l2`` effort: rows whose right-hand sides differ by ``EPSILON`` from a
degenerate vertex make it claim optimality and then fail its own check by about ``1e-6`` ("Solve
error"). A point that lands within ``tolerances.HOLD`` of where it was (``sum |u - u_QP|``),
or whose ``sum u^2`` is within the relative gap of that at HiGHS's point (step 2's ``l2``
effort: HiGHS's point is its optimum up to those tolerances, so the landed plan is within the
gap of the optimum too), counts as step 2 done (the message says so); one that moves further
lands as a reported fallback.
Only when the landing fails too is the step-1 plan kept, and the monitor judges it like any other;
out of time, it is kept only when it meets the enforced predicates (:func:`out_of_time`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from pyomo.contrib.solver.common.results import TerminationCondition
from pyomo.environ import ConcreteModel, Objective, Reals, Var, minimize, value

from stlplan.planner.backend.session import HighsSession, Solved, solve_once
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.kept_sides import KeptSides
from stlplan.planner.core.watch import trajectory_states
from stlplan.planner.encoding.continuous import (
    add_predicate_rows,
    broken_predicates,
    continuous_model,
    copy_plan,
    landing_model,
    plan_margin,
    plan_states,
)
from stlplan.planner.encoding.ledger import Enforced
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock, Phase
from stlplan.planner.tolerances import HOLD, ROUND_OFF

INFEASIBLE = {
    TerminationCondition.provenInfeasible.name,
    TerminationCondition.infeasibleOrUnbounded.name,
}
"""Terminations that mean the fixed decisions admit no plan."""


OUT_OF_TIME = "the time limit and its grace ran out before the continuous solve"
"""Why the stage failed when its pieces would take (or took) the time left (a large team's)."""


@dataclass(frozen=True)
class Finish:
    """How the continuous stage ended."""

    failed: str | None = None
    """None when it succeeded; else why it failed (HiGHS's termination of the failed solve)."""
    infeasible: bool = False
    """It failed because the fixed decisions admit no plan."""
    kept: str = "the step-1 plan"
    """What the plan is when it failed."""
    note: str = ""
    """How it succeeded, when not plainly (a landed point)."""
    broken: bool = False
    """It failed with step 1's plan breaking a predicate its decisions enforce (or with
    decisions that admit no plan): that plan met them only within HiGHS's integrality
    tolerance, and may be written only as this stage (or a strict retry) finishes it."""
    unfinished: bool = False
    """The time ran out before a ``broken`` plan was finished: no plan (:func:`out_of_time`)."""


def _broken(pm: PlanModel, enforced: list[Enforced]) -> bool:
    """Whether step 1's plan, loaded in ``pm``, breaks an ``enforced`` predicate beyond HiGHS's
    feasibility tolerance."""
    return broken_predicates(pm, enforced, trajectory_states(pm)) > 0


def out_of_time(pm: PlanModel, enforced: list[Enforced]) -> Finish:
    """The stage out of time, step 1's plan loaded in ``pm``: that plan is kept when it meets
    the ``enforced`` predicates to HiGHS's tolerance; otherwise there is no plan (it met its
    decisions only within the integrality tolerance, and the stage that would have set it
    onto its predicates did not run)."""
    broken = _broken(pm, enforced)
    return Finish(OUT_OF_TIME, broken=broken, unfinished=broken)


def fix_decisions(pm: PlanModel) -> None:
    """Fix every binary at its rounded value (domain made real first: HiGHS has no MIQP).

    Each ``rho_s^l`` keeps its step-1 value as a lower bound (the fixed runs pin it anyway), and
    so does a maximized margin.
    """
    for v in pm.model.component_data_objects(Var, active=True):
        if v.is_binary() and not v.fixed:
            rounded = float(round(v.value or 0.0))
            v.domain = Reals
            v.fix(rounded)
    for enc in pm.synchronous:
        enc.rho_s.setlb(max(0.0, round(float(enc.rho_s.value), 6) - 1e-6))
    if not isinstance(pm.margin, float):
        pm.margin.setlb(float(pm.margin.value) - ROUND_OFF)


def enforced_predicates(
    pm: PlanModel, config: PlannerConfig, clock: Clock, phase: Phase, budget: Budget
) -> tuple[list[Enforced] | None, float, str]:
    """The predicates step 1's fixed decisions enforce, the seconds it took, and how the LP
    ended (HiGHS's termination, by name).

    With the binaries fixed, every indicator has a least feasible value, 1 exactly where the
    decisions enforce it (requirements only push indicators up). One LP finds them all:
    ``min sum z`` over the step-1 rows. Returns None if that LP fails.
    """
    model = pm.model
    model.step1.deactivate()
    model.least = Objective(expr=sum(model.spec.indicators.values()), sense=minimize)
    results, seconds, _ = solve_once(model, config, clock, phase, budget, mip=False)
    model.del_component(model.least)
    model.step1.activate()
    ended = results.termination_condition.name
    if results.termination_condition != TerminationCondition.convergenceCriteriaSatisfied:
        return None, seconds, ended
    guarded = [enforced for z, enforced in pm.ledger.guarded if value(z) > 0.5]
    return pm.ledger.required + guarded, seconds, ended


@dataclass
class _Rows:
    """The rows a continuous (or landing) model holds: the enforced predicates and the kept
    sides held so far (:mod:`stlplan.planner.core.kept_sides`), added to as solves break sides."""

    pm: PlanModel
    enforced: list[Enforced]
    sides: KeptSides

    def solve(self, session: HighsSession, clock: Clock, budget: Budget) -> tuple[Solved, bool]:
        """Solve the session's model until its plan breaks no kept side; returns the last
        solve and whether its plan meets every side (False: out of time, or the solve failed)."""
        model = session.model
        while True:
            solved = session.solve(budget)
            if (
                solved.results.termination_condition
                != TerminationCondition.convergenceCriteriaSatisfied
            ):
                return solved, False
            more = self.sides.broken(plan_states(model, self.pm), plan_margin(model, self.pm))
            if not more:
                return solved, True
            if budget.expired():
                return solved, False
            self.enforced += more
            with clock.building():
                add_predicate_rows(model, more, self.pm)


def _held_rows(pm: PlanModel, enforced: list[Enforced], config: PlannerConfig) -> _Rows:
    """The enforced predicates with the kept sides near step 1's plan (loaded in ``pm``)."""
    states = trajectory_states(pm)
    sides = KeptSides.of(pm, states)
    near = sides.near(states, float(value(pm.margin)), config.continuous.near_sides)
    return _Rows(pm, enforced + near, sides)


def _target(session: HighsSession, model: ConcreteModel) -> dict[Any, float] | None:
    """The inputs of the point HiGHS ended at, by key of ``model.u`` (None without one)."""
    columns = session.columns()
    point = session.last_point()
    if len(point) == 0 or any(id(u) not in columns for u in model.u.values()):
        return None
    return {key: float(point[columns[id(u)]]) for key, u in model.u.items()}


def effort_kept(pm: PlanModel, target: dict[Any, float], gap: float) -> bool:
    """For step 2's ``l2`` effort: whether the inputs loaded in ``pm`` have a ``sum u^2`` within
    the relative ``gap`` of that of ``target`` (HiGHS's point, by key of ``u``)."""
    if pm.problem.mission.objective.effort != "l2":
        return False
    at_target = sum(u * u for u in target.values())
    landed = sum(float(pm.model.u[key].value) ** 2 for key in target)
    return landed - at_target <= gap * max(at_target, ROUND_OFF)


def _land(
    pm: PlanModel,
    rows: _Rows,
    target: dict[Any, float],
    config: PlannerConfig,
    clock: Clock,
    phase: Phase,
    budget: Budget,
) -> float | None:
    """Copy into ``pm`` the plan nearest ``target`` that meets every enforced predicate and kept
    side; returns how far it is (``sum |u - target|``), None when the LP fails."""
    with clock.building():
        landing = landing_model(pm, rows.enforced, target)
    _, met = rows.solve(HighsSession(landing, config, clock, phase, mip=False), clock, budget)
    if not met:
        return None
    copy_plan(landing, pm)
    return float(value(landing.goal))


def finish(pm: PlanModel, config: PlannerConfig, clock: Clock, budget: Budget) -> Finish:
    """Step 2 (or the one-step polish) with step 1's decisions fixed, the plan loaded in ``pm``,
    within ``budget`` (a finishing one: the plan is found).

    On failure the step-1 solution stays loaded in ``pm``, unless a landing succeeded.
    """
    phase: Phase = "step2" if config.continuous.two_step else "polish"
    enforced = _enforced_in_time(pm, config, clock, phase, budget)
    if isinstance(enforced, Finish):
        return enforced
    rows = _held_rows(pm, enforced, config)
    with clock.building():
        small = continuous_model(pm, rows.enforced, "effort" if phase == "step2" else "polish")
    if budget.expired():
        return out_of_time(pm, enforced)
    session = HighsSession(small, config, clock, phase, mip=False)
    solved, met = rows.solve(session, clock, budget)
    ended = solved.results.termination_condition.name
    if met:
        copy_plan(small, pm)
        return Finish()
    if ended == TerminationCondition.convergenceCriteriaSatisfied.name:
        return out_of_time(pm, enforced)
    if ended in INFEASIBLE:
        return Finish(f"the continuous solve ended {ended}", True, broken=_broken(pm, enforced))
    return _landed(pm, rows, session, ended, config, clock, phase, budget)


def _enforced_in_time(
    pm: PlanModel, config: PlannerConfig, clock: Clock, phase: Phase, budget: Budget
) -> list[Enforced] | Finish:
    """The predicates step 1's decisions enforce (its plan left loaded in ``pm``), or how the
    stage failed: the LP failed, or the rest of the stage would not fit in ``budget``."""
    snapshot = [(v, v.value) for v in pm.model.component_data_objects(Var)]
    tick = time.perf_counter()
    fix_decisions(pm)
    enforced, _, ended = enforced_predicates(pm, config, clock, phase, budget)
    for v, val in snapshot:
        v.set_value(val, skip_validation=True)
    if enforced is None:
        infeasible = ended in INFEASIBLE  # the decisions admit no plan
        failed = f"the LP finding the enforced predicates ended {ended}"
        return Finish(failed, infeasible, broken=infeasible)
    # building and loading the continuous model takes about as long as loading step 1's did
    if budget.remaining() < budget.min_solve + time.perf_counter() - tick:
        return out_of_time(pm, enforced)
    return enforced


def _landed(
    pm: PlanModel,
    rows: _Rows,
    session: HighsSession,
    ended: str,
    config: PlannerConfig,
    clock: Clock,
    phase: Phase,
    budget: Budget,
) -> Finish:
    """After a continuous solve that ended ``ended`` short of optimality: its point landed on
    the rows (:func:`_land`), or the step-1 plan kept."""
    failed = f"the continuous solve ended {ended}"
    target = _target(session, session.model)
    moved = None if target is None else _land(pm, rows, target, config, clock, phase, budget)
    if target is None or moved is None:
        return Finish(failed)
    kept = config.continuous.two_step and effort_kept(pm, target, config.solver.gap)
    if moved <= HOLD or kept:
        return Finish(
            note=f"HiGHS's solve ended {ended}; its point landed {moved:.1g} away by an LP"
        )
    return Finish(
        failed, kept=f"step 1's plan moved {moved:.3g} onto the enforced predicates (an LP)"
    )
