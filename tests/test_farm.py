"""The paper's farm cases solved end to end (slow: minutes each)."""

from __future__ import annotations

import pytest

from stlplan import api
from stlplan.result import PlanStatus
from tests.conftest import MISSIONS

pytestmark = pytest.mark.slow


def test_case_one_reaches_the_papers_synchronization() -> None:
    _, result = api.plan(MISSIONS / "farm.yaml", time_limit=900, threads=2)
    assert result.status is PlanStatus.OPTIMAL
    assert result.report is not None and result.report.satisfied
    crop_c = result.report.verdict("crop_C")
    assert (crop_c.run_start, crop_c.run_length, crop_c.rho_s) == (3, 7, 5)


@pytest.mark.parametrize("name", ["farm-case2.yaml", "farm-case3.yaml"])
def test_cases_two_and_three_give_accepted_plans(name: str) -> None:
    _, result = api.plan(MISSIONS / name, time_limit=600, threads=2)
    assert result.status.has_plan
    assert result.report is not None and result.report.satisfied
    assert result.report.rho_s is not None and result.report.rho_s >= 0
