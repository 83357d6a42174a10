"""``final: at_rest``: an agent ends at an equilibrium of its dynamics, planned and checked."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.mission.problem import build_problem
from stlplan.mission.schema import Mission
from stlplan.monitor.verdicts import check
from stlplan.result import PlanStatus, Trajectory
from tests.helpers.dynamics import DOUBLE_INTEGRATOR_U1


def reach(final: str, effort: str) -> Any:
    """Reach Goal once within 6 steps, from rest at the origin."""
    return build_problem(
        Mission.model_validate(
            {
                "name": "reach",
                "horizon": 6,
                "dynamics": {"di": DOUBLE_INTEGRATOR_U1},
                "agents": [
                    {"name": "r", "dynamics": "di", "initial_state": [0, 0, 0, 0], "final": final}
                ],
                "regions": {"Goal": {"box": [[3, 4], [-1, 1]]}},
                "tasks": {"go": {"formula": "F[0,6] in(p, Goal)", "roles": {"p": {"agent": "r"}}}},
                "objective": {"beta": 0.1, "effort": effort},
            }
        )
    )


@pytest.mark.parametrize("effort", ["l1", "l2"])
def test_an_agent_at_rest_ends_with_zero_velocity(effort: str) -> None:
    _, free = api.plan(reach("free", effort), overrides=Overrides(threads=1))
    _, rest = api.plan(reach("at_rest", effort), overrides=Overrides(threads=1))
    assert free.status is rest.status is PlanStatus.OPTIMAL
    assert free.trajectory is not None and rest.trajectory is not None
    assert np.abs(free.trajectory.states["r"][-1, 2:]).max() > 0.1  # coasting is cheaper
    assert np.abs(rest.trajectory.states["r"][-1, 2:]).max() < 1e-6
    assert rest.effort is not None and free.effort is not None and rest.effort > free.effort
    assert rest.report is not None and rest.report.satisfied


def test_the_monitor_rejects_a_plan_that_does_not_end_at_rest() -> None:
    _, free = api.plan(reach("free", "l1"), overrides=Overrides(threads=1))
    assert free.trajectory is not None
    moving: Trajectory = free.trajectory
    report = check(reach("at_rest", "l1"), moving)
    verdict = report.verdict("dynamics r")
    assert not verdict.satisfied and "not at rest" in (verdict.detail or "")
    assert check(reach("free", "l1"), moving).satisfied
