"""The small shipped missions solve to their known optima, and the monitor agrees."""

from __future__ import annotations

import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.result import PlanStatus
from tests.conftest import MISSIONS


def test_reach_avoid_reaches_the_largest_possible_margin() -> None:
    # The goal is a 2 x 2 box: no point is deeper inside than 1 (its centre), and a path around
    # the obstacle keeping 1 away from it exists within the horizon, so the optimum margin is 1.
    _, result = api.plan(MISSIONS / "reach-avoid.yaml")
    assert result.status is PlanStatus.OPTIMAL
    assert result.margin == pytest.approx(1.0, abs=1e-6)
    assert result.report is not None and result.report.satisfied
    assert result.report.spatial_robustness == pytest.approx(1.0, abs=1e-6)


def test_sync_pair_synchronizes_from_the_first_reachable_step() -> None:
    # Neither robot can be in Goal before step 4; from there both stay to the horizon 8: a run of
    # 5 steps with hold 2 gives rho_s = 5 - 1 - 2 = 2.
    _, result = api.plan(MISSIONS / "sync-pair.yaml")
    assert result.status is PlanStatus.OPTIMAL
    assert result.report is not None and result.report.satisfied
    meet = result.report.verdict("meet")
    assert (meet.rho_s, meet.run_start, meet.run_length) == (2, 4, 5)
    assert result.rho_s["meet"] == 2


def test_one_step_and_two_step_share_decisions_and_step_two_lowers_effort() -> None:
    _, two = api.plan(MISSIONS / "sync-pair.yaml")
    _, one = api.plan(MISSIONS / "sync-pair.yaml", overrides=Overrides(two_step=False))
    assert one.objective == pytest.approx(two.objective, abs=1e-6)
    assert two.effort is not None and one.effort is not None
    assert two.effort <= one.effort + 1e-6
