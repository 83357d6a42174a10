"""One planning run: cheap checks, the solve, the diagnosis of an infeasible mission, and the
monitor's verdict on the plan (the core of :func:`stlplan.api.plan`, :func:`stlplan.api.solve`
and every sweep run).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stlplan.analysis.diagnose import cheap_diagnosis, cheap_reasons, diagnose
from stlplan.analysis.recovery import restored_later, with_recoveries
from stlplan.analysis.size import check_size
from stlplan.degraded import Undecided, degrade
from stlplan.mission.loader import check_enumerable, load_problem
from stlplan.mission.problem import Problem
from stlplan.native_output import discard_highs_banner
from stlplan.planner.config import PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Plan
from stlplan.result import Confirmation, PlanResult, PlanStatus
from stlplan.runtime import signals
from stlplan.verify import verified
from stlplan.words import counted


@contextlib.contextmanager
def _quiet_pyomo() -> Iterator[None]:
    """Silence Pyomo's warnings about solver values a hair outside bounds (solver round-off)."""
    logger = logging.getLogger("pyomo.core")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def plan(
    mission: str | Path | Problem,
    overrides: Overrides | None = None,
    progress: Callable[[Any], None] | None = None,
    diagnose_infeasible: bool = True,
    start: Plan | None = None,
) -> tuple[Problem, PlanResult]:
    """Solve a mission and verify the plan with the monitor.

    ``overrides`` change the mission's settings for this run (:class:`Overrides`: time limit,
    gap, threads, seed, encoding, two steps, inter-sample safety, any planner knob). The time limit bounds
    the whole call, diagnosis included. An infeasible mission comes back with a
    :class:`~stlplan.result.Diagnosis` (cheap reasons found before solving, or a minimal
    conflict found by feasibility solves).

    In the main thread, SIGINT and SIGTERM during a solve stop HiGHS and the best plan so far
    comes back verified with status ``interrupted`` (:mod:`stlplan.runtime.signals`); a second signal, or
    one outside a solve, raises :class:`stlplan.runtime.signals.Interrupted`.

    ``start``: a plan step 1 starts from (:func:`stlplan.planner.solve.plan`).
    """
    from stlplan.planner.solve import plan as solve_plan
    from stlplan.planner.strategy import describe

    signals.catch_up()  # a search a replan's deadline left behind ends first
    discard_highs_banner()  # the first HiGHS object of a process prints it on stdout
    overrides = overrides or Overrides()
    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    problem = problem.with_inter_sample(overrides.inter_sample)
    config = PlannerConfig.from_mission(problem.mission, overrides.dotted())
    problem = with_recoveries(problem.robust(config.model.robust_to))
    if config.model.tasks == "groups":
        check_enumerable(problem)
    run = Budget.for_run(config)
    check_size(problem, config)
    used: dict[str, Any] = {
        "config": config.model_dump(),
        "strategy": describe(config),
        "robust_to": problem.robust_to,
    }
    early = _infeasible_before_solving(problem)
    if early is not None and not config.diagnosis.degrade:
        return problem, dataclasses.replace(early, **used)
    with signals.stop_on_signals(), _quiet_pyomo():
        result = early or solve_plan(problem, config, progress=progress, budget=run, start=start)
        if result.status is PlanStatus.INFEASIBLE:
            how = _Solving(config, run, progress, start)
            problem, result = _when_infeasible(problem, result, how, diagnose_infeasible)
        with run.stage("verify"):
            result = verified(problem, result, config.solver.gap)
        used["robust_to"] = problem.robust_to  # (smaller when the margins were reduced)
        return problem, dataclasses.replace(result, stage_seconds=dict(run.ledger), **used)


@dataclass(frozen=True)
class _Solving:
    """How a run solves: its configuration, budget, progress reports and starting plan."""

    config: PlannerConfig
    run: Budget
    progress: Callable[[Any], None] | None
    start: Plan | None


