"""A short time limit is used, and never turns a feasible mission into an infeasible one."""

from __future__ import annotations

import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.budget import grace_of, least_solve
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS


@pytest.mark.parametrize("limit", [0.3, 0.8, 2.0])
def test_a_short_time_limit_never_calls_a_feasible_mission_infeasible(limit: float) -> None:
    _, result = api.plan(MISSIONS / "warehouse.yaml", Overrides(time_limit=limit))
    assert result.status is not PlanStatus.INFEASIBLE
    assert "infeasible" not in result.message
    assert all(c.outcome != "confirmed" for c in result.confirmations)
    assert result.build_seconds + result.solve_seconds >= min(limit, 1.0) * 0.5


@pytest.mark.parametrize("limit", [0.3, 0.8])
def test_a_short_time_limit_holds_with_its_grace(limit: float) -> None:
    # every solve may run 1 s, or the grace when a short limit makes it smaller: before, a
    # 0.8 s limit spent 1.4 to 2.5 s in step 1 (its least solves and confirmations)
    config = PlannerConfig.from_mission(
        api.validate(MISSIONS / "warehouse.yaml").mission, {"solver.time_limit": limit}
    )
    assert least_solve(config) == pytest.approx(grace_of(config)) == pytest.approx(0.1 * limit)
    _, result = api.plan(MISSIONS / "warehouse.yaml", Overrides(time_limit=limit, threads=1))
    planning = sum(t for stage, t in result.stage_seconds.items() if stage != "verify")
    assert planning <= limit + grace_of(config) + 1.0, result.stage_seconds  # (building)
