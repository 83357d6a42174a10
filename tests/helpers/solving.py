"""Solving a test problem: with a count of lazy rounds, the up-front reference, the monitor's word."""

from __future__ import annotations

from typing import Any

from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.planner.clock import Progress
from stlplan.planner.options import PlanOptions
from stlplan.planner.solve import plan
from stlplan.result import PlanResult

ENCODINGS = ["log", "standard"]
"""The SOS1 encodings of disjunctions and group choices."""


def solve(problem: Problem, **options: Any) -> tuple[PlanResult, int]:
    """Plan with ``options``; returns the result and the number of lazy rounds."""
    rounds = [0]

    def seen(progress: Progress) -> None:
        rounds[0] = max(rounds[0], progress.round or 0)

    result = plan(problem, PlanOptions(time_limit=60, **options), progress=seen)
    return result, rounds[0]


def up_front_optimum(problem: Problem) -> PlanResult:
    """The reference optimum: every row in the model from the start, no floors, proven to a gap
    of 1e-6."""
    return plan(problem, PlanOptions(time_limit=60, gap=1e-6, lazy=False, floors=False))


def accepted(problem: Problem, result: PlanResult) -> bool:
    """Whether the monitor accepts the plan of ``result`` (which must have one)."""
    assert result.trajectory is not None
    return check(problem, result.trajectory).satisfied
