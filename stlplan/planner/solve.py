"""Solving the planning MILP with HiGHS (through Pyomo), in one or two steps (DESIGN 2.3).

Step 1 solves problem (step1) of :mod:`stlplan.planner.encoding.model`; by default obstacle and collision
avoidance enter it lazily (:mod:`stlplan.planner.core.lazy`), which proves the same optimum. Step 2 fixes every
binary of step 1 (groups, time windows, obstacle sides) and every ``rho_s^l``, then minimizes the
mission's effort norm: ``l2`` is ``sum u^2`` (a convex QP), ``l1`` is ``sum |u|`` and ``linf`` is
``sum_p max |u_p|`` (LPs). In one-step mode the same fixing is followed by a continuous re-solve of
the step-1 objective, which moves the plan to an exact vertex: integrality tolerances cannot then
leak into the predicates the monitor checks.

Both continuous solves (:mod:`stlplan.planner.core.finish`) run on a small model
(:mod:`stlplan.planner.encoding.continuous`): an LP over the
step-1 model first finds the predicates the fixed decisions enforce, then only those, the
dynamics (states eliminated) and the effort remain. HiGHS's QP solver stalls on the full model,
whose Hessian is singular. Lazy requirements never added to the MILP keep, in the continuous
stage, the half-plane the step-1 plan meets best: the side an up-front encoding would have fixed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pyomo.environ import ConcreteModel, Constraint, Var

from stlplan.mission.problem import Problem
from stlplan.planner.backend.values import load_values, plan_of
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.finish import Finish, finish
from stlplan.planner.core.lazy import added_by_kind
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.encoding.readout import plan_result
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock, ProgressCallback
from stlplan.planner.run.outcome import Outcome, Plan, gap_words, unfinished
from stlplan.planner.run.reached import Reached
from stlplan.planner.strategy import build_strategy
from stlplan.planner.tolerances import ROUND_OFF
from stlplan.result import Fallback, ModelSize, PlanResult, PlanStatus
from stlplan.runtime import signals


def model_size(model: ConcreteModel) -> ModelSize:
    """Free variables, binaries among them, and active constraints of ``model``."""
    free = [v for v in model.component_data_objects(Var, active=True) if not v.fixed]
    rows = sum(1 for _ in model.component_data_objects(Constraint, active=True))
    return ModelSize(len(free), sum(1 for v in free if v.is_binary()), rows)


def strict(config: PlannerConfig) -> PlannerConfig:
    """``config`` with HiGHS's integrality tolerance at round-off (:data:`ROUND_OFF`)."""
    extra = dict(config.solver.highs_options)
    extra["mip_feasibility_tolerance"] = ROUND_OFF
    return config.with_overrides({"solver.highs_options": extra})


def _strict_note(config: PlannerConfig) -> str:
    tolerance = ROUND_OFF
    return (
        f"step 1 solved again with integrality tolerance {tolerance:g}: its first plan met"
        " its decisions only within HiGHS's default tolerance"
    )


@dataclass
class _Run:
    """What the stages of one run hand on: the problem, the configuration (made strict by a
    retry), the clock, the budget, and what each stage found."""

    problem: Problem
    config: PlannerConfig
    clock: Clock
    budget: Budget
    start: Plan | None = None
    pm: PlanModel | None = None
    step1: Outcome | None = None
    plan: Plan | None = None
    size: ModelSize | None = None
    ended: Finish = dataclasses.field(default_factory=Finish)
    strictly: bool = False


def _step_one(run: _Run) -> None:
    """Build and solve problem (step 1) by the strategy the configuration composes."""
    run.clock.reached = Reached(order=tuple(a.name for a in run.problem.agents))
    run.clock.report("build")
    strategy = build_strategy(run.config)
    with run.budget.stage("step 1"):
        run.pm, run.step1 = strategy.solve(
            run.problem, run.config, run.clock, run.budget, run.start
        )
    run.size = model_size(run.pm.model)  # before the continuous stage fixes its decisions
    has_plan = run.step1.status.has_plan
    run.plan = plan_of(run.pm.model, run.pm.model.step1, run.pm.added) if has_plan else None
    _step_one_ended(run)


def _step_one_ended(run: _Run) -> None:
    """The last point of the run's convergence record: step 1's plan (if any) and bound."""
    assert run.step1 is not None
    objective = run.step1.objective if run.step1.status.has_plan else None
    run.clock.convergence.ended(run.clock.elapsed(), objective, run.step1.bound)


def _continuous(run: _Run) -> None:
    """Step 2 (or the polish) with step 1's decisions fixed, when step 1 has a plan."""
    if run.pm is None or run.plan is None:
        run.ended = Finish()
        return
    load_values(run.pm.model, run.plan.values)  # the decisions the continuous stage holds
    # after a stop request too: step 2 is a quick LP or QP
    with signals.finishing(), run.budget.stage("continuous"):
        run.ended = finish(run.pm, run.config, run.clock, run.budget.finishing())


