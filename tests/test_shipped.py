"""The small shipped missions solve to their known optima, and the monitor agrees."""

from __future__ import annotations

import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.mission.loader import load_mission
from stlplan.monitor.verdicts import check
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS


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
    assert result.report.spatial_robustness >= CLEARANCE - 1e-6  # the mission's margin.minimum


CLEARANCE = 0.2
"""The least clearance of the small shipped missions' plans: their maps are a few units across
and their robots move about one unit a step."""


@pytest.mark.parametrize("name", ["sync-pair", "warehouse", "reach-avoid"])
def test_a_small_shipped_mission_requires_a_clearance(name: str) -> None:
    margin = load_mission(MISSIONS / f"{name}.yaml").objective.margin
    assert margin.minimum >= CLEARANCE


def test_one_step_and_two_step_share_decisions_and_step_two_lowers_effort() -> None:
    _, two = api.plan(MISSIONS / "sync-pair.yaml")
    _, one = api.plan(MISSIONS / "sync-pair.yaml", overrides=Overrides(two_step=False))
    assert one.objective == pytest.approx(two.objective, abs=1e-6)
    assert two.effort is not None and one.effort is not None
    assert two.effort <= one.effort + 1e-6


@pytest.mark.heavy
def test_warehouse_plan_stays_clear_of_the_wall_between_steps() -> None:
    # The sampled plan keeps every step 0.2 from the L-shaped wall yet drives through it between
    # steps; with the default safety between steps the whole path keeps the margin.
    problem, safe = api.plan(MISSIONS / "warehouse.yaml")
    assert safe.status is PlanStatus.OPTIMAL
    assert safe.report is not None and safe.report.satisfied
    for name in ("avoid_wall_v", "avoid_wall_h"):
        assert safe.report.verdict(name).robustness >= 0.2 - 1e-6
    _, sampled = api.plan(MISSIONS / "warehouse.yaml", overrides=Overrides(inter_sample=False))
    assert sampled.status is PlanStatus.OPTIMAL and sampled.trajectory is not None
    assert sampled.objective is not None and safe.objective is not None
    assert sampled.objective >= safe.objective - 1e-6
    judged = check(problem, sampled.trajectory)
    crossed = [v for v in judged.verdicts if not v.satisfied]
    assert crossed and all("on the segment" in v.detail for v in crossed)


@pytest.mark.slow
def test_surveillance_is_planned_with_its_counts_and_visits_met() -> None:
    # the paper's opening mission: A watched by some camera robot within every 10 steps, two
    # ground robots in B together, 10 visits to C; a plan the monitor accepts, each with the
    # mission's margin of 0.05
    problem, result = api.plan(MISSIONS / "surveillance.yaml")
    assert result.status in (PlanStatus.OPTIMAL, PlanStatus.FEASIBLE)
    assert result.trajectory is not None
    report = check(problem, result.trajectory)
    assert report.satisfied
    for task in ("watch_A", "meet_B", "visit_C"):
        assert report.verdict(task).robustness >= 0.05 - 1e-6
