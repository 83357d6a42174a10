"""Solving the planning MILP with HiGHS (through Pyomo), in one or two steps (DESIGN 2.3).

Step 1 solves problem (step1) of :mod:`stlplan.planner.encoding.model`; by default obstacle and collision
avoidance enter it lazily (:mod:`stlplan.planner.lazy`), which proves the same optimum. Step 2 fixes every
binary of step 1 (groups, time windows, obstacle sides) and every ``rho_s^l``, then minimizes the
mission's effort norm: ``l2`` is ``sum u^2`` (a convex QP), ``l1`` is ``sum |u|`` and ``linf`` is
``sum_p max |u_p|`` (LPs). In one-step mode the same fixing is followed by a continuous re-solve of
the step-1 objective, which moves the plan to an exact vertex: integrality tolerances cannot then
leak into the predicates the monitor checks.

Both continuous solves run on a small model (:mod:`stlplan.planner.encoding.continuous`): an LP over the
step-1 model first finds the predicates the fixed decisions enforce, then only those, the
dynamics (states eliminated) and the effort remain. HiGHS's QP solver stalls on the full model,
whose Hessian is singular. Lazy requirements never added to the MILP keep, in the continuous
stage, the half-plane the step-1 plan meets best: the side an up-front encoding would have fixed.
"""

from __future__ import annotations

import dataclasses
import math

from pyomo.environ import ConcreteModel, Constraint, Objective, Reals, Var, minimize, value

from stlplan.mission.problem import Problem
from stlplan.planner import stops
from stlplan.planner.clock import FLOORS_SHARE, Clock, Phase, ProgressCallback
from stlplan.planner.components import solve_parts
from stlplan.planner.encoding.continuous import continuous_model, copy_plan
from stlplan.planner.encoding.deferred import best_option
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.encoding.readout import plan_result
from stlplan.planner.encoding.stl import Enforced
from stlplan.planner.lazy import Step1, solve_step1, trajectory_states
from stlplan.planner.session import TC, PlanOptions, solve_once
from stlplan.result import Fallback, ModelSize, PlanResult, PlanStatus

__all__ = ["enforced_predicates", "fix_decisions", "model_size", "plan"]


def model_size(model: ConcreteModel) -> ModelSize:
    """Free variables, binaries among them, and active constraints of ``model``."""
    free = [v for v in model.component_data_objects(Var, active=True) if not v.fixed]
    rows = sum(1 for _ in model.component_data_objects(Constraint, active=True))
    return ModelSize(len(free), sum(1 for v in free if v.is_binary()), rows)


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
        pm.margin.setlb(float(pm.margin.value) - 1e-9)