def _strict_retry(run: _Run) -> None:
    """When step 1's decisions, taken exactly, admit no plan, its plan met them only within
    HiGHS's integrality tolerance (a binary at ``1e-6`` from 0 or 1 relaxes a big-M row by
    ``M 1e-6``, more than ``EPSILON``): step 1 and the continuous stage again, with an
    integrality tolerance of round-off. When that runs out of time without a plan, the first
    one stands for the monitor to judge if it meets the predicates its decisions enforce, and
    otherwise the run has no plan (:attr:`Finish.broken`); a strict verdict of infeasibility
    stands."""
    tolerance = run.config.solver.highs_options.get("mip_feasibility_tolerance")
    if not run.ended.infeasible or tolerance == ROUND_OFF:
        return
    first = dataclasses.replace(run)
    run.config, run.strictly = strict(run.config), True
    run.clock.convergence.restart(run.clock.elapsed())  # the first plan met its decisions loosely
    run.clock.trace.restart()
    _step_one(run)
    _continuous(run)
    out_of_time = (PlanStatus.NO_PLAN, PlanStatus.INTERRUPTED_NO_PLAN)
    if run.step1 is None or run.step1.status in out_of_time:
        run.pm, run.step1, run.plan = first.pm, first.step1, first.plan
        run.size = first.size
        # a first plan the continuous stage found broken was the retry's to finish
        run.ended = dataclasses.replace(first.ended, unfinished=first.ended.broken)
        _step_one_ended(run)


STAGES: tuple[tuple[str, Callable[[_Run], None]], ...] = (
    ("step 1", _step_one),
    ("continuous", _continuous),
    ("strict retry", _strict_retry),
)
"""The stages of a run, in order; the readout (:func:`plan`) follows them."""


def plan(
    problem: Problem,
    config: PlannerConfig | None = None,
    progress: ProgressCallback | None = None,
    budget: Budget | None = None,
    start: Plan | None = None,
) -> PlanResult:
    """Plan ``problem``: build the MILP, solve step 1, then step 2 (or a polish).

    Parameters
    ----------
    problem
        A checked problem.
    config
        The planner's configuration (default: from the mission).
    progress
        Called with :class:`Progress` at phase changes and while HiGHS works.
    budget
        The run's time (default: ``solver.time_limit`` from now); its ledger gets the seconds
        of step 1 and of the continuous stage.
    start
        A plan for step 1 to start from (of an earlier model of the problem, or states and
        inputs only: HiGHS completes it, or drops it when it meets no plan of this model).

    Returns
    -------
    PlanResult
        Status, trajectory and solver figures; ``report`` is left None for the monitor.
        ``model_size`` is the size of the last MILP step 1 solved (lazy rows included);
        ``values`` is step 1's plan, a start for a later solve.
    """
    config = config or PlannerConfig.from_mission(problem.mission)
    clock = Clock.started(progress)
    run = _Run(problem, config, clock, budget or Budget.for_run(config), start)
    for _, stage in STAGES:
        stage(run)
    return _readout(run)


def _candidates(pm: PlanModel) -> dict[str, Any]:
    """The step requirements of the whole team's model by kind, how many the lazy loop could
    add, and how many reachability proved unneeded (none without a lazy loop)."""
    if pm.deferral is None:
        return {}
    return {
        "requirements_by_kind": added_by_kind(pm),
        "requirements_candidates": len(pm.deferral.lazy),
        "requirements_unneeded": pm.deferral.dropped,
    }


def unfinished_words(config: PlannerConfig) -> str:
    """Why a run whose continuous stage ran out of time with a plan that needed it has none
    (:func:`stlplan.planner.core.finish.out_of_time`)."""
    return (
        f"no plan within the time limit of {config.solver.time_limit:g} s: step 1's plan was"
        " found but not finished in time (it meets its decisions only within HiGHS's"
        " tolerances): give it more time (--time-limit)"
    )


def _readout(run: _Run) -> PlanResult:
    """The plan of the run's model as a result, with how the run ended and what it did."""
    assert run.pm is not None and run.step1 is not None and run.size is not None
    step1, clock, config = run.step1, run.clock, run.config
    step1 = unfinished(step1) if run.ended.unfinished else step1
    found: dict[str, Any] = {
        "rounds": len(clock.round_log),
        "requirements_added": step1.added,
        "requirements_completed": step1.completion_added,
        **_candidates(run.pm),
        "events": run_events(step1, run.ended, config, clock, run.strictly),
        "confirmations": tuple(clock.confirmations),
        "round_log": tuple(clock.round_log),
        "first_plan_seconds": clock.first_plan if step1.status.has_plan else None,
        "convergence": tuple(clock.convergence.points),
        "trace": clock.trace.record(clock.round_log),
    }
    build, solve = clock.build_seconds, clock.elapsed() - clock.build_seconds
    if not step1.status.has_plan:
        clock.report("done")
        message = step1_message(step1, config, clock)
        if run.ended.unfinished and step1.status is PlanStatus.NO_PLAN:
            message = unfinished_words(config)
        return PlanResult(
            step1.status, message, bound=step1.bound, model_size=run.size,
            build_seconds=build, solve_seconds=solve, **found,
        )  # fmt: skip
    clock.report("done", step1.objective, step1.bound, step1.gap)
    message, fallback = _finished(
        step1_message(step1, config, clock), run.ended, config, run.problem
    )
    figures = {"objective": step1.objective, "bound": step1.bound, "gap": step1.gap}
    steps = 2 if config.continuous.two_step and fallback is None else 1
    result = plan_result(run.pm, step1.status, message, figures, run.size, build, solve, steps)
    values = run.plan.values if run.plan is not None else {}
    return dataclasses.replace(result, fallback=fallback, values=values, **found)