def _when_infeasible(
    problem: Problem, result: PlanResult, how: _Solving, diagnose_infeasible: bool
) -> tuple[Problem, PlanResult]:
    """An infeasible mission degraded (smaller robust margins first, then fewer tasks) when
    ``diagnosis.degrade`` asks for it, else diagnosed when ``diagnose_infeasible`` does."""
    from stlplan.planner.solve import plan as solve_plan

    config, run, progress, start = how.config, how.run, how.progress, how.start
    if not config.diagnosis.degrade:
        if not diagnose_infeasible:
            return problem, result
        with run.stage("diagnosis"):
            return problem, _diagnosed(problem, config, result, run)
    fractions = config.diagnosis.margin_fractions
    if problem.robust_to > 0 and fractions:
        with run.stage("smaller margins"):

            def solve(smaller: Problem, budget: Budget) -> PlanResult:
                return solve_plan(smaller, config, progress=progress, budget=budget, start=start)

            problem, result = _smaller_margins(problem, result, fractions, solve, run)
    if result.status is not PlanStatus.INFEASIBLE:
        return problem, result
    with run.stage("degraded"):
        problem, result = _degraded(problem, result, how)
        return _restored_later(problem, result, how)


def _restored_later(
    problem: Problem, result: PlanResult, how: _Solving
) -> tuple[Problem, PlanResult]:
    """A replan infeasible even with tasks dropped, whose pairs left too close by its past are
    apart again as soon as their reachable boxes allow: planned again (and degraded) with
    them apart one step later each time (:func:`stlplan.analysis.recovery.restored_later`), while
    that is infeasible and the run has time."""
    from stlplan.planner.solve import plan as solve_plan

    later = restored_later(problem)
    while result.status is PlanStatus.INFEASIBLE and later is not None and not how.run.expired():
        found = solve_plan(later, how.config, progress=how.progress, budget=how.run)
        problem, result = later, found
        if found.status is PlanStatus.INFEASIBLE:
            problem, result = _degraded(later, found, how)
        later = restored_later(later)
    return problem, result


def _infeasible_before_solving(problem: Problem) -> PlanResult | None:
    """The result of a mission the cheap reasons already rule out (None when none is found)."""
    reasons = cheap_reasons(problem)
    if not reasons:
        return None
    diagnosis = cheap_diagnosis(problem, reasons)
    message = f"infeasible before solving: {counted(len(reasons), 'requirement')} cannot be met"
    return PlanResult(PlanStatus.INFEASIBLE, message, diagnosis=diagnosis)


_Solve = Callable[[Problem, Budget], PlanResult]
"""A solve of a problem by the run's planner and settings within a budget."""


class _DiagnosisStopped(Exception):
    """A stop request ended the diagnosis."""


def _prober(
    config: PlannerConfig,
    run: Budget,
    confirmations: list[Confirmation],
    plans: dict[int, PlanResult] | None = None,
) -> Callable[[Problem], PlanStatus]:
    """A feasibility solve of a sub-mission within a quarter of the time ``run`` has left now,
    its confirmations recorded as a diagnosis probe's (and its result in ``plans``,
    by the sub-mission's ``id``, when it has a plan); a stop request raises
    :class:`_DiagnosisStopped`."""
    from stlplan.planner.solve import plan as solve_plan

    probe = config.with_overrides(
        {
            "solver.time_limit": max(run.min_solve, run.remaining() / 4),
            "solver.first_plan": True,  # a probe asks whether there is a plan, not the best
            "continuous.two_step": False,
        }
    )  # (a probe with parts falls back to the whole team when their plans do not assemble)
    whole = probe.with_overrides({"parts.enabled": False})
    large = config.parts.plan_first_agents

    def feasibility(subset: Problem) -> PlanStatus:
        # a team smaller than a large one's part is probed whole: its parts' first plans
        # collide, and their merges' repairs cost more than the team's own lazy rounds
        small = large is None or len(subset.agents) < large
        settings = whole if small else probe
        found = solve_plan(subset, settings, budget=Budget.for_run(settings, run.deadline))
        confirmations.extend(
            dataclasses.replace(c, where=f"diagnosis probe, {c.where}") for c in found.confirmations
        )
        if found.status.interrupted:
            raise _DiagnosisStopped
        if plans is not None and found.status.has_plan:
            plans[id(subset)] = found
        return found.status

    return feasibility


