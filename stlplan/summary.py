"""The plan summary: a JSON-ready dict built from a PlanResult and its monitor report."""

from __future__ import annotations

from typing import Any

from stlplan.problem import Problem
from stlplan.result import MonitorReport, PlanResult, Verdict


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
        entry.update(rho_s=v.rho_s, run_start=v.run_start, run_length=v.run_length)
    return entry


def report_dict(report: MonitorReport) -> dict[str, Any]:
    """The monitor's verdicts as plain data."""
    return {
        "satisfied": report.satisfied,
        "rho_s": report.rho_s,
        "spatial_robustness": report.spatial_robustness,
        "verdicts": [_verdict(v) for v in report.verdicts],
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
        "steps": result.steps,
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
    }
