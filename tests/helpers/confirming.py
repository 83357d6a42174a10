"""Confirming the infeasible verdict of a model HiGHS reads from a file (an MPS regression)."""

from __future__ import annotations

import math
import time
from typing import Any

from stlplan.planner.backend.confirm import (
    Settings,
    applied,
    confirm,
    option,
    says_infeasible,
    verdict,
)
from stlplan.planner.config import BudgetConfig
from stlplan.result import Confirmation


def solve_confirmed(highs: Any, seed: int = 0, time_limit: float = math.inf) -> Confirmation | None:
    """Solve ``highs`` (options as set), confirming an infeasible verdict (module docstring).

    Returns the confirmation, or None when the solve did not say infeasible. ``highs`` holds the
    last solve. ``time_limit`` bounds all solves together.
    """
    deadline = time.perf_counter() + time_limit
    limit = float(option(highs, "time_limit"))

    def run(settings: Settings, seconds: float) -> None:
        highs.setOptionValue("time_limit", min(limit, seconds))
        highs.run()

    with applied(highs, {"random_seed": seed, "time_limit": limit}):
        tick = time.perf_counter()
        run({}, max(BudgetConfig().min_solve_seconds, deadline - tick))
        if not says_infeasible(highs):
            return None
        first = (verdict(highs), time.perf_counter() - tick)
        return confirm(highs, first, run, seed, lambda: deadline - time.perf_counter())