def enforced_predicates(
    pm: PlanModel, options: PlanOptions, clock: Clock, phase: Phase
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
    results, seconds, _ = solve_once(model, options, clock, phase, mip=False)
    model.del_component(model.least)
    model.step1.activate()
    ended = results.termination_condition.name
    if results.termination_condition != TC.convergenceCriteriaSatisfied:
        return None, seconds, ended
    guarded = [enforced for z, enforced in pm.ledger.guarded if value(z) > 0.5]
    return pm.ledger.required + guarded, seconds, ended


def kept_sides(pm: PlanModel) -> list[Enforced]:
    """For each lazy requirement never added: the half-plane the loaded plan meets best."""
    if pm.deferral is None:
        return []
    states = trajectory_states(pm)
    return [e for n in pm.pending() for e in best_option(pm.deferral.lazy[n], states)]


def _continuous(pm: PlanModel, options: PlanOptions, clock: Clock) -> tuple[str | None, float]:
    """Step 2 (or the one-step polish) with step 1's decisions fixed; None on success, else why
    it failed (HiGHS's termination of the failed solve).

    On failure the step-1 solution stays loaded in ``pm``.
    """
    snapshot = [(v, v.value) for v in pm.model.component_data_objects(Var)]
    phase: Phase = "step2" if options.two_step else "polish"
    fix_decisions(pm)
    enforced, seconds, ended = enforced_predicates(pm, options, clock, phase)
    for v, val in snapshot:
        v.set_value(val, skip_validation=True)
    if enforced is None:
        return f"the LP finding the enforced predicates ended {ended}", seconds
    enforced += kept_sides(pm)
    with clock.building():
        small = continuous_model(pm, enforced, "effort" if options.two_step else "polish")
    results, more, _ = solve_once(small, options, clock, phase, mip=False)
    if results.termination_condition != TC.convergenceCriteriaSatisfied:
        return f"the continuous solve ended {results.termination_condition.name}", seconds + more
    copy_plan(small, pm)
    return None, seconds + more


def _step1(problem: Problem, options: PlanOptions, clock: Clock) -> tuple[PlanModel, Step1]:
    """Build and solve problem (step 1), part by part when it splits; returns the model with
    the plan loaded and how step 1 ended (building is timed on the clock)."""
    clock.report("build")
    by_parts = solve_parts(problem, options, clock) if options.lazy and options.decompose else None
    if by_parts is not None:
        return by_parts
    with clock.building():
        pm = build_model(
            problem,
            options.encoding,
            lazy=options.lazy,
            floors=options.floors,
            floors_deadline=clock.share(FLOORS_SHARE),
            task_encoding=options.tasks,
        )
    return pm, solve_step1(pm, options, clock)


def plan(
    problem: Problem,
    options: PlanOptions | None = None,
    progress: ProgressCallback | None = None,
    deadline: float | None = None,
) -> PlanResult:
    """Plan ``problem``: build the MILP, solve step 1, then step 2 (or a polish).

    Parameters
    ----------
    problem
        A checked problem.
    options
        Solver options (default: from the mission).
    progress
        Called with :class:`Progress` at phase changes and while HiGHS works.
    deadline
        ``time.perf_counter()`` time by which the run must end, when earlier than the options'
        time limit from now (a run that shares its budget with other work).

    Returns
    -------
    PlanResult
        Status, trajectory and solver figures; ``report`` is left None for the monitor.
        ``model_size`` is the size of the last MILP step 1 solved (lazy rows included).
    """
    options = options or PlanOptions.from_mission(problem.mission)
    clock = Clock.started(options.time_limit, progress, deadline)
    pm, step1 = _step1(problem, options, clock)
    size = model_size(pm.model)
    if not step1.status.has_plan:
        clock.report("done")
        return PlanResult(
            status=step1.status,
            message=_message(step1, options, clock),
            bound=step1.bound,
            model_size=size,
            build_seconds=clock.build_seconds,
            solve_seconds=clock.elapsed() - clock.build_seconds,
            confirmations=tuple(clock.confirmations),
        )
    with stops.finishing():  # after a stop request too: step 2 is a quick LP or QP
        failed, _ = _continuous(pm, options, clock)
    clock.report("done", step1.objective, step1.bound, step1.gap)
    message = _message(step1, options, clock)
    fallback = None
    if failed is not None:
        step = "step 2" if options.two_step else "polish"
        message += f"; the continuous re-solve failed ({failed}), the step-1 plan is kept"
        fallback = Fallback(step, failed, "the step-1 plan")
    elif options.two_step:
        message += f"; step 2 minimized the {problem.mission.objective.effort} effort"
    figures = {"objective": step1.objective, "bound": step1.bound, "gap": step1.gap}
    result = plan_result(
        pm,
        step1.status,
        message,
        figures,
        size,
        clock.build_seconds,
        clock.elapsed() - clock.build_seconds,
        steps=2 if options.two_step and failed is None else 1,
    )
    return dataclasses.replace(result, confirmations=tuple(clock.confirmations), fallback=fallback)


def _message(step1: Step1, options: PlanOptions, clock: Clock) -> str:
    """One line on how step 1 ended (with its lazy rounds)."""
    bound, gap = step1.bound, step1.gap
    known = gap is not None and bound is not None and math.isfinite(bound)
    where = f"gap {gap:.2%}, bound {bound:.6g}" if known else "no bound yet"
    texts = {
        PlanStatus.OPTIMAL: "optimal plan",
        PlanStatus.FEASIBLE: f"a plan, not proven optimal: HiGHS stopped ({step1.stop}; {where})",
        PlanStatus.INFEASIBLE: "the tasks and constraints cannot be met together",
        PlanStatus.NO_PLAN: f"no plan found within the time limit of {options.time_limit:g} s",
        PlanStatus.ERROR: f"HiGHS failed: {step1.stop}",
        PlanStatus.INTERRUPTED: f"the best plan found before the stop request ({where})",
        PlanStatus.INTERRUPTED_NO_PLAN: "interrupted before a plan meeting every requirement was found",
    }
    text = texts[step1.status]
    outcomes = [c.outcome for c in clock.confirmations]
    if "overturned" in outcomes:
        text += f" ({outcomes.count('overturned')} infeasible verdict(s) of HiGHS overturned)"
    if "undecided" in outcomes and not step1.status.has_plan:
        text += " (HiGHS said infeasible, but a confirmation solve ended without a verdict)"
    if options.lazy and step1.rounds > 1:
        text += f" ({step1.rounds} lazy rounds, {step1.added} requirements added"
        text += ", completed with step-1 decisions fixed)" if step1.completed else ")"
    return text
