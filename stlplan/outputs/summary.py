"""The plan summary: a JSON-ready dict built from a PlanResult and its monitor report."""

from __future__ import annotations

import dataclasses
from typing import Any

from stlplan.mission.problem import Problem
from stlplan.monitor.dynamics import DYNAMICS_CHECKED
from stlplan.result import Confirmation, Fallback, MonitorReport, PlanResult, SolverFigures, Verdict


def _verdict(v: Verdict) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "name": v.name,
        "kind": v.kind,
        "satisfied": v.satisfied,
        "robustness": v.robustness,
        "detail": v.detail,
    }
    if v.group is not None:
        entry["group"] = [list(e) for e in v.group]
    if v.rho_s is not None:
        entry.update(
            rho_s=v.rho_s, counted=v.counted, run_start=v.run_start, run_length=v.run_length
        )
    return entry


def report_dict(report: MonitorReport) -> dict[str, Any]:
    """The monitor's verdicts as plain data."""
    return {
        "satisfied": report.satisfied,
        "rho_s": report.rho_s,
        "spatial_robustness": report.spatial_robustness,
        "trajectory_gives": report.known,
        "dynamics": DYNAMICS_CHECKED[report.known],
        "tolerance": report.tolerance,
        "verdicts": [_verdict(v) for v in report.verdicts],
    }


def confirmation_dict(confirmation: Confirmation) -> dict[str, Any]:
    """How one infeasible verdict was confirmed: each solve's settings, verdict and time."""
    return {
        "where": confirmation.where,
        "outcome": confirmation.outcome,
        "solves": [
            {"settings": dict(c.settings), "verdict": c.verdict, "seconds": c.seconds}
            for c in confirmation.checks
        ],
    }


def solver_dict(solver: SolverFigures | None) -> dict[str, Any] | None:
    """The solver's own objective, margin and rho_s."""
    if solver is None:
        return None
    return {"objective": solver.objective, "margin": solver.margin, "rho_s": dict(solver.rho_s)}


def fallback_dict(fallback: Fallback | None) -> dict[str, Any] | None:
    """A failed step, why, what was kept and what it costs."""
    if fallback is None:
        return None
    return {
        "step": fallback.step,
        "reason": fallback.reason,
        "kept": fallback.kept,
        "cost": dict(fallback.cost),
    }


def summary_dict(problem: Problem, result: PlanResult, options: dict[str, Any]) -> dict[str, Any]:
    """Everything ``summary.json`` holds."""
    size = result.model_size
    return {
        "mission": problem.mission.name,
        "source": problem.source,
        "status": result.status.value,
        "message": result.message,
        "objective": result.objective,
        "bound": result.bound,
        "gap": result.gap,
        "rho_s": dict(result.rho_s),
        "effort": {"norm": problem.mission.objective.effort, "value": result.effort},
        "margin": result.margin,
        "inter_sample": problem.inter_sample,
        "solver": solver_dict(result.solver),
        "steps": result.steps,
        "strategy": result.strategy,
        "rounds": result.rounds,
        "requirements_added": result.requirements_added,
        "requirements_completed": result.requirements_completed,
        "requirements_by_kind": dict(result.requirements_by_kind),
        "requirements_candidates": result.requirements_candidates,
        "requirements_unneeded": result.requirements_unneeded,
        "events": list(result.events),
        "round_log": [dict(record) for record in result.round_log],
        "first_plan_seconds": result.first_plan_seconds,
        "convergence": [dataclasses.asdict(point) for point in result.convergence],
        "stage_seconds": dict(result.stage_seconds),
        "trace": dict(result.trace),
        "config": dict(result.config),
        "fallback": fallback_dict(result.fallback),
        "replan": None if result.replan is None else dataclasses.asdict(result.replan),
        "dropped": [dataclasses.asdict(d) for d in result.dropped],
        "broken_by_the_past": list(result.broken_by_the_past),
        "robust_to": result.robust_to,
        "assignments": [
            {
                "task": a.task,
                "group": [list(e) for e in a.group],
                "rho_s": a.rho_s,
                "run_start": a.run_start,
                "run_length": a.run_length,
            }
            for a in result.assignments
        ],
        "model_size": None if size is None else vars(size),
        "build_seconds": result.build_seconds,
        "solve_seconds": result.solve_seconds,
        "options": options,
        "monitor": None if result.report is None else report_dict(result.report),
        "diagnosis": None if result.diagnosis is None else vars(result.diagnosis),
        "infeasibility_checks": [confirmation_dict(c) for c in result.confirmations],
    }
