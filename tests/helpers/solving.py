"""Solving a test problem: with a count of lazy rounds, the up-front reference, the monitor's word."""

from __future__ import annotations

from typing import Any

from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.components import Parts
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock, Progress
from stlplan.planner.run.outcome import Outcome
from stlplan.planner.solve import plan
from stlplan.planner.strategy import LazyRounds
from stlplan.result import PlanResult
from tests.helpers.configs import UP_FRONT

ENCODINGS = ["log", "standard"]
"""The SOS1 encodings of disjunctions and group choices."""


def solve(problem: Problem, config: dict[str, Any] | None = None) -> tuple[PlanResult, int]:
    """Plan with the dotted ``config`` overrides (a 60 s limit unless they set one); returns
    the result and the number of lazy rounds."""
    rounds = [0]

    def seen(progress: Progress) -> None:
        rounds[0] = max(rounds[0], progress.round or 0)

    settings = PlannerConfig().with_overrides({"solver.time_limit": 60.0, **(config or {})})
    result = plan(problem, settings, progress=seen)
    return result, rounds[0]


def up_front_optimum(problem: Problem) -> PlanResult:
    """The reference optimum: every row in the model from the start, no floors, proven to a gap
    of 1e-6 (:data:`tests.helpers.configs.UP_FRONT`)."""
    return plan(problem, UP_FRONT)


def accepted(problem: Problem, result: PlanResult) -> bool:
    """Whether the monitor accepts the plan of ``result`` (which must have one)."""
    assert result.trajectory is not None
    return check(problem, result.trajectory).satisfied


def by_parts(
    problem: Problem, config: PlannerConfig, clock: Clock | None = None
) -> tuple[PlanModel, Outcome]:
    """Step 1 of ``problem`` part by part (:class:`~stlplan.planner.core.components.Parts`),
    each part's loop repairing by ``config``'s policy without the first-plan heuristics, within
    60 s."""
    parts = Parts(LazyRounds(RepairPolicy.of(config)))
    return parts.solve(problem, config, clock or Clock(0.0, None), Budget.of_seconds(60))
