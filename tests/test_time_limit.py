"""A short time limit is used, and never turns a feasible mission into an infeasible one."""

from __future__ import annotations

import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS


@pytest.mark.parametrize("limit", [0.3, 0.8, 2.0])
def test_a_short_time_limit_never_calls_a_feasible_mission_infeasible(limit: float) -> None:
    _, result = api.plan(MISSIONS / "warehouse.yaml", Overrides(time_limit=limit))
    assert result.status is not PlanStatus.INFEASIBLE
    assert "infeasible" not in result.message
    assert all(c.outcome != "confirmed" for c in result.confirmations)
    assert result.build_seconds + result.solve_seconds >= min(limit, 1.0) * 0.5
