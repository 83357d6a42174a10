"""One value per quantity: the figures reported for a plan are those of the plan written.

HiGHS's objective, margin and ``rho_s`` describe the point it returned; the trajectory written
can differ from that point slightly (integrality tolerances, a step 2 that moved it, a fallback
to the step-1 plan). The reported values are therefore recomputed from the written plan:

* ``rho_s`` of each synchronous task: the monitor's;
* the margin: the monitor's spatial robustness (the smallest over tasks, constraints and
  separation);
* the objective of problem (step1): ``t - beta * sum_{p,k} ||u_p(k)||_1 (+ w * margin when the
  margin is maximized)`` with ``t = min_l min(rho_s^l, gamma_l)`` (absent without synchronous
  tasks) and the inputs of the trajectory (a replan's from its step ``K`` on).

The solver's own values are kept as :class:`stlplan.result.SolverFigures`. A solver value the
plan does not reach (the monitor's value lower by more than the gap, ``tol + gap * |value|``) is
an error, as is a plan the monitor rejects.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from stlplan.errors import SolverError
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.planner.run.outcome import gap_words, relative_gap
from stlplan.result import (
    Assignment,
    MonitorReport,
    PlanResult,
    PlanStatus,
    SolverFigures,
    Trajectory,
    Verdict,
)

TOL = 1e-6
"""Absolute tolerance of the comparisons, added to the relative gap."""


def plan_objective(problem: Problem, trajectory: Trajectory, report: MonitorReport) -> float:
    """The step-1 objective of the written plan (module docstring)."""
    objective = problem.mission.objective
    first = 0 if problem.past is None else problem.past.step  # a replan's planned inputs
    effort = sum(float(np.abs(u[first:]).sum()) for u in trajectory.inputs.values())
    score = -objective.beta * effort
    capped = [
        min(float(report.verdict(t.name).rho_s or 0.0), t.sync.gamma)
        for t in problem.tasks
        if t.sync is not None
    ]
    if capped:
        score += min(capped)
    margin = report.spatial_robustness
    if objective.margin.maximize and math.isfinite(margin):
        score += objective.margin.weight * margin
    return score


def _short_of(claimed: float | None, seen: float | None, gap: float) -> bool:
    """Whether ``seen`` falls short of ``claimed`` by more than the gap."""
    if claimed is None:
        return False
    return seen is None or seen < claimed - (TOL + gap * abs(claimed))


def _check(result: PlanResult, solver: SolverFigures, report: MonitorReport, gap: float) -> None:
    """Raise when the plan written falls short of what the solver claims of it: its synchronous
    robustness, and but for a fallback (whose shortfall is reported as its cost: step 1's
    plan meets its rows within HiGHS's integrality tolerance only) its margin and objective."""
    for task, rho in solver.rho_s.items():
        seen = report.verdict(task).rho_s
        if _short_of(rho, seen, 0.0):
            raise SolverError(
                f"synchronous robustness of '{task}' disagrees: solver {rho}, monitor {seen}"
            )
    if result.fallback is not None:  # step 1's plan, off by up to its integrality slack
        return  # (the fallback reports what it costs, quantity by quantity)
    seen = report.spatial_robustness  # (inf: nothing has a margin to keep)
    if _short_of(solver.margin, seen, gap):
        raise SolverError(
            f"the spatial margin disagrees beyond the gap: solver {solver.margin}, monitor {seen}"
        )
    if result.steps == 1 and _short_of(solver.objective, result.objective, gap):
        raise SolverError(
            f"the objective disagrees beyond the gap: solver {solver.objective}, plan "
            f"{result.objective}"
        )


def reported(problem: Problem, result: PlanResult, report: MonitorReport, gap: float) -> PlanResult:
    """``result`` with the written plan's objective, margin and rho_s; the solver's kept apart.

    A fallback's cost is the solver's value minus the plan's, per quantity.
    """
    assert result.trajectory is not None
    solver = SolverFigures(result.objective, result.margin, dict(result.rho_s))
    margin = report.spatial_robustness
    rho_s = {t: report.verdict(t).rho_s for t in result.rho_s}
    objective = plan_objective(problem, result.trajectory, report)
    gap_of_plan = _plan_gap(result, objective, gap)
    said = gap_words(result.gap, result.bound)  # the message speaks of the written plan too
    out = dataclasses.replace(
        result,
        assignments=tuple(_monitors_run(a, report) for a in result.assignments),
        objective=objective,
        gap=gap_of_plan,
        message=result.message.replace(said, gap_words(gap_of_plan, result.bound)),
        margin=margin if math.isfinite(margin) else None,
        rho_s={t: float(v) for t, v in rho_s.items() if v is not None},
        solver=solver,
        report=report,
    )
    _check(out, solver, report, gap)
    if out.fallback is not None:
        cost = {
            name: float(mine - theirs)
            for name, mine, theirs in (
                ("objective", solver.objective, out.objective),
                ("margin", solver.margin, out.margin),
            )
            if mine is not None and theirs is not None
        }
        out = dataclasses.replace(out, fallback=dataclasses.replace(out.fallback, cost=cost))
    return out


def _monitors_run(assignment: Assignment, report: MonitorReport) -> Assignment:
    """A synchronous task's assignment with the run the monitor names (its longest, the
    earliest of those, of the group that keeps it), so the task line and the monitor's table
    name one run; the solver may have counted a shorter one (a run capped at gamma, agents
    starting in the region)."""
    verdict = next((v for v in report.verdicts if v.name == assignment.task), None)
    if verdict is None or verdict.kind != "synchronous" or verdict.run_start is None:
        return assignment
    return dataclasses.replace(
        assignment,
        group=verdict.group or assignment.group,
        rho_s=verdict.rho_s,
        run_start=verdict.run_start,
        run_length=verdict.run_length,
    )


def _plan_gap(result: PlanResult, objective: float | None, gap: float) -> float | None:
    """The gap of the written plan to the solver's bound when step 1 was not proven (a plan
    improved after the solver's gap was taken, by a polish or a whole team's solve, gets its
    own); a proven step 1 (optimal, or a degraded plan's within the run's ``gap``) keeps the
    solver's."""
    proven = result.status is PlanStatus.OPTIMAL or (
        result.status is PlanStatus.DEGRADED and result.gap is not None and result.gap <= gap
    )
    if proven or result.bound is None:
        return result.gap
    if not math.isfinite(result.bound):
        return result.gap
    return relative_gap(objective, result.bound)


def verified(problem: Problem, result: PlanResult, gap: float) -> PlanResult:
    """Attach the monitor's report and report the written plan's figures
    (:func:`reported`); a plan the monitor rejects is an error, never an output.

    A replan's report judges the whole trajectory, but the plan is held to what it decided:
    constraints after the replan's step (the monitor's ``planned_only`` check), whose margin
    its figures report. A constraint the executed past broke, which no plan can mend, makes
    the result degraded, and is named.
    """
    if result.trajectory is None:
        return result
    report = monitor_check(problem, result.trajectory)
    judged = report
    if problem.past is not None:  # what the plan decided: constraints after the replan's step
        judged = monitor_check(problem, result.trajectory, planned_only=True)
    if not judged.satisfied:
        lines = "; ".join(f"{v.name}: {v.detail}" for v in judged.verdicts if not v.satisfied)
        raise SolverError(f"the solver's plan is rejected by the monitor ({lines})")
    out = dataclasses.replace(reported(problem, result, judged, gap), report=report)
    failed = [v for v in report.verdicts if not v.satisfied]
    return _broken_by_the_past(out, failed) if failed else out


def _broken_by_the_past(result: PlanResult, failed: list[Verdict]) -> PlanResult:
    """``result`` degraded by the constraints the executed past broke (``failed``, named once:
    in the monitor's report, with what the plan did about them)."""
    names = tuple(v.name for v in failed)
    message = f"the executed past breaks {', '.join(names)}; {result.message}"
    return dataclasses.replace(
        result, status=PlanStatus.DEGRADED, broken_by_the_past=names, message=message
    )