def _diagnosed(
    problem: Problem, config: PlannerConfig, result: PlanResult, run: Budget
) -> PlanResult:
    """``result`` with a minimal conflict found by feasibility solves (deletion filter), each
    infeasible verdict confirmed (recorded as a diagnosis probe), all within the ``run``'s
    budget (a quarter of what it has left a probe)."""
    confirmations = list(result.confirmations)
    feasibility = _prober(config, run, confirmations)
    try:
        seconds = max(0.0, run.remaining())
        diagnosis = diagnose(problem, feasibility, seconds)
        out = dataclasses.replace(result, diagnosis=diagnosis)
    except _DiagnosisStopped:
        out = dataclasses.replace(result, message=result.message + " (diagnosis interrupted)")
    return dataclasses.replace(out, confirmations=tuple(confirmations))


def _smaller_margins(
    problem: Problem, result: PlanResult, fractions: Sequence[float], solve: _Solve, run: Budget
) -> tuple[Problem, PlanResult]:
    """The first plan ``solve`` finds that meets every task with the robust margins scaled by
    one of ``fractions`` in turn (``problem`` and ``result`` unchanged when none does): a task
    kept matters more than a margin against the next disturbance. Each solve has an equal share
    of the time left, and one more share is kept for the degraded plan; a smaller problem that
    the cheap reasons already rule out is not solved."""
    asked = problem.robust_to
    confirmations = list(result.confirmations)
    for n, fraction in enumerate(fractions):
        if run.expired() or signals.requested():
            break
        smaller = with_recoveries(problem.robust(asked * fraction))
        if _infeasible_before_solving(smaller) is not None:
            continue
        found = solve(smaller, run.share(1 / (len(fractions) - n + 1)))
        where = f"margins {smaller.robust_to:g}, "
        confirmations += [
            dataclasses.replace(c, where=where + c.where) for c in found.confirmations
        ]
        if found.status.has_plan:
            words = (
                f"margins reduced to {smaller.robust_to:g} (no plan keeps every task with "
                f"margins of {asked:g})"
            )
            return smaller, dataclasses.replace(
                found,
                message=f"{words}; {found.message}",
                confirmations=tuple(confirmations),
                events=(*found.events, words),
            )
    return problem, dataclasses.replace(result, confirmations=tuple(confirmations))


def _undecided(
    result: PlanResult, found: Undecided, config: PlannerConfig, confirmations: list[Confirmation]
) -> PlanResult:
    """An infeasible mission whose degraded plan the time did not allow: no plan within the
    time limit, the verdict on the mission as it is and the tasks a plan was to drop said."""
    names = ", ".join(found.dropped)
    message = (
        f"{result.message}; with {names} dropped, no plan found within the time limit of "
        f"{config.solver.time_limit:g} s: give it more time (--time-limit)"
    )
    return dataclasses.replace(
        result, status=PlanStatus.NO_PLAN, message=message, confirmations=tuple(confirmations)
    )


def _degraded(problem: Problem, result: PlanResult, how: _Solving) -> tuple[Problem, PlanResult]:
    """The infeasible mission planned without the fewest tasks (by priority) it must drop
    (:mod:`stlplan.degraded`), within the run's budget; the mission as it was, with a
    diagnosis, when no set of tasks will do."""
    from stlplan.planner.solve import plan as solve_plan

    config, run, progress, start = how.config, how.run, how.progress, how.start
    confirmations = list(result.confirmations)
    probed: dict[int, PlanResult] = {}
    try:
        seconds = max(0.0, run.remaining())
        found = degrade(problem, _prober(config, run, confirmations, probed), seconds)
    except _DiagnosisStopped:
        found = None
    if found is None:  # (a cheap diagnosis stands as it is)
        return problem, result if result.diagnosis else _diagnosed(problem, config, result, run)
    if isinstance(found, Undecided):
        return problem, _undecided(result, found, config, confirmations)
    probe = probed.get(id(found.problem))
    if probe is not None and config.solver.first_plan:  # the probe's plan is a first plan
        planned = probe
    else:  # the probe's plan of the mission kept starts its solve
        start = start if probe is None else Plan(math.nan, probe.values, meets_all=False)
        planned = solve_plan(found.problem, config, progress=progress, budget=run, start=start)
    status = PlanStatus.DEGRADED if planned.status.has_plan else planned.status
    names = ", ".join(d.task for d in found.dropped)
    message = f"{counted(len(found.dropped), 'task')} dropped ({names}); " + planned.message
    out = dataclasses.replace(
        planned, status=status, message=message, dropped=found.dropped,
        confirmations=tuple(confirmations) + planned.confirmations,
    )  # fmt: skip
    return found.problem, out