def _finished(
    message: str, ended: Finish, config: PlannerConfig, problem: Problem
) -> tuple[str, Fallback | None]:
    """The message with how the continuous stage ended, and its fallback when it failed."""
    if ended.failed is not None:
        step = "step 2" if config.continuous.two_step else "polish"
        message += f"; {step} failed ({ended.failed}): the plan written is {ended.kept}"
        return message, Fallback(step, ended.failed, ended.kept)
    if config.continuous.two_step:
        message += f"; step 2 minimized the {problem.mission.objective.effort} effort"
    return message, None


def step1_message(step1: Outcome, config: PlannerConfig, clock: Clock) -> str:
    """One line on how step 1 ended (the run's internal events apart: :func:`run_events`).

    Parameters
    ----------
    step1, config, clock
        Step 1's result, the run's configuration and its clock (the confirmations).

    Returns
    -------
    str
        The status in words, with why a run without a plan ended so.
    """
    where = gap_words(step1.gap, step1.bound)
    texts = {
        PlanStatus.OPTIMAL: "optimal plan",
        PlanStatus.FEASIBLE: (
            f"the first plan that meets every requirement ({where})"
            if config.solver.first_plan
            else f"a plan, not proven optimal: HiGHS stopped ({step1.stop}; {where})"
        ),
        PlanStatus.INFEASIBLE: "the tasks and constraints cannot be met together",
        PlanStatus.NO_PLAN: (
            f"no plan found within the time limit of {config.solver.time_limit:g} s: give it "
            "more time (--time-limit)"
            + ("" if config.solver.first_plan else " or ask for a first plan only (--first-plan)")
        ),
        PlanStatus.ERROR: f"HiGHS failed: {step1.stop}",
        PlanStatus.INTERRUPTED: f"the best plan found before the stop request ({where})",
        PlanStatus.INTERRUPTED_NO_PLAN: "interrupted before a plan meeting every requirement was found",
    }
    return texts[step1.status] + ("" if step1.status.has_plan else _without_plan(step1, clock))


def _without_plan(step1: Outcome, clock: Clock) -> str:
    """What a user may need to know of a step 1 without a plan beyond its status: a verdict of
    infeasibility left unconfirmed (how far it got is among the run's events)."""
    if "undecided" in [c.outcome for c in clock.confirmations]:
        return " (HiGHS said infeasible, but a confirmation solve ended without a verdict)"
    return ""


def _how_far(step1: Outcome, clock: Clock) -> list[str]:
    """How far a step 1 without a plan got, for the run's events (none for a verdict)."""
    found = []
    if step1.completed and not step1.status.has_plan:
        found.append(
            "at the time limit the last round's plan violated requirements that its decisions, "
            "fixed, cannot meet"
        )
    if step1.status in _UNFINISHED:
        found.append(f"step 1 ended without a plan: {clock.reached.describe()}")
    return found


_UNFINISHED = (PlanStatus.NO_PLAN, PlanStatus.INTERRUPTED_NO_PLAN, PlanStatus.ERROR)
"""Endings without a plan or a verdict: the message says how far step 1 got."""


def run_events(
    step1: Outcome, ended: Finish, config: PlannerConfig, clock: Clock, strictly: bool
) -> tuple[str, ...]:
    """What happened on the way, in words: lazy rounds, a completion, confirmations that
    overturned HiGHS, a strict retry, a landed step 2 (``summary.json`` and ``--verbose``).

    Parameters
    ----------
    step1, ended
        Step 1's result and how the continuous stage ended.
    config, clock
        The run's configuration and its clock (the confirmations).
    strictly
        Whether step 1 was solved again with an integrality tolerance of round-off.

    Returns
    -------
    tuple[str, ...]
        One sentence per event, in the order above; empty for a run without any.
    """
    events = []
    rounds = len(clock.round_log)
    if config.lazy.enabled and rounds > 1:
        line = f"{rounds} lazy rounds, {step1.added} requirements added"
        if step1.completion_added:
            line += f"; the completion added {step1.completion_added} more"
        events.append(line)
    if step1.completed and step1.status.has_plan:
        events.append("the last round's plan completed with its step-1 decisions fixed")
    events += _how_far(step1, clock)
    overturned = [c for c in clock.confirmations if c.outcome == "overturned"]
    if overturned:
        events.append(f"{len(overturned)} infeasible verdict(s) of HiGHS overturned by a check")
    if strictly:
        events.append(_strict_note(config))
    if ended.note:
        events.append(ended.note)
    return tuple(events)
